"""An emulator stops when told: ``--duration`` ends the run at that scene time whether or not
a host reads, in real time and as fast as possible, and a full pty never holds it forever."""

import itertools
import subprocess
import sys

import pytest
import serial
from toolchain import missing

from tactile.board.stream_decoder import StreamDecoder
from tactile_sim.emulator import load_scene
from tactile_sim.emulator.device import EmulatedBoard
from tactile_sim.emulator.pty_server import PtyServer
from tactile_sim.emulator.server import HOLD_LIMIT_S

pytestmark = pytest.mark.realtime  # on the wall clock: bench/realtime_soak.py
BOUND_S = 60  # far beyond what each run takes (HOLD_LIMIT_S and a second of scene)


def _emulate(*argv):
    """``tactile emulate`` with nobody on its pty: (exit code, stderr) once it ends."""
    proc = subprocess.run(
        [sys.executable, "-m", "tactile.cli.main", "emulate", *argv],
        capture_output=True, text=True, timeout=BOUND_S,
    )  # fmt: skip
    return proc.returncode, proc.stderr


@pytest.mark.parametrize("fast", [False, True])
def test_a_run_nobody_reads_ends_at_its_duration(fast):
    code, err = _emulate("press", "--duration", "1", "--now", *(["--fast"] if fast else []))
    assert code == 0 and "Traceback" not in err, err


def test_a_qemu_run_nobody_reads_ends_at_its_duration():
    from tactile_sim.emulator.qemu_core import QemuUnavailable, image

    try:
        image()
    except QemuUnavailable as exc:
        missing(str(exc))
    code, err = _emulate("press", "--core", "qemu", "--fast", "--duration", "1", "--now")
    assert code == 0 and "Traceback" not in err, err


def _serve_unopened(core, tmp_path, clock):
    """``press`` on ``core`` as fast as possible for 0.3 s of board time, waiting for a host as
    ``tactile emulate`` does without --now; the cores this machine cannot run are skipped."""
    from tactile.errors import TactileError
    from tactile_sim.emulator.servers import serve

    options = {"flash": tmp_path / "board.flash"} if core == "rp2040" else {}
    if core == "rp2040":
        from pico_target import need_pico

        need_pico()
    server = serve("press", core=core, realtime=False, duration_s=0.3, when_opened=True,
                   clock=clock, **options)  # fmt: skip
    try:
        server.prepare()  # (the C core, the QEMU image built here, or refused)
    except TactileError as exc:
        server.close()
        missing(str(exc))
    return server


@pytest.mark.parametrize("core", ["python", "c", "qemu", "rp2040"])
def test_a_run_no_host_opens_ends_at_its_duration_on_every_core(core, tmp_path):
    """Started to wait for a host (the default), no host comes: the wait is a hold like any
    other, at most HOLD_LIMIT_S (the injected clock passes it at once), then the duration
    counts; it used to wait for ever on every core but the Pico."""
    ticks = itertools.count(step=HOLD_LIMIT_S / 4)
    server = _serve_unopened(core, tmp_path, lambda: next(ticks))
    with server:
        assert server.wait(BOUND_S), f"{core}: the run waited for a host that never came"
        assert server.t_us >= 300_000


def test_emulate_without_a_host_ends_at_its_duration():
    code, err = _emulate("press", "--fast", "--duration", "2")  # (no --now: waits for a host)
    assert code == 0 and "Traceback" not in err, err


def test_a_host_that_stops_reading_holds_a_fast_run_for_a_bounded_time():
    """The host opens the port, reads a little and stops: time holds for it (the pty and
    the board's ring fill), then the board runs on to the end, dropping and counting what
    nobody read; the host finds the frames it left as lost, not a hang."""
    ticks = itertools.count(step=HOLD_LIMIT_S / 4)  # each look at the clock: a quarter hold
    server = PtyServer(EmulatedBoard(load_scene("press")), realtime=False, duration_s=2.0,
                       clock=lambda: next(ticks))  # fmt: skip
    decoder = StreamDecoder()
    with server, serial.Serial(server.path, timeout=0.2) as port:
        first = decoder.feed(port.read(2000))  # then nothing more is read
        assert server.wait(BOUND_S), "the run held for a host that stopped reading"
        assert server.board.t_us >= 2_000_000
        rest = decoder.feed(port.read(port.in_waiting or 1))
    assert first and first[0].type_name == "HELLO"
    assert rest  # what the pty held is still there for the host


def test_a_longer_hold_limit_waits_out_a_host_stalled_past_the_default():
    """``hold_limit_s``: a hold lasts that long in a row, not ``HOLD_LIMIT_S`` (a test's
    in-process host can stall for seconds on a loaded machine); a drain's stall too."""
    from tactile_sim.emulator.server import HoldLimit, Stalled

    now = [0.0]
    hold, stalled = HoldLimit(lambda: now[0], 60.0), Stalled(lambda: now[0], 60.0)
    assert hold(True) and not stalled("same")
    now[0] = 2 * HOLD_LIMIT_S  # past the default: a host stalled this long is still held
    assert hold(True) and not stalled("same")
    now[0] = 60.0
    assert not hold(True) and stalled("same")
    assert PtyServer(EmulatedBoard(load_scene("press")), hold_limit_s=60.0)._limit.limit_s == 60


def test_emulate_help_says_duration_ends_the_run(capsys):
    from tactile.cli import main as cli_main

    with pytest.raises(SystemExit) as done:
        cli_main.main(["emulate", "--help"])
    out = " ".join(capsys.readouterr().out.split())
    assert done.value.code == 0
    assert "stop after this much of the board's time, in seconds, whether or not a host came" in out
