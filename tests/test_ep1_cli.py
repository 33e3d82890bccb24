"""EP1 command line: tactile ep1 estimate, tactile sim ep1, tactile study ep1-*."""

import json
import subprocess
import sys

import numpy as np
import pytest

from tactile.cli.main import main
from tactile.ep1.probes import format_probes, read_probes
from tactile.errors import InputError
from tactile_sim.ep1.probes import measure, sphere_plus_probes

# issue 12: no numpy warning may reach a user of the CLI
pytestmark = pytest.mark.filterwarnings("error::RuntimeWarning")


@pytest.fixture
def sphere_csv(tmp_path):
    rows = measure(sphere_plus_probes(1.0, 2.0, 0.1), 1.0)
    path = tmp_path / "probes.csv"
    path.write_text(format_probes(rows))
    return path


def test_csv_round_trip(sphere_csv):
    th, dp = read_probes(sphere_csv)
    assert th.shape == (8, 2) and dp.shape == (8, 2)


def test_estimate_json(sphere_csv, capsys):
    assert main(["ep1", "estimate", str(sphere_csv), "--finger-radius", "1", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    for key in ("kx", "ky", "K", "k1", "k2", "direction1", "residual", "n_probes", "status"):
        assert key in out
    assert out["kx"] == pytest.approx(0.5, rel=1e-9)
    assert out["status"] == "ok" and out["n_probes"] == 8


def test_bad_cell_names_file_line_column(tmp_path, capsys):
    path = tmp_path / "bad.csv"
    path.write_text("dtheta_x,dtheta_y,du,dv\n0.1,0,0,0.05\n0,abc,-0.05,0\n")
    assert main(["ep1", "estimate", str(path), "--finger-radius", "1"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0
    assert f"{path}:3: column 'dtheta_y'" in err


def test_missing_column_and_bad_radius(tmp_path, capsys):
    path = tmp_path / "m.csv"
    path.write_text("dtheta_x,du,dv\n0.1,0,0\n")
    assert main(["ep1", "estimate", str(path), "--finger-radius", "1"]) == 2
    assert "dtheta_y" in capsys.readouterr().err
    with pytest.raises(InputError):
        read_probes(tmp_path / "nope.csv")
    path.write_text("dtheta_x,dtheta_y,du,dv\n0.1,0,0,0.05\n")
    assert main(["ep1", "estimate", str(path), "--finger-radius", "-1"]) == 2


def test_underdetermined_exit_3_with_reason(tmp_path, capsys):
    path = tmp_path / "x.csv"
    path.write_text("dtheta_x,dtheta_y,du,dv\n0.1,0,0,0.05\n-0.1,0,0,-0.05\n")
    assert main(["ep1", "estimate", str(path), "--finger-radius", "1"]) == 3
    assert "independent directions" in capsys.readouterr().err


def test_below_resolution_exit_3_with_bound(tmp_path, capsys):
    rows = measure(sphere_plus_probes(1.0, 0.001, 0.05), 1.0, resolution=0.01, sensor="array")
    path = tmp_path / "sharp.csv"
    path.write_text(format_probes(rows))
    code = main(
        ["ep1", "estimate", str(path), "--finger-radius", "1", "--resolution", "0.01", "--json"]
    )
    assert code == 3
    cap = capsys.readouterr()
    assert json.loads(cap.out)["status"] == "below_resolution"
    assert "radius below" in cap.err


def test_sim_ep1_reports_estimate_truth_and_error(capsys):
    argv = [
        "sim",
        "ep1",
        "--object",
        "ellipsoid",
        "--a",
        "1.5",
        "--b",
        "0.8",
        "--c",
        "1.2",
        "--at",
        "0.2",
        "0.3",
        "--finger-radius",
        "1",
        "--dtheta",
        "0.01",
        "--json",
    ]
    assert main(argv) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["truth"]["k1"] == pytest.approx(out["k1"], rel=1e-2)
    assert max(out["relative_error"].values()) < 1e-2


def test_sim_ep1_sphere_with_noise_and_probes_file(tmp_path, capsys):
    probes = tmp_path / "p.csv"
    argv = [
        "sim",
        "ep1",
        "--object",
        "sphere",
        "--radius",
        "2",
        "--finger-radius",
        "1",
        "--dtheta",
        "0.5",
        "--noise-theta",
        "0.001",
        "--resolution",
        "0.0001",
        "--seed",
        "3",
        "-o",
        str(probes),
    ]
    assert main(argv) == 0
    assert "truth" in capsys.readouterr().out
    th, dp = read_probes(probes)
    assert len(th) == 8


def test_sim_ep1_bad_inputs_exit_2(capsys):
    base = ["sim", "ep1", "--object", "sphere", "--finger-radius", "1"]
    assert main(base + ["--dtheta", "7"]) == 2
    assert main(base + ["--dtheta", "0.1", "--radius", "0"]) == 2
    assert main(base + ["--dtheta", "0.1", "--at", "3", "0"]) == 2
    assert main(base + ["--dtheta", "0.1", "--resolution", "-1"]) == 2


def test_study_commands_write_csv_and_png(tmp_path, capsys):
    for name in ("ep1-noise", "ep1-arclength"):
        argv = ["study", name, "--out", str(tmp_path), "--trials", "3", "--quiet"]
        assert main(argv) == 0
        assert (tmp_path / f"{name}.csv").stat().st_size > 100
        assert (tmp_path / f"{name}.png").stat().st_size > 1000
    text = (tmp_path / "ep1-noise.csv").read_text()
    assert "nan" not in text.lower() and "inf" not in text.lower()
    assert text.count("\n") == 2 + 9 * 4 * 7 and text.startswith("# units: lengths in fingertip")


def test_group_families_import_no_numpy():
    """Building ``tactile sim``'s or ``tactile study``'s parser imports every family of it:
    none loads NumPy or more before its subcommand runs."""
    code = (
        "import sys, tactile_studies.commands.sim_ep1, tactile_studies.commands.study_ep1,"
        " tactile_sim.commands.sim_ep2, tactile_studies.commands.study_ep2;"
        "bad = [m for m in ('numpy', 'scipy', 'matplotlib', 'tqdm') if m in sys.modules];"
        "print(bad); sys.exit(1 if bad else 0)"
    )
    assert subprocess.run([sys.executable, "-c", code]).returncode == 0


def test_probe_csv_values_round_trip_exactly(tmp_path):
    rows = np.array([[0.1, -0.2, 1e-17, 3.0], [1 / 3, 2 / 3, -1e300, 5e-324]])
    path = tmp_path / "r.csv"
    path.write_text(format_probes(rows))
    th, dp = read_probes(path)
    np.testing.assert_array_equal(np.column_stack([th, dp]), rows)


@pytest.mark.filterwarnings("error")
@pytest.mark.parametrize("scale", [1e-320, 1e-300, 1e300])
def test_probes_at_the_floats_edges_print_no_nan(tmp_path, capsys, scale):
    """Issue 12: du, dv of 1e-320 once printed kx: nan (1 / subnormal overflowed)."""
    rows = measure(sphere_plus_probes(1.0, 2.0, 0.1), 1.0)
    rows[:, 2:] *= scale
    path = tmp_path / "edge.csv"
    path.write_text(format_probes(rows))
    code = main(["ep1", "estimate", str(path), "--finger-radius", "1"])
    out, err = capsys.readouterr()
    assert code in (0, 3) and "nan" not in (out + err).lower() and err.count("\n") <= 1
    code = main(["ep1", "estimate", str(path), "--finger-radius", "1e-320"])
    assert (
        code == 2
        and "--finger-radius: must be a number in [1e-300, 1e300]" in capsys.readouterr().err
    )
