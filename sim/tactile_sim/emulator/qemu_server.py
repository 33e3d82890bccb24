"""The C core's Cortex-M0 image, running in QEMU, on a pseudo-terminal.

``QemuServer(emulated)`` takes an ``EmulatedBoard`` built with ``core="qemu"`` (its
simulated sensors, buses, flash and faults) and, once a host has the pty open (or at once,
``when_opened=False``), starts QEMU (``qemu_core``).  Its step moves bytes between the
nRF51 UART's socket and the host's queue, and answers the image's device channel; ``Server``
(``server``) owns the pty, host presence, hold, drain, keep and drop:

- QEMU starts only once the host is announced, so the host sees the boot's HELLO; the
  image has no ``opened`` signal afterwards, so a host that reopens asks GET_INFO, as it
  does of a Pico;
- real time: QEMU's clock is the host's; a host that does not read makes the firmware's
  TX ring drop and count frames, as on a board;
- ``fast``: QEMU counts instructions (``-icount``, time skips WFI); what it sends waits for
  a host to come, and the device channel is not answered while more than ``HOLD_BYTES``
  wait for the host, so the board's time holds (at most ``HOLD_LIMIT_S`` in a row in a run
  with an end: then it runs on, and what the host leaves beyond ``KEEP_BYTES`` is dropped
  and counted).  At the end the board runs on until a frame stamped at or after the end
  has left its UART (what its TX ring still held when its clock passed the end would
  otherwise die with QEMU: how much depends on the host machine's load), then the host
  reads it all.

Disconnect windows are not served (the UART is QEMU's).  An image that exits by itself
(a CPU fault, a broken device channel) ends the run with a ``BoardError``.
"""

import select
import shutil
import tempfile
import time

from tactile_protocol.errors import BoardError
from tactile_protocol.framing import FRAME_OK, FrameAssembler
from tactile_sim.emulator.qemu_core import connect_uart, image
from tactile_sim.emulator.server import Server

RUN_OUT_US = 500_000  # fast, at the end: board time allowed for the TX ring to empty
RUN_OUT_S = 10.0  # ... and wall time
IDLE_S = 0.005
EXITS = {1: "a CPU fault", 2: "no device channel", 3: "the device channel broke"}


class LastFrame:
    """Fast mode's end: whether a frame stamped ``end_us`` or later has left the board.
    Read with the protocol's own framing (the emulator checks the host, not with it)."""

    def __init__(self, end_us):
        self.end_us, self.seen = end_us, False
        self._frames = FrameAssembler()

    def feed(self, data):
        frames = self._frames
        for byte in data:
            if frames.feed(byte) == FRAME_OK:
                try:
                    t_us = frames.message()[2]
                except ValueError:  # a frame of the wrong layout: not a stamp to go by
                    continue
                self.seen = self.seen or t_us >= self.end_us


class QemuServer(Server):
    """See the module docstring; ``board`` is an ``EmulatedBoard(scene, core="qemu")``."""

    def __init__(self, board, link_path=None, realtime=True, faults=None, when_opened=True,
                 **options):  # fmt: skip
        if board.core != "qemu":
            raise ValueError("QemuServer serves an EmulatedBoard built with core='qemu'")
        super().__init__(board, link_path, realtime, faults, when_opened=when_opened, **options)
        self.proc = self.device = self.uart = self.workdir = None
        self.to_board, self.from_board = bytearray(), bytearray()
        self.exit_status = None
        self._last = None  # fast, at the end: a LastFrame watching for the last frame

    # --- the core ---------------------------------------------------------------------------
    @property
    def keeps_for_absent_host(self):
        return not self.realtime  # (the image has no opened signal: its HELLO waits)

    def prepare(self):
        image()  # built (or refused in one line) before the port is offered

    def start(self):
        self.workdir = tempfile.mkdtemp(prefix="tactile-qemu-")
        self.proc, self.device = self.board.board.launch(self.workdir, fast=not self.realtime)
        self.uart = connect_uart(self.workdir, self.proc)
        self.device.open_reply()

    def read(self):
        data = bytes(self.from_board)
        self.from_board.clear()
        return data

    def write(self, data):
        self.to_board += data

    def step(self, held):
        """Host bytes to the UART, the UART's bytes in, and the device requests unless
        ``held`` (the board's time then holds); False once QEMU has ended."""
        poller = select.poll()
        poller.register(self.uart, select.POLLIN | (select.POLLOUT if self.to_board else 0))
        if not held:
            poller.register(self.device.req_fd, select.POLLIN)
        busy = self.readable or (self.to_host and self.endpoint.host_present)
        for fd, ev in poller.poll(0 if busy else IDLE_S * 1000):
            if fd == self.uart.fileno():
                if ev & select.POLLIN and not self._from_uart():
                    return False
                if ev & select.POLLOUT and self.to_board:
                    self._to_uart()
            elif not self.device.serve_burst():
                return False
        if self.proc.poll() is not None:
            self.exit_status = self.proc.returncode
            return False
        return True

    def _from_uart(self):
        try:
            data = self.uart.recv(65536)
        except BlockingIOError:
            return True
        if not data:
            return False
        if self._last is not None:
            self._last.feed(data)
        self.from_board += data
        return True

    def _to_uart(self):
        try:
            n = self.uart.send(self.to_board)
        except BlockingIOError:
            return
        del self.to_board[:n]

    def finish(self):
        """Fast mode's end: run the board until a frame stamped at the end or later has left
        its UART, so the frames its TX ring held at the end reach the host."""
        if self.realtime or self.end_us is None:
            return
        self._last = LastFrame(self.end_us)
        deadline = time.monotonic() + RUN_OUT_S
        try:
            while not (self._last.seen or self.stop) and time.monotonic() < deadline:
                if self.board.t_us >= self.end_us + RUN_OUT_US or not self._turn():
                    return
        finally:
            self._last = None

    def check(self):
        """QEMU stops with status 0 only when told; the image's own exit is a fault."""
        if self.exit_status:
            why = EXITS.get(self.exit_status, "exit status")
            raise BoardError(f"the QEMU image stopped: {why} ({self.exit_status})")

    def halt(self):
        if self.proc is not None and self.proc.poll() is None:
            self.proc.kill()
        if self.proc is not None:
            self.proc.wait(5)
            self.proc.stderr.close()
        if self.uart is not None:
            self.uart.close()
        if self.device is not None:
            self.device.close()
        if self.workdir is not None:
            shutil.rmtree(self.workdir, ignore_errors=True)
        self.proc = self.uart = self.device = self.workdir = None
