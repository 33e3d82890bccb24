"""EP2 trust regressions: the promises the default keeps where the data are thin or wrong.

- a single finger's line or path, two nearly coincident lines, a cluster, rows duplicated
  onto two stops: refused with "not determined" naming the direction (exit 3, one line)
  or, if answered, never confidently wrong (``bench/ep2_trust.py:wrong_label``);
- curved positions with flat or mirrored normals: "positions and normals disagree"
  (``tactile.ep2.jet_answers``); planes are never mislabelled;
- the JSON record: a plane has S, C, radius null and k1/k2 intervals; ``model`` explains
  itself in one line and names how far the answer moved toward the 3-jet;
- exact duplicate rows count once (a warning), intervals unchanged;
- steep normals are left out by name, with the limit and its option;
- the emulated EP2 sweep (normals through F/T): the radius interval holds the true radius.

Known misses are pinned as strict xfails whose reason names them (docs/ep2.md, Limits).
"""

import json
import pathlib
import re

import numpy as np
import pytest
from conftest import load_bench

from tactile.ep2 import analyze_patch
from tactile.ep2.edges import EdgeError
from tactile.errors import DataError
from tactile.output.text import dumps
from tactile_sim.ep2 import make, sweep
from tactile_sim.ep2.sweep import write_csv
from tactile_studies.ep2 import cases, peers

ROOT = pathlib.Path(__file__).resolve().parents[1]


BENCH = load_bench("ep2_trust")


def _answer(d):
    """(bench output dict or None, refusal message or None) for a dict of contacts."""
    try:
        return BENCH.default(d["points"], d["normals"], d.get("finger")), None
    except DataError as err:
        return None, str(err)


def _confident(out):
    return out["shape"] != "uncertain" and out["confidence"] >= BENCH.CONFIDENT


def _case(family, layout, params, noise=0.0, **kw):
    case = cases.new(family, layout=layout, params=params, noise=noise, **kw)
    assert case is not None, (family, layout, params, kw)
    return case


def _named_direction(message):
    """The world direction a 'not determined' refusal names, as a unit vector."""
    m = re.search(r"curvature (?:along|across) \(([-\d.]+), ([-\d.]+), ([-\d.]+)\)", message)
    assert m, message
    v = np.array([float(g) for g in m.groups()])
    return v / np.linalg.norm(v)


R10 = dict(radius=10.0)
KNOWN_CLUSTER = (
    "a cylinder's 0.05-wide cluster at noise 0.005: S interval [0.51, 0.80] misses 0.5 "
    "in one of 4 trials: known miss, docs/ep2.md 'Limits'"
)
KNOWN_FLAT = (
    "flat normals under a sphere at noise 0.02: one of 3 trials passes the consistency test "
    "and is called plane: known miss, docs/ep2.md 'Limits'"
)

# -- a single line, noise-free ----------------------------------------------------------


def test_single_finger_off_the_apex_is_not_determined():
    """The issue's reproducer: the finger at x = 1 of a 0..4 sweep over a sphere r 10."""
    d = cases.draw(_case("sphere", "line", {"n": 36}, apex=(1.0, 0.0), **R10))
    with pytest.raises(DataError, match="not determined"):
        analyze_patch(d["points"], d["normals"], finger=d["finger"])


def test_single_finger_off_the_apex_exits_3_with_one_line(tmp_path, cli):
    d = cases.draw(_case("sphere", "line", {"n": 36}, apex=(1.0, 0.0), **R10))
    path = tmp_path / "line.csv"
    write_csv(path, d)
    code, out, err = cli("ep2", "analyze", path)
    assert code == 3 and out == ""
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err
    assert "not determined" in err and str(path) in err


def _thesis_finger(x, samples=6, repeats=2, kind="sphere", **kw):
    """One finger of the thesis's sweep (sweep.py: 6 stops x 2 readings) at x over y 0..4;
    the object's apex is at (2, 2)."""
    return sweep(
        make(kind, 10.0, **kw), fingers=1, origin=(x, 0.0), samples=samples, repeats=repeats
    )


NOISE_FREE_LINES = [
    pytest.param(lambda: cases.draw(_case("sphere", "line", {"n": 27}, **R10)), id="apex"),
    pytest.param(
        lambda: cases.draw(_case("sphere", "line", {"n": 27, "angle": 45.0}, **R10)),
        id="45deg-apex",
    ),
    pytest.param(
        lambda: cases.draw(_case("sphere", "line", {"n": 27, "angle": 30.0}, apex=(0.5, 1), **R10)),
        id="30deg-off",
    ),
    pytest.param(
        lambda: cases.draw(
            _case("saddle", "line", {"n": 27, "angle": 30.0}, apex=(0.5, 1.0), **R10)
        ),
        id="saddle-30deg-off",
    ),
    pytest.param(
        lambda: cases.draw(_case("plane", "line", {"n": 27}, slope=(1.0, 1.0))), id="plane"
    ),
    pytest.param(lambda: _thesis_finger(2.0), id="thesis-finger-x2"),
    pytest.param(
        lambda: cases.draw(_case("sphere", "line", {"n": 36}, apex=(1.0, 0.0), **R10)),
        id="issue-x1",
    ),
    pytest.param(
        lambda: _thesis_finger(1.0),
        id="thesis-finger-x1",
    ),
    pytest.param(
        lambda: _thesis_finger(0.0, samples=9, repeats=1),
        id="thesis27-finger-x0",
    ),
    pytest.param(
        lambda: cases.draw(
            _case("cylinder", "line", {"n": 36, "angle": 45.0}, rotation_deg=30.0, **R10)
        ),
        id="cylinder-45deg",
    ),
]


@pytest.mark.parametrize("make_line", NOISE_FREE_LINES)
def test_noise_free_line_is_not_determined_across_it(make_line):
    """Exact data on one line fix the curvature along it, never across it: the refusal says
    'not determined' and names a direction across the line (centre_result's promise)."""
    d = make_line()
    p = d["points"]
    along = np.linalg.svd(p - p.mean(axis=0))[2][0]  # the line's direction (world)
    with pytest.raises(DataError) as err:
        analyze_patch(p, d["normals"])
    message = str(err.value)
    assert "not determined" in message
    assert abs(_named_direction(message) @ along) < 0.2, message


# -- other degenerate layouts -------------------------------------------------------------

DEGENERATE = [
    ("sphere", "line", {"n": 27, "angle": 45.0}, dict(apex=(1.0, 0.5), **R10)),
    ("sphere", "line", {"n": 27, "angle": 30.0}, R10),
    ("cylinder", "line", {"n": 36, "angle": 30.0}, dict(rotation_deg=30.0, apex=(1.0, 0.0), **R10)),
    ("sphere", "sweep", {"stops": 18, "xs": (0.0, 0.004)}, R10),
    ("sphere", "sweep", {"stops": 18, "xs": (0.0, 0.004), "angle": 45.0}, dict(apex=(1, 0), **R10)),
    ("cylinder", "sweep", {"stops": 18, "xs": (0.0, 0.04)}, dict(rotation_deg=30.0, **R10)),
    ("sphere", "cluster", {"n": 27}, R10),
    ("cylinder", "cluster", {"n": 36, "spread": 0.05}, dict(rotation_deg=45.0, **R10)),
    ("sphere", "duplicates", {"distinct": 2, "n": 36}, R10),
    ("sphere", "duplicates", {"distinct": 2, "n": 36}, dict(apex=(1.0, 0.0), **R10)),
    ("cylinder", "duplicates", {"distinct": 2, "n": 36, "angle": 90.0}, R10),
]


@pytest.mark.parametrize("noise", [0.0, 0.005, 0.02])
@pytest.mark.parametrize("family,layout,params,kw", DEGENERATE)
def test_degenerate_layouts_are_refused_or_never_confidently_wrong(
    family, layout, params, kw, noise, request
):
    if layout == "cluster" and params.get("spread") == 0.05 and noise == 0.005:
        request.applymarker(pytest.mark.xfail(strict=True, reason=KNOWN_CLUSTER))
    case = _case(family, layout, params, noise=noise, **kw)
    for trial in range(1 if noise == 0 else 4):
        d = cases.draw(case, trial)
        out, why = _answer(d)
        if out is None:
            assert "not determined" in why or "disagree" in why, why
            continue
        tr = d["truth"]
        assert not BENCH.wrong_label(out, tr), (case.id, trial, out)
        if out["S_reported"]:
            assert BENCH._inside(out["S_interval"], tr["S"]), (case.id, trial, out)


NOISY_LINES = [
    lambda s, seed: _noisy_thesis_finger(0.0, "sphere", s, seed),
    lambda s, seed: _noisy_thesis_finger(1.0, "sphere", s, seed),
    lambda s, seed: _noisy_thesis_finger(2.0, "cylinder", s, seed, rotation_deg=30.0),
    lambda s, seed: cases.draw(_case("sphere", "line", {"n": 27, "angle": 45.0}, s, **R10), seed),
    lambda s, seed: cases.draw(
        _case("cylinder", "line", {"n": 36, "angle": 30.0}, s, rotation_deg=60.0, **R10), seed
    ),
    lambda s, seed: cases.draw(
        _case("saddle", "line", {"n": 27, "angle": 135.0}, s, apex=(0.5, 1.0), **R10), seed
    ),
]


def _noisy_thesis_finger(x, kind, noise, seed, **kw):
    obj = make(kind, 10.0, **kw)
    return sweep(obj, fingers=1, origin=(x, 0.0), noise_pos=noise, noise_normal=noise, seed=seed)


@pytest.mark.parametrize("k", range(len(NOISY_LINES)))
def test_noisy_single_and_diagonal_lines_give_no_confident_label(k):
    """30 seeds per line, noise 0.005-0.02: whatever is answered is not confident."""
    confident = []
    for seed in range(30):
        noise = (0.005, 0.01, 0.02)[seed % 3]
        out, _ = _answer(NOISY_LINES[k](noise, seed))
        if out is not None and _confident(out):
            confident.append((seed, out["shape"], out["confidence"]))
    assert confident == []


# -- positions and normals that disagree --------------------------------------------------

INCONSISTENT = [
    ("sphere", cases.THESIS27, dict(normals_from="flat", **R10)),
    ("sphere", cases.THESIS36, dict(normals_from="flipped", radius=6.0)),
    ("cylinder", cases.THESIS36, dict(normals_from="flipped", **R10)),
    ("cylinder", cases.THESIS27, dict(normals_from="flat", rotation_deg=30.0, **R10)),
    ("pit", cases.THESIS27, dict(normals_from="flat", radius=8.0)),
    ("saddle", cases.THESIS27, dict(normals_from="flipped", **R10)),
    ("quadric", cases.THESIS36, dict(normals_from="flipped", k=(0.1, -0.04))),
]


def _inconsistent_params():
    out = []
    for family, params, kw in INCONSISTENT:
        for noise in (0.0, 0.005, 0.02):
            name = f"{family}-{kw['normals_from']}-{noise:g}"
            out.append(pytest.param(family, params, kw, noise, id=name))
    return out


@pytest.mark.parametrize("family,params,kw,noise", _inconsistent_params())
def test_curved_positions_with_flat_or_mirrored_normals_are_refused(
    family, params, kw, noise, request
):
    if (family, kw["normals_from"], noise) == ("sphere", "flat", 0.02):
        request.applymarker(pytest.mark.xfail(strict=True, reason=KNOWN_FLAT))
    case = _case(family, "sweep", params, noise=noise, **kw)
    for trial in range(1 if noise == 0 else 3):
        d = cases.draw(case, trial)
        with pytest.raises(DataError, match="positions and normals disagree"):
            analyze_patch(d["points"], d["normals"], finger=d["finger"])


def test_a_mirrored_saddle_is_told_apart_by_direction():
    """A saddle's flipped normals give the same principal curvatures as its positions, just
    turned by 90 deg: the refusal names a direction where the two estimates differ and the
    values there, of opposite sign."""
    d = cases.draw(_case("saddle", "sweep", cases.THESIS36, 0.0, normals_from="flipped", **R10))
    with pytest.raises(DataError) as err:
        analyze_patch(d["points"], d["normals"])
    m = re.search(r"along \(([-\d., ]+)\) (\S+) from the positions vs (\S+) from", str(err.value))
    assert m, err.value
    direction = np.array([float(v) for v in m.group(1).split(",")])
    kp, kn = float(m.group(2)), float(m.group(3))
    assert kp * kn < 0 and min(abs(kp), abs(kn)) > 0.05, err.value
    assert abs(np.linalg.norm(direction) - 1) < 0.02


@pytest.mark.parametrize("normals_from", ["flat", "flipped"])
@pytest.mark.parametrize("noise", [0.0, 0.01])
def test_planes_are_never_mislabelled_whatever_their_normals(normals_from, noise):
    """A level plane's flat or mirrored normals are its own: it stays a plane.  A sloped
    plane's are not: refused, or no confident label (every one counts as wrong)."""
    level = _case("plane", "sweep", cases.THESIS36, noise, normals_from=normals_from)
    sloped = _case(
        "plane", "sweep", cases.THESIS36, noise, slope=(1.0, 1.0), normals_from=normals_from
    )
    for trial in range(1 if noise == 0 else 3):
        d = cases.draw(level, trial)
        out, why = _answer(d)
        assert why is None and out["shape"] == "plane", why
        assert not BENCH.wrong_label(out, d["truth"])
        d = cases.draw(sloped, trial)
        out, why = _answer(d)
        assert out is None or not BENCH.wrong_label(out, d["truth"], inconsistent=True), out


# -- the JSON record ----------------------------------------------------------------------


def _numbers(obj):
    """Every number in a record (``dumps`` would print a NaN as null: look before it does)."""
    if isinstance(obj, dict):
        return [v for x in obj.values() for v in _numbers(x)]
    if isinstance(obj, list | tuple | np.ndarray):
        return [v for x in obj for v in _numbers(x)]
    return [obj] if isinstance(obj, float | int | np.number) else []


def _record(res):
    rec = res.to_dict("p")
    assert all(np.isfinite(v) for v in _numbers(rec)), rec
    return json.loads(dumps(rec))


@pytest.mark.parametrize("slope", [(0.0, 0.0), (1.0, 1.0)])
def test_a_plane_has_null_S_C_radius_and_k_intervals(slope):
    d = sweep(make("plane", slope=slope), noise_pos=0.01, noise_normal=0.01, seed=3)
    rec = _record(analyze_patch(d["points"], d["normals"]))
    assert rec["shape"] == "plane"
    for key in ("S", "C", "radius", "S_interval", "radius_interval", "S_mean", "C_mean"):
        assert rec[key] is None, key
    for key in ("k1", "k2"):
        lo, hi = rec[f"{key}_interval"]
        assert lo <= rec[key] <= hi and lo < 0.0 < hi  # the true curvature, 0, inside
        assert hi - lo < 0.1 / 4  # resolved well enough to call it a plane on a 4 x 4 patch


def test_an_uncertain_label_still_has_an_S_interval():
    """A faint cylinder (r 200, noise 0.01): S straddles the cylinder/saddle edge."""
    seen = 0
    for seed in range(10):
        d = sweep(make("cylinder", radius=200.0), noise_pos=0.01, noise_normal=0.01, seed=seed)
        try:
            res = analyze_patch(d["points"], d["normals"])
        except DataError:
            continue
        if res.shape != "uncertain":
            continue
        seen += 1
        rec = _record(res)
        lo, hi = rec["S_interval"]
        assert lo <= rec["S"] <= hi and rec["radius"] is not None and rec["C"] is not None
        assert rec["confidence"] < 0.999 and len(rec["votes"]) >= 2
    assert seen >= 3


@pytest.mark.parametrize(
    "obj",
    [
        make("sphere", 8.0),
        make("cylinder", 5.0, rotation_deg=30.0),
        make("quadric", k=(1 / 6, -0.4 / 6), rotation_deg=30.0),
        make("saddle", 10.0),
        make("plane", slope=(1.0, 1.0)),
    ],
)
def test_every_record_explains_its_model_in_one_field(obj):
    d = sweep(obj, noise_pos=0.002, noise_normal=0.002, seed=1)
    rec = _record(analyze_patch(d["points"], d["normals"]))
    model = rec["model"]
    assert isinstance(model, str) and "\n" not in model
    assert model.startswith("2-jet of positions and normals") and "truncation checked" in model


def test_the_model_field_names_the_order_the_record_reports():
    """The answer moves from the 2-jet toward the 3-jet by the evidence for it (a scatter
    over a surface with a cubic term moves; high noise keeps the 2-jet); the model line
    gives that weight and ``order`` says 3 once it is past half way."""
    rng = np.random.default_rng(0)
    weights = []
    for noise in (0.0, 0.01, 0.05):
        for c3 in (0.0, 0.1, 0.3):
            x, y = rng.uniform(0.0, 4.0, (2, 40))
            z = 0.2 * x * x - 0.05 * y * y + c3 * x**3 / 4
            nrm = np.stack([-(0.4 * x + 0.75 * c3 * x * x), 0.1 * y, np.ones_like(x)], 1)
            nrm = nrm / np.linalg.norm(nrm, axis=1)[:, None] + noise * rng.standard_normal((40, 3))
            pts = np.stack([x, y, z], 1) + noise * rng.standard_normal((40, 3))
            rec = _record(analyze_patch(pts, nrm))
            w = float(re.search(r"moved ([0-9.]+) of the way to the 3-jet", rec["model"])[1])
            assert rec["order"] == (3 if w > 0.5 else 2), rec["model"]
            weights.append(w)
    assert min(weights) < 0.5 < max(weights), weights


@pytest.mark.xfail(
    strict=True,
    reason="noise-free, |k| L 1: the normals' 2-jet misses the positions by 0.005 L, 25x its "
    "expected size: known miss, docs/ep2.md 'Limits'",
)
def test_a_noise_free_strongly_curved_cylinder_is_not_called_inconsistent():
    d = sweep(make("cylinder", 4.0))
    assert analyze_patch(d["points"], d["normals"]).shape == "cylinder"


# -- duplicated rows ----------------------------------------------------------------------


@pytest.mark.parametrize("stack", ["repeat", "append"])
def test_exact_duplicates_count_once_and_leave_the_intervals_alone(stack):
    d = sweep(make("cylinder", 8.0, rotation_deg=30), noise_pos=0.01, noise_normal=0.01, seed=4)
    p, n, f = d["points"], d["normals"], d["finger"]
    one = analyze_patch(p, n, finger=f)
    if stack == "repeat":  # each row twice in a row (two readings per stop, no noise)
        p2, n2, f2 = (np.repeat(v, 2, axis=0) for v in (p, n, f))
    else:  # the whole file twice
        p2, n2, f2 = (np.concatenate([v, v]) for v in (p, n, f))
    two = analyze_patch(p2, n2, finger=f2)
    assert one.warnings == [] and two.warnings == [f"{len(p)} duplicated row(s) counted once"]
    assert two.n_points == one.n_points == len(p) == len(p2) // 2
    assert two.S == pytest.approx(one.S, rel=1e-12)
    for key in ("S_interval", "k1_interval", "k2_interval", "radius_interval"):
        assert getattr(two, key) == pytest.approx(getattr(one, key), rel=1e-12), key


def test_noise_free_repeats_do_not_narrow_the_intervals():
    """The thesis's 2 readings per stop, noise-free, are exact duplicates."""
    d = sweep(make("sphere", 8.0), samples=6, repeats=2)
    single = sweep(make("sphere", 8.0), samples=6, repeats=1)
    two = analyze_patch(d["points"], d["normals"])
    one = analyze_patch(single["points"], single["normals"])
    assert two.n_points == one.n_points == 18 and "18 duplicated" in two.warnings[0]
    assert two.radius_interval == pytest.approx(one.radius_interval, rel=1e-12)


# -- two fingers, row order (found while writing these tests) ------------------------------


@pytest.mark.parametrize("noise", [0.0, 0.005])
@pytest.mark.parametrize("radius", [4.0, 9.0])
def test_two_fingers_along_a_cylinder_are_refused_as_an_edge_or_a_curve(radius, noise):
    """Fingers at x = 0 and 4 along a cylinder's axis: each line's normals are constant, as
    on two faces; a crease fits as well as the cylinder.  Every seed is refused alike,
    naming the edge where the two tangent planes meet (x = 2, along y, the normals' turn)."""
    turn = np.degrees(2 * np.arcsin(2.0 / radius))
    for seed in range(1 if noise == 0 else 3):
        d = sweep(make("cylinder", radius), fingers=2, spacing=4.0, length=2.0, samples=12,
                  repeats=1, noise_pos=noise, noise_normal=noise, seed=seed)  # fmt: skip
        with pytest.raises(EdgeError, match="cannot tell an edge from a smooth curve") as err:
            analyze_patch(d["points"], d["normals"])
        edge = err.value.edge
        assert edge.ambiguous and "sweep across it" in str(err.value)
        lo, hi = edge.dihedral_interval
        assert lo - 1e-6 <= 180 - turn <= hi + 1e-6, (seed, edge)
        assert abs(edge.point[0] - 2.0) < 0.02 and abs(edge.direction[1]) > 0.999


ORDERED = [
    pytest.param(
        lambda: sweep(make("cylinder", 9.0, rotation_deg=30.0), noise_pos=0.01, noise_normal=0.01),
        id="noisy-thesis-sweep",
    ),
    pytest.param(lambda: sweep(make("sphere", 6.0), samples=9, repeats=1), id="noise-free-sphere"),
    pytest.param(
        lambda: sweep(
            make("concave_cylinder", 9.0, rotation_deg=10.0),
            fingers=2,
            spacing=4.0,
            length=2.0,
            samples=12,
            repeats=1,
        ),
        id="noise-free-two-fingers",
    ),
]


@pytest.mark.parametrize("make_sweep", ORDERED)
def test_row_order_does_not_change_the_answer(make_sweep):
    d = make_sweep()
    p, n = d["points"], d["normals"]
    base = analyze_patch(p, n)
    for order in (np.arange(len(p))[::-1], np.lexsort((p[:, 0], p[:, 1]))):
        res = analyze_patch(p[order], n[order])
        assert res.shape == base.shape
        assert (res.k1, res.k2) == pytest.approx((base.k1, base.k2), rel=1e-9, abs=1e-12)
        for key in ("k1_interval", "k2_interval", "S_interval", "radius_interval"):
            got, want = getattr(res, key), getattr(base, key)
            assert (got is None) == (want is None), key
            if want is not None:  # the ends are sampled on the ellipsoid: 1 % of the width
                assert got == pytest.approx(want, abs=0.01 * (want[1] - want[0]) + 1e-12), key


# -- strongly curved shapes ---------------------------------------------------------------

STRONG = [
    ("sphere", dict(radius=4.0)),
    pytest.param(
        "sphere",
        dict(radius=6.0),
        marks=pytest.mark.xfail(
            strict=True,
            reason="S error 0.0018-0.0019 against the 2-jet's 0.0014-0.0016: "
            "known miss, docs/ep2.md 'Limits'",
        ),
    ),
    pytest.param(
        "cylinder",
        dict(radius=3.0, rotation_deg=30.0),
        marks=pytest.mark.xfail(
            strict=True,
            reason="|k| L 1.3: 'plane' at confidence 0.04-0.07 (the k1 interval "
            "excludes 0): known miss, docs/ep2.md 'Limits'",
        ),
    ),
    ("pit", dict(radius=4.0)),
]


@pytest.mark.parametrize("params", [cases.THESIS27, cases.THESIS36], ids=["27", "36"])
@pytest.mark.parametrize("family,kw", STRONG)
def test_strongly_curved_noise_free_shapes_at_the_centre(family, kw, params):
    d = cases.draw(_case(family, "sweep", params, **kw))
    tr = d["truth"]
    radius = kw["radius"]
    assert tr["radius"] == pytest.approx(radius, rel=1e-9)  # constant curvature: closed form
    res = analyze_patch(d["points"], d["normals"], finger=d["finger"])
    err = abs(res.S - tr["S"])
    k1, k2 = (float(v[0]) for v in peers.jet(d["points"], d["normals"], 1e-6, 1e-6))
    jet_err = abs(BENCH.shape_index(k1, k2) - tr["S"])
    assert err <= 0.006 and err <= jet_err, (err, jet_err)  # a 3-jet's truncation
    assert res.radius == pytest.approx(radius, rel=0.2)  # |k| L 1: the 2-jet's bias, counted
    lo, hi = res.radius_interval
    assert lo <= radius <= hi
    assert not BENCH.wrong_label(BENCH.default(d["points"], d["normals"], d["finger"]), tr)


# -- the normal-angle limit ---------------------------------------------------------------


def test_steep_normals_beyond_two_are_a_bad_patch_and_the_option_moves_the_limit(tmp_path, cli):
    """A cylinder r 2.02 across a 4-wide patch: twelve edge normals are 82 deg from the
    mean, more than the two the screen leaves out: a bad patch, the limit and its option in
    the line.  At 85 deg they stay, and a 2-jet cannot follow a surface this bent over the
    patch: refused, with the hint to take a smaller patch."""
    path = tmp_path / "steep.csv"
    write_csv(path, sweep(make("cylinder", 2.02)))
    code, out, err = cli("ep2", "analyze", path)
    assert code == 3 and len(err.strip().splitlines()) == 1 and "Traceback" not in err
    assert "82-82 deg" in err and "limit 80 deg" in err and "--max-normal-angle" in err
    assert "a bad patch: 12 normals" in err and "smaller patch" in err
    code, out, err = cli("ep2", "analyze", path, "--max-normal-angle", "85")
    assert code == 3 and "limit 80" not in err and "smaller patch" in err


# -- the emulated EP2 sweep ---------------------------------------------------------------


def _emulated_contacts(tmp_path, seed, noiseless=False):
    """Record ``sim://ep2_sweep_sphere`` (scene seed ``seed``) and place its CONTACT frames in
    the world through the pose log, as tests/test_emulator_sweep.py does."""
    from sweep_record import record_sweep

    from tactile.localize.posed import posed_world_contacts
    from tactile.logs.read import read_pose_log
    from tactile_sim.emulator.scene import SCENE_DIR

    text = (SCENE_DIR / "ep2_sweep_sphere.toml").read_text(encoding="utf-8")
    text, n = re.subn(r"(?m)^seed = .*$", f"seed = {seed}", text)
    assert n == 1
    if noiseless:
        text = re.sub(r"(?m)^noise_(force_N|torque_Nm) = .*$", r"noise_\1 = [0.0, 0.0, 0.0]", text)
    # The data these seeds were chosen on: the sweep rested 0.03 s before it loaded (it now
    # rests 1 s, for the host's TARE; no TARE is taken here), and the noise follows time.
    text += "\nrest_s = 0.03\n"  # in [motion]
    scene = tmp_path / "ep2_sweep_sphere.toml"
    scene.write_text(text, encoding="utf-8")
    motion, t, sensor, wrench, _, _ = record_sweep(f"sim://{scene}")
    poses = tmp_path / "poses.csv"
    motion.write_pose_log(poses)
    points, normals, finger, _ = posed_world_contacts(read_pose_log(poses), t, sensor, wrench, 1.39)
    return motion, points, normals, finger


EMULATED = [(seed, False) for seed in (11, 21, 28, 1, 2, 3, 4, 5)] + [(11, True)]


@pytest.mark.parametrize("seed,noiseless", EMULATED)
def test_emulated_sphere_sweep_radius_interval_holds_the_true_radius(tmp_path, seed, noiseless):
    """Normals localised through F/T (friction, calibration: errors the position noise does
    not show): the radius interval at the centre must hold R, and stay informative."""
    motion, points, normals, finger = _emulated_contacts(tmp_path, seed, noiseless)
    res = analyze_patch(points, normals, finger=finger)
    R = motion.cfg["radius_m"]
    assert res.shape in ("sphere", "uncertain") and max(res.votes, key=res.votes.get) == "sphere"
    lo, hi = res.radius_interval
    assert lo < R < hi, (res.radius, res.radius_interval, res.warnings)
    assert 0.5 * R < lo and hi < 1.5 * R  # not held by being uninformative
    assert res.S_interval[0] <= 1.0 <= res.S_interval[1]


# -- found by the first holdout run ----------------------------------------------------


@pytest.mark.parametrize("tilt", [0.0, 46.0])
def test_a_low_noise_cylinder_keeps_its_k2_at_zero(tilt):
    """The interval floor (1e-3) once also debiased the anisotropy, pulling k1 and k2 of a
    cylinder at low noise together."""
    case = _case("cylinder", "sweep", cases.THESIS36, 1e-6, tilt_deg=tilt, radius=100.0)
    for trial in range(3):
        d = cases.draw(case, trial)
        res = analyze_patch(d["points"], d["normals"], finger=d["finger"])
        assert abs(res.S - d["truth"]["S"]) < 3e-5, (res.S, res.model)  # was 6-9e-5
        assert abs(res.k2) < 5e-7, (res.k1, res.k2)  # k1 = 0.01; was 1.0-1.4e-6
        lo, hi = res.S_interval
        assert lo <= d["truth"]["S"] <= hi


def test_a_surface_no_3_jet_follows_is_not_called_inconsistent():
    """A saddle of radius 1.7 tilted 48 deg under two fingers at noise 6e-5: both 3-jets
    misfit by ~30 sd.  That is model error, not positions against normals: the answer,
    when given, holds the truth in its interval, and a refusal never blames the normals
    on every trial."""
    case = _case(
        "saddle",
        "sweep",
        (("angle", 171.4), ("length", 5.711), ("stops", 18), ("xs", (0.0, 3.613))),
        2.078e-4,
        radius=5.57,
        unit=0.297,
        rotation_deg=10.26,
        tilt_deg=47.88,
        tilt_axis_deg=168.1,
        apex=(-2.818, 2.353),
    )
    blamed = 0
    for trial in range(6):
        d = cases.draw(case, trial)
        out, why = _answer(d)
        if why is not None:
            blamed += "disagree" in why
            continue
        assert out["S_interval"][0] <= d["truth"]["S"] <= out["S_interval"][1], out
    assert blamed < 6


# -- found by the property test: one path off the apex ------------------------------------


def test_six_contacts_on_one_line_off_a_sphere_apex_are_refused():
    """Found by the property test: the line is a planar curve that bends 0.12 across itself
    in the mean-normal frame, so it passed the spread test and was labelled 'plane'."""
    from tactile_sim.ep2 import make as make_object

    obj = make_object("sphere", 5.623413251903491, centre=(1.5, 0.0))
    y = np.linspace(-3.0, 3.0, 6)
    x = np.zeros_like(y)
    pts = np.stack([x, y, obj.height(x, y)], axis=1)
    nrm = obj.normals(x, y)
    with pytest.raises(DataError, match="not determined"):
        analyze_patch(pts, nrm)


@pytest.mark.parametrize("family", ["sphere", "cylinder", "saddle"])
@pytest.mark.parametrize("angle", [0, 35, 90, 140])
@pytest.mark.parametrize("noise", [0.0, 0.003])
def test_one_straight_path_off_the_apex_never_gets_a_label(family, angle, noise):
    """One finger's straight path across a curved object, off its apex, in any direction:
    its contacts lie in one plane standing across the surface; refused or 'uncertain'."""
    rng = np.random.default_rng(angle)
    obj = make(family, 8.0, centre=(1.5, 0.4))
    a = np.radians(angle)
    s = np.linspace(-3.0, 3.0, 9)
    x, y = s * np.cos(a) + 1.0 * np.sin(a), s * np.sin(a) - 1.0 * np.cos(a)
    pts = np.stack([x, y, obj.height(x, y)], axis=1) + noise * rng.standard_normal((9, 3))
    nrm = obj.normals(x, y) + noise * rng.standard_normal((9, 3))
    nrm /= np.linalg.norm(nrm, axis=1)[:, None]
    try:
        res = analyze_patch(pts, nrm)
    except DataError as err:
        assert "not determined" in str(err) or "disagree" in str(err), err
        return
    assert res.shape == "uncertain", (res.shape, res.confidence)


# --- three uneven finger lines with normals much noisier than the positions (holdout3) ----

UNEVEN36 = (("length", 4.0), ("repeats", 2), ("stops", 6), ("xs", (0.0, 0.9, 4.4)))


@pytest.mark.parametrize(
    "family,kw", [("cylinder", {"radius": 10.0}), ("quadric", {"k": (0.05, -0.02)})]
)
@pytest.mark.xfail(
    strict=True,
    reason="9-17x the 2-jet's RMS S error with normals 60x noisier than positions: "
    "known miss, docs/ep2.md 'Limits'",
)
def test_three_uneven_lines_with_noisy_normals_keep_near_the_2_jet(family, kw):
    """Three lines leave the 3-jet's positions blind to a cubic that, with uneven spacing,
    trades with the curvature across them; with normals 60 x noisier than the positions the
    3-jet's S was 4.9 (cylinder) and 6.8 (quadric) x the 2-jet's RMS error (given the true
    noise); the shrinkage toward the 2-jet brings it to about 2 (docs/ep2.md, holdout3)."""
    case = cases.new(
        family, layout="sweep", params=UNEVEN36, noise=0.005, normal_ratio=60.0,
        rotation_deg=30.0, tilt_deg=10.0, **kw,
    )  # fmt: skip
    ours, jet = [], []
    for trial in range(20):
        d = cases.draw(case, trial)
        out, why = _answer(d)
        assert out is not None, why
        ours.append(out["S"] - d["truth"]["S"])
        k1, k2 = peers.jet(d["points"], d["normals"], d["noise_pos"], d["noise_normal"])
        jet.append(BENCH.shape_index(float(k1[0]), float(k2[0])) - d["truth"]["S"])
    ratio = np.sqrt(np.mean(np.square(ours)) / np.mean(np.square(jet)))
    assert ratio < 2.5, ratio
