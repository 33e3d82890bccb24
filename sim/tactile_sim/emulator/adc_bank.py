"""The emulated converters answered in C for the C firmware core (``adc_bank.c``).

Through its HAL's Python callbacks the C core costs a ctypes round trip, a ``SimI2C`` and
an ``ADS122C04Model`` call per register read, twelve a sample.  ``AdcBank`` mirrors the
converters in a C struct that answers RREG (DRDY polls) and RDATA itself, bit for bit as
the model, and asks Python for the transducer's six gauges once per conversion instant.
Writes, faults on a bus (``nack``, ``fail_next``) and whatever the mirror cannot hold go
to the Python models as before, the two sides synchronised around them.  ``CBoard`` takes
it as ``i2c`` (``attach``, then ``enter`` and ``leave`` around each call into the core).

The models stay authoritative: their ``watch`` marks a converter changed from outside
(a fault knob, a setting), ``enter`` pushes it; ``leave`` gives back what C changed
(``n_read``, ``code``, the read pointer, the bus counters).  The converters' clock must
not move during a call into the core (the emulator's does not).
"""

import ctypes
import functools
import pathlib

from tactile_fw_tools import ccore
from tactile_sim.adc_model import ADS122C04Model
from tactile_sim.emulator.cache import cache_dir

SOURCE = pathlib.Path(__file__).with_name("adc_bank.c")
FLAGS = ("-std=c99", "-O2", "-fPIC", "-ffp-contract=off", "-Wall", "-Wextra", "-Werror")
BUSES, ADCS, MODELS = 4, 32, 8
_i8, _u8, _u32, _i32 = ctypes.c_int8, ctypes.c_uint8, ctypes.c_uint32, ctypes.c_int32
_i64, _u64, _f64 = ctypes.c_int64, ctypes.c_uint64, ctypes.c_double

GAUGES = ctypes.CFUNCTYPE(ctypes.c_int, ctypes.c_int, _f64)
SYNC = ctypes.CFUNCTYPE(None, ctypes.c_int, ctypes.c_int, ctypes.c_int)


class Bank(ctypes.Structure):  # ab_bank_t
    _fields_ = [
        ("py_write", ctypes.c_void_p),
        ("py_read", ctypes.c_void_p),
        ("gauges", GAUGES),
        ("sync", SYNC),
        ("now", _i64),
        ("epoch", _u32),
        ("fast", _u8 * BUSES),
        ("index", (_i8 * 128) * BUSES),
        ("t_start", _i64 * ADCS),
        ("n_read", _i64 * ADCS),
        ("period", _f64 * ADCS),
        ("vref", _f64 * ADCS),
        ("gain", _f64 * ADCS),
        ("fs", _f64 * ADCS),
        ("code", _i32 * ADCS),
        ("regs", (_u8 * 4) * ADCS),
        ("ok", _u8 * ADCS),
        ("running", _u8 * ADCS),
        ("continuous", _u8 * ADCS),
        ("stuck", _u8 * ADCS),
        ("model", _u8 * ADCS),
        ("gauge", _u8 * ADCS),
        ("saturate", _i8 * ADCS),
        ("ptr", _i8 * ADCS),
        ("transactions", _u32 * BUSES),
        ("bits", _u64 * BUSES),
        ("n_touched", _u8),
        ("touched", _u8 * ADCS),
        ("is_touched", _u8 * ADCS),
        ("g_epoch", _u32 * MODELS),
        ("g_t", _f64 * MODELS),
        ("g", (_f64 * 6) * MODELS),
    ]


@functools.lru_cache(maxsize=1)
def library():
    """adc_bank.c as a loaded library, built next to the C core's (``cache.cache_dir``)."""
    path = ccore.build(cache_dir(), FLAGS, ("-lm",), "libtactile_adcbank-{digest}.so", [SOURCE])
    lib = ctypes.CDLL(str(path))
    lib.ab_bank_size.restype = ctypes.c_size_t
    if lib.ab_bank_size() != ctypes.sizeof(Bank):
        raise ccore.CoreBuildError("adc_bank.c and adc_bank.py disagree on ab_bank_t")
    return lib


def mirrorable(buses):
    """Whether ``AdcBank`` can hold these buses (else the callbacks serve them)."""
    adcs = [d for bus in buses for d in bus.devices.values()]
    if len(buses) > BUSES or len(adcs) > ADCS or any(type(a) is not ADS122C04Model for a in adcs):
        return False
    models = {getattr(a.source, "gauges", None) for a in adcs}
    return len(models) <= MODELS and len({a.clock_us for a in adcs}) <= 1


class AdcBank:
    """The C mirror of ``buses``' converters; see the module docstring."""

    def __init__(self, buses):
        self.lib, self.buses = library(), buses
        self.bank = b = Bank()
        self.adcs, self._where, self._models, self._dirty = [], {}, [], set()
        self._index = {}  # id(converter) -> its place in the mirror
        for i in range(BUSES):
            ctypes.memset(ctypes.addressof(b.index[i]), 0xFF, 128)  # -1: not mirrored
        for i, bus in enumerate(buses):
            for addr, adc in bus.devices.items():
                k = len(self.adcs)
                self.adcs.append(adc)
                self._where[i, addr] = self._index[id(adc)] = k
                b.index[i][addr] = k
                adc.watch = self._watch
                self._dirty.add(k)
        self._clock = self.adcs[0].clock_us if self.adcs else (lambda: 0)
        self._error = None
        self._keep = (GAUGES(self._gauges), SYNC(self._sync))
        b.gauges, b.sync = self._keep
        b.epoch = 1
        self._n_read, self._code, self._ptr = b.n_read, b.code, b.ptr
        self._is_touched = ctypes.addressof(b) + Bank.is_touched.offset

    def attach(self, write, read):
        """Python's I2C callbacks for the rest; the C ones to install, with their context."""
        self._py = (write, read)  # (kept referenced)
        self.bank.py_write = ctypes.cast(write, ctypes.c_void_p).value
        self.bank.py_read = ctypes.cast(read, ctypes.c_void_p).value
        addr = lambda fn: ctypes.cast(fn, ctypes.c_void_p).value  # noqa: E731
        return ctypes.addressof(self.bank), addr(self.lib.ab_i2c_write), addr(self.lib.ab_i2c_read)

    # --- around each call into the core ---------------------------------------------
    def enter(self):
        b = self.bank
        now = self._clock()
        b.now = now if type(now) is int and abs(now) < 1 << 52 else 0
        b.epoch = (b.epoch + 1) & 0xFFFFFFFF or 1  # the models' instants may have moved
        self._push_dirty()
        self._bus_flags(b.now == now)

    def leave(self):
        self._pull()
        if self._error is not None:
            exc, self._error = self._error, None
            raise exc

    def _bus_flags(self, clock_ok=True):
        """A bus is answered in C while no fault is pending on it (and the clock fits)."""
        for i, bus in enumerate(self.buses):
            self.bank.fast[i] = clock_ok and not (bus.nack or bus.fails_pending())

    # --- callbacks from C ---------------------------------------------------------------
    def _watch(self, adc):
        self._dirty.add(self._index[id(adc)])

    def _gauges(self, m, t_us):
        try:
            self.bank.g[m][:] = self._models[m](t_us)[:6]
            return 0
        except OSError as exc:
            return ccore._code(exc)
        except BaseException as exc:  # raised by leave(), as CBoard raises its callbacks'
            if self._error is None:
                self._error = exc
            return 0xFF

    def _sync(self, after, bus, addr):
        """Around a call to the Python side: take back C's changes, then give it Python's."""
        try:
            if not after:
                self._pull()
                return
            k = self._where.get((bus, addr))
            if k is not None:
                self._dirty.add(k)
            self._push_dirty()
            self._bus_flags(self.bank.now == self._clock())
            self.bank.epoch = (self.bank.epoch + 1) & 0xFFFFFFFF or 1
        except BaseException as exc:
            if self._error is None:
                self._error = exc

    # --- Python <-> C ----------------------------------------------------------------
    def _pull(self):
        b, adcs = self.bank, self.adcs
        n = b.n_touched
        if n:
            n_read, code, ptr = self._n_read[:], self._code[:], self._ptr[:]
            for k in b.touched[:n]:
                a = adcs[k]
                a.n_read, a.code, a._ptr = n_read[k], code[k], ptr[k]
            ctypes.memset(self._is_touched, 0, ADCS)
            b.n_touched = 0
        for i, bus in enumerate(self.buses):
            if b.transactions[i]:
                bus.transactions += b.transactions[i]
                bus.bits += b.bits[i]
                b.transactions[i] = b.bits[i] = 0

    def _push_dirty(self):
        while self._dirty:
            self._push(self._dirty.pop())

    def _push(self, k):
        a, b = self.adcs[k], self.bank
        src = a.source  # the emulator's gauge sources say which model and gauge they read
        fn = getattr(src, "gauges", None) if getattr(src, "adc", None) is a else None
        if fn is not None and fn not in self._models:
            self._models.append(fn)
        b.t_start[k], b.n_read[k], b.code[k] = a.t_start, a.n_read, a.code
        b.period[k], b.vref[k], b.gain[k], b.fs[k] = a.period, a.vref_v, a.pga_gain, a._fs
        b.regs[k][:] = a.regs
        b.running[k], b.continuous[k], b.stuck[k] = a.running, a.continuous, bool(a.stuck_drdy)
        b.saturate[k] = 0 if not a.saturate else 1 if a.saturate > 0 else -1
        b.model[k] = 255 if fn is None else self._models.index(fn)
        b.gauge[k] = src.gauge if fn is not None else 0
        b.ok[k] = fn is not None and _exact(a)


def _exact(a):
    """Whether C's arithmetic is the model's for converter ``a``: an integer start, a float
    period, values within what the mirror's types hold."""
    return (
        type(a.t_start) is int
        and type(a.n_read) is int
        and type(a.period) is float
        and a.period > 0
        and abs(a.t_start) < 1 << 52
        and 0 <= a.n_read < 1 << 52
        and -0x800000 <= a.code <= 0x7FFFFF
    )
