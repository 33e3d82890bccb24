"""The C core as a Cortex-M0 image in QEMU (``-M microbit``), on the scene's simulated sensors.

QEMU has no model of our ADCs.  The image (``firmware/c/qemu``) reaches the I2C bus and
the flash over a device channel: two FIFOs it opens by semihosting, ``dev.req`` and
``dev.rep``.  ``QemuDevice`` answers each request from the emulator's own ``SimI2C`` buses
and ``ADS122C04Model``s, at the time the board's TIMER0 read when it asked (the clock of
the models is set to it; the scene's sensor faults are applied at it), and from its
``MemoryStorage`` (the scene's settings and calibration).  Host bytes go through the
nRF51's UART, which QEMU connects to a socket that ``qemu_server`` bridges to a pty.

``QemuBoard`` is what ``cores.make_board("qemu", ...)`` gives: it holds the hardware for
the device channel, knows the board's rate ceiling (the same rule as the other cores),
and starts QEMU (``launch``).  It has no ``poll``: QEMU runs the firmware on its own
clock, real time or, with ``-icount``, instruction-counted time that skips idle periods.
"""

import errno
import os
import pathlib
import select
import shutil
import socket
import subprocess
import time

from tactile_fw import frontend
from tactile_fw.identity import NO_BOARD_ID, board_id_from
from tactile_fw_tools import cross
from tactile_protocol.errors import BoardError
from tactile_sim.emulator.cache import cache_dir

QEMU = "qemu-system-arm"
INSTALL = "apt-get install qemu-system-arm"
REQ, REP, UART = "dev.req", "dev.rep", "uart.sock"
MODE_RUN, MODE_BENCH, MODE_PROFILE = 0, 1, 2
OPEN_TIMEOUT_S = 10.0
TX_RING = 4096


def qemu_command(elf, workdir, fast, icount_shift=3, extra=()):
    """QEMU's arguments: the image, the UART on a socket, semihosting files in ``workdir``.

    Real time: the virtual clock is the host's.  ``fast``: ``-icount`` (one instruction =
    2^shift ns; shift 3 is a 125 MHz core) with ``sleep=off``, so time jumps over WFI.
    """
    qemu = shutil.which(QEMU)
    if qemu is None:
        raise QemuUnavailable(f"core 'qemu': no {QEMU} on PATH: {INSTALL}")
    cmd = [
        qemu, "-M", "microbit", "-nographic", "-monitor", "none", "-kernel", str(elf),
        "-chardev", f"socket,id=uart,path={pathlib.Path(workdir) / UART},server=on,wait=on",
        "-serial", "chardev:uart",
        "-semihosting-config", "enable=on,target=native",
    ]  # fmt: skip
    if fast:
        cmd += ["-icount", f"shift={icount_shift},sleep=off"]
    return cmd + list(extra)


class QemuUnavailable(BoardError):
    """QEMU or the cross compiler is missing (one line, exit 4)."""


class QemuBoard:
    """The hardware the image is served: see the module docstring."""

    def __init__(
        self, buses, layout, link, clock, storage, max_rate_hz=None, boot_id=0, board_id=None
    ):
        self.buses, self.layout, self.clock, self.storage = buses, layout, clock, storage
        self.boot_id = boot_id & 0xFFFFFFFF
        self.board_id = board_id_from(NO_BOARD_ID if board_id is None else board_id)
        self.override = max_rate_hz or 0
        sensors = [frontend.make_sensor(buses[b], s, bus_key=b) for b, s in layout]
        self.max_rate_hz = max_rate_hz or frontend.max_rate_hz(sensors)
        self.faults = None  # the emulator's FaultSchedule, applied at the board's time

    def boot(self):
        """Nothing yet: the image boots when QEMU starts (``launch``)."""

    def launch(self, workdir, fast, mode=MODE_RUN, icount_shift=3, extra=()):
        """Start QEMU on the image in ``workdir`` (``extra``: more QEMU arguments); returns
        (process, QemuDevice)."""
        elf = image()
        req = pathlib.Path(workdir) / REQ
        for fifo in (req, pathlib.Path(workdir) / REP):
            os.mkfifo(fifo)
        req_fd = os.open(req, os.O_RDONLY | os.O_NONBLOCK)  # before QEMU opens it to write
        proc = subprocess.Popen(
            qemu_command(elf, workdir, fast, icount_shift, extra),
            cwd=workdir,
            stdin=subprocess.DEVNULL,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.PIPE,
            preexec_fn=_die_with_parent,
        )
        return proc, QemuDevice(self, req_fd, pathlib.Path(workdir) / REP, proc, mode)


def connect_uart(workdir, proc, timeout_s=10.0):
    """The UART's socket, once QEMU listens on it (it waits for us before it starts)."""
    path = str(pathlib.Path(workdir) / UART)
    deadline = time.monotonic() + timeout_s
    while True:
        s = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        try:
            s.connect(path)
            s.setblocking(False)
            return s
        except OSError:
            s.close()
            if proc.poll() is not None or time.monotonic() > deadline:
                raise QemuUnavailable(f"core 'qemu': QEMU did not start: {said(proc)}") from None
            time.sleep(0.01)


def said(proc):
    """QEMU's last line on stderr (once it has exited)."""
    if proc.poll() is None:
        return "no answer"
    lines = proc.stderr.read().decode(errors="replace").strip().splitlines()
    return lines[-1] if lines else f"exit status {proc.returncode}"


def bench(emulated, timeout_s=600.0, profile=()):
    """Run the image's bench mode on ``emulated``'s hardware under ``-icount shift=0`` (one
    instruction per virtual nanosecond); the values it reports (``bench.c``).  ``profile``:
    QEMU arguments that log what it runs (bench/fw_c_profile.py); the stages run once."""
    import tempfile

    workdir = tempfile.mkdtemp(prefix="tactile-qemu-")
    mode = MODE_PROFILE if profile else MODE_BENCH
    proc, dev = emulated.board.launch(workdir, True, mode, icount_shift=0, extra=profile)
    uart = None
    try:
        uart = connect_uart(workdir, proc)
        dev.open_reply()
        end = time.monotonic() + timeout_s
        while proc.poll() is None and time.monotonic() < end:
            ready = select.select([dev.req_fd, uart], [], [], 0.05)[0]
            if uart in ready and not uart.recv(65536):
                break
            if dev.req_fd in ready and not dev.serve_burst():
                break
        proc.wait(5)
        if proc.returncode != 0 or not dev.reports:
            raise QemuUnavailable(f"core 'qemu': the bench image failed: {said(proc)}")
        return dev.reports[0]
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait(5)
        proc.stderr.close()
        if uart is not None:
            uart.close()
        dev.close()
        shutil.rmtree(workdir, ignore_errors=True)


def _die_with_parent():
    """In QEMU's process, before exec: SIGKILL when the emulator dies, however it dies."""
    import ctypes
    import signal

    try:
        ctypes.CDLL(None).prctl(1, signal.SIGKILL)  # PR_SET_PDEATHSIG (Linux)
    except (OSError, AttributeError):
        pass


def image():
    """The cross-compiled image, built once per source version in the user's cache."""
    try:
        return cross.build(cache_dir())
    except cross.NoToolchain as exc:
        raise QemuUnavailable(f"core 'qemu': {exc}") from None
    except cross.ImageBuildError as exc:
        raise QemuUnavailable(f"core 'qemu': {str(exc).splitlines()[-1]}") from None


def _errno(exc):
    code = exc.args[0] if exc.args and isinstance(exc.args[0], int) else 0xFF
    return code if code & 0xFF else code | 0x100  # as ccore's HAL: errno 0 is still a failure


class QemuDevice:
    """The device channel's server: parse requests from ``dev.req``, answer on ``dev.rep``."""

    def __init__(self, board, req_fd, rep_path, proc, mode):
        self.board, self.req_fd, self.proc, self.mode = board, req_fd, proc, mode
        self.rep_path, self.rep_fd = rep_path, None
        self.buf = bytearray()
        self.t_us = 0  # the board's time at its latest request, unwrapped
        self._last = None
        self.requests = 0
        self.reports = []  # 'M' requests: the bench's results

    def open_reply(self):
        """Open ``dev.rep`` once the image opens it to read (it does right after dev.req)."""
        deadline = time.monotonic() + OPEN_TIMEOUT_S
        while self.rep_fd is None:
            try:
                self.rep_fd = os.open(self.rep_path, os.O_WRONLY | os.O_NONBLOCK)
            except OSError as exc:
                if exc.errno != errno.ENXIO or self.proc.poll() is not None:
                    raise
                if time.monotonic() > deadline:
                    why = "core 'qemu': the image never opened its device channel"
                    raise QemuUnavailable(why) from None
                time.sleep(0.005)
        os.set_blocking(self.rep_fd, True)

    def close(self):
        for fd in (self.req_fd, self.rep_fd):
            if fd is not None:
                os.close(fd)
        self.req_fd = self.rep_fd = None

    def _clock(self, ticks):
        """The board's 32-bit microsecond ticks as unwrapped time; the models' clock."""
        if self._last is not None:
            self.t_us += (ticks - self._last) & 0xFFFFFFFF
        self._last = ticks
        self.board.clock.t_us = self.t_us
        if self.board.faults is not None:
            self.board.faults.update(self.t_us)

    def serve(self):
        """Answer every complete request waiting; False once the image has closed dev.req."""
        try:
            data = os.read(self.req_fd, 4096)
        except BlockingIOError:
            return True
        if not data:
            return False
        self.buf += data
        while (n := self._complete()) > 0:
            req, self.buf = bytes(self.buf[:n]), self.buf[n:]
            self.requests += 1
            os.write(self.rep_fd, self._answer(req))
        return True

    def serve_burst(self, seconds=0.002, gap_s=0.0005):
        """Answer requests as they come, for up to ``seconds`` or until none comes within
        ``gap_s`` (the image asks the next one microseconds after each answer); False once
        the image has closed dev.req."""
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            if not select.select([self.req_fd], [], [], gap_s)[0]:
                return True
            if not self.serve():
                return False
        return True

    def _complete(self):
        """Length of the first request in ``buf`` if it has all arrived, else 0."""
        b = self.buf
        if not b:
            return 0
        op = chr(b[0])
        need = {"C": 1, "R": 9, "B": 4}.get(op)
        if need is None and len(b) >= 4:
            need = {
                "W": 8 + b[3],
                "S": 4 + (b[2] | b[3] << 8),
            }.get(op)
        if op == "M" and len(b) >= 2:
            need = 2 + 4 * b[1]
        if need is None and op not in "WSM":
            raise QemuUnavailable(f"core 'qemu': unknown device request {b[0]:#04x}")
        return need if need is not None and len(b) >= need else 0

    def _answer(self, req):
        """The reply to one complete request (layouts: ``firmware/c/qemu/port_microbit.c``)."""
        return getattr(self, "_op_" + chr(req[0]))(req)

    def _op_C(self, req):  # the board's configuration
        hw = self.board
        head = bytes((len(hw.layout), self.mode)) + _le(hw.override, 2) + _le(hw.boot_id, 4)
        tail = bytes(v for entry in hw.layout for v in entry)
        return head + _le(TX_RING, 2) + hw.board_id + tail

    def _op_R(self, req):  # I2C: command, repeated start, read n bytes
        bus, addr, cmd, n = req[1:5]
        self._clock(_int(req, 5, 4))
        buf = bytearray(n)
        try:
            self.board.buses[bus].readfrom_mem_into(addr, cmd, buf)
            err = 0
        except OSError as exc:
            err, buf = _errno(exc), bytearray(n)
        return _le(err, 2) + bytes(buf)

    def _op_W(self, req):  # I2C write
        bus, addr, n = req[1:4]
        self._clock(_int(req, 4, 4))
        data = req[8 : 8 + n]
        try:
            if n >= 2:  # WREG: the driver's writeto_mem
                self.board.buses[bus].writeto_mem(addr, data[0], data[1:])
            else:
                self.board.buses[bus].writeto(addr, data)
            return _le(0, 2)
        except OSError as exc:
            return _le(_errno(exc), 2)

    def _op_B(self, req):  # a blob from flash: its length (-1: none), then its bytes
        cap = _int(req, 2, 2)
        data = self.board.storage.read(_blob(req[1]))
        if data is None:
            return _le(-1, 2)
        return _le(len(data), 2) + bytes(data[:cap])

    def _op_S(self, req):  # a blob to flash
        n = _int(req, 2, 2)
        try:
            self.board.storage.write(_blob(req[1]), bytes(req[4 : 4 + n]))
            return _le(0, 2)
        except OSError as exc:
            return _le(_errno(exc), 2)

    def _op_M(self, req):  # the bench's results
        self.reports.append(tuple(_int(req, 2 + 4 * k, 4) for k in range(req[1])))
        return _le(0, 2)


def _le(value, n):
    """``value`` as ``n`` little-endian bytes (two's complement, wrapped)."""
    return (value & ((1 << (8 * n)) - 1)).to_bytes(n, "little")


def _int(data, at, n):
    return int.from_bytes(data[at : at + n], "little")


def _blob(key):
    from tactile_fw_tools.ccore import blob_name

    return blob_name(key)
