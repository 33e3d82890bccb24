"""The crease and tilt checks' stacked screens (``tactile.ep2.check_screens``): a patch they
clear passes the per-patch check exactly, and smooth patches are cleared (the batch skips
their per-patch checks)."""

import numpy as np

from tactile.ep2 import check_screens, curvature_jump, edges, patch_input, tilt
from tactile.errors import DataError
from tactile_sim.ep2 import make
from tactile_studies.ep2 import edge_cases, families

GRID = np.linspace(0.0, 4.0, 6)
XY = np.column_stack([np.repeat(GRID, 6), np.tile(GRID, 6)])


def _smooth(kind, noise, rng):
    obj = make(kind, 8.0)
    z, _, _ = obj.eval(XY[:, 0], XY[:, 1])
    pts = np.column_stack([XY, z]) + noise * rng.standard_normal((36, 3))
    nrm = obj.normals(XY[:, 0], XY[:, 1]) + noise * rng.standard_normal((36, 3))
    return pts, nrm


def _turned(nrm, deg):
    a = np.radians(deg)
    return nrm @ np.array([[np.cos(a), 0, np.sin(a)], [0, 1, 0], [-np.sin(a), 0, np.cos(a)]]).T


def _crease(dihedral, rng, noise=0.005):
    half = np.radians(180 - dihedral) / 2
    u = XY[:, 0] - 2.0 + rng.uniform(-0.5, 0.5)
    pts = np.column_stack([u * np.cos(half), XY[:, 1], -np.abs(u) * np.sin(half)])
    nrm = np.where((u < 0)[:, None], [[np.sin(half), 0, np.cos(half)]],
                   [[-np.sin(half), 0, np.cos(half)]])  # fmt: skip
    return pts + noise * rng.standard_normal(pts.shape), nrm + noise * rng.standard_normal((36, 3))


def _patches():
    """(points, normals, what) of smooth, noise-free, tilted, creased and flipped patches."""
    rng = np.random.default_rng(7)
    out = []
    for kind in ("sphere", "cylinder", "saddle", "pit"):
        out += [(*_smooth(kind, 0.01, rng), "smooth") for _ in range(10)]
        out.append((*_smooth(kind, 0.0, rng), "noise-free"))
        for deg in (0.5, 1.0, 2.0, 4.0, 9.9, 12.0):
            pts, nrm = _smooth(kind, 0.002, rng)
            out.append((pts, _turned(nrm, deg), "tilted"))
        pts, nrm = _smooth(kind, 0.01, rng)
        nrm[:3] *= -1
        out.append((pts, nrm, "flipped"))
    out += [(*_crease(d, rng), "crease") for d in (35.0, 90.0, 120.0, 150.0, 163.0, 170.0)]
    return out


def _screened(patches):
    kw = patch_input.keywords()
    preps = [patch_input.prepare(p, n, None, None, kw) for p, n, _ in patches]
    P = np.stack([p.points for p in preps])
    N = np.stack([p.normals for p in preps])
    return preps, *check_screens.clear(P, N, [p.jet for p in preps])


def _trips_edges(prep):
    try:
        edges.check(prep)
    except DataError:
        return True
    return False


def test_a_cleared_patch_passes_the_per_patch_checks():
    patches = _patches()
    preps, edge_ok, tilt_ok = _screened(patches)
    trips = [_trips_edges(p) for p in preps]
    named = [tilt.untilt(p)[1] is not None for p in preps]
    assert not any(t and ok for t, ok in zip(trips, edge_ok, strict=True))
    assert not any(t and ok for t, ok in zip(named, tilt_ok, strict=True))
    what = [w for _, _, w in patches]
    assert sum(t for t, w in zip(trips, what, strict=True) if w in ("crease", "flipped")) >= 6
    assert sum(t for t, w in zip(named, what, strict=True) if w == "tilted") >= 8


def test_smooth_patches_are_cleared_of_both_checks():
    patches = [p for p in _patches() if p[2] == "smooth"]
    _, edge_ok, tilt_ok = _screened(patches)
    assert edge_ok.mean() >= 0.9 and tilt_ok.mean() >= 0.9


def test_creases_named_by_flat_faces_alone_are_not_cleared():
    """Sweeps over a crease whose normals a smooth field fits as well as the step: the
    screen leaves them to ``edges.check``, which names the edge."""
    for kind, index in (("ridge", 1245), ("valley", 375)):
        case = edge_cases.make("tune", kind, index)
        (prep,), edge_ok, _ = _screened([(case["points"], case["normals"], "crease")])
        assert not edge_ok[0] and _trips_edges(prep)


def test_a_patch_the_jump_screen_clears_has_no_jump_and_smooth_ones_are_cleared():
    """``no_jump`` clears a patch only where ``curvature_jump.find_jump`` finds nothing; joins of a
    plane and a cylinder (the tune split) are left to it, and it names most of them."""
    patches = [(p, n) for p, n, _ in _patches()]
    joins = [edge_cases.make("tune", "join", i) for i in range(20, 40)]
    kw = patch_input.keywords()
    preps = [patch_input.prepare(p, n, None, None, kw) for p, n in patches]
    preps += [patch_input.prepare(d["points"], d["normals"], None, None, kw) for d in joins]
    cleared, found = [], []
    for size in {len(p.points) for p in preps}:
        same = [p for p in preps if len(p.points) == size]
        ok = check_screens.no_jump(np.stack([p.points for p in same]),
                                   np.stack([p.normals for p in same]))  # fmt: skip
        cleared += ok.tolist()
        found += [curvature_jump.find_jump(p.points, p.normals) is not None for p in same]
    assert not any(c and f for c, f in zip(cleared, found, strict=True))
    assert sum(found) >= 5
    assert np.mean(cleared) >= 0.7


def _cone(deg, rng, n=12):
    """Noise-free normals on a cone of half-angle ``deg`` about z (mean z), a flat patch's
    points: at the edge gate's angle, round-off decides ``edges.find``'s gate."""
    phi = np.linspace(0.0, 2 * np.pi, n, endpoint=False) + rng.uniform(0, 1)
    a = np.radians(deg)
    nrm = np.column_stack([np.sin(a) * np.cos(phi), np.sin(a) * np.sin(phi), np.full(n, np.cos(a))])
    return np.column_stack([rng.uniform(-2, 2, (n, 2)), np.zeros(n)]), nrm


def _screen_turns(patches):
    """(per patch: ``no_turn``'s verdict, ``edges.find`` (loose) finds an edge) for (points,
    normals)."""
    kw = patch_input.keywords()
    preps = [patch_input.prepare(p, n, None, None, kw) for p, n in patches]
    out = [None] * len(preps)
    for size in {len(p.points) for p in preps}:
        idx = [i for i, p in enumerate(preps) if len(p.points) == size]
        ok = check_screens.no_turn(np.stack([preps[i].points for i in idx]),
                                   np.stack([preps[i].normals for i in idx]),
                                   [preps[i].jet for i in idx])  # fmt: skip
        for i, cleared in zip(idx, ok.tolist(), strict=True):
            p = preps[i]
            out[i] = (cleared, edges.find(p.points, p.normals, p.jet.noise_normal, strict=False))
    return out


def test_a_patch_the_turn_screen_clears_has_no_loose_edge():
    """``no_turn`` clears a patch only where ``edges.find`` (loose) finds no edge, so a
    ``plane`` beside it needs no ``check_answer``: near-flat patches are cleared, flipped
    normals and creases turning 30 deg or more are not, and cones of normals at the gate's
    angle (round-off decides the gate) are decided with a margin: inside it cleared, on it
    left to the check where their main axis ties (a round cone's does)."""
    rng = np.random.default_rng(3)
    flat = [(np.column_stack([rng.uniform(-2, 2, (n, 2)), 1e-3 * rng.standard_normal(n)]),
             [0, 0, 1] + 0.01 * rng.standard_normal((n, 3)))
            for n in (9, 16, 36) for _ in range(5)]  # fmt: skip
    others = [(p, n) for p, n, w in _patches() if w == "flipped"]
    others += [_crease(d, rng) for d in (90.0, 120.0, 150.0)]
    cones = [_cone(edges.GATE_DEG + d, rng) for d in (-1e-3, -1e-9, 0.0, 1e-9, 1e-3)]
    got = _screen_turns(flat + others + cones)
    assert all(edge is None for cleared, edge in got if cleared)
    assert all(c for c, _ in got[: len(flat)])
    assert not any(c for c, _ in got[len(flat) : len(flat) + len(others)])
    assert got[-5][0]


def test_noise_free_symmetric_patches_are_cleared_of_the_edge_check():
    """A noise-free, gently curved sphere, cylinder or pit over a symmetric grid ties the
    normal screen's seed (several contacts' normals are equally central): each tied seed
    puts the same contacts near, so the screen clears it; three flipped normals still go
    to the check, which refuses them."""
    kw = patch_input.keywords()
    preps, trips = [], []
    for kind in ("sphere", "cylinder", "pit"):
        obj = make(kind, 60.0)
        z, _, _ = obj.eval(XY[:, 0], XY[:, 1])
        pts, nrm = np.column_stack([XY, z]), obj.normals(XY[:, 0], XY[:, 1])
        bad = nrm.copy()
        bad[[0, 14, 35]] *= -1
        for n in (nrm, bad):
            preps.append(patch_input.prepare(pts, n, None, None, kw))
            trips.append(_trips_edges(preps[-1]))
    P, N = np.stack([p.points for p in preps]), np.stack([p.normals for p in preps])
    edge_ok, _ = check_screens.clear(P, N, [p.jet for p in preps])
    assert trips == [False, True] * 3
    assert edge_ok.tolist() == [True, False] * 3


def _sweeps(kind, rng, deg=0.0):
    """Three close finger sweeps (0.2 apart) of 6 contacts, 4 long, over a curved patch,
    normals turned by ``deg``."""
    x = np.tile(np.linspace(0.0, 4.0, 6), 3) + rng.uniform(-0.05, 0.05, 18)
    y = np.repeat([1.8, 2.0, 2.2], 6) + rng.uniform(-0.005, 0.005, 18)
    obj = make(kind, 12.0)
    z, _, _ = obj.eval(x, y)
    pts = np.column_stack([x, y, z]) + 0.002 * rng.standard_normal((18, 3))
    nrm = obj.normals(x, y) + 0.002 * rng.standard_normal((18, 3))
    return pts, _turned(nrm, deg)


def test_sweeps_without_a_tilt_are_cleared_and_tilted_sweeps_are_not():
    """Close sweeps make the tilt fit's quadratic columns ill-conditioned for the normal
    equations (cond ~ 2e3, its square beyond their bound): the screen fits them by QR, so
    tilt-free sweeps skip ``tilt.untilt`` while a 4 deg tilt still goes to it and is named."""
    rng = np.random.default_rng(5)
    patches = [(*_sweeps(k, rng, deg), deg) for k in ("sphere", "cylinder", "saddle")
               for deg in (0.0, 0.0, 4.0)]  # fmt: skip
    preps, _, tilt_ok = _screened(patches)
    named = [tilt.untilt(p)[1] is not None for p in preps]
    assert named == [deg > 0 for _, _, deg in patches]
    assert tilt_ok.tolist() == [deg == 0 for _, _, deg in patches]


def _families_prepared():
    """The tune split's first draw of 60 cases a family, prepared and untilted (as fitted), and
    their points and normals padded into one stack with a row mask."""
    kw = patch_input.keywords()
    preps = []
    for case in families.split("tune", 60):
        d = families.draw(case)
        try:
            preps.append(
                tilt.untilt(patch_input.prepare(d["points"], d["normals"], None, None, kw))[0]
            )
        except DataError:
            continue
    n = max(len(p.points) for p in preps)
    P, N, mask = (
        np.zeros((len(preps), n, 3)),
        np.zeros((len(preps), n, 3)),
        np.zeros((len(preps), n), bool),
    )
    for b, p in enumerate(preps):
        k = len(p.points)
        P[b, :k], N[b, :k], mask[b, :k] = p.points, p.normals, True
    return preps, P, N, mask


def test_over_the_families_each_screen_clears_only_patches_its_check_passes():
    """Over the families (every family, size, layout, noise and outliers of the tune
    split): a patch ``no_jump`` clears has no curvature jump, one ``no_turn`` clears no
    edge by ``edges.find`` (loose), one ``clear`` clears passes ``edges.check``
    and keeps its tilt.  The jump screen clears nearly every patch without a jump, those
    whose slopes' curvature changes over the patch (past ``find_jump``'s first test) too."""
    preps, P, N, mask = _families_prepared()
    jumps = [curvature_jump.find_jump(p.points, p.normals) is not None for p in preps]
    smooth = check_screens.no_jump(P, N, mask)
    assert not any(smooth & jumps)
    assert smooth[~np.array(jumps)].mean() >= 0.94  # (its first test alone: 0.85)
    for size in {len(p.points) for p in preps}:
        same = [p for p in preps if len(p.points) == size]
        Ps, Ns = np.stack([p.points for p in same]), np.stack([p.normals for p in same])
        for prep, ok in zip(
            same, check_screens.no_turn(Ps, Ns, [p.jet for p in same]), strict=True
        ):
            if ok:
                args = prep.points, prep.normals, prep.jet.noise_normal
                assert edges.find(*args, strict=False) is None
        edge_ok, tilt_ok = check_screens.clear(Ps, Ns, [p.jet for p in same])
        assert not any(_trips_edges(p) for p, ok in zip(same, edge_ok, strict=True) if ok)
        assert not any(tilt.untilt(p)[1] for p, ok in zip(same, tilt_ok, strict=True) if ok)
