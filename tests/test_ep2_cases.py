"""EP2 case generator (``tactile_studies.ep2.cases``) and the trust bench (bench/ep2_trust.py).

The truth at the patch centre is checked against closed forms (spheres, pits,
cylinders at any rotation) and against a route it shares nothing with: finite
differences of the unit normal field (Weingarten, dn = S dX) of the sim's own
height function.
"""

import json
import os
import pathlib
import subprocess
import sys

import numpy as np
import pytest
from conftest import load_bench

from tactile.ep2.geometry import frame_from_contacts
from tactile_sim.ep2 import layouts
from tactile_sim.ep2.objects import make
from tactile_sim.ep2.sweep import sweep
from tactile_studies.ep2 import cases, truth

ROOT = pathlib.Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def tune():
    return cases.tune_cases()


@pytest.fixture(scope="module", params=["holdout", "holdout2"])
def holdout(request):
    return cases.split(request.param)


@pytest.fixture(scope="module")
def degenerate():
    return cases.degenerate_cases()


def _weingarten(obj, x, y, step=1e-5):
    """(k1, k2) from central differences of the upward unit normal: dn = S dX (convex > 0)."""
    _, p, q = obj.eval(x, y)
    tangents = np.array([[1.0, 0.0, p], [0.0, 1.0, q]]).T
    dn = np.column_stack(
        [
            (
                obj.normals(np.array([x + step]), np.array([y]))[0]
                - obj.normals(np.array([x - step]), np.array([y]))[0]
            )
            / (2 * step),
            (
                obj.normals(np.array([x]), np.array([y + step]))[0]
                - obj.normals(np.array([x]), np.array([y - step]))[0]
            )
            / (2 * step),
        ]
    )
    shape_op = np.linalg.lstsq(tangents, dn, rcond=None)[0]
    return np.sort(np.linalg.eigvals(shape_op).real)[::-1]


@pytest.mark.parametrize(
    "kind,radius,rot",
    [("sphere", 4.0, 0.0), ("sphere", 1000.0, 0.0), ("pit", 7.0, 0.0), ("cylinder", 3.0, 0.0)]
    + [("cylinder", 10.0, a) for a in (17.0, 45.0, 90.0)]
    + [("concave_cylinder", 6.0, a) for a in (0.0, 30.0, 72.0)],
)
def test_truth_closed_forms(kind, radius, rot):
    """Spheres k = 1/R, cylinders (1/R, 0) at any rotation, offset apex, tilt and unit."""
    case = cases.new(
        kind,
        radius=radius,
        rotation_deg=rot,
        apex=(0.7, -0.4),
        noise=0.01,
        unit=25.4,
        tilt_deg=20.0,
        tilt_axis_deg=35.0,
    )
    t = cases.draw(case, 2)["truth"]
    k = {"sphere": (1, 1), "pit": (-1, -1), "cylinder": (1, 0), "concave_cylinder": (0, -1)}
    want = np.array(k[kind]) / (radius * 25.4)
    assert np.allclose([t["k1"], t["k2"]], want, rtol=1e-9, atol=1e-12 / radius)
    s_want = {"sphere": 1.0, "pit": -1.0, "cylinder": 0.5, "concave_cylinder": -0.5}[kind]
    assert t["S"] == pytest.approx(s_want, abs=1e-9)
    assert t["radius"] == pytest.approx(radius * 25.4, rel=1e-9)


@pytest.mark.parametrize("seed", range(6))
def test_truth_against_finite_differences(seed):
    """Random quadrics, saddles and caps with offset apex: curvature at the found surface
    point equals the finite-difference Weingarten map of the height function there."""
    rng = np.random.default_rng(seed)
    kind = ("quadric", "saddle", "sphere", "pit", "cylinder", "quadric")[seed]
    k = tuple(rng.choice([-1, 1]) * np.array([1.0, rng.uniform(-0.9, 1)]) / rng.uniform(5, 30))
    case = cases.new(
        kind,
        radius=12.0,
        k=k if kind == "quadric" else None,
        rotation_deg=rng.uniform(0, 90),
        apex=tuple(rng.uniform(-2, 2, 2)),
        noise=0.02,
        tilt_deg=rng.uniform(0, 40),
        tilt_axis_deg=rng.uniform(0, 180),
    )
    d = cases.draw(case, 1)
    t = d["truth"]
    obj = cases.build(case)
    x, y, z = t["xyz"]
    assert z == pytest.approx(float(obj.height(x, y)), abs=1e-12)
    assert [t["k1"], t["k2"]] == pytest.approx(list(_weingarten(obj, x, y)), rel=1e-5, abs=1e-8)
    # the point lies on the patch-frame z line through the contacts' box centre
    n = d["normals"] / np.linalg.norm(d["normals"], axis=1, keepdims=True)
    frame = frame_from_contacts(d["points"], n)
    q = frame.to_patch(d["points"])[:, :2]
    on = frame.to_patch(np.array([x, y, z]) @ cases.tilt_matrix(case).T)
    assert on[:2] == pytest.approx(0.5 * (q.min(axis=0) + q.max(axis=0)), abs=1e-9)


def test_hessian_against_finite_differences():
    rng = np.random.default_rng(3)
    for kind in ("sphere", "pit", "cylinder", "concave_cylinder", "saddle", "quadric"):
        obj = make(kind, 9.0, rng.uniform(0, 180), centre=(0.3, -0.2), k=(0.1, -0.03))
        x, y = rng.uniform(-3, 3, 2)
        h = 1e-5
        _, zxp, zyp = obj.eval(x + h, y)
        _, zxm, zym = obj.eval(x - h, y)
        _, _, zyyp = obj.eval(x, y + h)
        _, _, zyym = obj.eval(x, y - h)
        fd = ((zxp - zxm) / (2 * h), (zyp - zym) / (2 * h), (zyyp - zyym) / (2 * h))
        assert truth.hessian(obj, x, y) == pytest.approx(fd, rel=1e-6, abs=1e-9)


def test_curvatures_match_eig_of_first_and_second_forms():
    rng = np.random.default_rng(5)
    for p, q, a, b, c in rng.normal(size=(20, 5)):
        first = np.array([[1 + p * p, p * q], [p * q, 1 + q * q]])
        second = -np.array([[a, b], [b, c]]) / np.sqrt(1 + p * p + q * q)
        ev = np.sort(np.linalg.eigvals(np.linalg.solve(first, second)).real)[::-1]
        assert truth.curvatures(p, q, a, b, c) == pytest.approx(tuple(ev), rel=1e-10, abs=1e-12)


def test_draw_is_deterministic_and_trials_differ():
    case = cases.new("cylinder", radius=10.0, rotation_deg=30.0, noise=0.01)
    a, b, c = cases.draw(case, 4), cases.draw(case, 4), cases.draw(case, 5)
    assert np.array_equal(a["points"], b["points"]) and np.array_equal(a["normals"], b["normals"])
    assert not np.allclose(a["points"], c["points"])


def test_seed_does_not_depend_on_the_hash_salt():
    code = (
        "from tactile_studies.ep2 import cases;"
        "print(cases.seed(cases.new('sphere', radius=10.0, noise=0.01), 7))"
    )
    env = dict(os.environ, PYTHONHASHSEED="12345", PYTHONPATH=os.pathsep.join(sys.path))
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True)
    assert int(out.stdout) == cases.seed(cases.new("sphere", radius=10.0, noise=0.01), 7)


def test_thesis_layout_matches_the_sweep_module():
    """THESIS36 = sweep.py's 3 fingers x 6 stops x 2 readings, apex at the patch centre."""
    case = cases.new("cylinder", radius=10.0, rotation_deg=30.0, params=cases.THESIS36)
    ref = sweep(make("cylinder", 10.0, 30.0, centre=(2.0, 2.0)))
    d = cases.draw(case)
    assert np.allclose(d["points"], ref["points"] - [2.0, 2.0, 0.0], atol=1e-12)
    assert np.allclose(d["normals"], ref["normals"], atol=1e-12)
    assert np.array_equal(d["finger"], ref["finger"])


def test_every_case_draws_its_contact_count(tune, holdout, degenerate):
    for case in tune[::37] + holdout + degenerate:
        d = cases.draw(case, 0)
        assert d["points"].shape == d["normals"].shape == (case.n, 3)
        assert d["finger"].shape == (case.n,)
        assert case.n in (27, 36)
        assert np.all(np.isfinite(d["points"])) and np.all(np.isfinite(d["normals"]))


def test_layout_sizes_and_counts():
    xy, finger, _, size = layouts.place("sweep", cases.THESIS27)
    assert len(xy) == 27 and size == 4.0 and sorted(set(finger.tolist())) == [0, 1, 2]
    assert sorted(set(np.round(xy[:, 0], 12).tolist())) == [-2.0, 0.0, 2.0]
    assert len(layouts.place("grid", {"nx": 3, "ny": 9, "size": 6.0})[0]) == 27
    turned, _, _, size = layouts.place("sweep", dict(cases.THESIS27, angle=30.0))
    assert size == 4.0
    assert np.allclose(np.linalg.norm(turned, axis=1), np.linalg.norm(xy, axis=1))


def test_tune_and_holdout_share_no_parameter_value(tune, holdout):
    def values(cs):
        out = {}
        for c in cs:
            for key, v in (
                ("r", c.radius),
                ("k", c.k if c.kind == "quadric" else None),
                ("rot", c.rotation_deg),
                ("noise", c.noise),
                ("unit", c.unit),
                ("tilt", c.tilt_deg),
                ("apex", c.apex),
                ("size", c.size),
                ("slope", c.slope if c.family == "plane" else None),
                ("layout", (c.layout, c.params)),
            ):
                out.setdefault(key, set()).add(v)
        return out

    t, h = values(tune), values(holdout)
    for key in t:
        assert not (t[key] & h[key]) - {None}, key
    assert len(holdout) >= 0.95 * len(cases.FAMILIES) * cases.HOLDOUT_PER_FAMILY
    assert {c.family for c in holdout} == set(cases.FAMILIES)
    assert {c.layout for c in holdout} == {"sweep", "grid", "scatter"}
    assert all(2.0 <= c.size <= 8.0 for c in holdout)
    assert all(0 < c.noise <= 0.03 for c in holdout)


def test_tune_grid_covers_the_targets(tune):
    fam = {f: [c for c in tune if c.family == f] for f in cases.FAMILIES}
    assert {c.radius for c in fam["sphere"]} == set(cases.TUNE_RADII)
    assert {c.radius for c in fam["cylinder"]} == set(cases.TUNE_CYLINDER_RADII)
    assert {c.rotation_deg for c in fam["cylinder"]} == set(cases.TUNE_ROTATIONS)
    assert {c.noise for c in tune} == set(cases.TUNE_NOISES)
    assert {c.n for c in tune} == {27, 36}
    assert all(c.k[0] != -c.k[1] for c in fam["quadric"])
    assert {np.sign(c.k[0] + c.k[1]) for c in fam["quadric"]} == {-1.0, 1.0}


def test_degenerate_flags(tune, holdout, degenerate):
    assert not any(c.degenerate or c.inconsistent for c in tune + holdout)
    assert all(c.degenerate or c.inconsistent for c in degenerate)
    for case in degenerate:
        d = cases.draw(case, 0)
        assert d["truth"]["determined"] is False
        centred = d["xy"] - d["xy"].mean(axis=0)
        sv = np.linalg.svd(centred, compute_uv=False)
        if case.degenerate in ("line", "duplicates"):
            assert sv[1] < 1e-12 * sv[0]
        if case.degenerate == "near_lines":  # 1 % of the patch apart or less
            assert sv[1] < 0.02 * sv[0]
        if case.normals_from == "flat" and case.noise == 0:
            assert np.allclose(d["normals"], [0.0, 0.0, 1.0])
    off = [c for c in degenerate if c.degenerate == "line" and c.apex == (1.0, 0.0)]
    assert off and off[0].family == "sphere" and off[0].radius == 10.0


def test_steep_and_unreachable_cases():
    assert cases.new("cylinder", radius=2.85, rotation_deg=45.0).steep  # 82.9 deg > 80
    assert not cases.new("cylinder", radius=3.0, rotation_deg=45.0).steep  # 70.5 deg
    assert cases.new("sphere", radius=4.0, apex=(2.0, 2.0)) is None  # far corner 5.66 > 4


def _bench():
    return load_bench("ep2_trust")


def test_wrong_label_rule():
    bench = _bench()
    out = dict(
        shape="sphere", confidence=0.99, S_interval=(0.8, 1.0), k1_interval=None, k2_interval=None
    )
    cyl = dict(S=0.5, k1=0.1, k2=0.0, size=4.0)
    assert bench.wrong_label(out, cyl)
    assert not bench.wrong_label(dict(out, S_interval=(0.45, 1.0)), cyl)
    assert not bench.wrong_label(dict(out, confidence=0.9), cyl)
    plane = dict(out, shape="plane", k1_interval=(-0.01, 0.01), k2_interval=(-0.01, 0.01))
    assert bench.wrong_label(plane, cyl)  # k L = 0.4
    assert not bench.wrong_label(plane, dict(cyl, k1=0.005))


def test_bench_smoke(tmp_path, capsys):
    bench = _bench()
    path = tmp_path / "out.json"
    args = [
        "--split",
        "tune",
        "--match",
        "r=10 rot=30 sweep",
        "--families",
        "cylinder",
        "--trials",
        "3",
        "--jobs",
        "1",
        "--json",
        str(path),
    ]
    assert bench.main(args + ["--estimator", "jet"]) == 0
    text = capsys.readouterr().out
    assert "| cylinder |" in text and "| all |" in text
    rows = json.loads(path.read_text())["cases"]
    assert len(rows) == 12
    assert all(r["ratio"] in (None, 1.0) for r in rows) and any(r["ratio"] for r in rows)
    assert (
        bench.main(
            [
                "--split",
                "degenerate",
                "--match",
                "line(n=27)",
                "--trials",
                "2",
                "--jobs",
                "1",
                "--json",
                str(path),
            ]
        )
        == 0
    )
    rows = json.loads(path.read_text())["cases"]
    assert {r["group"] for r in rows} == {"line"}
    assert all(r["answered"] + r["refused"] + r["crashed"] == r["trials"] for r in rows)


@pytest.mark.parametrize("estimator", ["default", "stated"])
def test_bench_batch_scores_as_the_loop(tmp_path, capsys, estimator):
    """``--batch`` (each case's trials in one analyze_patches call) scores every case as the
    per-patch loop does: refusals and their reasons, labels, coverage, to round-off in the
    errors; only the time differs."""
    bench = _bench()
    got = {}
    for flag in ([], ["--batch"]):
        path = tmp_path / f"out{len(flag)}.json"
        args = ["--split", "tune", "--families", "cylinder", "--match", "r=200 rot=30 sweep"]
        args += ["--trials", "3", "--jobs", "1", "--estimator", estimator, "--json", str(path)]
        assert bench.main(args + flag) == 0
        got[bool(flag)] = json.loads(path.read_text())["cases"]
    capsys.readouterr()
    assert len(got[True]) == len(got[False]) >= 8
    for a, b in zip(got[False], got[True], strict=True):
        for key in ("id", "answered", "refused", "null", "wrong", "reasons", "n_cover_S"):
            assert a[key] == b[key], key
        assert a["s_err"] == pytest.approx(b["s_err"], rel=1e-6, abs=1e-12)
        for key in ("cover_S", "cover_k1", "cover_k2"):
            assert a[key] == b[key], key
