"""EP2 trust regressions: one test per reproducer of the trust issue against the old default.

The old default (a B-spline patch, ``git show edaf568:host/tactile/ep2/api.py``) answered
where the data do not determine the curvature, gave confident labels on single finger lines,
let duplicated rows narrow its intervals, reported grid means instead of the curvature at the
patch centre and lost to a 2-jet on strongly curved shapes.  Guarded here:

- a single finger's line (any direction, through the apex or not), two nearly coincident
  lines, a cluster at one end, rows duplicated onto two stops: refused with "not determined"
  (exit 3, one line) or, if answered, never confidently wrong by the bench's rule
  (``bench/ep2_trust.py:wrong_label``) and the S interval holds the truth;
- a little noise on single and diagonal lines: no confident label at all;
- curved positions with flat or mirrored normals: "positions and normals disagree";
  planes are never mislabelled;
- the JSON record: a plane has S, C, radius null and k1/k2 intervals; ``uncertain`` keeps
  its S interval; ``model`` explains itself in one line;
- exact duplicate rows count once (a warning), intervals unchanged;
- strongly curved noise-free shapes: S at the centre within 0.003 and no worse than the
  2-jet with normals (``tactile.ep2.peers.jet``);
- the normal-angle refusal says what to do, and ``--max-normal-angle`` raises the limit;
- the emulated EP2 sweep (normals through F/T: systematic errors): the radius interval at
  the centre holds the true radius;
- found while writing these: two fingers over a cylinder are answered, and the order of the
  rows does not change the answer.

Library bugs are pinned as strict xfails (their ``reason`` says what is wrong).

Truth comes from ``tactile_studies.ep2.truth`` (at the patch centre) or closed forms.
"""

import json
import pathlib
import re

import numpy as np
import pytest
from conftest import load_bench

from tactile.ep2 import analyze_patch, peers
from tactile.errors import DataError
from tactile.jsonout import dumps
from tactile_sim.ep2 import make, sweep
from tactile_sim.ep2.sweep import write_csv
from tactile_studies.ep2 import cases, truth

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
    family, layout, params, kw, noise
):
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
def test_curved_positions_with_flat_or_mirrored_normals_are_refused(family, params, kw, noise):
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
    m = re.search(r"along \(([-\d., ]+)\) (\S+) vs (\S+),", str(err.value))
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
    "obj,first",
    [
        (make("sphere", 8.0), "round"),
        (make("cylinder", 5.0, rotation_deg=30.0), "round"),
        (make("quadric", k=(1 / 6, -0.4 / 6), rotation_deg=30.0), "quadric"),
        (make("saddle", 10.0), "quadric"),
        (make("plane", slope=(1.0, 1.0)), None),
    ],
)
def test_every_record_explains_its_model_in_one_field(obj, first):
    d = sweep(obj, noise_pos=0.002, noise_normal=0.002, seed=1)
    rec = _record(analyze_patch(d["points"], d["normals"]))
    model = rec["model"]
    assert isinstance(model, str) and model.strip() and "\n" not in model
    assert model.split()[0] in ("round", "quadric") and ":" in model  # what, then why
    if first is not None:
        assert model.split()[0] == first, model


def test_the_model_field_names_the_order_the_record_reports():
    """The 2-jet shrinkage (``centre_jet._lower_order``) can leave a patch on its 2-jet or
    between the two: the model line names the order of ``order`` and, for a blend, the
    3-jet's weight (it said "3-jet" for every patch before)."""
    seen = {"2": 0, "3": 0, "blend": 0}
    for noise in (0.0, 0.001, 0.01, 0.03):
        for seed in range(4):
            d = sweep(make("cylinder", 10.0), noise_pos=noise, noise_normal=noise, seed=seed)
            rec = _record(analyze_patch(d["points"], d["normals"]))
            what = rec["model"].split(":")[0]
            assert f" {rec['order']}-jet" in what, rec["model"]
            assert f"{5 - rec['order']}-jet" not in what.split(" blended")[0], rec["model"]
            seen[str(rec["order"])] += 1
            weight = re.search(r"3-jet weight ([0-9.]+)\)", what)
            if weight is not None:
                seen["blend"] += 1
                w = float(weight.group(1))
                near_half = abs(w - 0.5) <= 0.005  # shown to 2 decimals
                assert 0 < w < 1 and (near_half or (w > 0.5) == (rec["order"] == 3)), rec["model"]
    assert min(seen.values()) >= 1, seen


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


@pytest.mark.parametrize(
    "radius",
    [
        pytest.param(4.0),
        pytest.param(9.0),
    ],
)
def test_two_fingers_over_a_noise_free_cylinder_are_answered(radius):
    """Fingers at x = 0 and 4 across a cylinder: their normals fix the curvature across."""
    d = sweep(make("cylinder", radius), fingers=2, spacing=4.0, length=2.0, samples=12, repeats=1)
    res = analyze_patch(d["points"], d["normals"])
    assert res.shape == "cylinder"
    assert res.radius_interval[0] <= radius <= res.radius_interval[1]


@pytest.mark.parametrize("radius", [4.0, 9.0])
def test_two_fingers_over_a_noisy_cylinder_are_answered(radius):
    """The same layout with a little noise is answered: the layout itself is not the problem."""
    for seed in range(3):
        d = sweep(
            make("cylinder", radius),
            fingers=2,
            spacing=4.0,
            length=2.0,
            samples=12,
            repeats=1,
            noise_pos=0.005,
            noise_normal=0.005,
            seed=seed,
        )
        out, why = _answer(d)
        assert why is None and out["shape"] == "cylinder", why
        tr = truth.at_centre(make("cylinder", radius), d["points"], d["normals"])
        assert not BENCH.wrong_label(out, tr)


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
    ("sphere", dict(radius=6.0)),
    ("cylinder", dict(radius=3.0, rotation_deg=30.0)),
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
    assert err <= 0.003 and err <= jet_err, (err, jet_err)
    assert res.radius == pytest.approx(radius, rel=1e-3)
    lo, hi = res.radius_interval
    assert lo <= radius <= hi
    assert not BENCH.wrong_label(BENCH.default(d["points"], d["normals"], d["finger"]), tr)


# -- the normal-angle limit ---------------------------------------------------------------


def test_normal_angle_refusal_says_what_to_do_and_the_option_raises_the_limit(tmp_path, cli):
    """A cylinder r 2.02 across a 4-wide patch: its edge normals are 82 deg from the mean."""
    radius = 2.02
    path = tmp_path / "steep.csv"
    write_csv(path, sweep(make("cylinder", radius)))
    code, out, err = cli("ep2", "analyze", path)
    assert code == 3 and len(err.strip().splitlines()) == 1 and "Traceback" not in err
    assert "limit 80 deg" in err and "smaller patch" in err and "--max-normal-angle" in err
    code, out, err = cli("ep2", "analyze", path, "--max-normal-angle", "85", "--json")
    assert code == 0, err
    rec = json.loads(out)
    assert rec["shape"] == "cylinder"
    assert rec["radius_interval"][0] <= radius <= rec["radius_interval"][1]
    code, _, err = cli("ep2", "analyze", path, "--max-normal-angle", "81")
    assert code == 3 and "limit 81 deg" in err


# -- the emulated EP2 sweep ---------------------------------------------------------------


def _emulated_contacts(tmp_path, seed, noiseless=False):
    """Record ``sim://ep2_sweep_sphere`` (scene seed ``seed``) and place its CONTACT frames in
    the world through the pose log, as tests/test_emulator_sweep.py does."""
    from sweep_record import record_sweep

    from tactile.localize.pose_log import read_pose_log
    from tactile.localize.posed import posed_world_contacts
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
    assert res.shape == "sphere"
    lo, hi = res.radius_interval
    assert lo < R < hi, (res.radius, res.radius_interval, res.warnings)
    assert 0.75 * R < lo and hi < 1.25 * R  # not held by being uninformative
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


# -- found by holdout2 ---------------------------------------------------------------------


@pytest.mark.parametrize("key", ["saddle r=22.44", "quadric k=-0.07321/0.02319"])
def test_a_tilted_height_field_at_low_noise_has_intervals_that_hold_the_truth(key):
    """Tilted quadric height fields at noise ~2e-5: the 3-jet keeps a truncation bias far
    above the noise; the intervals held the truth in 0-3 % of trials until the 4-jet's view
    of that bias widened them."""
    (case,) = [c for c in cases.split("holdout2") if key in c.id]
    for trial in range(4):
        d = cases.draw(case, trial)
        res = analyze_patch(d["points"], d["normals"], finger=d["finger"])
        for name in ("S", "k1", "k2"):
            lo, hi = getattr(res, f"{name}_interval")
            assert lo <= d["truth"][name] <= hi, (name, lo, hi, d["truth"][name])


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


# --- the normals' noise estimate where position noise dominates the slopes ---------------


def _noisy_positions(seed, noise_normal):
    d = sweep(make("cylinder", 10.0, 30.0), noise_pos=0.05, noise_normal=noise_normal, seed=seed)
    return d["points"], d["normals"]


@pytest.mark.parametrize("seed", range(10))
def test_tiny_normal_noise_under_position_noise_is_estimated_not_cycled(seed):
    """1 % position noise, 0.0005 rad normal noise: the slopes' covariance is mostly the
    position noise's.  The fixed point used to cycle there (sigma_n 0 <-> 0.19 rad, its
    value set by the number of passes) and 4 of these 10 patches were refused."""
    res = analyze_patch(*_noisy_positions(seed, 0.0005))
    rec = res.to_dict("p")
    assert 0.0005 / 3 <= rec["noise_normal"] <= 0.0005 * 3
    assert rec["shape"] == "cylinder" and abs(res.k1 * 10.0 - 1.0) < 0.05


def test_the_normals_noise_is_the_root_of_chi2_per_spare_row(monkeypatch):
    """Independent check of the estimate: the slopes' own REML fit at the returned sigma_n
    has chi^2 per spare row 1 (to the stopping tolerance), for every patch of a batch,
    including the ones where position noise dominates."""
    from tactile.ep2 import jet_noise

    seen = {}
    real = jet_noise._normal_noise

    def spy(p, nrm, mask, sig, geo, count):
        out = real(p, nrm, mask, sig, geo, count)
        trial = np.stack([sig[:, 0], out[0]], axis=1)
        seen["scale"] = jet_noise._reml(p, nrm, mask, trial, geo, "slopes", count)[0]
        seen["sigma"] = out[0]
        return out

    monkeypatch.setattr(jet_noise, "_normal_noise", spy)
    from tactile.ep2 import analyze_patches

    patches = [_noisy_positions(s, n) for s in range(6) for n in (0.0005, 0.005, 0.02)]
    analyze_patches(patches)
    above = seen["sigma"] > 10 * jet_noise.WEIGHT_FLOOR
    assert above.sum() >= 15
    np.testing.assert_allclose(seen["scale"][above], 1.0, atol=5 * jet_noise.NOISE_TOL)


# --- three uneven finger lines with normals much noisier than the positions (holdout3) ----

UNEVEN36 = (("length", 4.0), ("repeats", 2), ("stops", 6), ("xs", (0.0, 0.9, 4.4)))


@pytest.mark.parametrize(
    "family,kw", [("cylinder", {"radius": 10.0}), ("quadric", {"k": (0.05, -0.02)})]
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


# --- strongly curved quadrics where the round model wins (holdout4) -----------------------


@pytest.mark.parametrize("key", ["quadric k=0.1744/0.1542", "quadric k=0.1886/-0.05852"])
def test_a_round_3_jet_on_a_strongly_curved_quadric_has_its_truncation_seen(key):
    """|k| L 1.2-1.4, tilted: the round 3-jet beats the quadric 3-jet by chi^2 300-10000 yet
    misfits itself (chi^2 / dof 2-150), and its S is off by 0.02-0.04, 5-8 sd.  Its 4-jet
    (the round model one order up) sees that bias (cosine 0.99 with the true error); the
    bias vector of the intervals was zero for the round model, and these intervals held the
    truth in none of 20 trials (two confident wrong labels on the second case)."""
    (case,) = [c for c in cases.split("holdout4") if key in c.id]
    held = 0
    for trial in range(6):
        d = cases.draw(case, trial)
        res = analyze_patch(d["points"], d["normals"], finger=d["finger"])
        assert res.model.startswith("round"), res.model
        lo, hi = res.S_interval
        held += lo <= d["truth"]["S"] <= hi
    assert held >= 5, held
