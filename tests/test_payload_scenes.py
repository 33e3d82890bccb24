"""The simulator's weighted scenes through record, payload identify and --payload: the tool
identified from payload_poses, no contact from payload_turn, EP1 answered on
ep1_roll_weighted."""

import json

import pytest

from tactile.cli.main import main
from tactile.payload import Tool, read_tool, write_tool
from tactile_sim.emulator.device import build_motion
from tactile_sim.emulator.scene import load_scene


def logged(tmp_path, scene, probe=None):
    motion = build_motion(load_scene(scene))
    log = tmp_path / f"{scene}.csv"
    (motion.write_probe_log if hasattr(motion, "write_probe_log") else motion.write_pose_log)(log)
    if probe:
        head, rest = log.read_text().split("\n", 1)
        log.write_text(f"{head}\n# probe: {probe}\n{rest}")
    return motion, log


def rows(path):
    return sum(1 for ln in path.read_text().splitlines() if ln and ln[0] not in "#x")


def test_payload_poses_identifies_the_30_g_fingertip(tmp_path, capsys):
    _, log = logged(tmp_path, "payload_poses")
    out = tmp_path / "held"
    assert main(["record", "--port", "sim://payload_poses", "--no-tare", "--pose-log", str(log),
                 "-o", str(out), "--quiet"]) == 0  # fmt: skip
    assert "no contacts.csv (a log of holds?" in capsys.readouterr().out
    assert main(["payload", "identify", str(out), "--pose-log", str(log), "-o",
                 str(tmp_path / "tool.json")]) == 0  # fmt: skip
    tool = read_tool(tmp_path / "tool.json")
    assert tool.mass_kg == pytest.approx(0.03, abs=4 * tool.mass_kg_se)
    assert tool.com_m[0] == pytest.approx(0.02, abs=4 * tool.com_m_se[0])
    assert abs(tool.mass_kg - 0.03) * 9.81 < 0.01  # under 10 mN of weight left


def test_payload_turn_gives_no_contact_with_the_payload(tmp_path):
    """A 100 g tool turned through 180 deg touching nothing: the board's gate makes contacts,
    contacts.csv has none with --payload."""
    _, log = logged(tmp_path, "payload_turn", "sphere radius_m=0.012 centre_m=0.03,0,0")
    write_tool(tmp_path / "tool.json", Tool(0.1, [0.02, 0, 0], cal_id=1))
    base = ["record", "--port", "sim://payload_turn", "--pose-log", str(log), "--quiet"]
    assert main([*base, "-o", str(tmp_path / "plain")]) == 0
    assert main([*base, "-o", str(tmp_path / "pay"), "--payload", str(tmp_path / "tool.json")]) == 0
    assert rows(tmp_path / "plain" / "contacts.csv") > 0
    assert rows(tmp_path / "pay" / "contacts.csv") == 0
    meta = json.loads((tmp_path / "pay" / "meta.json").read_text())
    assert meta["contacts_begun"] > 0 and meta["payload"]["compensation"][0]["contacts"] == 0


def test_ep1_roll_weighted_is_answered_with_the_payload(tmp_path, capsys):
    motion, log = logged(tmp_path, "ep1_roll_weighted")
    write_tool(tmp_path / "tip.json", Tool(0.03, [0.02, 0, 0], cal_id=1))
    base = ["record", "--port", "sim://ep1_roll_weighted", "--pose-log", str(log), "--quiet"]
    k = motion.true_curvature()["kx"]
    err = {}
    for name, more in (("plain", []), ("pay", ["--payload", str(tmp_path / "tip.json")])):
        assert main([*base, "-o", str(tmp_path / name), *more]) == 0
        capsys.readouterr()
        assert main(["ep1", "estimate", str(tmp_path / name / "probes.csv"), "--finger-radius",
                     "0.01", "--json"]) == 0  # fmt: skip
        got = json.loads(capsys.readouterr().out)
        err[name] = max(abs(got["kx"] - k), abs(got["ky"] - k)) / k
    assert err["plain"] > 1.0 and err["pay"] < 0.15, err
