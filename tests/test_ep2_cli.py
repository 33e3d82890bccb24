"""``tactile ep2 analyze`` and ``tactile sim ep2``: outputs and exit codes."""

import json

import pytest

from tactile.cli.main import main

# issue 12: no numpy warning may reach a user of the CLI
pytestmark = pytest.mark.filterwarnings("error::RuntimeWarning")


@pytest.fixture
def cyl_csv(tmp_path):
    path = tmp_path / "cyl.csv"
    code = main(
        [
            "sim",
            "ep2",
            "--object",
            "cylinder",
            "--radius",
            "6.6",
            "--rotation",
            "30",
            "--noise-pos",
            "0.01",
            "--noise-normal",
            "0.01",
            "--patches",
            "3",
            "-o",
            str(path),
        ]
    )
    assert code == 0
    return path


def test_sim_then_analyze_json(cyl_csv, capsys):
    capsys.readouterr()
    assert main(["ep2", "analyze", str(cyl_csv), "--json"]) == 0
    lines = capsys.readouterr().out.strip().splitlines()
    assert len(lines) == 3
    for line in lines:
        rec = json.loads(line)
        assert rec["shape"] == "cylinder"
        assert rec["radius"] == pytest.approx(6.6, rel=0.1)
        lo, hi = rec["S_interval"]
        assert lo <= rec["S"] <= hi  # one definition: S and its interval are at the centre
        assert rec["model"].startswith("2-jet of positions and normals") and rec["order"] == 2
        assert "NaN" not in line and "Infinity" not in line
    assert [json.loads(x)["patch"] for x in lines] == [1, 2, 3]  # numbers stay numbers


def test_table_prints_centre_values_with_units_and_the_thesis_spline_on_request(cyl_csv, capsys):
    capsys.readouterr()
    assert main(["ep2", "analyze", str(cyl_csv)]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[0].split()[:5] == ["patch", "n", "shape", "conf", "S"]
    assert "radius (cm)" in out[0] and "C (R in 1/cm)" in out[0]  # the sim writes cm
    assert "lengths in cm" in out[-1]
    assert sum("cylinder" in line for line in out) == 3
    args = ["ep2", "analyze", str(cyl_csv), "--method", "spline", "--order", "3"]
    assert main([*args, "--weighting", "tangent", "--grid", "6"]) == 0
    assert capsys.readouterr().out.count("B-spline degree 3x3") == 3


def test_spline_options_without_the_spline_are_refused(cyl_csv, capsys):
    assert main(["ep2", "analyze", str(cyl_csv), "--order", "3"]) == 2
    assert "--method spline" in capsys.readouterr().err


@pytest.mark.parametrize(
    "ids,expected",
    [(("3", "12"), [3, 12]), (("2.5", "a"), [2.5, "a"]), (("007", "1.50"), ["007", "1.50"])],
)
def test_patch_ids_keep_their_csv_form(tmp_path, capsys, ids, expected):
    from tactile_sim.ep2 import make, sweep
    from tactile_sim.ep2.sweep import write_rows

    path = tmp_path / "ids.csv"
    with open(path, "w") as fh:
        for i, pid in enumerate(ids):
            write_rows(fh, sweep(make("sphere", 8.0), seed=i), patch=pid, header=i == 0)
    assert main(["ep2", "analyze", str(path), "--json"]) == 0
    assert [json.loads(x)["patch"] for x in capsys.readouterr().out.splitlines()] == expected


def _write(tmp_path, text):
    path = tmp_path / "bad.csv"
    path.write_text(text)
    return str(path)


@pytest.mark.parametrize(
    "text,needle",
    [
        ("x,y,z,nx,ny\n0,0,0,0,0\n", "missing required column(s) nz"),
        ("x,y,z,nx,ny,nz\n0,0,0,0,0,1\n1,0,abc,0,0,1\n", ":3: column 'z': not a number"),
        ("x,y,z,nx,ny,nz\n# c\n0,0,nan,0,0,1\n", ":3: column 'z': not a finite number"),
        ("x,y,z,nx,ny,nz\n0,0,0,0,0,1\n1,0,0,0,0,0\n", ":3: column 'nx': zero-length normal"),
    ],
)
def test_bad_input_exit_2_one_line(tmp_path, capsys, text, needle):
    assert main(["ep2", "analyze", _write(tmp_path, text)]) == 2
    err = capsys.readouterr().err.strip()
    assert needle in err and len(err.splitlines()) == 1 and "Traceback" not in err


def test_single_finger_exit_3(tmp_path, capsys):
    rows = "\n".join(f"0,{y},0,0,0,1" for y in range(6))
    assert main(["ep2", "analyze", _write(tmp_path, "x,y,z,nx,ny,nz\n" + rows + "\n")]) == 3
    err = capsys.readouterr().err.strip()
    assert "not determined" in err and "one line" in err and len(err.splitlines()) == 1


def test_one_bad_patch_among_good_ones_exit_3_and_others_reported(cyl_csv, tmp_path, capsys):
    text = cyl_csv.read_text() + "".join(f"0,{y},0,0,0,1,0,bad\n" for y in range(6))
    path = tmp_path / "mixed.csv"
    path.write_text(text)
    capsys.readouterr()
    assert main(["ep2", "analyze", str(path), "--json"]) == 3
    cap = capsys.readouterr()
    recs = [json.loads(x) for x in cap.out.splitlines()]
    assert [r["shape"] for r in recs] == ["cylinder"] * 3 + [None]
    assert recs[-1]["patch"] == "bad" and "not determined" in recs[-1]["error"]
    assert "patch bad" in cap.err


def test_sim_rejects_object_smaller_than_the_sweep(tmp_path, capsys):
    code = main(
        ["sim", "ep2", "--object", "sphere", "--radius", "1", "-o", str(tmp_path / "s.csv")]
    )
    assert code == 2
    assert "sweep reaches beyond the object" in capsys.readouterr().err
    assert not (tmp_path / "s.csv").exists()  # a refused run leaves no empty file behind


def test_analyze_takes_a_run_folder_as_plot_and_export_do(cyl_csv, tmp_path, capsys):
    run = tmp_path / "run1"
    run.mkdir()
    (run / "contacts.csv").write_bytes(cyl_csv.read_bytes())
    outs = []
    for source in (run / "contacts.csv", run):
        capsys.readouterr()
        assert main(["ep2", "analyze", str(source), "--json"]) == 0
        outs.append(capsys.readouterr().out)
    assert outs[0] == outs[1] and '"shape":"cylinder"' in outs[1]
    empty = tmp_path / "empty"
    empty.mkdir()
    assert main(["ep2", "analyze", str(empty)]) == 2
    err = capsys.readouterr().err
    assert err == f"tactile ep2: error: {empty}: no contacts.csv in this directory (expected" \
        f" 'tactile record -o {empty} --pose-log LOG')\n"  # fmt: skip
