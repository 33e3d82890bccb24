"""An emulator run twice: each new host session plays the scene again from its start, the
robot's log written again for it (``tactile emulate``'s default); ``--once`` plays it once,
and ``record`` then says the log had ended and how to start again; the emulator's own
unplugged port coming back is the same session, not a new one."""

import json
import os
import signal
import subprocess
import sys
import time
from contextlib import contextmanager

import pytest
import serial

from tactile.logs.read import read_pose_log
from tactile_sim.emulator import load_scene
from tactile_sim.emulator.device import EmulatedBoard
from tactile_sim.emulator.pty_server import PtyServer

pytestmark = pytest.mark.realtime  # on the wall clock: bench/realtime_soak.py


@contextmanager
def emulating(cwd, *argv):
    """``tactile emulate ARGV`` in the background in ``cwd``: its pty, until the block ends."""
    proc = subprocess.Popen(
        [sys.executable, "-m", "tactile.cli.main", "emulate", *argv], cwd=cwd, text=True,
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, start_new_session=True,
    )  # fmt: skip
    try:
        pty = proc.stdout.readline().strip()
        assert pty.startswith("/dev/"), proc.stderr.read()
        yield pty
    finally:
        os.killpg(proc.pid, signal.SIGTERM)
        proc.wait(10)


def _record(cli, pty, cwd, run):
    return cli("record", "--port", pty, "--pose-log", cwd / "sweep.csv", "-o", cwd / run,
               "--quiet")  # fmt: skip


def _starts(path):
    """The log's window starts and its end (board us)."""
    log = read_pose_log(path)
    return [int(t) for t in log.t_start], log.end_us


@pytest.mark.slow
def test_record_twice_on_one_emulator_records_the_robots_run_twice(cli, tmp_path):
    with emulating(tmp_path, "ep2_sweep_sphere", "--fast", "--pose-log", "sweep.csv") as pty:
        written = _starts(tmp_path / "sweep.csv")
        metas = []
        for run in ("run1", "run2"):
            code, out, err = _record(cli, pty, tmp_path, run)
            assert code == 0, err
            assert "(stopped by the pose log's end)" in out and "lost 0 frames" in out, out
            metas.append(json.loads((tmp_path / run / "meta.json").read_text()))
        again = _starts(tmp_path / "sweep.csv")
    # the whole sweep both times: as many contacts, and the second on the sphere too
    assert metas[0]["contacts_ended"] == metas[1]["contacts_ended"] == 3  # one per finger
    assert min(m["samples"] for m in metas) > 1000  # (1,305 readings a sweep)
    code, out, err = cli("ep2", "analyze", tmp_path / "run2" / "contacts.csv", "--json")
    fit = json.loads(out.splitlines()[0])
    assert code == 0 and fit["S"] > 0.9 and abs(fit["radius"] - 0.05) < 0.005, out
    # the log of the second run: the same robot's run, stamped from the board's time at its
    # start, which came after the first run's end
    shift = again[1] - written[1]
    assert shift >= metas[0]["device_time_s"] * 1e6
    assert again[0] == [t + shift for t in written[0]]
    assert metas[1]["time_base"]["segments"][0]["board_first_us"] >= shift


@pytest.mark.slow
def test_with_once_a_second_record_says_the_robots_log_has_ended(cli, tmp_path):
    with emulating(tmp_path, "ep2_sweep_sphere", "--fast", "--once", "--pose-log",
                   "sweep.csv") as pty:  # fmt: skip
        assert _record(cli, pty, tmp_path, "run1")[0] == 0
        code, out, err = _record(cli, pty, tmp_path, "run2")
    assert code == 3 and err.count("\n") == 1, err
    assert "sweep.csv: the robot's log ended at board 2.878 s, before this recording began" in err
    assert "start the robot again (an emulator: 'tactile emulate' again, or without --once)" in err
    assert "TARE" not in err and (tmp_path / "run2" / "capture.bin").stat().st_size > 0


def test_the_emulators_own_unplugged_port_coming_back_is_the_same_session(tmp_path):
    """A scene's [link] disconnect window: the host that opens the port again after it is
    the session that was there, and the scene runs on; a host that opens it later is a new
    session, and the scene starts again (the board's clock and settings run on)."""
    path = tmp_path / "unplug.toml"
    path.write_text(load_scene("press").path.read_text() + "\n[link]\ndisconnect = [[0.2, 0.3]]\n")
    scene, starts = load_scene(path), []
    board = EmulatedBoard(scene)
    server = PtyServer(board, link_path=str(tmp_path / "board"), realtime=False,
                       disconnects=scene.link["disconnect"], replay=True,
                       on_scene=starts.append)  # fmt: skip
    with server:
        with serial.Serial(server.path, timeout=0.05) as port:
            with pytest.raises(serial.SerialException):  # the port dies in the window
                while True:  # (the board's time runs while the host reads)
                    port.read(4096)
        while server.reconnects == 0:
            time.sleep(0.01)
        with serial.Serial(server.path, timeout=0.05) as port:  # back, behind the link
            while board.t_us < 400_000:
                port.read(4096)
        assert server.replays == 0 and starts == [] and board.scene_start_us == 0
        with serial.Serial(server.path, timeout=0.05) as port:  # a new host session
            while server.replays == 0:
                port.read(4096)
    assert starts == [board.scene_start_us] and board.scene_start_us >= 400_000


def test_a_host_that_closes_and_opens_again_at_once_is_a_new_session():
    """A host that opens the port again before the server has looked (a script's next
    command; a loaded machine) is a new session all the same: pyserial's open flushes the
    port's input, which the pty's packet mode lets the server hear.  It used to be taken
    for the host that had left, the scene not played again (a second record found the
    robot's log over)."""
    starts = []
    board = EmulatedBoard(load_scene("press"))
    server = PtyServer(board, realtime=False, replay=True, when_opened=True,
                       on_scene=starts.append)  # fmt: skip
    with server:
        port = serial.Serial(server.path, timeout=0.5)
        assert port.read(1)  # the first session: the board is sending
        for k in range(1, 4):
            port.close()
            port = serial.Serial(server.path, timeout=0.5)  # at once: no wait for the server
            until_us = board.t_us + 2_000_000  # (a new session comes long before)
            while server.replays < k and board.t_us < until_us:
                port.read(4096)
            assert server.replays == k, f"open {k + 1}: taken for the host that had left"
        port.close()
    assert server.replays == 3 and len(starts) == 3


@pytest.mark.parametrize("scene", ["ch5_convex", "ep2_sweep_sphere", "ep1_roll", "payload_poses"])
def test_every_robot_log_is_written_from_the_scenes_start(scene, tmp_path):
    """Each motion's robot log, written for a start of the scene at board time T, is the log
    of its start at 0 moved by T: every window and the end (what emulate writes at a replay)."""
    from tactile_sim.commands.emulate import _write_log

    motion = EmulatedBoard(load_scene(scene)).motion
    texts = []
    for at_us in (0, 12_345_678):
        _write_log(motion, tmp_path / f"{at_us}.csv", at_us)
        texts.append((tmp_path / f"{at_us}.csv").read_text().splitlines())
    head = next(i for i, line in enumerate(texts[0]) if not line.startswith("#"))
    names = texts[0][head].split(",")
    starts = [names.index(c) for c in names if c.startswith(("t_start", "t_end"))]
    assert len(starts) == 2 and len(texts[0]) == len(texts[1]) > head + 1
    for a, b in zip(texts[0][head + 1 :], texts[1][head + 1 :]):
        a, b = a.split(","), b.split(",")
        assert [int(b[k]) - int(a[k]) for k in starts] == [12_345_678] * 2
        assert [v for k, v in enumerate(a) if k not in starts] == [
            v for k, v in enumerate(b) if k not in starts
        ]
    (end0,) = [ln for ln in texts[0] if ln.startswith("# end:")]
    (end1,) = [ln for ln in texts[1] if ln.startswith("# end:")]
    assert int(end1.split("=")[1]) - int(end0.split("=")[1]) == 12_345_678
