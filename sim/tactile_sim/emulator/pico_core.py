"""An emulated Raspberry Pi Pico: stock MicroPython on rp2040js, on the scene's sensors.

``PicoBoard`` is what ``cores.make_board("rp2040", ...)`` gives: the scene's I2C buses, wired
as the Pico is (``docs/firmware.md``: sensor i on I2C(i % 2), address block i // 2), and
``launch``, which starts the chip (``pico_chip.mjs`` under node) on a flash file.  Nothing of
ours is on the chip until ``tactile flash`` puts it there: the flash file holds what a
user's Pico holds, MicroPython and its littlefs, and keeps it across runs.

``PicoChip`` is the running chip as the parent sees it: USB bytes both ways, and the
chip's I2C transactions answered from the same ``SimI2C`` buses and ``ADS122C04Model``s the
other cores use, with the models' clock at the chip's time.  The scene's time is the
chip's, counted from its first I2C transaction after each reset (the firmware powering
its sensors), so a robot log written for the scene lines up with the firmware's clock.

What it needs, each missing one refused in one line (exit 2): node, the npm packages of
``npm/package.json`` (installed once into the user's cache by ``ensure_npm``), and the
RP2040's boot ROM and MicroPython's image (``rp2_dir``: ``$TACTILE_RP2_DIR``, or
``../shared/rp2`` beside a source checkout; the ROM is not ours to ship).
"""

import errno
import fcntl
import hashlib
import json
import os
import pathlib
import select
import shutil
import subprocess
import sys
import time

from tactile.output.text import printable
from tactile_protocol.errors import BoardError, InputError, MissingExtra
from tactile_sim.emulator.cache import cache_dir

HERE = pathlib.Path(__file__).resolve().parent
CHIP_JS = HERE / "pico_chip.mjs"
NPM_DIR = HERE / "npm"
ROM, IMAGE = "bootrom-b1.bin", "micropython-rpi_pico.uf2"
READ_AHEAD = 16  # bytes a read answers with (pico_chip.mjs)
GAP_S = 0.0005  # a burst of I2C requests goes on while the next comes within this
BURST_S = 0.005  # and for at most this long, before the server looks at its host again
FLASH_SIZE = 2 * 1024 * 1024


class PicoUnavailable(MissingExtra):
    """node, the npm packages or the ROM and image are missing (one line, exit 2)."""


class PicoError(BoardError):
    """The emulated chip stopped or its flash file is unusable (one line, exit 4)."""


# --- what it runs on --------------------------------------------------------------------------
def rp2_dir():
    """The folder with the boot ROM and MicroPython's image, or PicoUnavailable."""
    env = os.environ.get("TACTILE_RP2_DIR")
    # (a checkout's ../shared/rp2, or the same beside a folder further up)
    candidates = [pathlib.Path(env)] if env else [d / "shared" / "rp2" for d in HERE.parents[3:]]
    for folder in candidates:
        if (folder / ROM).is_file() and (folder / IMAGE).is_file():
            return folder
    where = f"TACTILE_RP2_DIR={env}" if env else f"{candidates[0]} (set TACTILE_RP2_DIR)"
    raise PicoUnavailable(
        f"core 'rp2040': no {ROM} and {IMAGE} in {where}: the RP2040's boot ROM and "
        "MicroPython for the Pico (docs/emulator.md#the-emulated-pico)"
    )


def node():
    exe = shutil.which("node")
    if exe is None:
        raise PicoUnavailable("core 'rp2040': node not found: install Node.js 18 or newer "
                              "(apt-get install nodejs npm)")  # fmt: skip
    return exe


def npm_prefix():
    """Where the packages of ``npm/package-lock.json`` go: the user's cache, one folder per
    lock file's content."""
    digest = hashlib.sha256((NPM_DIR / "package-lock.json").read_bytes()).hexdigest()[:12]
    return cache_dir().parent / f"npm-pico-{digest}"


def ensure_npm(quiet=False):
    """The ``node_modules`` folder holding rp2040js, installed with ``npm ci`` on first use."""
    prefix = npm_prefix()
    modules = prefix / "node_modules"
    if (modules / "rp2040js" / "package.json").is_file() and (modules / "uf2").is_dir():
        return modules
    npm = shutil.which("npm")
    if npm is None:
        raise PicoUnavailable("core 'rp2040': npm not found, needed once to install rp2040js: "
                              "apt-get install npm")  # fmt: skip
    prefix.mkdir(parents=True, exist_ok=True)
    for name in ("package.json", "package-lock.json"):
        shutil.copyfile(NPM_DIR / name, prefix / name)
    if not quiet:
        print(printable(f"installing rp2040js from npm into {prefix} (once)"), file=sys.stderr)
    cmd = [npm, "ci", "--prefix", str(prefix), "--no-audit", "--no-fund", "--loglevel=error"]
    r = subprocess.run(cmd, capture_output=True, text=True, timeout=600)
    if r.returncode != 0 or not (modules / "rp2040js").is_dir():
        last = (r.stderr.strip().splitlines() or ["no message"])[-1]
        raise PicoUnavailable(f"core 'rp2040': npm could not install rp2040js 1.4.1 and uf2 "
                              f"2.0.0 into {prefix}: {last}")  # fmt: skip
    return modules


def default_flash():
    root = os.environ.get("XDG_STATE_HOME") or pathlib.Path.home() / ".local" / "state"
    return pathlib.Path(root) / "tactile" / "pico.flash"


def lock_flash(path):
    """Hold ``path`` (created by the chip if new) for this emulator: an open file, locked."""
    path = pathlib.Path(path)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        if path.exists() and (not path.is_file() or path.stat().st_size != FLASH_SIZE):
            raise InputError(f"{path}: not an emulated Pico's flash (a file of 2 MB)")
        fd = os.open(path.with_name(path.name + ".lock"), os.O_RDWR | os.O_CREAT, 0o644)
    except OSError as exc:
        raise PicoError(f"{path}: {exc.strerror}") from None
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError:
        os.close(fd)
        raise PicoError(f"{path}: in use by another emulated Pico (--flash another file)") from None
    return fd


def flash_board_id(flash):
    """The unique id of the Pico whose flash is the file ``flash`` (8 bytes): a Pico's id is
    its flash chip's, so one flash file is one board, whichever emulator runs it."""
    path = os.fsencode(pathlib.Path(flash).resolve())
    return hashlib.sha256(b"tactile emulated pico\0" + path).digest()[:8]


# --- the board the scene wires ---------------------------------------------------------------
class PicoBoard:
    """The hardware around the chip: see the module docstring."""

    def __init__(
        self, buses, layout, link, clock, storage, max_rate_hz=None, boot_id=0, board_id=None
    ):
        self.buses, self.layout, self.clock = buses, layout, clock
        self.board_id = board_id  # the flash chip's unique id; None: ``flash_board_id``
        self.faults = None  # the emulator's FaultSchedule, applied at the chip's time
        self.adcs = []  # every converter, reset with the chip
        self.max_rate_hz = max_rate_hz or 0  # the firmware on the chip decides

    def boot(self):
        """Nothing: the chip boots when it is launched."""

    def launch(self, flash, fast=False, bus_time=True, journal=None):
        """Start the chip on the flash file ``flash``; a ``PicoChip``.  ``journal``: a file
        that gets every erase and program of the flash (pico_chip.mjs), for tests."""
        folder, exe, modules = rp2_dir(), node(), ensure_npm()
        lock = lock_flash(flash)
        cfg = {
            "node_modules": str(modules),
            "bootrom": str(folder / ROM),
            "image": str(folder / IMAGE),
            "flash": str(pathlib.Path(flash).resolve()),
            "fast": bool(fast),
            "bus_time": bool(bus_time),
            "spin_skip": os.environ.get("TACTILE_PICO_SPIN") != "0",
            "flash_journal": str(journal) if journal else None,
            "unique_id": (self.board_id or flash_board_id(flash)).hex(),
        }
        return PicoChip(self, [exe, str(CHIP_JS), json.dumps(cfg)], lock)


class PicoChip:
    """The chip under node: USB bytes in and out, its I2C answered here."""

    def __init__(self, board, argv, lock):
        self.board = board
        out_r, out_w = os.pipe()  # chip -> here (fd 3 there)
        rep_r, rep_w = os.pipe()  # answers (fd 4 there)
        in_r, in_w = os.pipe()  # host bytes and orders (fd 5 there)
        fds = {3: out_w, 4: rep_r, 5: in_r}
        self.proc = subprocess.Popen(
            argv,
            stdin=subprocess.DEVNULL,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.PIPE,
            pass_fds=(3, 4, 5, *fds.values()),  # (the child's close_fds runs after preexec_fn)
            preexec_fn=lambda: _dup_fds(fds),
        )
        for fd in fds.values():
            os.close(fd)
        self.fd, self.reply_fd, self.order_fd, self.lock = out_r, rep_w, in_w, lock
        os.set_blocking(self.fd, False)
        self.buf = bytearray()
        self.usb = bytearray()  # from the chip, for the host
        self.t_us = 0.0  # the chip's clock since its last reset
        self.origin = None  # the chip's time at the scene's start (its first I2C)
        self.resets = 0
        self.configured = False
        self.fatal = None
        self.ended = False
        self._dev = {}  # bus -> the device of the transaction in progress
        self.requests = 0

    # --- to the chip ---------------------------------------------------------------------
    def _order(self, kind, payload=b""):
        try:
            os.write(self.order_fd, kind + len(payload).to_bytes(2, "little") + payload)
        except (BrokenPipeError, OSError):
            pass  # the chip has gone: serve() says so

    def to_usb(self, data):
        for at in range(0, len(data), 4096):
            self._order(b"H", bytes(data[at : at + 4096]))

    def hold(self, on):
        self._order(b"P", bytes((1 if on else 0,)))

    # --- from the chip -------------------------------------------------------------------
    def serve(self, fds=(), timeout_s=0.0, burst_s=BURST_S):
        """Handle what the chip sends, waiting up to ``timeout_s`` for it or for one of
        ``fds`` to be readable; then answer the requests that follow within ``GAP_S`` of
        each other (the chip asks its next I2C transaction microseconds after an answer), for
        up to ``burst_s``.  Returns the ``fds`` found readable; ``alive()`` says whether the
        chip still runs."""
        ready = select.select([self.fd, *fds], [], [], timeout_s)[0]
        if self.fd not in ready:
            return ready
        end = time.monotonic() + burst_s
        while self._pump() and time.monotonic() < end:
            if not select.select([self.fd], [], [], GAP_S)[0]:
                break
        return [fd for fd in ready if fd != self.fd]

    def _pump(self):
        """Handle every message waiting; False once the chip has closed its end."""
        try:
            data = os.read(self.fd, 65536)
        except BlockingIOError:
            return True
        if not data:
            self.ended = True
            return False
        self.buf += data
        self._messages()
        return True

    def take_usb(self):
        """The bytes the chip sent its host since the last call."""
        data = bytes(self.usb)
        self.usb.clear()
        return data

    def alive(self):
        """False once the chip has stopped (``fatal`` then says why, if it failed)."""
        if self.ended or self.proc.poll() is not None:
            self.ended = True
            self._ended()
        return not self.ended and self.fatal is None

    def _messages(self):
        buf = self.buf
        at = 0
        while len(buf) - at >= 3:
            n = buf[at + 1] | buf[at + 2] << 8
            if len(buf) - at < 3 + n:
                break
            kind, payload = buf[at], bytes(buf[at + 3 : at + 3 + n])
            at += 3 + n
            self._handle(kind, payload)
        del buf[:at]

    def _handle(self, kind, p):
        if kind == 0x55:  # 'U'
            self.usb += p
        elif kind == 0x41:  # 'A': a write's address phase
            self._at(p[2:10])
            err = self._begin(p[0], p[1])
            os.write(self.reply_fd, bytes((err,)) + self._until(p[0], p[1], err))
        elif kind == 0x52:  # 'R': a read's address phase, after the bytes written before it
            self._at(p[2:10])
            err, data = self._read(p[0], p[1], p[10:])
            os.write(self.reply_fd, bytes((err,)) + self._until(p[0], p[1], err) + data)
        elif kind == 0x57:  # 'W': a write-only transaction, at its STOP
            self._at(p[2:10])
            self._write(p[0], p[1], p[10:])
        elif kind == 0x54:  # 'T'
            self.t_us = _us(p)
        elif kind == 0x58:  # 'X': a watchdog reset
            self.resets += 1
            self.origin, self.t_us, self.configured, self._dev = None, 0.0, False, {}
            for bus in self.board.buses:
                for dev in bus.devices.values():
                    dev.reset()
        elif kind == 0x43:  # 'C'
            self.configured = True
        elif kind == 0x45:  # 'E'
            self.fatal = p.decode(errors="replace")

    def _at(self, t):
        """The chip's time of a request: the models' and the faults' clock."""
        self.t_us = _us(t)
        if self.origin is None:
            self.origin = self.t_us
        now = int(self.t_us - self.origin)
        self.board.clock.t_us = now
        if self.board.faults is not None:
            self.board.faults.update(now)
        self.requests += 1

    @property
    def scene_us(self):
        """The scene's time: the chip's since its first I2C transaction (0 before)."""
        return 0 if self.origin is None else int(self.t_us - self.origin)

    def _begin(self, bus, addr):
        """An address phase: 0 (ACK) or the errno the bus gives (NACK); the device is kept for
        the transaction's bytes."""
        if bus >= len(self.board.buses):
            return errno.ENODEV
        try:
            self._dev[bus] = self.board.buses[bus].begin(addr)
            return 0
        except OSError as exc:
            self._dev.pop(bus, None)
            return exc.errno or errno.EIO

    def _device(self, bus, addr):
        """The device of the transaction in progress: the one its address phase found, or
        (the chip answered that phase itself) the bus's now; None when it NACKs."""
        dev = self._dev.pop(bus, None)
        if dev is None and self._begin(bus, addr) == 0:
            dev = self._dev.pop(bus)
        return dev

    def _until(self, bus, addr, err):
        """8 bytes: the chip's time (ns) until which ``addr`` on ``bus`` ACKs with no need to
        ask, i.e. until the scene's next fault (0: ask every time)."""
        if err or bus >= len(self.board.buses) or self.board.buses[bus].fails_pending():
            return bytes(8)
        nxt = None if self.board.faults is None else self.board.faults.next_us()
        if nxt is None:
            return (2**63 - 1).to_bytes(8, "little")
        return int((self.origin + nxt) * 1000).to_bytes(8, "little")

    def _write(self, bus, addr, data):
        dev = self._device(bus, addr)
        if dev is not None:
            dev.write(bytes(data))

    def _read(self, bus, addr, written):
        """(errno, READ_AHEAD bytes): the read of a transaction, after ``written``."""
        dev = self._device(bus, addr)
        buf = bytearray(READ_AHEAD)
        if dev is None:
            return errno.EIO, bytes(buf)
        if len(written) == 1 and hasattr(dev, "read_mem_into"):
            dev.read_mem_into(written[0], buf)
        else:
            if written:
                dev.write(bytes(written))
            dev.read_into(buf)
        return 0, bytes(buf)

    def _ended(self):
        self.proc.wait(5)
        if self.fatal is None and self.proc.returncode not in (0, -9):
            said = self.proc.stderr.read().decode(errors="replace").strip().splitlines()
            self.fatal = said[-1] if said else f"node exited with status {self.proc.returncode}"

    def close(self):
        """Quit the chip: 'Q', and the pipes closed, which ends it too where it is blocked
        on one (a write to a full pipe nobody drains now, a read of an answer: it used to
        sit there until the kill 5 s later); the flash file's lock last."""
        if self.proc.poll() is None:
            self._order(b"Q")
        self._close_fds(self.fd, self.reply_fd, self.order_fd)
        if self.proc.poll() is None:
            try:
                self.proc.wait(5)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait(5)
        self._close_fds(self.lock)
        self.proc.stderr.close()

    @staticmethod
    def _close_fds(*fds):
        for fd in fds:
            try:
                os.close(fd)
            except OSError:
                pass


def _us(t):
    """The chip's time in a message (8 bytes, ns) in microseconds."""
    return int.from_bytes(t, "little") / 1000


def _dup_fds(fds):
    """In the child: the pipes at the fds pico_chip.mjs reads and writes, and SIGKILL when the
    emulator dies, however it dies."""
    import ctypes
    import signal

    taken = {target: os.dup(fd) for target, fd in fds.items()}  # (sources may sit at 3..5)
    for target, fd in taken.items():
        os.dup2(fd, target)
        os.close(fd)
    try:
        ctypes.CDLL(None).prctl(1, signal.SIGKILL)  # PR_SET_PDEATHSIG (Linux)
    except (OSError, AttributeError):
        pass
