"""tactile.load_recording(..., payload=): the tool's weight removed from the rows, frames.csv's
values kept beside them, contacts gated on the host."""

import numpy as np
import pytest
from conftest import load_bench

import tactile
from tactile.errors import InputError
from tactile.payload import Tool, write_tool

synth = load_bench("payload_synth")
HEAVY = Tool(0.1, [0.03, 0.0, 0.0], cal_id=4242)


@pytest.fixture(scope="module")
def turned(tmp_path_factory):
    """A 100 g tool tared upright, then turned over and to the side, touching nothing."""
    d = tmp_path_factory.mktemp("turned")
    poses = synth.Poses([(0, 0, 0), (180, 0, 0), (90, 0, 0), (0, 90, 0)], hold_s=1.5, move_s=1.0)
    t = np.arange(0.0, poses.duration_s, 1 / 500)
    W = synth.readings(t, poses.at(t), 0.1, [0.03, 0, 0], 0.0, 0.0, [0.02] * 3 + [1e-3] * 3)
    synth.write_run(d / "run", synth.board_frames(t, W, tare_at=0.2))
    poses.write_log(d / "poses.csv")
    write_tool(d / "tool.json", HEAVY)
    return d


def test_the_weight_is_gone_and_the_board_values_are_kept(turned):
    plain = tactile.load_recording(turned / "run")
    rec = tactile.load_recording(turned / "run", payload=turned / "tool.json",
                                 pose_log=turned / "poses.csv")  # fmt: skip
    assert plain.raw_force_N is None and plain.payload is None
    assert np.array_equal(rec.raw_force_N, plain.force_N)
    assert np.abs(plain.force_N).max() > 1.5  # the board's values: the weight turned over
    assert np.abs(rec.force_N).max() < 0.15  # noise and the moves' interpolation
    assert np.any(plain.is_contact) and not np.any(rec.host_phase >= 0)
    comp = rec.payload["compensation"][0]
    assert comp["bias_from"] == "the host's tare" and comp["contacts"] == 0
    assert rec.payload["tools"][0]["tool"]["mass_kg"] == 0.1


def test_a_tool_object_and_the_wrong_calibration(turned):
    rec = tactile.load_recording(turned / "run", payload=[HEAVY], pose_log=turned / "poses.csv")
    assert np.abs(rec.force_N).max() < 0.15
    other = Tool(0.1, [0.03, 0, 0], cal_id=1)
    with pytest.raises(InputError, match="calibration id 1 of sensor 0, but that sensor reports"):
        tactile.load_recording(turned / "run", payload=other, pose_log=turned / "poses.csv")


def test_without_a_pose_log_it_says_so(turned):
    with pytest.raises(InputError, match="needs the robot log"):
        tactile.load_recording(turned / "run", payload=HEAVY)
