"""The EP2 sweep path of docs/cli.md (issue 14, part 1): TARE under load is refused in one line,
``record`` with a pose log ends when the log does and says what it waits for, and a
recording that localises under half its readings says so and why."""

import json
import re

import numpy as np
import pytest

from tactile.logs.read import read_pose_log
from tactile.recording.session import Session
from tactile_sim.emulator import load_scene
from tactile_sim.emulator.device import build_motion

pytestmark = pytest.mark.realtime  # on the wall clock: bench/realtime_soak.py


def _scene(tmp_path, extra=""):
    path = tmp_path / "sweep.toml"
    path.write_text(load_scene("ep2_sweep_sphere").path.read_text() + "\n" + extra + "\n")
    return path


def _log(tmp_path, scene="ep2_sweep_sphere"):
    log = tmp_path / "sweep.csv"
    build_motion(load_scene(str(scene))).write_pose_log(log)
    return log


def _one_line(code, out, err, exit_code):
    lines = err.strip().splitlines()
    assert code == exit_code and "Traceback" not in err, err
    assert len(lines) == 1 and lines[0].startswith("tactile "), err
    return lines[0]


def test_sim_sweep_without_a_stop_option_ends_with_its_scene(cli, tmp_path):
    """Before: 10 minutes, 7.9 M readings, 1 GB and '0 contacts'."""
    log, out = _log(tmp_path), tmp_path / "run"
    code, stdout, err = cli("record", "--port", "sim://ep2_sweep_sphere", "--pose-log", log,
                            "-o", out)  # fmt: skip
    assert code == 0, err
    assert "record: stops when the pose log is done (board 2.878 s: its '# end:' line)" in err
    meta = json.loads((out / "meta.json").read_text())
    assert meta["ended"] == "pose log end" and meta["tared"]
    assert meta["stops_at"] == {"clock": "board", "time_us": 2_878_000,
                                "from": "the pose log: its '# end:' line"}  # fmt: skip
    # the board's time as last heard: past the end, and not long past (in fast emulation
    # an idle board's clock runs ahead between PINGs, by how much depends on the machine)
    assert 2_878_000 <= meta["time_base"]["segments"][0]["board_last_us"] < 15_000_000
    assert meta["contacts_ended"] == 3 and meta["samples"] < 2000
    assert "1283 of 1302 contact readings localised" in stdout and "warning" not in err
    code, stdout, err = cli("ep2", "analyze", out / "contacts.csv", "--json")
    assert code == 0 and json.loads(stdout.splitlines()[0])["shape"] == "sphere"


def test_without_an_end_line_it_stops_half_a_second_after_the_last_entry(cli, tmp_path):
    log, out = _log(tmp_path), tmp_path / "run"
    log.write_text("".join(ln for ln in log.open() if not ln.startswith("# end:")))
    last = int(read_pose_log(log).t_end.max())
    code, _, err = cli("record", "--port", "sim://ep2_sweep_sphere", "--pose-log", log, "-o", out)
    assert code == 0, err
    assert "0.5 s after its last entry" in err
    meta = json.loads((out / "meta.json").read_text())
    assert meta["ended"] == "pose log end" and meta["stops_at"]["time_us"] == last + 500_000


def test_a_host_clock_log_needs_a_time_base_that_fast_emulation_lacks(cli, tmp_path):
    """The run stops by the host's monotonic clock (4 s from now); the in-process emulator runs
    on simulated time, so nothing can be joined, and the line says why."""
    import time

    log = tmp_path / "mono.csv"
    text = _log(tmp_path).read_text().replace("t_start_us,t_end_us", "t_start_mono_s,t_end_mono_s")
    end = f"# end: t_mono_s={time.monotonic() + 4.0:.6f}"
    log.write_text(text.replace("# end: t_us=2878000", end))
    code, stdout, err = cli("record", "--port", "sim://ep2_sweep_sphere", "--pose-log", log,
                            "-o", tmp_path / "run", "--quiet")  # fmt: skip
    line = _one_line(code, stdout.split("\n", 2)[-1], err, 3)
    assert "(stopped by the pose log's end)" in stdout
    segments = json.loads((tmp_path / "run" / "meta.json").read_text())["time_base"]["segments"]
    assert not any(s["usable"] for s in segments)  # (the port's word: not the machine's load)
    assert "stamped in monotonic time, but the recording cannot say when its frames" in line
    assert "simulated time: board time only" in line


def test_tare_under_load_is_refused_in_one_line_and_force_tares_anyway(cli, tmp_path):
    loaded = _scene(tmp_path, "rest_s = 0.0")  # the fingers press from the start
    url = f"sim://{loaded}"
    code, out, err = cli("record", "--port", url, "--duration", "1", "-o", tmp_path / "r",
                         "--quiet")  # fmt: skip
    line = _one_line(code, out, err, 4)
    assert "board refused TARE: sensor 0 is loaded (force above the 1.39 N contact gate)" in line
    assert "tactile tare --force" in line
    assert json.loads((tmp_path / "r" / "meta.json").read_text())["ended"] == "error"
    code, out, err = cli("tare", "--port", url)
    assert "is loaded" in _one_line(code, out, err, 4)
    code, out, err = cli("tare", "--port", url, "--force")
    assert code == 0 and out.startswith("tared all sensors"), err


def test_a_recording_that_localises_under_half_its_readings_says_why(cli, tmp_path):
    """A log whose windows for fingers 0 and 1 are 2 s late (another run's) leaves two thirds
    of the frames outside every window."""
    log, out = _log(tmp_path), tmp_path / "run"
    rows = log.read_text().splitlines()
    shifted = []
    for row in rows:
        if row[:1].isdigit() and row.split(",")[2] in ("0", "1"):
            t0, t1, rest = row.split(",", 2)
            row = f"{int(t0) + 2_000_000},{int(t1) + 2_000_000},{rest}"
        shifted.append(row)
    log.write_text("\n".join(shifted) + "\n")
    code, stdout, err = cli("record", "--port", "sim://ep2_sweep_sphere", "--pose-log", log,
                            "-o", out, "--quiet")  # fmt: skip
    assert code == 0, err
    (warning,) = [ln for ln in err.splitlines() if ln.startswith("warning:")]
    assert "were localised" in warning and "outside every pose window of their finger" in warning
    assert "warning" not in stdout


def test_waiting_says_what_for(tmp_path):
    session = Session("sim://ep2_sweep_sphere", tmp_path / "r", until=("board", 2_878_000, "x"))
    assert session.waiting_for() == "pose log end (board 2.878 s); no board time heard yet"
    session = Session("x", tmp_path / "s", until=("utc", 1e15, "x"), utc=lambda: 999_999_998.5)
    assert session.waiting_for().startswith("pose log end in 1.5 s (2001-09-09T01:46:40")
    assert Session("x", tmp_path / "t").waiting_for() is None


@pytest.mark.parametrize(
    "line, error",
    [
        ("# end: t_mono_s=3", "end: expected 't_us=...' (this log is in the board clock)"),
        ("# end: t_us=-1", "end: t_us must be 0..4294967295"),
    ],
)
def test_a_bad_end_line_is_one_line_naming_it(tmp_path, line, error):
    from tactile.errors import InputError

    log = _log(tmp_path)
    log.write_text(log.read_text().replace("# end: t_us=2878000", line))
    with pytest.raises(InputError, match=re.escape(f"sweep.csv:4: {error}")):  # under # units
        read_pose_log(log)


def test_time_columns_of_two_clocks_are_refused(tmp_path):
    from tactile.errors import InputError

    log = tmp_path / "two.csv"
    log.write_text("# probe: sphere radius_m=0.01 centre_m=0,0,0\nt_start_us,t_end_us,"
                   "t_start_utc_s,t_end_utc_s,finger,px,py,pz,qw,qx,qy,qz\n"
                   "0,1,0,1,0,0,0,0,1,0,0,0\n")  # fmt: skip
    with pytest.raises(InputError, match="two.csv:2: time columns of two clocks"):
        read_pose_log(log)
    log.write_text("# probe: sphere radius_m=0.01 centre_m=0,0,0\nt_start_utc_s,t_end_utc_s,"
                   "finger,px,py,pz,qw,qx,qy,qz\n1.7e9,1.6e9,0,0,0,0,1,0,0,0\n")  # fmt: skip
    with pytest.raises(InputError, match="two.csv:3: column .t_end_utc_s.: ends before"):
        read_pose_log(log)
    assert np.array_equal(
        read_pose_log(_log(tmp_path)).t_start[:2], [1_000_000, 1_000_000]
    )  # board logs read as before


def test_force_raises_the_gate_for_the_tare_only(tmp_path):
    """On one open port: the loaded TARE is refused, the forced one is taken, and INFO then
    shows the gate as it was."""
    import serial

    from tactile.board.client import BoardClient, CommandRefused
    from tactile_sim.urlhandler import register

    register()
    port = serial.serial_for_url(f"sim://{_scene(tmp_path, 'rest_s = 0.0')}", timeout=0.01)
    client = BoardClient(port, "sim")
    client.handshake()
    before = client.get_info()
    with pytest.raises(CommandRefused, match="sensor 0 is loaded"):
        client.tare()
    client.tare(force=True)
    after = client.get_info()
    fields = ("enter_threshold", "exit_threshold", "debounce", "rate_hz", "flags")
    assert [getattr(after, f) for f in fields] == [getattr(before, f) for f in fields]
    assert after.enter_threshold == 1_390_000
    for cal in port.emulator.board.cals:  # each bias holds its finger's load, in N:
        f = np.reshape(cal.coefficients(), (6, 6)) @ np.array(cal.bias_counts())
        assert np.hypot(f[0], f[1]) > 1.39  # above the gate the plain TARE refused
