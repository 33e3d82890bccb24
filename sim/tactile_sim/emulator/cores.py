"""The firmware cores an emulated board can run, by name: ``python``, ``c`` and ``qemu``.

- ``python``: ``tactile_fw.board.Board``, the MicroPython firmware, on the simulated buses;
- ``c``: the C core (``firmware/c``) built by ``cc`` into ``$XDG_CACHE_HOME/tactile/ccore``
  (once per version of its sources, named by their hash) and driven through ctypes
  (``tactile_fw_tools.ccore``): its HAL's I2C calls reach the same simulated buses
  and ADC models (the sampling reads answered by their C mirror, ``adc_bank``); its byte
  link, clock and flash are the same ``PipeLink``, ``ManualClock`` and ``MemoryStorage``.

Both take the same arguments and give an object with ``boot``, ``poll``, ``idle_us``,
``max_rate_hz`` and the STATUS counters, so nothing above this module knows which runs;
for the same scene and boot id the two write the same bytes (tests/test_emulator_cores.py).
``qemu`` (``qemu_core``) is the C core cross-compiled for a Cortex-M0 and run by QEMU on
its own clock: served on a pty only (``qemu_server``), never stepped in process; so is
``rp2040`` (``pico_core``), stock MicroPython on an emulated Raspberry Pi Pico, which runs
whatever ``tactile flash`` put on it.
"""

import functools

from tactile_fw.board import Board
from tactile_fw.frontend import make_sensor
from tactile_fw_tools import ccore
from tactile_protocol.errors import BoardError
from tactile_sim.emulator import adc_bank
from tactile_sim.emulator.cache import cache_dir
from tactile_sim.emulator.pico_core import PicoBoard
from tactile_sim.emulator.qemu_core import QemuBoard

CORES = ("python", "c")  # a scene's [board] core, sim://?core=
SERVED = (*CORES, "qemu", "rp2040")  # also on a pty only: QEMU's image, the emulated Pico
DEFAULT_CORE = "python"
C_I2C = "bank"  # or "callbacks": the C core's I2C through Python per transaction (tests)


class CoreUnavailable(BoardError):
    """The core cannot run here (the C core without a C compiler); one line, exit 4."""


@functools.lru_cache(maxsize=1)
def c_library():
    """The C core as a loaded shared library, built on first use (cached across runs)."""
    try:
        return ccore.load(ccore.build(cache_dir(), name="libtactile_core-{digest}.so"))
    except ccore.NoCompiler as exc:
        raise CoreUnavailable(f"core 'c': {exc}") from None
    except ccore.CoreBuildError as exc:
        first = str(exc).splitlines()[-1] if str(exc).strip() else "no message"
        raise CoreUnavailable(f"core 'c': the C compiler refused firmware/c: {first}") from None
    except OSError as exc:
        raise CoreUnavailable(f"core 'c': cannot build in {cache_dir()}: {exc}") from None


def python_board(buses, layout, link, clock, storage, **kw):
    sensors = [make_sensor(buses[bus], slot, bus_key=bus) for bus, slot in layout]
    return Board(sensors, link, clock, storage, **kw)


def c_i2c(buses):
    """What answers the C core's I2C: the converters mirrored in C (``adc_bank``) when
    ``C_I2C`` is ``"bank"`` and they can be, else None (a Python callback per transaction)."""
    if C_I2C != "bank" or not adc_bank.mirrorable(buses):
        return None
    try:
        return adc_bank.AdcBank(buses)
    except (ccore.NoCompiler, ccore.CoreBuildError, OSError) as exc:
        raise CoreUnavailable(f"core 'c': cannot build the emulator's ADC bank: {exc}") from None


def c_board(buses, layout, link, clock, storage, **kw):
    lib = c_library()
    return ccore.CBoard(lib, buses, layout, link, clock, storage, i2c=c_i2c(buses), **kw)


BUILDERS = {"python": python_board, "c": c_board, "qemu": QemuBoard, "rp2040": PicoBoard}


def wiring(core, i):
    """Sensor ``i``'s (bus, address block).  The Pico's firmware spreads sensors over its two
    controllers first (docs/firmware.md); the other cores fill a bus's two blocks first."""
    return (i % 2, i // 2) if core == "rp2040" else (i // 2, i % 2)


def make_board(core, buses, layout, link, clock, storage, **kw):
    """Firmware ``core`` on ``buses`` (by index); ``layout``: (bus, address slot) per sensor.

    ``kw``: ``max_rate_hz``, ``boot_id`` (as ``Board`` takes them).
    """
    return BUILDERS[core](buses, layout, link, clock, storage, **kw)


def tx_dropped(board):
    """Frames the board's TX ring dropped (either core)."""
    tx = getattr(board, "tx", None)
    return tx.dropped if tx is not None else board.tx_dropped
