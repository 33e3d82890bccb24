"""The C firmware core (``firmware/c``) on the host: build it with ``cc``, drive it via ctypes.

``build(out_dir)`` compiles the core into a shared library (``CoreBuildError`` with the
compiler's message when that fails, ``NoCompiler`` when there is none); ``load(path)``
declares its functions. ``CBoard`` runs the C board on the same injected hardware as
``tactile_fw.board.Board``: machine.I2C-style buses, a link (``readinto``/``write``/
``opened``), a clock (``ticks_us``) and a storage (``read``/``write`` by file name), each
reached through the C core's HAL callbacks. Host only: never copied to a board.
"""

import ctypes
import hashlib
import os
import pathlib
import shutil
import subprocess

from tactile_fw.identity import NO_BOARD_ID, board_id_from
from tactile_fw.timing import TICKS_PERIOD
from tactile_protocol.constants import BOARD_ID_SIZE

SRC = pathlib.Path(__file__).resolve().parents[2] / "firmware" / "c"
CFLAGS = ("-std=c99", "-O2", "-fPIC", "-Wall", "-Wextra", "-Wpedantic", "-Werror")
SANITIZE = ("-fsanitize=address,undefined", "-fno-sanitize-recover=all", "-g", "-O1")
TICKS_BITS = TICKS_PERIOD.bit_length() - 1  # MicroPython's ticks_us wraps at 2^30
MAX_SENSORS = 4
SETTINGS_FILE = "settings.bin"


class NoCompiler(RuntimeError):
    """No C compiler on PATH."""


class CoreBuildError(RuntimeError):
    """The compiler refused the core."""


def sources():
    """The core's translation units (the sanitizer harness is not one)."""
    return sorted(SRC.glob("tc_*.c"))


def compiler():
    for name in (os.environ.get("CC"), "cc", "gcc", "clang"):
        if name and shutil.which(name):
            return shutil.which(name)
    raise NoCompiler("no C compiler (cc, gcc or clang) on PATH: install build-essential")


def build(out_dir, flags=CFLAGS, extra=(), name="libtactile_core.so", files=None):
    """Compile the core as a shared library in ``out_dir``; its path (reused if current).

    ``name`` may hold ``{digest}``, replaced by a hash of the sources and flags: a cache
    shared by checkouts of different sources then keeps one library per version.
    ``files``: other translation units instead of the core's (a host-only helper).
    """
    cc = compiler()
    files = sources() if files is None else [pathlib.Path(f) for f in files]
    digest = hashlib.sha256()
    for f in [*files, *sorted(SRC.glob("*.h"))]:
        digest.update(f.read_bytes())
    digest.update(repr((cc, flags, extra)).encode())
    out = pathlib.Path(out_dir) / name.format(digest=digest.hexdigest()[:16])
    stamp = out.with_suffix(".sha256")
    if out.exists() and stamp.exists() and stamp.read_text() == digest.hexdigest():
        return out
    out.parent.mkdir(parents=True, exist_ok=True)
    # Built under a name of this process's own, then renamed: processes that share a cache
    # directory (tests, two emulators) never load a half-written library.
    tmp = out.with_name("%s.%d.tmp" % (out.name, os.getpid()))
    cmd = [cc, *flags, "-shared", "-I", str(SRC), *map(str, files), *extra, "-o", str(tmp)]
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode != 0:
        tmp.unlink(missing_ok=True)
        raise CoreBuildError("%s failed:\n%s" % (" ".join(cmd), r.stderr))
    os.replace(tmp, out)
    tmp_stamp = stamp.with_name("%s.%d.tmp" % (stamp.name, os.getpid()))
    tmp_stamp.write_text(digest.hexdigest())
    os.replace(tmp_stamp, stamp)
    return out


# --- ctypes mirror of tactile_core.h ---------------------------------------------------
_u8, _u16, _u32, _sz = ctypes.c_uint8, ctypes.c_uint16, ctypes.c_uint32, ctypes.c_size_t
_vp, _pu8 = ctypes.c_void_p, ctypes.POINTER(ctypes.c_uint8)

I2C_WRITE = ctypes.CFUNCTYPE(ctypes.c_int, _vp, _u8, _u8, _pu8, _sz)
I2C_READ = ctypes.CFUNCTYPE(ctypes.c_int, _vp, _u8, _u8, _u8, _vp, _sz)  # buf: an address
LINK_WRITE = ctypes.CFUNCTYPE(_sz, _vp, _pu8, _sz)
LINK_READ = ctypes.CFUNCTYPE(_sz, _vp, _pu8, _sz)
TICKS = ctypes.CFUNCTYPE(_u32, _vp)
BLOB_READ = ctypes.CFUNCTYPE(ctypes.c_int, _vp, _u8, _pu8, _sz)
BLOB_WRITE = ctypes.CFUNCTYPE(ctypes.c_int, _vp, _u8, _pu8, _sz)
OPENED = ctypes.CFUNCTYPE(ctypes.c_int, _vp)
STREAMING = ctypes.CFUNCTYPE(None, _vp, ctypes.c_int)


class Hal(ctypes.Structure):
    _fields_ = [
        ("ctx", _vp),
        ("i2c_write", I2C_WRITE),
        ("i2c_read", I2C_READ),
        ("write", LINK_WRITE),
        ("read", LINK_READ),
        ("ticks_us", TICKS),
        ("blob_read", BLOB_READ),
        ("blob_write", BLOB_WRITE),
        ("opened", OPENED),
        ("streaming", STREAMING),
    ]


class SensorCfg(ctypes.Structure):
    _fields_ = [
        ("bus", _u8),
        ("slot", _u8),
        ("bus_hz", _u32),
        ("mux", _u8),
        ("gain", _u8),
        ("dr_code", _u8),
        ("turbo", _u8),
        ("vref", _u8),
    ]


class Config(ctypes.Structure):
    _fields_ = [
        ("n_sensors", _u8),
        ("sensors", SensorCfg * MAX_SENSORS),
        ("max_rate_hz", _u16),
        ("drdy_timeout_us", _u32),
        ("status_period_us", _u32),
        ("boot_id", _u32),
        ("board_id", _u8 * BOARD_ID_SIZE),
        ("ticks_bits", _u8),
        ("tx_buf", _pu8),
        ("tx_size", _sz),
    ]


class Field(ctypes.Structure):
    _fields_ = [("kind", _u8), ("count", _u8), ("wire", _u8), ("mem", _u16)]


class MsgDesc(ctypes.Structure):
    _fields_ = [
        ("type", _u8),
        ("body_len", _u8),
        ("n_fields", _u8),
        ("fields", ctypes.POINTER(Field)),
        ("name", ctypes.c_char_p),
    ]


class Header(ctypes.Structure):
    _fields_ = [("version", _u8), ("type", _u8), ("seq", _u16), ("timestamp_us", _u32)]


class Assembler(ctypes.Structure):  # tc_assembler_t
    _fields_ = [("buf", _u8 * 251), ("n", _u16), ("overflow", _u8), ("body_len", _u8)]


class Encoder(ctypes.Structure):  # tc_encoder_t
    _fields_ = [("seq", _u16), ("body", _u8 * 250), ("out", _u8 * 252)]


STATS = (
    "samples",
    "i2c_errors",
    "drdy_timeouts",
    "saturations",
    "overruns",
    "tx_dropped",
    "rx_errors",
    "last_error",
    "streaming",
    "tx_seq",
    "time_us",
    "max_rate_hz",
    "tx_used",
)
INIT_ERRORS = ("ok", "sensor count", "address slot", "converter setting", "tx buffer", "hal")


def load(path):
    """The library at ``path`` with its functions declared."""
    lib = ctypes.CDLL(str(path))
    sigs = {
        "tc_crc16": (_u16, [ctypes.c_char_p, _sz, _u16]),
        "tc_cobs_encode": (_sz, [ctypes.c_char_p, _sz, _pu8]),
        "tc_cobs_decode_in_place": (ctypes.c_int, [_pu8, _sz]),
        "tc_msg_desc": (ctypes.POINTER(MsgDesc), [_u8]),
        "tc_msg_size": (_sz, []),
        "tc_pack": (_sz, [_pu8, _u8, _u16, _u32, _vp]),
        "tc_unpack": (ctypes.c_int, [ctypes.c_char_p, _sz, ctypes.POINTER(Header), _vp]),
        "tc_encode": (_sz, [_vp, _u8, _u32, _vp]),
        "tc_assembler_init": (None, [_vp]),
        "tc_assembler_feed": (ctypes.c_int, [_vp, _u8]),
        "tc_cal_size": (_sz, []),
        "tc_cal_set": (None, [_vp, ctypes.POINTER(_u32), _u32]),
        "tc_cal_set_bias_sums": (None, [_vp, ctypes.POINTER(ctypes.c_int64), _u32]),
        "tc_cal_apply": (
            None,
            [_vp, ctypes.POINTER(ctypes.c_int32), ctypes.POINTER(ctypes.c_int32)],
        ),
        "tc_gate_size": (_sz, []),
        "tc_gate_configure": (None, [_vp, ctypes.c_int32, ctypes.c_int32, _u8, ctypes.c_int]),
        "tc_gate_update": (ctypes.c_int, [_vp, ctypes.c_int32, ctypes.c_int32, ctypes.c_int32]),
        "tc_board_size": (_sz, []),
        "tc_board_init": (ctypes.c_int, [_vp, ctypes.POINTER(Config), ctypes.POINTER(Hal)]),
        "tc_board_boot": (None, [_vp]),
        "tc_board_poll": (None, [_vp]),
        "tc_board_idle_us": (_u32, [_vp]),
        "tc_board_stat": (_u32, [_vp, ctypes.c_int]),
    }
    for name, (res, args) in sigs.items():
        fn = getattr(lib, name)
        fn.restype = res
        fn.argtypes = args
    return lib


def _code(exc):
    """An OSError as the HAL's nonzero error code (the board reports it & 0xFF, as Python)."""
    arg = exc.args[0] if exc.args else None
    if isinstance(arg, int) and not isinstance(arg, bool):
        return arg if arg & 0xFF else arg | 0x100  # errno 0 must still read as a failure
    return 0xFF


def blob_name(key):
    return SETTINGS_FILE if key == 0 else "cal%d.bin" % (key - 1)


class CBoard:
    """The C board on injected hardware; the same constructor knobs as ``Board``.

    ``buses``: machine.I2C-style objects by bus number; ``layout``: one ``(bus, slot)``
    or ``(bus, slot, bus_hz)`` per sensor (``frontend.ADDRESS_PLAN[slot]``).  ``i2c``: None,
    or what answers the core's I2C calls in C before they reach ``buses``:
    ``i2c.attach(write, read)`` takes the HAL's Python I2C callbacks (for what it leaves
    to them) and gives ``(ctx, write, read)`` to install; ``i2c.enter()`` and
    ``i2c.leave()`` bracket each call into the core.
    """

    def __init__(
        self,
        lib,
        buses,
        layout,
        link,
        clock,
        storage,
        max_rate_hz=None,
        drdy_timeout_us=None,
        status_period_us=None,
        tx_size=4096,
        boot_id=0,
        board_id=NO_BOARD_ID,
        ticks_bits=TICKS_BITS,
        i2c=None,
    ):
        self.lib, self.buses, self.link = lib, buses, link
        self.clock, self.storage = clock, storage
        self.n = len(layout)
        self._i2c = i2c
        self._error = None  # an exception raised inside a callback, re-raised after the call
        self._mem = ctypes.create_string_buffer(lib.tc_board_size())
        self._tx = (ctypes.c_uint8 * tx_size)()
        cfg = Config()
        cfg.n_sensors = len(layout)
        for i, entry in enumerate(layout[:MAX_SENSORS]):
            s = cfg.sensors[i]
            s.bus, s.slot = entry[0], entry[1]
            s.bus_hz = entry[2] if len(entry) > 2 else 1000000
            s.mux, s.gain, s.dr_code, s.turbo, s.vref = 0, 128, 6, 1, 0x02
        cfg.max_rate_hz = max_rate_hz or 0
        cfg.drdy_timeout_us = drdy_timeout_us or 0
        cfg.status_period_us = status_period_us or 0
        cfg.boot_id = boot_id & 0xFFFFFFFF
        cfg.board_id[:] = board_id_from(board_id)
        cfg.ticks_bits = ticks_bits
        cfg.tx_buf = ctypes.cast(self._tx, _pu8)
        cfg.tx_size = tx_size
        self._hal = self._make_hal()
        r = self._call(lib.tc_board_init, self._mem, ctypes.byref(cfg), ctypes.byref(self._hal))
        if r:
            raise ValueError("C board refused its configuration: %s" % INIT_ERRORS[r])

    # --- HAL callbacks (kept referenced: ctypes frees a callback that nobody holds) ----
    def _guard(self, fn, failed):
        def call(*args):
            try:
                return fn(*args)
            except OSError as exc:
                return failed if failed is not None else _code(exc)
            except BaseException as exc:  # surfaces after the C call returns
                if self._error is None:
                    self._error = exc
                return 0xFF if failed is None else failed

        return call

    def _make_hal(self):
        def i2c_write(ctx, bus, addr, data, n):
            raw = bytes(data[:n])
            if n >= 2:  # WREG: the driver's writeto_mem
                self.buses[bus].writeto_mem(addr, raw[0], raw[1:])
            else:
                self.buses[bus].writeto(addr, raw)
            return 0

        def i2c_read(ctx, bus, addr, cmd, buf, n):  # straight into the core's buffer
            self.buses[bus].readfrom_mem_into(addr, cmd, (_u8 * n).from_address(buf))
            return 0

        def write(ctx, data, n):
            return self.link.write(memoryview(ctypes.string_at(data, n))) or 0

        def read(ctx, buf, n):
            tmp = bytearray(n)
            got = self.link.readinto(tmp) or 0
            ctypes.memmove(buf, bytes(tmp[:got]), got)
            return got

        def ticks_us(ctx):
            return self.clock.ticks_us() & 0xFFFFFFFF

        def blob_read(ctx, key, buf, cap):
            data = self.storage.read(blob_name(key))
            if data is None:
                return -1
            ctypes.memmove(buf, bytes(data[:cap]), min(cap, len(data)))
            return len(data)

        def blob_write(ctx, key, data, n):
            self.storage.write(blob_name(key), ctypes.string_at(data, n))
            return 0

        def opened(ctx):
            return 1 if self.link.opened() else 0

        hook = getattr(self.link, "streaming", None)

        def streaming(ctx, on):
            hook(bool(on))

        self._callbacks = (
            I2C_WRITE(self._guard(i2c_write, None)),
            I2C_READ(self._guard(i2c_read, None)),
            LINK_WRITE(self._guard(write, 0)),
            LINK_READ(self._guard(read, 0)),
            TICKS(self._guard(ticks_us, 0)),
            BLOB_READ(self._guard(blob_read, -1)),
            BLOB_WRITE(self._guard(blob_write, None)),
            OPENED(self._guard(opened, 0)) if hasattr(self.link, "opened") else OPENED(),
            STREAMING(self._guard(streaming, 0)) if hook is not None else STREAMING(),
        )
        hal = Hal(None, *self._callbacks)
        if self._i2c is not None:
            ctx, w, r = self._i2c.attach(hal.i2c_write, hal.i2c_read)
            hal.ctx, hal.i2c_write, hal.i2c_read = ctx, I2C_WRITE(w), I2C_READ(r)
        return hal

    def _raise(self):
        if self._error is not None:
            exc, self._error = self._error, None
            raise exc

    def _call(self, fn, *args):
        """``fn(*args)`` into the core, bracketed for ``i2c``; a callback's exception raised."""
        if self._i2c is None:
            r = fn(*args)
        else:
            self._i2c.enter()
            try:
                r = fn(*args)
            finally:
                self._i2c.leave()
        self._raise()
        return r

    # --- the Board's entry points -----------------------------------------------------
    def boot(self):
        self._call(self.lib.tc_board_boot, self._mem)

    def poll(self):
        self._call(self.lib.tc_board_poll, self._mem)

    def idle_us(self):
        d = self.lib.tc_board_idle_us(self._mem)
        self._raise()
        return d

    def stat(self, name):
        return self.lib.tc_board_stat(self._mem, STATS.index(name))

    def __getattr__(self, name):  # counters: board.samples, board.i2c_errors, ...
        if name in STATS:
            return self.stat(name)
        raise AttributeError(name)
