"""How close a batched computation and the same computation alone must be: a tolerance
derived from the quantity's conditioning, not a fixed 1e-10.

A stack's QR and one patch's QR, or BLAS kernels that block and sum in another order
(OPENBLAS_CORETYPE, threads), each round differently.  How far that moves a quantity is
its sensitivity to a move of its data at the size of round-off: its condition number
times eps, plus whatever its own steps amplify (an interval end computed from a
covariance of 263 where the end is 0.1 loses digits no data move shows).  No fixed
relative tolerance holds for every patch: a noise-free two-finger patch has a covariance
entry of 3,655 beside entries of 1e-6, and two kernels put it 7.6e-10 apart, relative.

So the sensitivity is measured at that size: each input array is moved by ``ULPS`` ulps of
its largest entry (each entry its own normal draw, as round-off moves each entry), along
``DIRECTIONS`` directions, and the computation is run again; the field's largest change is
what a few ulps of data (and the rounding of every step after them) do to it.  The
tolerance of a field (an array, normwise, as a matrix perturbation bound is) is

    tol = K * max(change under a ULPS-ulp move, ULPS * eps * |value|)

with ``K`` = 8: two computations, each within a few ulps of data of the exact answer
(backward stable), and the largest of three random moves short of the worst direction by up
to a few times.  ``bench/blas_paths.py`` runs these checks under other BLAS kernel paths and
thread counts and reports the worst ratio of |difference| to this tolerance (below 1
everywhere; with TOLERANCE_LOG set each check appends its ratio to that file).
"""

import json
import os

import numpy as np

from tactile.ep1.estimator import estimate
from tactile.ep2 import analyze_patch

EPS = np.finfo(float).eps
K = 8.0
ULPS = 16.0
DIRECTIONS = 3


def numbers(obj, path=""):
    """{path: float array} of the numbers in ``obj`` (dicts, lists, tuples, arrays, floats;
    ints, bools, strings and None are not round-off and are compared exactly elsewhere)."""
    out = {}
    if isinstance(obj, dict):
        for k, v in obj.items():
            out.update(numbers(v, f"{path}.{k}"))
    elif isinstance(obj, list | tuple) and not all(_is_number(v) for v in obj):
        for i, v in enumerate(obj):
            out.update(numbers(v, f"{path}[{i}]"))
    elif isinstance(obj, np.ndarray) and obj.dtype.kind == "f":
        out[path] = obj.astype(float)
    elif isinstance(obj, list | tuple) and obj and all(_is_number(v) for v in obj):
        if any(isinstance(v, float) for v in obj):
            out[path] = np.array(obj, float)
    elif isinstance(obj, float | np.floating):
        out[path] = np.array(float(obj))
    return out


def _is_number(v):
    return isinstance(v, int | float | np.number) and not isinstance(v, bool)


def sensitivity(fn, inputs, moved=None, *, seed=0):
    """{field: the largest change of ``fn(*inputs)``'s numbers (``numbers``) when every
    input entry moves by ``ULPS`` ulps of its array's largest entry}, over ``DIRECTIONS``
    random moves.  ``moved``: per input, whether it moves (default all).  A move whose run
    refuses (raises) or gives other fields is skipped: a threshold crossed is no round-off."""
    base = numbers(fn(*inputs))
    rng = np.random.default_rng(seed)
    moved = [True] * len(inputs) if moved is None else moved
    out = {k: 0.0 for k in base}
    for _ in range(DIRECTIONS):
        args = []
        for x, m in zip(inputs, moved, strict=True):
            if m:
                x = np.asarray(x, float)
                size = ULPS * EPS * float(np.abs(x).max(initial=0.0))
                x = x + size * rng.standard_normal(x.shape)
            args.append(x)
        try:
            got = numbers(fn(*args))
        except Exception:  # (a refusal at a threshold)
            continue
        for k, v in base.items():
            if k in got and got[k].shape == v.shape:
                d = np.abs(got[k] - v)
                out[k] = max(out[k], float(d[np.isfinite(d)].max(initial=0.0)))
    return out


def tolerance(value, change):
    """K max(change, ULPS eps |value|) for a field (arrays: their largest entries)."""
    v = np.abs(np.asarray(value, float))
    return K * max(float(change), ULPS * EPS * float(v[np.isfinite(v)].max(initial=0.0)))


def assert_close(got, want, sens, label=""):
    """Every number of ``got`` within its field's derived tolerance of ``want``'s (the same
    fields, the same non-finite entries); returns the worst ratio |difference| / tolerance."""
    g, w = numbers(got), numbers(want)
    assert sorted(g) == sorted(w), (label, sorted(set(g) ^ set(w)))
    worst, said = 0.0, ""
    for k, v in w.items():
        a = g[k]
        assert a.shape == v.shape, (label, k, a.shape, v.shape)
        fin = np.isfinite(v)
        np.testing.assert_array_equal(np.isfinite(a), fin, err_msg=f"{label}{k}")
        np.testing.assert_array_equal(a[~fin], v[~fin], err_msg=f"{label}{k}")
        diff = float(np.abs(a[fin] - v[fin]).max(initial=0.0))
        tol = tolerance(v, sens.get(k, 0.0))
        ratio = diff / tol if tol > 0 else (0.0 if diff == 0 else np.inf)
        if ratio >= worst:
            worst = ratio
            said = (
                f"{label}{k}: differ by {diff:.3g}, tolerance {tol:.3g} (K max(change "
                f"{sens.get(k, 0.0):.3g} under a {ULPS:g}-ulp move of the data, "
                f"{ULPS:g} eps |value|))"
            )
    _log(label, worst)  # (before the assertion: the bench sees a failing ratio too)
    assert worst < 1.0, said
    return worst


def _log(label, ratio):
    """Append the check's worst ratio to $TOLERANCE_LOG (``bench/blas_paths.py``)."""
    path = os.environ.get("TOLERANCE_LOG")
    if path:
        test = os.environ.get("PYTEST_CURRENT_TEST", "").split(" ")[0]
        with open(path, "a", encoding="utf-8") as fh:
            fh.write(json.dumps({"test": test, "check": label, "ratio": ratio}) + "\n")


def assert_patch_close(got, want, fields, points, normals, finger=None, lines=None, **kw):
    """``assert_close`` for two EP2 results of one patch (``got``, ``want``: what ``fields``
    makes of a ``PatchResult``), the sensitivity that of ``analyze_patch`` on the patch's
    rows (exact repeats kept exact: it counts them once) with keywords ``kw``."""
    pts, nrm = np.asarray(points, float), np.asarray(normals, float)
    _, first = np.unique(np.column_stack([pts, nrm]), axis=0, return_index=True)
    rows = np.sort(first)
    finger = None if finger is None else np.asarray(finger)[rows]
    lines = None if lines is None else [lines[i] for i in rows]

    def record(p, q):
        return fields(analyze_patch(p, q, finger=finger, lines=lines, **kw))

    sens = sensitivity(record, (pts[rows], nrm[rows]))
    return assert_close(got, want, sens)


def _ep1_numbers(e):
    """The numbers of one point's ``Estimate`` that ``estimate_batch`` also gives."""
    out = {"S": np.array(e.S)[[0, 0, 1], [0, 1, 1]], "residual": e.residual}
    out.update({f: getattr(e, f) for f in ("kx", "ky", "k1", "k2") if getattr(e, f) is not None})
    if e.K is not None:
        out["kxy"] = e.K[0][1]
    for label in ("k1", "k2"):
        bound = e.bounds.get(label, {})
        for key in ("curvature_range", "curvature_min"):
            if key in bound:
                out[f"{label}.{key}"] = bound[key]
    return out


def _ep1_batched(out, i, want):
    """``estimate_batch``'s numbers of point i under ``_ep1_numbers``'s names."""
    side = {"k1": "lo", "k2": "hi"}
    got = {"S": out["S"][i], "residual": out["residual"][i], "kxy": out["kxy"][i]}
    got.update({f: out[f][i] for f in ("kx", "ky", "k1", "k2")})
    for label in ("k1", "k2"):
        k_lo, k_hi = out["klo_" + side[label]][i], out["khi_" + side[label]][i]
        got[f"{label}.curvature_range"] = [k_lo, k_hi]
        got[f"{label}.curvature_min"] = k_lo
    return {k: got[k] for k in want}


def assert_point_close(e, out, i, th, dp, args):
    """EP1: point i of ``estimate_batch``'s ``out`` has the numbers of ``estimate`` ``e`` of
    (th, dp, *args), each field within a tolerance derived from its own
    sensitivity to its data (``tests/tolerance.py``; a nearly parallel probe set, condition
    number ~1e3, gets a wider one than a well-spread set)."""
    want = _ep1_numbers(e)

    def single(th, dp):
        return _ep1_numbers(estimate(th, dp, *args))

    sens = sensitivity(single, (th, dp))
    return assert_close(_ep1_batched(out, i, want), want, sens)
