"""The emulated board: a real firmware core on simulated hardware.

The core is the scene's ``[board] core`` or the caller's choice (``cores``): the
MicroPython firmware (``tactile_fw.board.Board``) or the C core (``firmware/c``).

Per sensor: six ADS122C04 register models on a simulated I2C bus
(``tactile_sim.adc_model``, ``tactile_sim.i2c_bus``), each converting one
gauge of the transducer model, which the motion loads (plus the tool's weight at the
sensor's orientation, ``tool_weight``).  The clock is simulated and jumps straight
to the next thing that can happen (a due sample or a conversion end), so
"as fast as possible" costs only the firmware's own work.  The byte link is
the firmware's ``PipeLink``; the host side reads with ``take`` and writes
with ``put``.  Nothing here frames, checksums or encodes: the firmware does.

Each emulated board has its own board id (HELLO/INFO ``board_id``, the id a host checks
after a lost port): 8 random bytes unless the caller names one (``board_id``; ``tactile
emulate --link`` derives it from the link, so that an emulator restarted behind the same
link is the same board, rebooted: ``link_board_id``).  An emulated Pico's is its flash
chip's, one per flash file (``pico_core.flash_board_id``).
"""

import hashlib
import importlib
import math
import os

from tactile_fw import calibration, settings
from tactile_fw.frontend import ADDRESS_PLAN
from tactile_fw.identity import boot_id_from
from tactile_fw.link import PipeLink
from tactile_fw.storage import MemoryStorage
from tactile_fw.timing import ManualClock
from tactile_protocol import settings as vocabulary
from tactile_sim.adc_model import FULL_SCALE_CODES, ADS122C04Model
from tactile_sim.emulator import cores
from tactile_sim.emulator.ft_model import FTModel
from tactile_sim.emulator.gauge_drift import GaugeDrift
from tactile_sim.emulator.scene import MOTIONS
from tactile_sim.emulator.sensor_faults import FaultSchedule
from tactile_sim.emulator.tool_weight import ToolWeight
from tactile_sim.i2c_bus import SimI2C

LINK_CAPACITY = 1 << 16  # bytes the host side may leave unread (a USB/pty buffer)


def link_board_id(path):
    """The board id of the emulated board behind the link ``path`` (8 bytes): the same for
    every emulator served there, another for another path."""
    return hashlib.sha256(
        b"tactile emulated board\0" + os.fsencode(os.path.abspath(path))
    ).digest()[:8]


def build_motion(scene):
    return importlib.import_module(MOTIONS[scene.motion["kind"]]).build(scene)


def board_settings(scene, max_rate_hz):
    """The settings a shipped scene stores on the board (streaming from boot).

    The schema has checked each key; the firmware's own check remains the authority on
    what only the built board knows, the rate ceiling of its sensors on their buses.
    """
    b = scene.board
    s = settings.Settings(
        b["rate_hz"],
        vocabulary.to_counts(b["enter_threshold_N"]),
        vocabulary.to_counts(b["exit_threshold_N"]),
        b["debounce"],
        vocabulary.config_flags(b["gate"], b["streams"], b["autostart"]),
    )
    bad = vocabulary.check(*s.fields(), max_rate_hz)
    if bad == vocabulary.F_RATE:
        n = b["sensors"]
        why = (
            f"[board] max_rate_hz ({max_rate_hz})"
            if b["max_rate_hz"]
            else f"{max_rate_hz}, the ceiling of {n} sensor{'s' * (n > 1)} on this board"
        )
        raise scene.error("[board] rate_hz", f"must be <= {why}")
    if bad >= 0:
        field = ("rate_hz", "enter_threshold_N", "exit_threshold_N", "debounce", "streams")[bad]
        raise scene.error(f"[board] {field}", "refused by the firmware's settings check")
    return s


class EmulatedBoard:
    """Firmware + simulated sensors on simulated time; see the module docstring.

    ``core``: ``"python"`` or ``"c"`` (``cores.CORES``); None: the scene's ``[board] core``;
    ``"qemu"``: the hardware for ``qemu_server``, which runs the image (no ``step`` then);
    ``"rp2040"``: the hardware around an emulated Pico for ``pico_server`` (the scene's
    settings and calibration are not stored: the chip's flash holds what its user put there).
    """

    def __init__(self, scene, motion=None, boot_id=None, core=None, board_id=None):
        self.scene = scene
        self.core = core or scene.board["core"]
        if self.core not in cores.SERVED:
            raise ValueError(f"core must be one of {', '.join(cores.SERVED)}, got {self.core!r}")
        self.motion = motion if motion is not None else build_motion(scene)
        self.clock = ManualClock(0)
        self.scene_start_us = 0  # the models' time at which the scene (last) started
        self.link = PipeLink(LINK_CAPACITY)
        self.buses, self.adcs, self.models = [], [], []
        layout = [self._sensor(i) for i in range(scene.board["sensors"])]
        override = scene.board["max_rate_hz"] or None
        if override:
            period = 1e6 / override
            for adc in self.adcs:
                adc.conv_period_override = period
        storage = MemoryStorage()
        if boot_id is None:  # a new one per power-up, as a real board draws it
            boot_id = boot_id_from(os.urandom(8))
        if board_id is None and self.core != "rp2040":  # (a Pico's is its flash chip's)
            board_id = os.urandom(8)
        self.board_id = board_id
        self.board = cores.make_board(
            self.core,
            self.buses,
            layout,
            self.link,
            self.clock,
            storage,
            max_rate_hz=override,
            boot_id=boot_id,
            board_id=self.board_id,
        )
        if self.core != "rp2040":  # (a Pico's own flash holds what its user stored)
            board_settings(scene, self.board.max_rate_hz).save(storage)
            cal_id = scene.sensor["cal_id"]
            for i, model in enumerate(self.models):
                calibration.Calibration(model.calibration_coefficients(), cal_id).save(storage, i)
        self.faults = FaultSchedule.from_scene(scene, self)
        if self.core in ("qemu", "rp2040"):
            self.board.faults = self.faults  # applied at the board's own time
        self.board.boot()

    def _sensor(self, i):
        bus_index, slot = cores.wiring(self.core, i)
        while bus_index >= len(self.buses):
            self.buses.append(SimI2C())
        bus = self.buses[bus_index]
        weight = ToolWeight.from_scene(self.scene)
        model = FTModel(
            self.scene.sensor,
            self._scene_time(
                (lambda t, i=i: self.motion.wrench_at(t, i)) if weight is None
                else weight.loaded(self.motion, i)
            ),
            seed=self.scene.seed * 7919 + i,
            drift=GaugeDrift.from_sensor(self.scene.sensor, self.scene.seed, i),
        )  # fmt: skip
        self.models.append(model)
        for j, addr in enumerate(ADDRESS_PLAN[slot]):
            adc = ADS122C04Model(self._now)
            adc.source = self._gauge_source(model, adc, j)
            bus.attach(addr, adc)
            self.adcs.append(adc)
        return bus_index, slot

    @staticmethod
    def _gauge_source(model, adc, j):
        """Gauge j in volts at the converter's current reference and gain (its full scale)."""
        values = model.gauge_values

        def volts(t_us):
            return values(t_us)[j] * adc.vref_v / adc.pga_gain / FULL_SCALE_CODES

        volts.gauges, volts.gauge, volts.adc = values, j, adc  # for adc_bank's mirror
        return volts

    def _now(self):
        return self.clock.t_us

    def _scene_time(self, wrench_at):
        """``wrench_at(t_s)`` of the scene's time, taken at the models' time ``t_s``."""
        return lambda t: wrench_at(t - self.scene_start_us * 1e-6)

    def restart_scene(self, t_us, faults=True):
        """Play the scene from its start at the models' time ``t_us`` (the board runs on,
        its settings and clock as they are): the motion and, with ``faults``, the sensor
        faults count from there."""
        self.scene_start_us = int(t_us)
        if faults and self.faults is not None:
            self.faults.restart(t_us)

    @property
    def t_us(self):
        return self.clock.t_us

    @property
    def tx_dropped(self):
        """Frames the firmware dropped because the host did not read them."""
        return cores.tx_dropped(self.board)

    def _next_conversion_us(self):
        t = self.clock.t_us
        best = None
        for adc in self.adcs:
            if adc.running:
                period = adc.period
                k = math.floor((t - adc.t_start) / period) + 1
                nxt = adc.t_start + k * period
                best = nxt if best is None or nxt < best else best
        return 1 if best is None else max(1, math.ceil(best - t))

    def step(self, limit_us=None):
        """One firmware poll, then advance simulated time to the next event."""
        if self.faults is not None:
            self.faults.update(self.clock.t_us)
        self.board.poll()
        dt = self.board.idle_us() or self._next_conversion_us()
        if self.faults is not None and (nxt := self.faults.next_us()) is not None:
            dt = max(1, min(dt, nxt - self.clock.t_us))
        if limit_us is not None:
            dt = max(0, min(dt, limit_us - self.clock.t_us))
        self.clock.t_us += dt

    def skip_to(self, t_us):
        """Move simulated time to ``t_us`` without polling: the polls an overloaded board had
        no time for.  The firmware sees the missed periods at its next poll (overruns, the
        sample-late flag), as on the chip."""
        self.clock.t_us = max(self.clock.t_us, int(t_us))

    def run_until(self, t_us):
        """Run the firmware until simulated time ``t_us``."""
        while self.clock.t_us < t_us:
            self.step(t_us)
        self.board.poll()

    # host side of the link
    def read_host(self):
        return self.link.take()

    def write_host(self, data):
        self.link.put(data)

    def host_opened(self):
        self.link.host_open()

    def set_host_reading(self, reading):
        self.link.paused = not reading
