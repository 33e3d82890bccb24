"""tactile payload identify: each parameter with its error and unit; bad input one line,
exit 2 or 3, nothing written."""

import json

import numpy as np
import pytest
from conftest import load_bench

from tactile.cli.main import main
from tactile.errors import DataError, InputError
from tactile.payload import read_tool
from tactile.payload.fit import identify_run

synth = load_bench("payload_synth")
TRUTH = {"mass": 0.03, "com": [0.02, 0.0, 0.001]}


@pytest.fixture(scope="module")
def held(tmp_path_factory):
    """A synthetic run of a 30 g fingertip held at nine poses, and its pose log."""
    d = tmp_path_factory.mktemp("held")
    synth.identification_run(d / "run", d / "poses.csv", TRUTH["mass"], TRUTH["com"],
                             bias=[0.1, -0.05, 0.2, 0.001, 0, -0.002])  # fmt: skip
    return d


def identify(d, *more, log="poses.csv", run="run"):
    return main(["payload", "identify", str(d / run), "--pose-log", str(d / log), *more])


def test_identify_prints_each_parameter_with_its_error_and_unit(held, tmp_path, capsys):
    out = tmp_path / "tool.json"
    assert identify(held, "-o", str(out)) == 0
    text = capsys.readouterr().out.splitlines()
    assert text[0] == "tool of sensor 0 (calibration id 4242) from 9 poses, 2,709 readings"
    assert text[1].startswith("mass   ") and text[1].split()[2] == "+-" and " g " in text[1]
    assert text[2].endswith(" mm") and text[3].endswith(" mN") and text[4].endswith(" mN*m")
    assert "mN rms (force)" in text[5] and text[-1] == f"-> {out}"
    tool = read_tool(out)
    assert tool.mass_kg == pytest.approx(TRUTH["mass"], abs=4 * tool.mass_kg_se)
    assert np.allclose(tool.com_m, TRUTH["com"], atol=1e-3) and tool.cal_id == 4242


def test_the_same_as_a_python_function(held):
    tool, holds = identify_run(held / "run", held / "poses.csv")
    assert len(holds) == 9 and tool.poses == 9 and tool.residual_force_N < 0.01


def test_json_prints_the_file(held, tmp_path, capsys):
    assert identify(held, "-o", str(tmp_path / "t.json"), "--json") == 0
    assert json.loads(capsys.readouterr().out) == json.loads((tmp_path / "t.json").read_text())


def no_output(tmp_path, capsys, code, argv_tail, held, **where):
    out = tmp_path / "tool.json"
    assert identify(held, "-o", str(out), *argv_tail, **where) == code
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("tactile payload: error: ")
    assert not out.exists()
    return err


def test_a_pose_log_without_orientations_is_exit_2(held, tmp_path, capsys):
    probe = tmp_path / "probes.csv"
    probe.write_text(
        "# units: us, rad, m\n# probe: sphere radius_m=0.01 centre_m=0.05,0,0\n"
        "probe,t_start_us,t_end_us,dtheta_x,dtheta_y\n0,800000,1300000,0.5,0.0\n"
    )
    err = no_output(tmp_path, capsys, 2, [], held, log=str(probe))
    assert "the log has no orientations" in err and "qw,qx,qy,qz" in err


def test_poses_about_the_gravity_axis_are_exit_3(tmp_path, capsys):
    synth.identification_run(tmp_path / "run", tmp_path / "yaw.csv", 0.03, TRUTH["com"],
                             rpy=[(0, 0, a) for a in range(0, 360, 45)])  # fmt: skip
    err = no_output(tmp_path, capsys, 3, [], tmp_path, log="yaw.csv")
    assert "gravity points the same way" in err
    with pytest.raises(DataError):
        identify_run(tmp_path / "run", tmp_path / "yaw.csv")


def test_two_orientations_are_exit_3_naming_the_direction(tmp_path, capsys):
    synth.identification_run(tmp_path / "run", tmp_path / "two.csv", 0.03, TRUTH["com"],
                             rpy=[(0, 0, 0), (90, 0, 0), (0, 0, 0), (90, 0, 0)])  # fmt: skip
    err = no_output(tmp_path, capsys, 3, [], tmp_path, log="two.csv")
    assert "centre of mass along" in err


def test_a_run_of_another_board_time_is_exit_3(held, tmp_path, capsys):
    log = tmp_path / "late.csv"
    text = (held / "poses.csv").read_text().splitlines()
    rows = [",".join([str(int(r.split(",")[0]) + 10**9), str(int(r.split(",")[1]) + 10**9),
                      *r.split(",")[2:]]) for r in text[3:]]  # fmt: skip
    log.write_text("\n".join(text[:1] + text[2:3] + rows) + "\n")
    err = no_output(tmp_path, capsys, 3, [], held, log=str(log))
    assert "no readings of sensor 0 inside the pose log's holds" in err


@pytest.mark.parametrize(
    "tail, words",
    [
        (["--gravity", "0,0"], "--gravity: need GX,GY,GZ"),
        (["--gravity", "0,0,0"], "--gravity"),
        (["--sensor", "7"], "--sensor: 7 is not 0..3"),
        (["--sensor", "2"], "no window of sensor 2"),
        (["--trim", "0.5"], "--trim"),
    ],
)
def test_bad_options_are_exit_2(held, tmp_path, capsys, tail, words):
    assert words in no_output(tmp_path, capsys, 2, tail, held)


def test_an_output_that_is_a_directory_is_refused_before_the_work(held, tmp_path, capsys):
    assert identify(held, "-o", str(tmp_path)) == 2
    assert "a directory, not a regular file" in capsys.readouterr().err
    with pytest.raises(InputError):
        identify_run(held / "nowhere", held / "poses.csv")
