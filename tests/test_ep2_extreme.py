"""EP2 at the edge of the floats (issue 12): extreme scales answer as ordinary ones do, or
are refused in one line; no numpy warning ever (warnings are errors in this module).

- regressions: a coordinate of 1e308 (was a LinAlgError traceback), coordinates scaled by
  1e160 (OverflowError) and 1e-160 (RuntimeWarning lines), normals of any length, option
  values NaN/inf, through ``tactile ep2 analyze`` and ``tactile plot``;
- scale equivariance: for s = 10^k, k in -150..150, the contacts times s give curvatures / s
  and the same S, label and refusal (the library for many draws, the CLI for a few).
"""

import contextlib
import io
import json
import math
import pathlib
import re
import tempfile

import numpy as np
import pytest
from conftest import FUZZ_SCALE
from hypothesis import given, settings
from hypothesis import strategies as st

from tactile.cli.main import main
from tactile.ep2 import analyze_patch, analyze_sweep
from tactile.errors import DataError, InputError
from tactile_sim.ep2 import make, sweep

pytestmark = pytest.mark.filterwarnings("error")

KINDS = ("plane", "cylinder", "concave_cylinder", "sphere", "pit", "saddle")


def contacts(kind="cylinder", radius=6.6, rotation=30.0, noise=0.01, seed=0, repeats=2):
    obj = make(kind, radius, rotation, centre=(2.0, 2.0))
    d = sweep(obj, noise_pos=noise, noise_normal=noise, repeats=repeats, seed=seed)
    return d["points"], d["normals"], d["finger"]


def write(path, points, normals, finger=None):
    lines = ["x,y,z,nx,ny,nz" + (",finger" if finger is not None else "")]
    for i, row in enumerate(np.column_stack([points, normals])):
        cells = [repr(float(v)) for v in row] + ([str(finger[i])] if finger is not None else [])
        lines.append(",".join(cells))
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


def one_line(err):
    return err.count("\n") == 1 and "Traceback" not in err and "Warning" not in err


# -- regressions, through the CLI -------------------------------------------------------------


@pytest.mark.parametrize("value", ["1e308", "-1e308", "1.7976931348623157e308"])
@pytest.mark.parametrize("command", ["ep2", "plot"])
def test_a_coordinate_of_1e308_is_refused_in_one_line_naming_its_row(tmp_path, cli, value, command):
    pts, nrm, _ = contacts()
    path = write(tmp_path / "c.csv", pts, nrm)
    text = path.read_text().splitlines()
    text[3] = value + text[3][text[3].index(",") :]  # line 4, column x
    path.write_text("\n".join(text) + "\n")
    args = ("ep2", "analyze", path) if command == "ep2" else ("plot", path, "-o", tmp_path)
    code, out, err = cli(*args)
    assert code == 2 and out == "" and one_line(err)
    assert f"{path}:4: column 'x': the contacts spread over" in err and "1e+300" in err


@pytest.mark.parametrize("scale", [1e160, 1e-160, 1e299, 1e-299])
def test_scaled_files_answer_like_the_original(tmp_path, cli, scale):
    pts, nrm, finger = contacts()
    code, out, err = cli("ep2", "analyze", write(tmp_path / "a.csv", pts, nrm, finger), "--json")
    assert code == 0, err
    base = json.loads(out)
    code, out, err = cli("ep2", "analyze", write(tmp_path / "b.csv", pts * scale, nrm), "--json")
    assert (code, err) == (0, ""), err
    rec = json.loads(out)
    assert rec["shape"] == base["shape"] == "cylinder"
    assert rec["S"] == pytest.approx(base["S"], abs=1e-9)
    assert rec["k1"] * scale == pytest.approx(base["k1"], rel=1e-9)
    assert rec["radius"] / scale == pytest.approx(base["radius"], rel=1e-9)
    assert rec["C"] == pytest.approx(base["C"] - 2 / math.pi * math.log(scale), abs=1e-9)
    assert "Infinity" not in out and "NaN" not in out
    code, out, err = cli("ep2", "analyze", tmp_path / "b.csv")  # the table
    assert code == 0 and "inf" not in out and "nan" not in out


@pytest.mark.parametrize("scale", [1e160, 1e-160])
def test_plots_at_extreme_scales(tmp_path, cli, scale):
    pts, nrm, finger = contacts()
    path = write(tmp_path / "c.csv", pts * scale, nrm * 1e150, finger)
    code, out, err = cli("plot", path, "-o", tmp_path / "figs")
    assert (code, err) == (0, "")
    assert [p.rsplit("_", 1)[-1] for p in out.split()] == ["contacts.png", "patch.png", "maps.png"]


@pytest.mark.parametrize("scale", [1e300, 1e-300, 1e-150])
def test_normals_of_any_finite_length_are_directions(tmp_path, cli, scale):
    pts, nrm, _ = contacts()
    code, out, err = cli("ep2", "analyze", write(tmp_path / "a.csv", pts, nrm), "--json")
    base = json.loads(out)
    code, out, err = cli("ep2", "analyze", write(tmp_path / "b.csv", pts, nrm * scale), "--json")
    assert (code, err) == (0, "")
    assert json.loads(out)["k1"] == pytest.approx(base["k1"], rel=1e-12)


def test_spreads_outside_the_range_are_input_errors_and_a_point_is_a_data_error(tmp_path, cli):
    pts, nrm, _ = contacts()
    code, _, err = cli("ep2", "analyze", write(tmp_path / "tiny.csv", pts * 1e-310, nrm))
    assert code == 2 and one_line(err) and "spread over only" in err and "1e-300" in err
    same = np.repeat(pts[:1] * 1e300, len(pts), axis=0)
    code, _, err = cli("ep2", "analyze", write(tmp_path / "point.csv", same, nrm))
    assert code == 3 and one_line(err) and "all contacts at one point" in err


@pytest.mark.parametrize(
    "option, value",
    [("--noise-pos", "nan"), ("--noise-pos", "inf"), ("--noise-pos", "-1"),
     ("--noise-pos", "1e308"), ("--noise-normal", "nan"), ("--noise-normal", "4"),
     ("--max-normal-angle", "nan"), ("--break-angle", "inf"), ("--grid", "100000")],
)  # fmt: skip
def test_option_numbers_are_checked(tmp_path, cli, option, value):
    pts, nrm, _ = contacts()
    code, _, err = cli("ep2", "analyze", write(tmp_path / "c.csv", pts, nrm), option, value)
    assert code == 2 and one_line(err) and f"({option}): must be" in err


def test_a_split_sweep_at_1e150_splits_and_answers_as_at_1(tmp_path):
    pts, nrm, finger = contacts("plane", noise=0.0)
    crease = pts[:, 1] > 2.0  # fold the sweep's far half up by 40 deg across every finger
    pts[crease, 2] = np.tan(np.radians(40.0)) * (pts[crease, 1] - 2.0)
    nrm[crease] = [0.0, -np.sin(np.radians(40.0)), np.cos(np.radians(40.0))]
    base = analyze_sweep(pts, nrm, finger=finger, split=True)
    big = analyze_sweep(pts * 1e150, nrm, finger=finger, split=True)
    assert len(base) == len(big) == 2
    for a, b in zip(base, big, strict=True):
        assert (a.shape, a.n_points) == (b.shape, b.n_points)
        assert b.k1 * 1e150 == pytest.approx(a.k1, rel=1e-8, abs=1e-12)


# -- scale equivariance ----------------------------------------------------------------------


def _answer(points, normals, scale, **kw):
    try:
        return analyze_patch(points * scale, normals, **kw)
    except (DataError, InputError) as exc:
        return exc


def _numbers_out(text):
    return re.sub(r"[-+]?\d+(\.\d+)?(e[-+]?\d+)?", "#", text)


def assert_equivariant(a, b, s):
    """``b`` is ``a`` for the contacts times ``s``: curvatures / s, the same S and label, or
    the same refusal (its lengths scaled)."""
    if isinstance(a, Exception):
        assert type(b) is type(a), (a, b)
        assert _numbers_out(str(b)) == _numbers_out(str(a))
        return
    assert not isinstance(b, Exception), (a.shape, b)
    assert (b.shape, b.model.split(":")[0]) == (a.shape, a.model.split(":")[0])
    # noise-free spline fits estimate their noise from round-off, which is not scale-free
    assert b.confidence == pytest.approx(a.confidence, abs=1e-3)
    big = max(abs(a.k1), abs(a.k2))
    for k in ("k1", "k2"):
        assert getattr(b, k) * s == pytest.approx(getattr(a, k), abs=1e-8 * big + 1e-300)
    if a.S is None:
        assert b.S is None
    else:
        assert b.S == pytest.approx(a.S, abs=1e-8)
        assert b.radius / s == pytest.approx(a.radius, rel=1e-8)
    assert np.allclose(b.frame.origin / s, a.frame.origin, rtol=1e-12, atol=1e-12)


scenes = st.fixed_dictionaries(
    {
        "kind": st.sampled_from(KINDS),
        "radius": st.floats(3.0, 200.0),
        "rotation": st.floats(0.0, 180.0),
        "noise": st.sampled_from([0.0, 0.002, 0.02]),
        "seed": st.integers(0, 2**16),
        "repeats": st.integers(1, 2),
    }
)


@settings(max_examples=60 * FUZZ_SCALE)
@given(scene=scenes, k=st.integers(-150, 150), offset=st.floats(-1e3, 1e3), spline=st.booleans())
def test_scaling_the_contacts_scales_the_answer_library(scene, k, offset, spline):
    pts, nrm, finger = contacts(**scene)
    pts = pts + offset
    kw = dict(method="spline") if spline else {}
    s = 10.0**k
    assert_equivariant(_answer(pts, nrm, 1.0, **kw), _answer(pts, nrm, s, **kw), s)


def run_cli(*args):
    """(exit code, stdout, stderr) of ``tactile ARGS`` in-process (no pytest fixture, so
    hypothesis may call it per example)."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main([str(a) for a in args])
    return code, out.getvalue(), err.getvalue()


@settings(max_examples=4 * FUZZ_SCALE)
@given(scene=scenes, k=st.integers(-150, 150))
def test_scaling_the_contacts_scales_the_answer_cli(scene, k):
    pts, nrm, finger = contacts(**scene)
    s = 10.0**k
    out = []
    with tempfile.TemporaryDirectory() as tmp:
        for name, scale in (("a", 1.0), ("b", s)):
            path = write(pathlib.Path(tmp) / f"{name}.csv", pts * scale, nrm, finger)
            out.append(run_cli("ep2", "analyze", path, "--json"))
    (code_a, rec_a, err_a), (code_b, rec_b, err_b) = out
    assert code_a == code_b and one_line(err_a or "x\n") and one_line(err_b or "x\n")
    if code_a:
        assert _numbers_out(err_b.replace("b.csv", "a.csv")) == _numbers_out(err_a)
        return
    a, b = json.loads(rec_a), json.loads(rec_b)
    assert (a["shape"], a["S"] is None) == (b["shape"], b["S"] is None)
    if a["S"] is not None:
        assert b["S"] == pytest.approx(a["S"], abs=1e-8)
    big = max(abs(a["k1"]), abs(a["k2"]))
    assert b["k1"] * s == pytest.approx(a["k1"], abs=1e-8 * big)
    assert b["k2"] * s == pytest.approx(a["k2"], abs=1e-8 * big)
