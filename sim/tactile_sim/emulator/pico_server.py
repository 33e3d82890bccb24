"""An emulated Raspberry Pi Pico's USB serial port on a pseudo-terminal.

``PicoServer(emulated, flash)`` takes an ``EmulatedBoard`` built with ``core="rp2040"`` (the
scene's sensors, buses and faults) and a flash file, powers the chip up (``pico_core``) and
moves bytes between the chip's USB CDC and the host, which opens the pty as it opens
``/dev/ttyACM0``: mpremote, ``tactile flash``, ``tactile record``.  ``Server`` (``server``)
owns the pty, host presence, hold, drain, keep and drop.

- Real time (default): the chip powers up at once and never runs ahead of the wall clock;
  emulated, it runs slower than a real Pico while busy (docs/emulator.md).  While no host
  has the port open what it sends goes nowhere, as with a USB port nobody reads.
- ``fast``: the chip runs only while a host has the port open (and for ``BOOT_US`` after each
  reset, so a host never interrupts MicroPython's own boot), as fast as it can; its time
  never skips ahead of a host.

In both, the chip holds while the host leaves more than ``HOLD_BYTES`` unread, so nothing is
lost between the chip and a host that reads.  A hold (for a host that is not there, or
does not read) lasts at most ``HOLD_LIMIT_S`` in a row, so a run always ends at its
duration: then the chip runs on, and what the host leaves beyond ``KEEP_BYTES`` is dropped
and counted (``dropped``).  A Pico is powered, not opened: it serves at once, whatever
``when_opened`` says.  The pty stays when the chip resets (a real Pico's port would drop
and come back); the scene restarts with the chip's clock.
"""

from tactile_sim.emulator.pico_core import PicoError, default_flash
from tactile_sim.emulator.server import HOLD_BYTES, Server

IDLE_S = 0.005
BOOT_US = 250_000  # fast: a chip runs this long after each reset before it holds for a host


class PicoServer(Server):
    """See the module docstring; ``board`` is an ``EmulatedBoard(scene, core="rp2040")``."""

    def __init__(self, board, flash=None, link_path=None, realtime=True, faults=None,
                 bus_time=True, flash_journal=None, **options):  # fmt: skip
        if board.core != "rp2040":
            raise ValueError("PicoServer serves an EmulatedBoard built with core='rp2040'")
        super().__init__(board, link_path, realtime, faults, **options)
        self.when_opened = False  # (powered with its USB cable)
        self.flash = flash or default_flash()
        self.bus_time, self.flash_journal = bus_time, flash_journal
        self.chip = None
        self.board_us = 0.0  # the chip's time powered, over its resets
        self._before, self._resets = 0.0, 0  # board_us at the chip's last reset, and resets
        self._held = None  # what the chip was last told

    def launch(self):
        """Power the chip up (a missing tool or a flash file in use is refused before the
        port is offered)."""
        if self.chip is None:
            self.chip = self.board.board.launch(self.flash, not self.realtime, self.bus_time,
                                                self.flash_journal)  # fmt: skip
        return self.chip

    # --- the core ---------------------------------------------------------------------------
    def prepare(self):
        self.launch()

    def start(self):
        self.launch()

    @property
    def t_us(self):
        """The chip's time powered (``board_us``), counted on over its resets."""
        chip = self.chip
        if chip is None:  # (halted: its time as it ended)
            return self.board_us
        if chip.resets != self._resets:  # a new clock from 0, and the scene with it
            self._before, self._resets = self.board_us, chip.resets
            self.board.restart_scene(0, faults=False)
        self.board_us = self._before + chip.t_us
        return self.board_us

    def scene_at_us(self):
        """The chip's clock (the firmware's stamps) at the scene's start: its first I2C
        transaction after its last reset, and from there the scene's latest start."""
        origin = self.chip.origin if self.chip is not None else None
        return int(origin or 0) + self.board.scene_start_us

    def models_us(self):
        return self.chip.scene_us  # (the chip's latest time, not its latest I2C's)

    def wants_hold(self):
        present = self.endpoint.host_present
        if not self.realtime and not present and self.chip.t_us >= BOOT_US:
            return True  # (after its boot, as a board plugged in before the host came)
        return present and len(self.to_host) > HOLD_BYTES

    def step(self, held):
        chip = self.chip
        if held != self._held and not self.draining:  # (draining: as it was, so its USB empties)
            chip.hold(held)
            self._held = held
        chip.serve([self.endpoint.master], IDLE_S)
        return chip.alive()

    def read(self):
        return self.chip.take_usb()

    def write(self, data):
        self.chip.to_usb(data)

    def check(self):
        if self.chip.fatal:
            raise PicoError(f"the emulated Pico stopped: {self.chip.fatal}")

    def halt(self):
        if self.chip is not None:
            self.chip.close()
            self.chip = None
