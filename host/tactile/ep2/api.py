"""EP2 in one call: contacts and normals in, curvature at the patch centre with a label out.

``analyze_patch(points, normals)`` runs the thesis's algorithm (§4.1) with the
default estimator ``method="jet"`` (``local_jet``, ``jet_answers``): jets of
positions and normals about the patch centre, the 2-jet moved toward the 3-jet on
evidence, bad contacts left out by name, curvature reported AT THE CENTRE with
95 % intervals that count the model's truncation, refused (``DataError``) where
the data do not determine it or where positions and normals disagree.
``method="spline"`` is the thesis's B-spline patch (``spline_analysis``), kept to
reproduce chapters 4-5.

One definition everywhere (table, JSON, plots): ``S``, ``k1``, ``k2``,
``radius`` and ``C`` are at the patch centre (the middle of the contacts'
bounding box in the patch frame); ``S_mean``, ``S_std``, ``R_mean``,
``C_mean``, ``k1_mean`` ... are the thesis's statistics over the N x N grid
(§4.8.2).  Lengths are in the input unit, curvatures in 1/unit.

The steps: ``patch_input`` (validation, duplicates, centring), ``local_jet`` (the fit),
``jet_answers`` (refusals, positions against normals, intervals, labels), ``patch_result``
(the ``PatchResult``).
"""

import numpy as np

from tactile.ep2 import (
    jet_answers,
    local_jet,
    patch_frame,
    patch_input,
    patch_result,
)
from tactile.ep2.patch_input import JetOptions, SplineOptions
from tactile.ep2.patch_result import PatchResult
from tactile.errors import DataError

__all__ = ["JetOptions", "PatchResult", "SplineOptions", "analyze_patch", "analyze_sweep"]


def analyze_patch(
    points, normals, *, method="jet", jet=None, spline=None, finger=None, lines=None,
    maps=False, **options,
):  # fmt: skip
    """Fit and analyse one patch of contacts (world frame) with outward normals.

    points, normals: (n, 3), normals pointing from the object toward the finger.
    ``method`` "jet" (default) or "spline" (the thesis's B-spline).  ``jet``
    (``JetOptions``) holds the options both methods read: ``noise_pos`` (input
    unit) and ``noise_normal`` (rad) state the noise, what is not stated is
    estimated; ``max_normal_angle``, ``break_angle``, ``grid``, ``intervals``.
    ``spline`` (``SplineOptions``) holds the spline's own: ``order`` 2-4 per
    direction (default 2), ``segments``, ``weighting`` "tangent" / "position"
    100:1 as in §4.9 or "auto", ``align``, ``solver``, ``shrink``.  Any of them
    may be given by name instead (``noise_pos=0.01``, ``order=3``), over the
    dataclasses.  ``finger`` (one label per row, sweep order) enables the
    discontinuity check (§6.2.5); ``lines`` (CSV line per row) names rows in
    messages; ``maps`` keeps the grid maps (fig. 50).

    Raises ``InputError`` for malformed input and ``DataError`` when the
    contacts do not determine the curvature (the message says why).
    """
    kw = patch_input.keywords(method, jet, spline, maps, **options)
    prep = patch_input.prepare(points, normals, finger, lines, kw)
    pts, nrm, opts = prep.points, prep.normals, prep.opts
    if method == "spline":
        from tactile.ep2 import spline_analysis  # (start-up: scipy only for the spline)

        out = spline_analysis.analyze(pts, nrm, opts)
    else:
        out = _analyze_jet(pts, nrm, opts)
    return patch_result.from_fields(
        out, len(pts), method, maps, prep.breaks, prep.dropped, prep.middle
    )


def _analyze_jet(pts, nrm, opts):
    mask = np.ones((1, len(pts)), bool)
    stack = local_jet.fit(
        pts[None],
        nrm[None],
        mask,
        opts["noise_pos"],
        opts["noise_normal"],
        opts["max_normal_angle"],
    )
    (out,) = jet_answers.outcomes(stack, opts, [opts["names"]])
    if isinstance(out, DataError):
        raise out
    return out


def analyze_sweep(points, normals, finger=None, split=False, **kw):
    """Like ``analyze_patch``; with ``split`` a sweep broken by discontinuities
    (§6.2.5) is cut into parts analysed separately.  Returns a list of results."""
    lines = kw.pop("lines", None)
    kw = patch_input.keywords(**kw)
    parts = sweep_parts(points, normals, finger, lines, split, kw)
    if parts is None:
        return [analyze_patch(points, normals, finger=finger, lines=lines, **kw)]
    return [
        analyze_patch(p["points"], p["normals"], finger=p["finger"], lines=p["lines"], **kw)
        for p in parts
    ]


def sweep_parts(points, normals, finger, lines, split, kw):
    """The parts ``analyze_sweep`` fits (dicts of points, normals, finger, lines, as
    ``analyze_patches`` takes them), or None when it fits the patch whole (no ``split``, or
    no break).  Raises as ``analyze_sweep`` does for normals it cannot use."""
    nrm = patch_frame.unit_normals(np.asarray(normals, float))
    (breaks,) = patch_input.find_breaks(
        nrm[None], [finger], kw.get("break_angle", patch_input.BREAK_ANGLE_DEG)
    )
    if not (split and breaks):
        return None
    pts, fing = np.asarray(points, float), np.asarray(finger)
    return [
        {
            "points": pts[rows],
            "normals": nrm[rows],
            "finger": fing[rows],
            "lines": None if lines is None else [lines[i] for i in rows],
        }
        for rows in patch_input.split_parts(len(nrm), finger, breaks)
    ]
