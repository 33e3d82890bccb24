"""Properties of the EP2 default estimator over random scenes (hypothesis, derandomized).

Guards, for random spheres, pits, cylinders, quadric height fields, saddles and planes
(radius 3-1000, any rotation, apex off the patch centre), random sweeps (1-4 fingers at any
spacing, nearly coincident included, the sweep turned, 5-20 stops, repeated readings,
exact duplicate rows), noise 0-0.03, units 1e-3..1e3 and a tilted world frame:

- ``analyze_patch`` raises ``DataError``/``InputError`` or returns a result whose every
  number (``to_dict()``, through ``tactile.output.text.dumps``) is finite;
- a confident label (>= 0.95, not ``uncertain``) never contradicts the truth at the patch
  centre beyond its interval (the bench's rule, ``bench/ep2_trust.py:wrong_label``);
- a single line of contacts (spread across it exactly 0) is always refused;
- ``local_jet.fit`` on a padded stack of noisy patches of different sizes gives each patch
  what fitting it alone gives (t, cov, jet order, frame, noise), to a tolerance derived
  from each field's sensitivity to its data (``tests/tolerance.py``).

Bugs these properties found are pinned as strict xfails at the end (underflow to NaN
intervals; noise-free patches that depend on the padding; two finger lines over a noisy
cylinder answered plane, a known miss the first property lets pass so it can find others;
a single noisy line answered).
"""

import math
import pathlib

import numpy as np
import pytest
import tolerance
from conftest import FUZZ_SCALE, load_bench
from hypothesis import HealthCheck, assume, event, given, settings
from hypothesis import strategies as st

from tactile.ep2 import analyze_patch, local_jet
from tactile.ep2.geometry import design, unit_normals
from tactile.errors import DataError, InputError
from tactile.output.text import dumps
from tactile_sim.ep2 import layouts
from tactile_sim.ep2.objects import make
from tactile_sim.ep2.sweep import _tilt_normals, sweep
from tactile_studies.ep2 import truth

ROOT = pathlib.Path(__file__).resolve().parents[1]
KINDS = ("sphere", "pit", "cylinder", "concave_cylinder", "quadric", "saddle", "plane")
SETTINGS = dict(
    deadline=None,
    derandomize=True,
    database=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much],
)


BENCH = load_bench("ep2_trust")
_bench_out = BENCH.summarise  # the bench's own scoring of a result


# -- random scenes --------------------------------------------------------------------------


def _gap():
    """One finger spacing: zero, nearly coincident, or ordinary."""
    return st.one_of(
        st.just(0.0), st.floats(1e-4, 0.05), st.floats(0.3, 3.0), st.sampled_from([2.0, 1.0])
    )


def _real(lo, hi):
    """A float in [lo, hi] with no magnitude in (0, 1e-9): angles, offsets and slopes of
    1e-170 make the curvature underflow (``test_a_plane_tilted_by_1e_150_has_finite_intervals``
    pins that bug); here they would mask every other finding."""
    return st.floats(lo, hi).map(lambda v: 0.0 if abs(v) < 1e-9 else v)


@st.composite
def scenes(draw, single_line=False):
    """A random scene; ``single_line``: every finger on one line (spread across it 0)."""
    kind = draw(st.sampled_from(KINDS))
    radius = 10 ** draw(st.floats(math.log10(3.0), 3.0))
    k = None
    if kind == "quadric":
        ratio = draw(_real(-0.95, 1.0))
        sign = draw(st.sampled_from([-1.0, 1.0]))
        k = (sign / radius, sign * ratio / radius)
    fingers = draw(st.integers(1, 4))
    gaps = [0.0 if single_line else draw(_gap()) for _ in range(fingers - 1)]
    xs = np.concatenate([[0.0], np.cumsum(gaps)])
    params = dict(
        xs=tuple(float(v) for v in xs),
        length=draw(st.floats(1.0, 6.0)),
        stops=draw(st.integers(5, 20)),
        repeats=draw(st.integers(1, 2)),
        angle=draw(_real(0.0, 180.0)),
    )
    return dict(
        kind=kind,
        radius=radius,
        k=k,
        rotation=draw(_real(0.0, 180.0)),
        apex=(draw(_real(-1.5, 1.5)), draw(_real(-1.5, 1.5))),
        slope=(draw(_real(-2.0, 2.0)), draw(_real(-2.0, 2.0))),
        params=params,
        noise=draw(st.one_of(st.just(0.0), st.floats(1e-4, 0.03))),
        unit=10 ** draw(st.floats(-3.0, 3.0)),
        tilt=(draw(_real(0.0, 50.0)), draw(_real(0.0, 180.0))),
        duplicates=draw(st.integers(0, 6)),
        seed=draw(st.integers(0, 2**32 - 1)),
    )


def _tilt(tilt_deg, axis_deg):
    a, t = np.radians(axis_deg), np.radians(tilt_deg)
    rz = np.array([[np.cos(a), -np.sin(a), 0.0], [np.sin(a), np.cos(a), 0.0], [0.0, 0.0, 1.0]])
    rx = np.array([[1.0, 0.0, 0.0], [0.0, np.cos(t), -np.sin(t)], [0.0, np.sin(t), np.cos(t)]])
    return rz @ rx @ rz.T


def contacts(s):
    """(points, normals, finger, obj, rotation) of a scene; None if the sweep leaves the object.
    Lengths in the scene's unit; exact duplicates appended last."""
    obj = make(
        s["kind"],
        s["radius"],
        rotation_deg=s["rotation"],
        centre=s["apex"],
        k=s["k"],
        slope=s["slope"] if s["kind"] == "plane" else (0.0, 0.0),
    )
    xy, finger, _, _ = layouts.place("sweep", tuple(sorted(s["params"].items())))
    try:
        z, zx, zy = obj.eval(xy[:, 0], xy[:, 1])
    except ValueError:  # the sweep passes the sphere's or cylinder's rim
        return None
    nrm = np.column_stack([-zx, -zy, np.ones_like(zx)])
    nrm /= np.linalg.norm(nrm, axis=1, keepdims=True)
    if np.degrees(np.arccos(nrm[:, 2].min())) > 85.0:  # past what a finger can touch
        return None
    pts = np.column_stack([xy, z])
    rng = np.random.default_rng(s["seed"])
    if s["noise"] > 0:
        pts = pts + s["noise"] * rng.standard_normal(pts.shape)
        nrm = _tilt_normals(nrm, s["noise"], rng)
    rot = _tilt(*s["tilt"])
    pts, nrm = pts @ rot.T * s["unit"], nrm @ rot.T
    dup = rng.integers(0, len(pts), s["duplicates"])
    pts, nrm, finger = (np.concatenate([v, v[dup]]) for v in (pts, nrm, finger))
    return pts, nrm, finger, obj, rot


def _first_unique(pts, nrm):
    """The rows ``analyze_patch`` keeps: first of each exact duplicate, in order."""
    _, first = np.unique(np.column_stack([pts, nrm]), axis=0, return_index=True)
    return np.sort(first)


def _finite_everywhere(obj, path="record"):
    if isinstance(obj, dict):
        for k, v in obj.items():
            _finite_everywhere(v, f"{path}.{k}")
    elif isinstance(obj, list | tuple):
        for i, v in enumerate(obj):
            _finite_everywhere(v, f"{path}[{i}]")
    elif isinstance(obj, np.ndarray):
        assert obj.dtype.kind in "biuf" and np.all(np.isfinite(obj)), (path, obj)
    elif isinstance(obj, float | np.floating):
        assert math.isfinite(obj), (path, obj)


# -- analyze_patch --------------------------------------------------------------------------


@pytest.mark.slow
@settings(max_examples=300 * FUZZ_SCALE, **SETTINGS)
@given(scenes())
def test_answers_are_finite_and_never_confidently_wrong_and_lines_are_refused(scene):
    made = contacts(scene)
    assume(made is not None)
    pts, nrm, finger, obj, rot = made
    xs = scene["params"]["xs"]
    single_line = max(xs) - min(xs) == 0.0
    try:
        res = analyze_patch(pts, nrm, finger=finger)
    except (DataError, InputError) as err:
        assert str(err) and "\n" not in str(err)
        event(f"refused: {type(err).__name__}")
        return
    assert not single_line, "a single line of contacts was answered"
    event(f"answered: {res.shape}")
    rec = res.to_dict(patch=1)
    _finite_everywhere(rec)
    assert "NaN" not in dumps(rec) and "Infinity" not in dumps(rec)
    keep = _first_unique(pts, nrm)
    assert res.n_points == len(keep)
    try:
        tr = truth.at_centre(obj, pts[keep], unit_normals(nrm[keep]), scene["unit"], rot)
    except ValueError:  # the patch-centre normal line misses the object: no truth to judge by
        return
    out = _bench_out(res)
    if out["shape"] != "uncertain" and out["confidence"] >= BENCH.CONFIDENT:
        event("confident label judged against the truth")
    if len(set(xs)) == 2 and out["shape"] == "plane" and BENCH.wrong_label(out, tr):
        event("known miss: two finger lines answered plane")  # pinned at the end
        return
    assert not BENCH.wrong_label(out, tr), (out, tr)


@settings(max_examples=150, **SETTINGS)
@given(scenes(single_line=True))
def test_a_single_line_is_always_refused(scene):
    """Dedicated draws: 1-4 fingers all on one line (the mixed property above meets single
    lines a quarter of the time)."""
    made = contacts(scene)
    assume(made is not None)
    pts, nrm, finger, _, _ = made
    with pytest.raises(DataError):
        analyze_patch(pts, nrm, finger=finger)


# -- the batch fit --------------------------------------------------------------------------


@st.composite
def stacks(draw, noisy=True):
    """2-4 well-posed patches (3-4 fingers at ordinary spacings) of different sizes; noisy
    (noise-free data: see ``test_fitting_noise_free_patches_in_a_stack``)."""
    out = []
    for _ in range(draw(st.integers(2, 4))):
        s = draw(scenes())
        fingers = draw(st.integers(3, 4))
        s["params"]["xs"] = tuple(float(v) for v in np.linspace(0.0, 4.0, fingers))
        s["duplicates"] = 0
        s["noise"] = draw(st.floats(1e-4, 0.03)) if noisy else 0.0
        out.append(s)
    return out


def _fields(fits, b, n):
    """Per patch: its continuous fields (compared to a tolerance derived from their
    sensitivity, ``tolerance``) and its discrete ones (compared exactly); ``n`` its contacts."""
    cont = {
        "t": fits.t[b], "cov": fits.cov[b], "cov_noise": fits.cov_noise[b],
        "cov_quadric": fits.cov_quadric[b], "weight": fits.weight[b], "scale": fits.scale[b],
        "origin": fits.origin[b], "axes": fits.axes[b], "centre": fits.centre[b],
        "noise_pos": fits.noise[b][:1], "noise_normal": fits.noise[b][1:],
        "xy": fits.xy[b, :n], "coef": fits.coef[b],
    }  # fmt: skip
    exact = (int(fits.order[b]), int(fits.top[b]), fits.reason[b], fits.warnings[b])
    return {k: np.asarray(v, float) for k, v in cont.items()}, exact


def _alone(p, q):
    return local_jet.fit(p[None], q[None], np.ones((1, len(p)), bool))


def _assert_as_alone(batch, b, p, q):
    """Patch ``b`` of the stack ``batch`` is what fitting contacts p, normals q alone gives:
    discrete fields exactly, the rest to their derived tolerance (``tolerance``)."""
    alone = _alone(p, q)
    np.testing.assert_array_equal(batch.keep[b, : len(p)], alone.keep[0])
    got, got_exact = _fields(batch, b, len(p))
    want, want_exact = _fields(alone, 0, len(p))
    assert got_exact == want_exact
    p_alone = want["coef"].shape[0]  # the stack's top jet may be wider: zeros beyond
    assert not np.any(got["coef"][p_alone:])
    got["coef"] = got["coef"][:p_alone]

    def fields(pp, qq):
        f, _ = _fields(_alone(pp, unit_normals(qq)), 0, len(pp))
        return f

    sens = tolerance.sensitivity(fields, (p, q))
    tolerance.assert_close(got, want, sens, f"patch {b}: ")


@settings(max_examples=30, **SETTINGS)
@given(stacks(), st.integers(0, 2**31))
def test_fitting_a_stack_equals_fitting_each_patch_alone(scenes_, pad_seed):
    made = [contacts(s) for s in scenes_]
    assume(all(m is not None for m in made))
    patches = [(m[0], unit_normals(m[1])) for m in made]
    n = max(len(p) for p, _ in patches) + 3
    rng = np.random.default_rng(pad_seed)
    B = len(patches)
    # padding holds finite garbage: the mask alone must keep it out
    P = rng.normal(size=(B, n, 3)) * 100.0
    N = unit_normals(rng.normal(size=(B, n, 3)))
    mask = np.zeros((B, n), bool)
    for b, (p, q) in enumerate(patches):
        P[b, : len(p)], N[b, : len(p)], mask[b, : len(p)] = p, q, True
    batch = local_jet.fit(P, N, mask)
    for b, (p, q) in enumerate(patches):
        _assert_as_alone(batch, b, p, q)


# -- bugs found here, pinned ---------------------------------------------------------------


def test_a_plane_tilted_by_1e_150_has_finite_intervals():
    """Found by the property above (a tilt of 1e-169 deg): 10 contacts on a level plane, two
    fingers 0.5 apart, normals turned by 1e-150 rad (the positions with them)."""
    d = sweep(make("plane"), fingers=2, spacing=0.5, length=1.0, samples=5, repeats=1)
    nrm = d["normals"].copy()
    nrm[:, 1] = -1e-150
    pts = d["points"].copy()
    pts[:, 2] += 1e-150 * pts[:, 1]
    res = analyze_patch(pts, nrm)
    assert res.shape == "plane"
    _finite_everywhere(res.to_dict())


def test_fitting_noise_free_patches_in_a_stack():
    """A noise-free two-finger concave cylinder stacked (padded) with a noisy sphere."""
    one = sweep(
        make("concave_cylinder", 9.0, rotation_deg=10.0),
        fingers=2,
        spacing=4.0,
        length=2.0,
        samples=12,
        repeats=1,
    )
    two = sweep(make("sphere", 7.0), samples=9, repeats=1, noise_pos=0.01, noise_normal=0.01)
    p, q = one["points"], unit_normals(one["normals"])
    n = len(two["points"])
    P = np.zeros((2, n, 3))
    N = np.tile([0.0, 0.0, 1.0], (2, n, 1))
    mask = np.zeros((2, n), bool)
    P[0, : len(p)], N[0, : len(p)], mask[0, : len(p)] = p, q, True
    P[1], N[1], mask[1] = two["points"], unit_normals(two["normals"]), True
    batch = local_jet.fit(P, N, mask)
    _assert_as_alone(batch, 0, p, q)


def test_a_stiff_jet_in_a_stack_takes_lapacks_orthogonal_q():
    """The jet's Q is X R^-1 where that is orthogonal to round-off; a patch whose jet is
    stiffer than ``CHEAP_COND`` (contacts in a cluster 1e-3 of the patch wide beside a
    spread patch) takes LAPACK's formed Q, orthogonal to round-off whatever the condition."""
    rng = np.random.default_rng(3)
    xy = [
        rng.uniform(-1, 1, (30, 2)),
        np.vstack([rng.uniform(-1, 1, (3, 2)), 1e-3 * rng.uniform(-1, 1, (27, 2))]),
    ]
    spread, stiff = (design(c[:, 0], c[:, 1], 4)[0] for c in xy)
    X = np.stack([spread, stiff])
    cn = np.sqrt(np.einsum("bij,bij->bj", X, X))
    R, d, Rinv, Q = local_jet._qr(X, cn)
    cond = np.linalg.cond(X / cn[:, None, :])
    assert cond[0] < local_jet.CHEAP_COND < cond[1]  # one of each
    for b in range(2):
        assert np.abs(Q[b].T @ Q[b] - np.eye(X.shape[2])).max() < 1e-12
        assert np.allclose(Q[b] @ R[b], X[b] / cn[b], atol=1e-12)
    cheap = stiff / cn[1] @ np.linalg.inv(np.linalg.qr(stiff / cn[1], mode="r"))
    assert np.abs(cheap.T @ cheap - np.eye(X.shape[2])).max() > 1e-10  # what it would be


def test_the_consistency_tests_fits_are_least_squares_for_a_stiff_patch_too():
    """The positions' and the normals' own 2-jets (``local_jet._fit``, behind the consistency
    test) share the jet's Q (X R^-1, LAPACK's where stiff): their coefficients, covariance
    and residuals are ``lstsq``'s for a spread patch and for one stiffer than
    ``CHEAP_COND``; a patch whose columns are dependent is marked undetermined."""
    rng = np.random.default_rng(4)
    xy = [
        rng.uniform(-1, 1, (30, 2)),
        np.vstack([rng.uniform(-1, 1, (4, 2)), 1e-5 * rng.uniform(-1, 1, (26, 2))]),
        np.column_stack([np.linspace(-1, 1, 30), np.zeros(30)]),  # (one line: y's columns 0)
    ]
    A = np.stack([design(c[:, 0], c[:, 1], 2)[0] for c in xy])
    cond = np.linalg.cond(A[:2] / np.linalg.norm(A[:2], axis=1, keepdims=True))
    assert cond[0] < local_jet.CHEAP_COND < cond[1]  # one of each
    b = rng.normal(size=(3, 30, 2))
    coef, cov, s2, resid, ok = local_jet._fit(A, b)
    assert ok.tolist() == [True, True, False]
    for k in range(2):
        want, rss, *_ = np.linalg.lstsq(A[k], b[k], rcond=None)
        assert np.allclose(coef[k], want[1:], rtol=1e-8, atol=1e-9 * np.abs(want).max())
        assert np.allclose(resid[k], b[k] - A[k] @ want, atol=1e-10)
        assert np.allclose(s2[k], rss / (30 - 6), rtol=1e-9)
        inv = np.linalg.inv(A[k].T @ A[k])[1:, 1:]
        assert np.allclose(cov[k], inv, rtol=1e-6, atol=1e-9 * np.abs(inv).max())


def _scene(**kw):
    """A scene as ``scenes`` draws it: level, unit 1, no duplicates, unless ``kw`` says."""
    base = dict(k=None, rotation=0.0, apex=(0.0, 0.0), slope=(0.0, 0.0), unit=1.0)
    return dict(base, tilt=(0.0, 0.0), duplicates=0, **kw)


@pytest.mark.xfail(
    strict=True,
    reason="two doubled finger lines over a noisy cylinder answered plane: known miss, "
    "docs/ep2.md 'Limits'",
)
def test_two_doubled_finger_lines_over_a_noisy_cylinder_are_not_confidently_plane():
    """Found by the first property: fingers at x = 0, 0, 1, 1 (two lines 1 apart, 8 stops
    along 1) over a cylinder of radius 10, noise 1/64: 'plane' at confidence 0.996 where
    |k| L = 0.107 (a plane is wrong from 0.1)."""
    params = dict(xs=(0.0, 0.0, 1.0, 1.0), length=1.0, stops=8, repeats=1, angle=0.0)
    scene = _scene(kind="cylinder", radius=10.0, params=params, noise=0.015625, seed=3)
    pts, nrm, finger, obj, rot = contacts(scene)
    res = analyze_patch(pts, nrm, finger=finger)
    keep = _first_unique(pts, nrm)
    tr = truth.at_centre(obj, pts[keep], unit_normals(nrm[keep]), scene["unit"], rot)
    assert not BENCH.wrong_label(_bench_out(res), tr)


def test_three_fingers_on_one_turned_line_over_a_noisy_quadric_are_refused():
    """Found by the first property: three fingers at x = 0 (one line, sweep turned 16 deg,
    7 stops along 1, each read twice) over a quadric k = (-0.1, 0), noise 1/64."""
    params = dict(xs=(0.0, 0.0, 0.0), length=1.0, stops=7, repeats=2, angle=16.0)
    scene = _scene(kind="quadric", radius=10.0, params=params, noise=0.015625, seed=0)
    scene["k"] = (-0.1, -0.0)
    pts, nrm, finger, _, _ = contacts(scene)
    with pytest.raises(DataError):
        analyze_patch(pts, nrm, finger=finger)
