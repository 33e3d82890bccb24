"""``analyze_patches`` equals ``analyze_patch`` patch by patch (issue 13): labels, model
choice, values and intervals to round-off; a refused or malformed patch gives its error
in its place and the others still come out."""

import numpy as np
import pytest
import tolerance

from tactile.ep2 import analyze_patch, analyze_patches
from tactile.errors import DataError, InputError
from tactile_studies.ep2 import cases, edge_cases

FIELDS = ("S", "k1", "k2", "radius", "C", "S_mean", "R_mean", "noise_pos", "noise_normal")
INTERVALS = ("S_interval", "k1_interval", "k2_interval", "radius_interval")


def _mixture():
    """Shapes, sizes, contact counts, noise, a line (refused), a malformed patch."""
    picked = [c for c in cases.split("holdout2")[::15]] + cases.split("degenerate")[::8]
    patches = []
    for k, case in enumerate(picked):
        d = cases.draw(case, k)
        patches.append({"points": d["points"], "normals": d["normals"], "finger": d["finger"]})
    nan = patches[0]["points"].copy()
    nan[3, 0] = np.nan
    bad = dict(patches[0], points=nan)  # malformed: InputError
    zero = dict(patches[1], normals=np.zeros_like(patches[1]["normals"]))  # DataError
    return patches[:5] + [bad, zero] + patches[5:]


def _numbers(res):
    return {f: getattr(res, f) for f in ("confidence", *FIELDS, *INTERVALS)}


@pytest.mark.parametrize("chunk", [1, 7, 256])
def test_batch_equals_one_at_a_time(chunk):
    patches = _mixture()
    batch = analyze_patches(patches, chunk=chunk)
    assert len(batch) == len(patches)
    kinds = set()
    for p, got in zip(patches, batch, strict=True):
        try:
            want = analyze_patch(p["points"], p["normals"], finger=p["finger"])
        except (DataError, InputError) as exc:
            assert type(got) is type(exc) and str(got) == str(exc)
            kinds.add(type(exc).__name__)
            continue
        kinds.add("answer")
        _assert_same(got, want, p, {})
    assert kinds == {"answer", "DataError", "InputError"}


def _assert_same(got, want, p, kw):
    """Labels and text exactly; numbers to a tolerance derived from their sensitivity to the
    patch's data (``tests/tolerance.py``): a stack sums in another order than one patch."""
    assert (got.shape, got.model, got.warnings) == (want.shape, want.model, want.warnings)
    for f in FIELDS + INTERVALS:  # an interval's open (None) end is no round-off
        assert (getattr(got, f) is None) == (getattr(want, f) is None), f

    tolerance.assert_patch_close(
        _numbers(got), _numbers(want), _numbers, p["points"], p["normals"], p.get("finger"),
        p.get("lines"), **kw,
    )  # fmt: skip


def test_spline_falls_back_to_one_at_a_time():
    p = _mixture()[0]
    (got,) = analyze_patches([(p["points"], p["normals"])], method="spline", order=3)
    want = analyze_patch(p["points"], p["normals"], method="spline", order=3)
    assert got.S == want.S and got.model == want.model


def test_stacked_preparation_equals_one_patch_at_a_time():
    """Patches of one size are checked and centred together (``patch_input.prepare_stack``):
    a duplicated row, a wild coordinate, a zero normal or a stated noise beyond the spread
    in one patch leaves it to the one-patch path, with its own message naming its CSV
    line, and the others of its size come out as alone."""
    base = [cases.draw(c, k) for k, c in enumerate(cases.split("holdout2")[:4])]
    patches = []
    for k, d in enumerate(base):
        pts, nrm = d["points"].copy(), d["normals"].copy()
        if k == 1:
            pts[5], nrm[5] = pts[4], nrm[4]  # a duplicated row: counted once, with a warning
        if k == 2:
            pts[7, 1] = 1e305  # beyond what EP2 represents: InputError naming the line
        if k == 3:
            nrm[2] = 0.0  # DataError naming the contact
        lines = list(range(10 + 100 * k, 10 + 100 * k + len(pts)))
        patches.append({"points": pts, "normals": nrm, "finger": d["finger"], "lines": lines})
    for noise_pos in (1e-3, None):
        batch = analyze_patches(patches, noise_pos=noise_pos)
        for p, got in zip(patches, batch, strict=True):
            try:
                want = analyze_patch(
                    p["points"], p["normals"], finger=p["finger"], lines=p["lines"],
                    noise_pos=noise_pos,
                )  # fmt: skip
            except (DataError, InputError) as exc:
                assert type(got) is type(exc) and str(got) == str(exc)
                continue
            _assert_same(got, want, p, dict(noise_pos=noise_pos))
    assert "duplicated" in batch[1].warnings[0]
    assert isinstance(batch[2], InputError) and "line 217" in str(batch[2])
    assert isinstance(batch[3], DataError) and "contact 2" in str(batch[3])


@pytest.mark.parametrize(
    ("script", "flag"),
    [
        ("ep2_families.py", "--trials"),
        ("ep2_families.py", "--per-family"),
        ("ep2_breakdown.py", "--trials"),
        ("ep2_breakdown.py", "--per-family"),
    ],
)
@pytest.mark.parametrize("value", ["0", "x"])
def test_the_ep2_benches_refuse_a_count_below_one_in_one_line(script, flag, value):
    """A count of patches or trials below 1 (once a division by zero after the whole run)
    is refused before any work: argparse's usage and one error line, exit 2."""
    import subprocess
    import sys

    from conftest import ROOT

    run = subprocess.run(
        [sys.executable, str(ROOT / "bench" / script), flag, value],
        capture_output=True, text=True, timeout=120, cwd=ROOT,
    )  # fmt: skip
    last = run.stderr.strip().splitlines()[-1]
    assert run.returncode == 2 and not run.stdout and "Traceback" not in run.stderr
    assert last.startswith(f"{script}: error: argument {flag}: ")
    assert ("at least 1" if value != "x" else "not a whole number") in last


def test_curvature_jumps_in_a_stack_are_named_as_one_at_a_time():
    """Plane-to-cylinder joins beside smooth patches of their sizes: the stack's jump screen
    (``check_screens.no_jump``) leaves each join to the per-patch test, so a join is
    ``uncertain`` with the jump named in the batch exactly where it is alone."""
    joins = [edge_cases.make("tune", "join", i) for i in range(20, 44)]
    patches = [{k: d[k] for k in ("points", "normals", "finger")} for d in joins]
    batch = analyze_patches(patches)
    named = 0
    for p, got in zip(patches, batch, strict=True):
        try:
            want = analyze_patch(p["points"], p["normals"], finger=p["finger"])
        except DataError as exc:
            assert type(got) is type(exc) and str(got) == str(exc)
            continue
        assert (got.shape, got.warnings) == (want.shape, want.warnings)
        named += any(w.startswith("a curvature jump at (") for w in got.warnings)
    assert named >= 3


@pytest.mark.parametrize("method", ["jet", "spline"])
def test_a_refusal_in_a_stack_holds_no_frame_of_it(method):
    """A refused patch's exception comes back without its traceback: the frames it was
    raised through hold the whole stack's arrays for as long as the result is kept."""
    line = {"points": np.column_stack([np.linspace(0, 1, 9), np.zeros(9), np.zeros(9)]),
            "normals": np.tile([0.0, 0.0, 1.0], (9, 1))}  # fmt: skip
    out = analyze_patches([line] * 3, method=method)
    assert all(isinstance(r, DataError) and r.__traceback__ is None for r in out)
