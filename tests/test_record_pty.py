"""End to end through the emulator on a real pseudo-terminal (issue 7): record, then analyse.

The host side is exactly what runs against a board: ``tactile record`` (or the replica's
``Session``) opens the pty's path with pyserial, waits for HELLO, TAREs, records; then
``tactile ep2 analyze`` / ``tactile ep1 estimate`` read the derived files.  The three
ch. 5 surfaces recorded over a pty and classified are the demo's recordings, checked by
tests/test_readme_demo.py (the suite runs the demo once).
"""

import json

import pytest

from tactile_sim.emulator import load_scene
from tactile_sim.emulator.device import EmulatedBoard
from tactile_sim.emulator.pty_server import PtyServer

pytestmark = pytest.mark.realtime  # on the wall clock: bench/realtime_soak.py


def _analyze(cli, csv, *extra):
    code, out, err = cli("ep2", "analyze", csv, "--json", *extra)
    assert code == 0, err
    return json.loads(out.splitlines()[0])


HOST_STALL_S = 60.0  # far beyond any stall, and the run still ends


def served_when_opened(scene, realtime=True):
    """``scene`` served on a pty once a host has the port open (a board powered by USB),
    for its motion's duration: ``with served_when_opened(scene) as served``."""
    board = EmulatedBoard(scene)
    duration = board.motion.duration_s + 0.1
    # a loaded machine can stall the in-process host for seconds (an import): as fast as
    # possible, the board's time holds for it that long rather than run on and drop frames
    return PtyServer(board, realtime=realtime, duration_s=duration, when_opened=True,
                     hold_limit_s=HOST_STALL_S)  # fmt: skip


def _scene_with(tmp_path, name, extra):
    path = tmp_path / f"{name}.toml"
    path.write_text(load_scene(name).path.read_text() + "\n" + extra + "\n")
    return load_scene(str(path))


@pytest.mark.slow
def test_record_cli_over_a_pty_gives_ep2_contacts_for_a_three_finger_sweep(cli, tmp_path):
    scene = _scene_with(tmp_path, "ep2_sweep_sphere", "rest_s = 0.3")  # time to connect
    # As fast as possible: the board's time holds for the host, so the readings (and the
    # fit) are the scene's whatever the machine's load; real time drops or flags late.
    log, out = tmp_path / "poses.csv", tmp_path / "run"
    with served_when_opened(scene, realtime=False) as served:
        served.board.motion.write_pose_log(log)
        code, stdout, err = cli("record", "--port", served.path, "--no-tare", "--contacts", "3",
                                "--pose-log", log, "-o", out, "--quiet")  # fmt: skip
    assert code == 0, err
    assert "contact readings localised (m)" in stdout and "lost 0 frames" in stdout
    result = _analyze(cli, out / "contacts.csv")
    assert result["shape"] == "sphere" and abs(result["radius"] - 0.05) / 0.05 < 0.1


@pytest.mark.slow
def test_record_cli_over_a_pty_gives_ep1_probes_for_a_rolling_fingertip(cli, tmp_path):
    log, out = tmp_path / "probes_log.csv", tmp_path / "run"
    with served_when_opened(load_scene("ep1_roll"), realtime=False) as served:  # (as above)
        motion = served.board.motion
        motion.write_probe_log(log)
        code, stdout, err = cli("record", "--port", served.path, "--contacts", "1",
                                "--pose-log", log, "-o", out, "--quiet")  # fmt: skip
    assert code == 0, err
    assert "8 of 8 probes usable" in stdout
    code, est, err = cli("ep1", "estimate", out / "probes.csv", "--finger-radius", "0.01", "--json")
    assert code == 0, err
    got = json.loads(est)
    true = motion.true_curvature()
    # 25 %: the bench's p90 error at this noise is 16 % (kx) and 11 % (ky), docs/ep1.md
    assert abs(got["kx"] - true["kx"]) / true["kx"] < 0.25
    assert abs(got["ky"] - true["ky"]) / true["ky"] < 0.25


def test_emulate_and_record_as_two_processes(cli, tmp_path):
    """The user's flow: 'tactile emulate' in one terminal, 'tactile record' in another
    (--fast: its time holds for the host, so nothing is lost however loaded the machine;
    in real time a host that stalls makes the board drop frames, as a board does)."""
    import subprocess
    import sys

    emulate = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "tactile.cli.main",
            "emulate",
            "press",
            "--fast",
            "--duration",
            "30",
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        path = emulate.stdout.readline().strip()
        assert path.startswith("/dev/"), emulate.stderr.read()
        code, stdout, err = cli("record", "--port", path, "--contacts", "1", "-o", tmp_path,
                                "--quiet")  # fmt: skip
    finally:
        emulate.terminate()
        emulate.wait(5)
    assert code == 0, err
    meta = json.loads((tmp_path / "meta.json").read_text())
    assert meta["contacts_ended"] == 1 and meta["decoder"]["lost_frames"] == 0
    assert meta["device"]["sensor_model"] == "FT6/ADS122C04x6"


def test_emulate_pose_log_needs_a_scene_with_a_robot_log(cli, tmp_path):
    code, _, err = cli("emulate", "press", "--pose-log", tmp_path / "p.csv")
    assert code == 2 and "this scene's motion has no robot log" in err


def _emulate(*args):
    """``tactile emulate ARGS`` as its own process, once it has printed its pty."""
    import subprocess
    import sys

    proc = subprocess.Popen(
        [sys.executable, "-m", "tactile.cli.main", "emulate", *map(str, args)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    if not proc.stdout.readline().strip():  # the path (or the --link), once serving
        pytest.fail(proc.stderr.read())  # (it exited: the read cannot block)
    return proc


def _record_across_a_restart(tmp_path, *second):
    """``record`` on an emulator behind --link that is killed half a second in and started
    again behind the same link (``second``: its extra arguments); (record process, out)."""
    import subprocess
    import sys
    import time

    link, out = tmp_path / "ttyTACTILE", tmp_path / "run"
    first = _emulate("press", "--link", link, "--duration", "30")
    record = subprocess.Popen(
        [sys.executable, "-m", "tactile.cli.main", "record", "--port", str(link),
         "--duration", "3", "-o", str(out), "--quiet", "--reconnect", "10"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    again = None
    try:
        deadline = time.monotonic() + 10
        while not (out / "meta.json").exists() and time.monotonic() < deadline:
            time.sleep(0.05)
        time.sleep(0.5)  # half a second of stream from the first board
        first.kill()  # the board dies: no goodbye, the pty just goes
        first.wait(5)
        again = _emulate("press", "--link", link, "--duration", "30", *second)
        stdout, err = record.communicate(timeout=30)
    finally:
        for proc in (first, record, again):
            if proc is not None and proc.poll() is None:
                proc.kill()
                proc.wait(5)
    return record.returncode, err, out


@pytest.mark.slow
def test_a_board_killed_and_restarted_behind_link_is_one_reboot_and_nothing_lost(tmp_path):
    """The new board's seq-0 HELLO goes to nobody: the host first sees HELLO seq 1 of a
    new boot id, which is a reboot, not a gap of lost (or out-of-order) frames.  The same
    link is the same board (its board id), so the run goes on."""
    from tactile.board.stream_decoder import decode_bytes

    code, err, out = _record_across_a_restart(tmp_path)
    assert code == 0 and "Traceback" not in err, err
    meta = json.loads((out / "meta.json").read_text())
    assert meta["reboots"] == 1 and len(meta["gaps"]) == 1 and meta["gaps"][0]["rebooted"]
    d = meta["decoder"]
    assert (d["reboots"], d["lost_frames"], d["out_of_order"]) == (1, 0, 0)
    capture = (out / "capture.bin").read_bytes()
    messages, replayed = decode_bytes(capture)
    assert (replayed.reboots, replayed.lost_frames) == (1, 0)  # the capture says the same
    rows = (out / "frames.csv").read_text().splitlines()[2:]  # below units, header
    readings = sum(m.type_name in ("SAMPLE", "CONTACT") for m in messages)
    assert meta["bytes"] == len(capture) and meta["samples"] == len(rows) == readings


@pytest.mark.slow
def test_another_board_behind_the_link_ends_the_run_in_one_line(tmp_path):
    """The issue's shared machine: another board takes the path while this one is gone."""
    from tactile.board.stream_decoder import decode_bytes

    code, err, out = _record_across_a_restart(tmp_path, "--board-id", "0badb0a2d0000001")
    assert code == 4 and err.count("\n") == 1 and "Traceback" not in err, err
    assert "another board answered after the port was lost (board id 0badb0a2d0000001" in err
    meta = json.loads((out / "meta.json").read_text())
    assert meta["ended"] == "other board" and meta["reboots"] == 0
    messages, replayed = decode_bytes((out / "capture.bin").read_bytes())
    assert replayed.reboots == 0 and meta["bytes"] == replayed.bytes > 0
    assert {m.board_id for m in messages if m.type_name in ("HELLO", "INFO")} == {
        bytes.fromhex(meta["board"]["board_id"])
    }  # nothing of the other board's in the capture
