"""The emulated Raspberry Pi Pico for tests: what it needs, a served port, a flashed board.

- ``need_pico()``: node, the npm packages (installed once) and ``../shared/rp2``; without
  one a test is skipped with the line naming what to install, and fails instead under CI
  (``CI=true``), where everything must be there.
- ``serve(scene, flash)``: a ``PicoServer`` on a pty, as ``tactile emulate SCENE --core
  rp2040 --flash FILE`` serves it: ``with serve(...) as server`` (``.path``, ``.chip``).
- ``flash_master(dir)``: a flash file with the firmware on it, flashed once per test session
  the way a user flashes a board (``tactile flash``); the ``pico_flashed`` fixture (conftest)
  gives each test its own copy.
"""

import fcntl
import os

from toolchain import missing


def need_pico():
    """Skip (fail under CI) with one line when the emulated Pico cannot run here."""
    from tactile_sim.emulator import pico_core

    try:
        pico_core.rp2_dir()
        pico_core.node()
        pico_core.ensure_npm(quiet=True)
    except pico_core.PicoUnavailable as exc:
        missing(str(exc))


def serve(scene="press", flash=None, fast=False, bus_time=True, flash_journal=None):
    """An emulated Pico serving ``scene`` on a pty until the block ends (a ``PicoServer``;
    ``flash_journal``: a file that gets every erase and program of its flash)."""
    from tactile_sim.emulator import servers

    need_pico()
    return servers.serve(scene, core="rp2040", flash=flash, realtime=not fast,
                         bus_time=bus_time, flash_journal=flash_journal)  # fmt: skip


def wait_booted(server, timeout_s=60.0):
    """Wait until the firmware on ``server``'s chip has started its sensors (its first I2C
    transaction): a host talking to a Pico during MicroPython's own boot, before main.py
    turns Ctrl-C off, can interrupt it, as on a real board plugged in a moment ago."""
    import time

    end = time.monotonic() + timeout_s
    while server.chip.requests == 0:
        assert time.monotonic() < end, "the firmware did not start its sensors"
        time.sleep(0.02)


def flash_master(session_dir, n_sensors=1):
    """A flash file holding the firmware, flashed the way a user flashes a board (``tactile
    flash --sensors n_sensors``), once per ``session_dir`` (``pico_master``: every xdist
    worker of a run shares it)."""
    from tactile.board import flashing

    need_pico()
    master = session_dir / f"pico-firmware-{n_sensors}.flash"
    with open(session_dir / f"pico-firmware-{n_sensors}.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)  # (xdist's workers share the directory: one flashes)
        if not master.exists():
            work = session_dir / f"flashing-{n_sensors}.flash"
            with serve(flash=work) as server:
                flashing.flash(server.path, n_sensors=n_sensors)
            os.replace(work, master)
    return master
