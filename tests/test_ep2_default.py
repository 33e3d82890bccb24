"""The default EP2 estimator's promises (docs/ep2.md, "The default"): bad contacts named and
left out, small and exact layouts answered, per-patch noise, and the spline's plane rule."""

import numpy as np
import pytest
import tolerance

from tactile.ep2 import analyze_patch, analyze_patches
from tactile.errors import DataError
from tactile_sim.ep2 import make, sweep
from tactile_studies.ep2 import implicit


def _noisy_sphere(seed=0, noise=0.002):
    return sweep(make("sphere", 8.0), noise_pos=noise, noise_normal=noise, seed=seed, repeats=1)


def _covers(interval, value):
    return interval[0] <= value <= interval[1]


def test_a_flipped_normal_is_named_and_the_answer_is_that_of_the_clean_patch():
    d = _noisy_sphere()
    clean = analyze_patch(d["points"], d["normals"])
    nrm = d["normals"].copy()
    nrm[5] = -nrm[5]
    res = analyze_patch(d["points"], nrm)
    assert [w for w in res.warnings if "left out" in w] == [
        w for w in res.warnings if w.startswith("contact 5 left out")
    ]
    assert len(res.warnings) == 1
    assert res.shape == clean.shape == "sphere"
    assert res.S == pytest.approx(clean.S, abs=0.01)
    assert _covers(res.S_interval, 1.0)


def test_a_point_off_the_surface_is_named_and_k2_still_covers():
    """One point 0.2 L above the surface: absorbed silently before (k2 coverage 0)."""
    d = _noisy_sphere(seed=1)
    pts = d["points"].copy()
    L = np.ptp(pts[:, :2], axis=0).max()
    pts[7, 2] += 0.2 * L
    res = analyze_patch(pts, d["normals"])
    assert any(w.startswith("contact 7 left out") for w in res.warnings), res.warnings
    assert _covers(res.k2_interval, 1 / 8.0) and _covers(res.k1_interval, 1 / 8.0)


@pytest.mark.parametrize("seed", range(3))
def test_two_points_off_the_surface_are_named_and_three_get_no_label(seed):
    """Up to two bad contacts are left out by name; with three the patch is refused or
    answered 'uncertain', never labelled (bench/ep2_breakdown.py counts this)."""
    d = _noisy_sphere(seed=seed)
    pts = d["points"].copy()
    L = np.ptp(pts[:, :2], axis=0).max()
    two = pts.copy()
    two[[2, 8], 2] += np.array([0.2, -0.25]) * L
    res = analyze_patch(two, d["normals"])
    assert sorted(w.split(" left out")[0] for w in res.warnings) == ["contact 2", "contact 8"]
    assert res.shape == "sphere" and _covers(res.radius_interval, 8.0)
    pts[[2, 8, 13], 2] += np.array([0.2, -0.25, 0.3]) * L
    try:
        res = analyze_patch(pts, d["normals"])
    except DataError as err:
        assert "contacts disagree" in str(err)
        return
    assert res.shape == "uncertain"


def test_normals_beyond_the_angle_limit_are_screened_two_at_most():
    """Two flipped normals are left out by name; four are a bad patch, said as one."""
    d = _noisy_sphere(seed=2)
    nrm = d["normals"].copy()
    nrm[[2, 8]] *= -1.0
    res = analyze_patch(d["points"], nrm)
    assert [w.split(" left out")[0] for w in res.warnings] == ["contact 2", "contact 8"]
    assert res.shape == "sphere" and _covers(res.radius_interval, 8.0)
    nrm[[13, 17]] *= -1.0
    with pytest.raises(DataError, match=r"^a bad patch: 4 normals \(contact 2, contact 8, cont"):
        analyze_patch(d["points"], nrm)


def test_six_contacts_with_normals_on_a_sphere_are_answered():
    """18 equations for a 2-jet's 6 unknowns: refused as 'near one line' before."""
    rng = np.random.default_rng(3)
    obj = make("sphere", 5.0)
    xy = rng.uniform(-1.0, 1.0, (6, 2))
    pts = np.column_stack([xy, obj.height(xy[:, 0], xy[:, 1])])
    nrm = obj.normals(xy[:, 0], xy[:, 1])
    res = analyze_patch(pts, nrm)
    assert res.shape == "sphere"
    assert _covers(res.radius_interval, 5.0) and res.radius == pytest.approx(5.0, rel=0.02)


def _ellipsoid_sweeps(L, fingers=3, stops=9):
    """Three finger sweeps (3 x 9) over x^2/10^2 + y^2/31.6^2 + z^2/4^2 = 1 about
    (1.405, 0.971, 3.958): the contacts and their normals, exactly, and the truth there."""
    surf = implicit.Surface("ellipsoid", (10.0, 31.6, 4.0))
    centre = np.array([1.405, 0.971, 3.958])
    centre = centre / np.sqrt(np.sum(centre**2 / np.array([10.0, 31.6, 4.0]) ** 2))
    n = implicit.normals(surf, centre[None])[0]
    t = implicit.tangent_basis(n[None])[0]
    u, v = np.meshgrid(np.linspace(-0.5, 0.5, fingers), np.linspace(-0.5, 0.5, stops))
    starts = centre + L * (u.reshape(-1, 1) * t[:, 0] + v.reshape(-1, 1) * t[:, 1])
    pts, ok = implicit.line_root(surf, starts, np.tile(n, (len(starts), 1)), L)
    assert ok.all()
    k1, k2 = implicit.principal(surf, centre[None])
    return pts, implicit.normals(surf, pts), float(k1[0]), float(k2[0])


@pytest.mark.parametrize("L", [1.0, 7.0, 10.0, 12.0])
def test_exact_ellipsoid_sweeps_are_answered(L):
    """Refused as 'positions and normals disagree' (L 1, 10) or 'not determined' (L 7)
    before, though 0.001 L of noise gave S within 0.003 of the truth: at L 10 the gap
    between the positions' and the normals' 2-jets is the answer's own cubic's."""
    pts, nrm, k1, k2 = _ellipsoid_sweeps(L)
    res = analyze_patch(pts, nrm)
    s_true = implicit.shape_index(k1, k2)
    assert res.S == pytest.approx(s_true, abs=0.01)
    assert _covers(res.S_interval, s_true)
    assert res.shape in ("sphere", "cylinder", "uncertain")


def _numbers(res):
    return {"S": res.S, "S_interval": res.S_interval, "noise_pos": res.noise_pos}


def test_per_patch_noise_in_a_batch_equals_the_keywords():
    a, b = _noisy_sphere(seed=4), _noisy_sphere(seed=5, noise=0.01)
    got = analyze_patches(
        [
            {"points": a["points"], "normals": a["normals"], "noise_pos": 0.002},
            {"points": b["points"], "normals": b["normals"], "noise_normal": 0.01},
            (a["points"], a["normals"]),
        ]
    )
    want = [
        analyze_patch(a["points"], a["normals"], noise_pos=0.002),
        analyze_patch(b["points"], b["normals"], noise_normal=0.01),
        analyze_patch(a["points"], a["normals"]),
    ]
    kws = [dict(noise_pos=0.002), dict(noise_normal=0.01), {}]
    for g, w, d, kw in zip(got, want, (a, b, a), kws, strict=True):
        tolerance.assert_patch_close(
            _numbers(g), _numbers(w), _numbers, d["points"], d["normals"], **kw
        )
    assert got[0].noise_pos == pytest.approx(0.002) and got[1].noise_normal == pytest.approx(0.01)
    assert got[2].noise_pos != pytest.approx(0.002)  # estimated: the keywords were per patch


def test_the_spline_says_plane_only_where_its_k_intervals_hold_zero():
    """z = -0.5x^2 - 0.1y^2 + x^3 + 0.4xy^2 about (0.15, 0.1), L 1, noise-free: 'plane' at
    confidence 0.68 on 720 of 720 such patches before, where k = (0.23, 0.05)."""
    rng = np.random.default_rng(6)
    xy = np.array([0.15, 0.1]) + rng.uniform(-0.5, 0.5, (36, 2))
    x, y = xy.T
    z = -0.5 * x * x - 0.1 * y * y + x**3 + 0.4 * x * y * y
    zx, zy = -x + 3 * x * x + 0.4 * y * y, -0.2 * y + 0.8 * x * y
    nrm = np.column_stack([-zx, -zy, np.ones_like(x)])
    nrm /= np.linalg.norm(nrm, axis=1, keepdims=True)
    res = analyze_patch(np.column_stack([x, y, z]), nrm, method="spline")
    holds_zero = _covers(res.k1_interval, 0.0) and _covers(res.k2_interval, 0.0)
    assert (res.shape == "plane") == holds_zero
    assert res.shape != "plane"


def test_a_strongly_curved_exact_sphere_takes_its_grid_from_the_top_jet():
    """S_mean over the grid of a sphere of radius 6 over a 4-wide patch, noise-free, was
    0.967 (the 2-jet's values drift off over the box); the top jet carries it."""
    d = sweep(make("sphere", 6.0))
    res = analyze_patch(d["points"], d["normals"], finger=d["finger"])
    assert res.S_mean == pytest.approx(1.0, abs=0.01)
    assert res.S == pytest.approx(1.0, abs=0.01)
    noisy = sweep(make("sphere", 6.0), noise_pos=0.01, noise_normal=0.01, seed=1)
    res = analyze_patch(noisy["points"], noisy["normals"], finger=noisy["finger"])
    assert res.S_mean < 0.99  # noise hides the 4-jet: the answer's own jet, as before
