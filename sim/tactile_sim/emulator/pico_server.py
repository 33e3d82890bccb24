"""Serve an emulated Raspberry Pi Pico's USB serial port on a pseudo-terminal.

``PicoServer(emulated, flash)`` takes an ``EmulatedBoard`` built with ``core="rp2040"`` (the
scene's sensors, buses and faults) and a flash file, starts the chip (``pico_core``) and
moves bytes between the chip's USB CDC and the pty, which a host opens as it opens
``/dev/ttyACM0``: mpremote, ``tactile flash``, ``tactile record``.

- Real time (default): the chip powers up at once and never runs ahead of the wall clock;
  emulated, it runs slower than a real Pico while busy (docs/emulator.md).  While no host
  has the port open what it sends goes nowhere, as with a USB port nobody reads.
- ``fast``: the chip runs only while a host has the port open (and for ``BOOT_US`` after each
  reset, so a host never interrupts MicroPython's own boot), as fast as it can, and holds
  while more than ``HOLD_BYTES`` wait for the host; its time never skips ahead of a host.

In both, the chip holds while the host leaves more than ``HOLD_BYTES`` unread, so nothing is
lost between the chip and a host that reads.  A hold (for a host that is not there, or
does not read) lasts at most ``HOLD_LIMIT_S`` (pty_server) in a row, so a run always ends
at its duration: then the chip runs on, and what the host leaves beyond ``KEEP_BYTES`` is
dropped and counted (``dropped``).  The pty stays when the chip resets (a real Pico's port
would drop and come back); the scene restarts with the chip's clock.
"""

import time

from tactile_sim.emulator import pty_link
from tactile_sim.emulator.pico_core import PicoError, default_flash
from tactile_sim.emulator.pty_server import (
    DRAINED_S,
    OPEN_SETTLE_S,
    HoldLimit,
    PtyEndpoint,
    Stalled,
)

HOLD_BYTES = 4096
KEEP_BYTES = 1 << 20  # bytes kept for a host that does not read (then dropped, counted)
IDLE_S = 0.005
BOOT_US = 250_000  # fast: a chip runs this long after each reset before it holds for a host


class PicoServer:
    """See the module docstring; ``board`` is an ``EmulatedBoard(scene, core="rp2040")``."""

    def __init__(self, board, flash=None, link_path=None, realtime=True, faults=None,
                 bus_time=True, flash_journal=None):  # fmt: skip
        if board.core != "rp2040":
            raise ValueError("PicoServer serves an EmulatedBoard built with core='rp2040'")
        self.board, self.link_path, self.realtime, self.faults = board, link_path, realtime, faults
        self.flash = flash or default_flash()
        self.bus_time, self.flash_journal = bus_time, flash_journal
        self.endpoint = self.chip = None
        self.to_host = bytearray()
        self.stop = False
        self._present_since = None
        self._held = None
        self._limit = HoldLimit()  # a hold for the host lasts at most HOLD_LIMIT_S
        self.dropped = 0  # bytes for a host that did not read, beyond KEEP_BYTES
        self.board_us = 0.0  # the chip's time powered, over its resets

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

    def launch(self):
        """Power the chip up (before ``serve``: a missing tool or a flash file in use is
        refused before the port is offered)."""
        if self.chip is None:
            self.chip = self.board.board.launch(self.flash, not self.realtime, self.bus_time,
                                                self.flash_journal)  # fmt: skip
        return self.chip

    # --- the run ----------------------------------------------------------------------------
    def serve(self, duration_s=None):
        """Serve until ``stop``, ``duration_s`` of the chip's time, or the chip's end."""
        if self.endpoint is None:
            self.open()
        chip = self.launch()
        end_us = None if duration_s is None else duration_s * 1e6
        self._limit.bounded = end_us is not None  # (a run without an end may hold)
        before, resets = 0.0, 0
        while not self.stop:
            if chip.resets != resets:  # a new clock from 0
                before, resets = self.board_us, chip.resets
            self.board_us = before + chip.t_us
            if end_us is not None and self.board_us >= end_us:
                break
            self._host()
            self._hold()
            chip.serve([self.endpoint.master], IDLE_S)
            if not chip.alive():
                break
            self._to_host()
        if not self.realtime:
            self._let_host_read()
        if chip.fatal:
            raise PicoError(f"the emulated Pico stopped: {chip.fatal}")

    def _host(self):
        """Host presence (announced after ``OPEN_SETTLE_S``, as PtyServer does) and its bytes."""
        ep = self.endpoint
        readable, present = ep._look(0.0)
        now = time.monotonic()
        if not present:
            self._present_since = None
        elif self._present_since is None:
            self._present_since = now
        ep.host_present = present and now - self._present_since >= OPEN_SETTLE_S
        if readable and ep.host_present:
            data = ep.read()
            if data:
                self.chip.to_usb(data)

    def _hold(self):
        present = self.endpoint.host_present
        want = len(self.to_host) > HOLD_BYTES and present
        if not self.realtime and not present and self.chip.t_us >= BOOT_US:
            want = True  # (after its boot, as a board plugged in before the host came)
        held = self._limit(want)
        if held != self._held:
            self.chip.hold(held)
            self._held = held

    def _to_host(self):
        chip, ep = self.chip, self.endpoint
        data = chip.take_usb()
        if data:
            if self.faults is not None:
                data = self.faults.apply(data)
            if ep.host_present and len(self.to_host) < KEEP_BYTES:
                self.to_host += data  # (nobody there: the bytes go nowhere, as on USB)
            elif ep.host_present:
                self.dropped += len(data)
        if self.to_host and ep.host_present:
            n = ep.write(bytes(self.to_host))
            del self.to_host[:n]

    def _let_host_read(self):
        """Fast mode's end: the host reads what is queued before the chip goes."""
        empty_since, stalled = None, Stalled()
        while self.endpoint.host_present and not self.stop and self.chip.alive():
            self._host()
            self.chip.serve([self.endpoint.master], IDLE_S)
            self._to_host()
            state = (len(self.to_host), self.endpoint.unread())
            if stalled(state):
                return
            if any(state):
                empty_since = None
            elif empty_since is None:
                empty_since = time.monotonic()
            elif time.monotonic() - empty_since >= DRAINED_S:
                return

    def close(self):
        if self.chip is not None:
            self.chip.close()
            self.chip = None
        if self.endpoint is not None:
            self.endpoint.close()
        if self.link_path:
            pty_link.remove(self.link_path)
