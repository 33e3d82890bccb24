"""``record``'s display (issue 15): the bar of a run that finishes as asked (a duration, a
count of contacts, the pose log's end) ends at 100 %, and the closing lines are words and
numbers, never a Python repr (a dict, a tuple, PoseReport(...), Path(...))."""

import re

import pytest

from tactile_sim.emulator import load_scene
from tactile_sim.emulator.device import build_motion

REPR = re.compile(r"[{}\[\]]|\w+\(\w+=|Path\(|Counter\(|\('|np\.float")


def _last_bar(err):
    bars = [b for b in re.split(r"[\r\n]", err) if b.startswith("record:")]
    return bars[-1]


@pytest.mark.parametrize(
    "stop, total", [(("--duration", "0.4"), "0.4/0.4 s"), (("--contacts", "1"), "1/1 contact")]
)
def test_a_finished_run_fills_its_bar_and_sums_up_in_words(cli, tmp_path, stop, total):
    code, out, err = cli("record", "--port", "sim://press", *stop, "-o", tmp_path / "run")
    assert code == 0, err
    bar = _last_bar(err)
    assert "100%" in bar and total in bar, bar
    lines = out.splitlines()
    assert lines[0].startswith("recorded ") and f"(stopped by its {stop[0]})" in lines[0]
    assert "1 contacts" not in out and "1 frames" not in out
    assert not any(REPR.search(ln) for ln in lines), out


def test_a_pose_log_run_fills_its_bar_and_its_derive_line_is_words(cli, tmp_path):
    log = tmp_path / "sweep.csv"
    build_motion(load_scene("ep2_sweep_sphere")).write_pose_log(log)
    code, out, err = cli("record", "--port", "sim://ep2_sweep_sphere", "--pose-log", log,
                         "-o", tmp_path / "run")  # fmt: skip
    assert code == 0, err
    bar = _last_bar(err)
    assert "100%" in bar and bar.count(" s [") == 1, bar
    assert "(stopped by the pose log's end)" in out
    assert "contact readings localised (m)" in out
    assert "PoseReport" not in out and not any(REPR.search(ln) for ln in out.splitlines()), out
    # what was not localised is said in words (19 readings too noisy to localise)
    assert re.search(r"localised \(m\) -> .*contacts\.csv; 19 too noisy$", out, re.M), out


def test_the_pose_report_in_words():
    from tactile.localize.posed import PoseReport

    whole = PoseReport(frames=5, outside=0, no_contact=0, unusable=0, usable=5, status={"ok": 5})
    assert str(whole) == "every reading in a pose window localised"
    mixed = PoseReport(frames=9, outside=2, no_contact=3, unusable=1, usable=3,
                       status={"ok": 3, "no_contact": 3, "miss": 1})  # fmt: skip
    assert str(mixed) == (
        "2 outside every pose window, 3 at or below the force gate, 1 missing the fingertip"
    )
