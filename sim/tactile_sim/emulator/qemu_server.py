"""Serve the C core's Cortex-M0 image, running in QEMU, on a pseudo-terminal.

``QemuServer(emulated)`` takes an ``EmulatedBoard`` built with ``core="qemu"`` (its
simulated sensors, buses, flash and faults) and, once a host opens the pty (or at once),
starts QEMU (``qemu_core``).  One loop then moves bytes between the host's pty and the
nRF51 UART's socket, applies the scene's ``[link]`` faults to what the board sends, and
answers the image's device channel.  As with ``PtyServer``:

- QEMU starts only when a host has had the port open for ``OPEN_SETTLE_S`` (pyserial
  flushes its input at the end of ``open()``), so the host sees the boot's HELLO; the
  image has no ``opened`` signal afterwards, so a host that reopens asks GET_INFO, as it
  does of a Pico;
- real time: QEMU's clock is the host's; a host that does not read makes the firmware's
  TX ring drop and count frames, as on a board;
- ``fast``: QEMU counts instructions (``-icount``, time skips WFI), and the device channel
  is not answered while more than ``HOLD_BYTES`` wait for the host, so the board's time
  holds until the host reads, for at most ``HOLD_LIMIT_S`` (pty_server) in a row: then it
  runs on, and what the host leaves beyond ``KEEP_BYTES`` is dropped and counted
  (``dropped``).  At the end the board runs on until a frame stamped at or after the end
  has left its UART (what its TX ring still held when its clock passed the end would
  otherwise die with QEMU: how much depends on the host machine's load), then the server
  waits for the host to read it all.

Disconnect windows are not served (the UART is QEMU's): ``qemu_server`` refuses a scene
that has them.
"""

import select
import shutil
import tempfile
import time

from tactile_sim.emulator import pty_link
from tactile_sim.emulator.pty_server import (
    DRAINED_S,
    OPEN_SETTLE_S,
    HoldLimit,
    PtyEndpoint,
    Stalled,
)
from tactile_sim.emulator.qemu_core import connect_uart

HOLD_BYTES = 4096  # fast: bytes for the host beyond which the board's time holds
KEEP_BYTES = 1 << 20  # fast: bytes kept for a host that does not read (then dropped, counted)
RUN_OUT_US = 500_000  # fast, at the end: board time allowed for the TX ring to empty
RUN_OUT_S = 10.0  # ... and wall time
CONNECT_TIMEOUT_S = 10.0
IDLE_S = 0.005


class QemuServer:
    """See the module docstring; ``board`` is an ``EmulatedBoard(scene, core="qemu")``."""

    def __init__(self, board, link_path=None, realtime=True, faults=None):
        if board.core != "qemu":
            raise ValueError("QemuServer serves an EmulatedBoard built with core='qemu'")
        self.board, self.link_path, self.realtime, self.faults = board, link_path, realtime, faults
        self.endpoint = None
        self.proc = self.device = self.uart = None
        self.workdir = None
        self.to_host, self.to_board = bytearray(), bytearray()
        self.stop = False
        self.exit_status = None
        self._tail = None  # fast, at the end: (decoder, end_us) watching for the last frame
        self._held = HoldLimit()
        self.dropped = 0  # fast: bytes for a host that did not read, beyond KEEP_BYTES
        self._tail_done = False

    @property
    def path(self):
        return self.link_path or self.endpoint.path

    def open(self):
        self.endpoint = PtyEndpoint()
        if self.link_path:
            try:
                pty_link.point(self.link_path, self.endpoint.path)
            except Exception:
                self.endpoint.close()
                raise
        return self.path

    # --- the run ----------------------------------------------------------------------
    def serve(self, duration_s=None, when_opened=True):
        """Start QEMU (when a host has opened the port, unless ``when_opened`` is False) and
        serve until ``stop``, ``duration_s`` of the board's time, or QEMU's exit."""
        if self.endpoint is None:
            self.open()
        if when_opened and not self._wait_for_host():
            return
        self._launch()
        end_us = None if duration_s is None else int(duration_s * 1e6)
        self._held.bounded = end_us is not None  # (a run without an end may hold)
        try:
            running = True
            while running and not self.stop and (end_us is None or self.board.t_us < end_us):
                running = self._step()
            if not self.realtime:
                if running and end_us is not None:
                    self._run_out(end_us)
                self._let_host_read()
        finally:
            self._halt()

    def _run_out(self, end_us):
        """Fast mode's end: run the board until a frame stamped ``end_us`` or later has left
        its UART, so the frames its TX ring held at the end reach the host."""
        from tactile.board.stream_decoder import StreamDecoder

        self._tail = (StreamDecoder(), end_us)
        deadline = time.monotonic() + RUN_OUT_S
        try:
            while not (self._tail_done or self.stop) and time.monotonic() < deadline:
                if self.board.t_us >= end_us + RUN_OUT_US or not self._step():
                    return
        finally:
            self._tail = None

    def _wait_for_host(self):
        since = None
        while not self.stop:
            _, present = self.endpoint.wait(0.01)
            now = time.monotonic()
            since = (since or now) if present else None
            if since is not None and now - since >= OPEN_SETTLE_S:
                self.endpoint.host_present = True
                return True
        return False

    def _launch(self):
        self.workdir = tempfile.mkdtemp(prefix="tactile-qemu-")
        self.proc, self.device = self.board.board.launch(self.workdir, fast=not self.realtime)
        self.uart = connect_uart(self.workdir, self.proc)
        self.device.open_reply()

    def _step(self, device=True):
        """One exchange: host input, board output, device requests (unless ``device`` is
        False: the board's time then holds); False once QEMU has ended."""
        ep = self.endpoint
        readable, present = ep._look(0.0)
        ep.host_present = present
        if readable:
            self.to_board += ep.read()
        held = self._held(not self.realtime and len(self.to_host) > HOLD_BYTES)
        poller = select.poll()
        poller.register(self.uart, select.POLLIN | (select.POLLOUT if self.to_board else 0))
        if device and not held:
            poller.register(self.device.req_fd, select.POLLIN)
        wait_ms = 0 if readable or (self.to_host and present) else IDLE_S * 1000
        for fd, ev in poller.poll(wait_ms):
            if fd == self.uart.fileno():
                if ev & select.POLLIN and not self._from_board():
                    return False
                if ev & select.POLLOUT and self.to_board:
                    self._to_board()
            elif not self.device.serve_burst():
                return False
        self._to_host()
        if self.proc.poll() is not None:
            self.exit_status = self.proc.returncode
            return False
        return True

    def _from_board(self):
        try:
            data = self.uart.recv(65536)
        except BlockingIOError:
            return True
        if not data:
            return False
        if self.faults is not None:
            data = self.faults.apply(data)
        if self._tail is not None:
            decoder, end_us = self._tail
            stamps = (getattr(m, "timestamp_us", -1) for m in decoder.feed(data))
            self._tail_done = self._tail_done or max(stamps, default=-1) >= end_us
        if not (self.endpoint.host_present or not self.realtime):
            return True  # (real time, nobody there: the bytes go nowhere, as on USB)
        if len(self.to_host) < KEEP_BYTES:
            self.to_host += data
        else:
            self.dropped += len(data)
        return True

    def _to_board(self):
        try:
            n = self.uart.send(self.to_board)
        except BlockingIOError:
            return
        del self.to_board[:n]

    def _to_host(self):
        if self.to_host and self.endpoint.host_present:
            n = self.endpoint.write(bytes(self.to_host))
            del self.to_host[:n]

    def _let_host_read(self):
        """Fast mode's end: the host reads what is queued or in flight before QEMU goes."""
        empty_since, stalled = None, Stalled()
        while self.endpoint.host_present and not self.stop:
            if not self._step(device=False):
                return
            state = (len(self.to_host), self.endpoint.unread())
            if stalled(state):
                return
            if any(state):
                empty_since = None
            elif empty_since is None:
                empty_since = time.monotonic()
            elif time.monotonic() - empty_since >= DRAINED_S:
                return

    def _halt(self):
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

    def close(self):
        self._halt()
        if self.endpoint is not None:
            self.endpoint.close()
        if self.link_path:
            pty_link.remove(self.link_path)
