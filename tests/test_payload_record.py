"""record --payload: the tool checked against the board before anything is written, the
SAMPLE stream switched on, the compensation in meta.json; derive on a synthetic run."""

import json

import numpy as np
import pytest
from conftest import load_bench

from tactile.board.stream_decoder import decode_bytes
from tactile.cli.main import main
from tactile.commands.derive import derive
from tactile.payload import Orientations, Tool, read_tool, write_tool
from tactile.payload.apply import ANY, Following, read_log
from tactile_protocol import constants as C
from tactile_sim.emulator.device import build_motion
from tactile_sim.emulator.scene import load_scene

synth = load_bench("payload_synth")
SCENE = "ep2_sweep_sphere"  # three sensors, calibration id 1 each, streams contacts only


@pytest.fixture(scope="module")
def poses(tmp_path_factory):
    path = tmp_path_factory.mktemp("log") / "poses.csv"
    build_motion(load_scene(SCENE)).write_pose_log(path)
    return path


def tool_file(path, **kw):
    write_tool(path, Tool(**{"mass_kg": 0.0, "com_m": [0.03, 0, 0], "cal_id": 1, **kw}))
    return str(path)


def record(out, poses, *more):
    argv = ["record", "--port", f"sim://{SCENE}", "--no-tare", "--contacts", "2",
            "--pose-log", str(poses), "-o", str(out), "--quiet", *more]  # fmt: skip
    return main(argv)


@pytest.mark.parametrize(
    "tool, words",
    [
        ({"cal_id": 8578}, "identified with calibration id 8578 of sensor 0, but that sensor"),
        ({"sensor": 3}, "the tool is for sensor 3"),
    ],
)
def test_a_tool_of_another_sensor_or_calibration_leaves_nothing(
    tmp_path, poses, capsys, tool, words
):
    out = tmp_path / "run"
    assert record(out, poses, "--payload", tool_file(tmp_path / "t.json", **tool)) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and words in err
    assert not out.exists()


def test_payload_needs_a_pose_log_with_orientations(tmp_path, capsys):
    tool = tool_file(tmp_path / "t.json")
    argv = ["record", "--port", f"sim://{SCENE}", "-o", str(tmp_path / "run"), "--payload", tool]
    assert main(argv) == 2
    assert "--payload: needs --pose-log" in capsys.readouterr().err
    probes = tmp_path / "probes.csv"
    probes.write_text(
        "# units: us, rad, m\n# probe: sphere radius_m=0.01 centre_m=0.05,0,0\n"
        "probe,t_start_us,t_end_us,dtheta_x,dtheta_y\n0,800000,1300000,0.5,0.0\n"
    )
    assert record(tmp_path / "run", probes, "--payload", tool) == 2
    assert "probe log has no orientations" in capsys.readouterr().err
    assert not (tmp_path / "run").exists()


def test_record_with_a_weightless_tool_switches_samples_on_and_says_what_it_did(
    tmp_path, poses, capsys
):
    """A tool of no mass changes nothing but where contacts are gated: the contacts come out
    as without it, and meta.json records the tool, the host's tare and the moves."""
    out = tmp_path / "run"
    assert record(out, poses, "--payload", tool_file(tmp_path / "t.json")) == 0
    said = capsys.readouterr().out
    assert "payload: sensor 0: the tool's weight removed from" in said
    meta = json.loads((out / "meta.json").read_text())
    assert meta["device"]["streams"] == ["samples", "contacts"]
    pay = meta["payload"]
    assert pay["samples_switched_on"] and pay["tools"][0]["tool"]["cal_id"] == 1
    sensor0 = pay["compensation"][0]
    assert sensor0["bias_from"] == "the host's tare" and sensor0["contacts"] >= 1
    assert "tare_at_s" in sensor0["rebias"][0]
    frames = (out / "frames.csv").read_text()
    assert ",SAMPLE," in frames  # frames.csv keeps what the board sent
    plain = tmp_path / "plain"
    assert record(plain, poses) == 0
    n = [len((d / "contacts.csv").read_text().splitlines()) for d in (out, plain)]
    assert abs(n[0] - n[1]) <= 0.1 * n[1]


def test_derive_removes_a_100_g_tool_turned_over_and_finds_no_contact(tmp_path):
    """frames.csv keeps the board's contacts (the weight's); contacts.csv has none."""
    poses = synth.Poses([(0, 0, 0), (180, 0, 0), (90, 0, 0)], hold_s=2.0, move_s=1.0)
    t = np.arange(0.0, poses.duration_s, 1 / 500)
    W = synth.readings(t, poses.at(t), 0.1, [0.03, 0, 0], 0.0, 0.0, [0.02] * 3 + [1e-3] * 3)
    run = synth.write_run(tmp_path / "run", synth.board_frames(t, W, tare_at=0.2))
    log = tmp_path / "poses.csv"
    poses.write_log(log)
    text = log.read_text().splitlines()  # derive needs the fingertip's sphere
    text.insert(1, "# probe: sphere radius_m=0.012 centre_m=0.03,0,0")
    log.write_text("\n".join(text) + "\n")
    tool = Tool(0.1, [0.03, 0, 0], cal_id=4242)
    assert ",CONTACT," in (run / "frames.csv").read_text()
    lines = derive(run, log, payload=[("t.json", tool)])
    assert lines[0].startswith("payload: sensor 0:") and "0 contacts on the host's gate" in lines[0]
    assert (run / "contacts.csv").read_text().splitlines()[-1].startswith("x,y,z")
    meta = json.loads((run / "meta.json").read_text())
    assert meta["payload"]["compensation"][0]["contacts"] == 0


def test_live_with_a_payload_shows_the_compensated_wrench(cli, tmp_path, poses):
    tool = tool_file(tmp_path / "t.json")
    code, out, err = cli("live", "--port", f"sim://{SCENE}", "--duration", "0.3",
                         "--pose-log", str(poses), "--payload", tool)  # fmt: skip
    assert code == 0, err
    assert "sensor 0  |F|" in out
    code, out, err = cli("live", "--port", f"sim://{SCENE}", "--duration", "0.3",
                         "--pose-log", str(poses), "--payload", tool_file(tmp_path / "x.json",
                         cal_id=5))  # fmt: skip
    assert code == 2 and "calibration id 5 of sensor 0" in err and err.count("\n") == 1
    code, out, err = cli("live", "--port", f"sim://{SCENE}", "--payload", tool)
    assert code == 2 and "--payload: needs --pose-log" in err


def test_following_a_stream_batch_by_batch_drops_the_weights_contacts():
    """What live and --foxglove see: a 100 g tool turned over, fed in batches of 200."""
    poses = synth.Poses([(0, 0, 0), (180, 0, 0)], hold_s=2.0, move_s=1.0)
    t = np.arange(0.0, poses.duration_s, 1 / 500)
    W = synth.readings(t, poses.at(t), 0.1, [0.03, 0, 0], 0.0, 0.0, [0.02] * 3 + [1e-3] * 3)
    msgs, _ = decode_bytes(synth.board_frames(t, W, tare_at=0.2))
    orient = Orientations({ANY: (np.rint(poses.t0 * 1e6), np.rint(poses.t1 * 1e6), poses.rot)})
    following = Following([Tool(0.1, [0.03, 0, 0], cal_id=4242)], orient)
    following.check(synth.DEVICE)
    seen = []
    for a in range(0, len(msgs), 200):
        out, _, arrived = following.feed(msgs[a : a + 200], synth.DEVICE, arrivals=[0.0] * 200)
        assert len(arrived) == len(out)
        seen += out
    assert any(m.type_code == C.MSG_CONTACT for m in msgs)
    assert not any(m.type_code == C.MSG_CONTACT for m in seen)
    assert following.report()[0]["bias_from"] == "the host's tare"


def test_record_serves_foxglove_the_compensated_stream(tmp_path, poses, mocker):
    """record --foxglove --payload: the server is fed what the host compensates, batch by
    batch, the same frames as the whole capture compensated at once; not the board's."""
    from tactile.foxglove.live import LiveServer

    fed = []
    real = LiveServer.follow
    mocker.patch.object(
        LiveServer, "follow", lambda self, s, m, h: (fed.extend(m), real(self, s, m, h))
    )
    tool = tool_file(tmp_path / "t.json", mass_kg=0.2)
    out = tmp_path / "run"
    assert record(out, poses, "--payload", tool, "--foxglove", "--foxglove-port", "0") == 0
    msgs, _ = decode_bytes((out / "capture.bin").read_bytes())
    meta = json.loads((out / "meta.json").read_text())
    log, orient = read_log(poses)
    whole, _, _ = Following([read_tool(tool)], orient).feed(msgs, meta["device"])

    def sensor0(frames):
        return [m for m in frames if m.type_code in (C.MSG_SAMPLE, C.MSG_CONTACT) and m.sensor == 0]

    online, offline = sensor0(fed), sensor0(whole)
    assert len(online) > 1000 and online == offline[: len(online)]
    assert online != sensor0(msgs)[: len(online)]
