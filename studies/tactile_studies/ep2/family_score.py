"""Scoring EP2 estimators on ``families`` cases: per-patch records and markdown tables.

An estimator is any callable taking a list of patch dicts (``points``, ``normals``,
``finger``, ``noise_pos``, ``noise_normal``, ``stated``) and returning one result per patch
in order: an object with ``S``, ``k1``, ``k2``, ``S_interval``, ``k1_interval``,
``k2_interval`` (None when not given), ``shape`` and ``warnings``, or an exception (a
refusal).  Where the estimator measured (the estimand, docs/ep2.md "One definition
everywhere"): a result with a ``centre`` attribute (a world point) is evaluated on the line
through it along its frame's z (``frame.rot[2]``; along the true normal where it has no
frame); otherwise the line through the middle of its contacts' box (``box`` x ``scale``
in ``frame``, as ``PatchResult`` holds them) along its frame z.  The truth is where that
line meets the true surface, so an estimator that leaves a contact out is judged at its own
centre.

Per record: S error (the reported S, or S of k1, k2 where S is null, as bench/ep2_trust.py),
(k - k_true) L for k1 and k2 (L the case's patch size), whether each 95 % interval holds the
truth, a confidently wrong label (a label other than uncertain/plane whose S band
excludes the true S, or any curved label where the true S is null), refusals (counted apart
where the case is ``well_posed``: the data determine the curvature, ``well_posed``), and for
outliers: contact indices named in warnings ("contact 3", "contacts 3 and 7", "contacts 3,
7"; discontinuity warnings "normals turn ..." are not counted), right (an outlier) or not.
"""

import math
import re

import numpy as np

from tactile_studies.ep2 import families, family_layouts, implicit, jet2

BANDS = jet2.BANDS
NOISE_BINS = ("none", "low", "mid", "high")
KL_BINS = ("<0.01", "0.01-0.1", "0.1-0.5", ">=0.5")  # |k|max L at the case's centre point
DETERMINED_HALFWIDTH = 0.25  # docs/ep2.md, "What is null": 95 % half-width x L above this
SPREAD_SIGMAS = 5.0  # ... or the contacts spread across their thinnest direction < 5 sigma
SIGMA_FLOOR = 1e-3  # of L and rad: no sensor resolves better (the default's floor)
_NAMED = re.compile(r"contacts?\s+(\d+(?:\s*(?:,|and)\s*\d+)*)")


def well_posed(cases):
    """(len(cases),) bool: the case's noise-free inliers, at its noise (floored at
    ``SIGMA_FLOOR``), determine the curvature by the documented rule: the 2-jet's 95 %
    half-width of the normal curvature in its worst direction at most 0.25/L, and a spread
    across the thinnest direction of at least 5 position sigmas."""
    out = np.zeros(len(cases), bool)
    groups = {}
    for j, c in enumerate(cases):
        keep = np.setdiff1d(np.arange(c.n), [i for i, _ in c.outliers])
        groups.setdefault(len(keep), []).append((j, keep))
    for items in groups.values():
        cs = [cases[j] for j, _ in items]
        P = np.stack([c.clean[k] for c, (_, k) in zip(cs, items)])
        N = np.stack([c.clean_normals[k] for c, (_, k) in zip(cs, items)])
        sp = np.array([max(c.eps, SIGMA_FLOOR) * c.size for c in cs])
        sn = np.array([max(c.sigma_n, SIGMA_FLOOR) for c in cs])
        half = jet2.worst_halfwidth(P, N, sp, sn)
        for b, ((j, keep), c) in enumerate(zip(items, cs)):
            uv = (c.clean[keep] - c.centre) @ c.tangent[:2].T
            thin = np.linalg.eigh(np.cov(uv.T))[1][:, 0]
            spread = np.ptp(uv @ thin)
            out[j] = half[b] <= DETERMINED_HALFWIDTH and spread >= SPREAD_SIGMAS * sp[b]
    return out


def kl_bin(kl):
    """The ``KL_BINS`` name of |k|max L."""
    return KL_BINS[int(np.searchsorted([0.01, 0.1, 0.5], kl, side="right"))]


def centre_line(res):
    """(origin, direction or None) in the data frame: where ``res`` says it measured."""
    frame = getattr(res, "frame", None)
    z = None if frame is None else np.asarray(frame.rot)[2]
    centre = getattr(res, "centre", None)
    if centre is not None:
        return np.asarray(centre, float), z
    b, L = res.box, res.scale
    mid = np.array([0.5 * (b[0] + b[1]) * L, 0.5 * (b[2] + b[3]) * L, 0.0])
    return frame.to_world(mid), z


def _truth(case, results):
    """Truth dicts (or None) at each answered result's centre, one batched call."""
    idx = [j for j, r in enumerate(results) if not isinstance(r, BaseException)]
    out = [None] * len(results)
    if not idx:
        return out
    lines = [centre_line(results[j]) for j in idx]
    o = np.array([p for p, _ in lines])
    d = []
    for p, z in lines:
        if z is None:  # no frame: along the true normal at the point (nearest surface point)
            q, _ = families.to_local(case, p, p)
            z = implicit.normals(case.surface, q)[0] @ case.rot.T
        d.append(z)
    t = families.truth(case, o, np.array(d))
    for m, j in enumerate(idx):
        if t["ok"][m]:
            out[j] = {"k1": t["k1"][m], "k2": t["k2"][m], "S": t["S"][m]}
    return out


def _inside(iv, v):
    return None if iv is None else bool(iv[0] <= v <= iv[1])


def wrong_label(shape, S_true):
    """A confidently wrong label (module docstring)."""
    if shape in ("uncertain", "plane") or shape not in BANDS:
        return False
    if S_true is None:
        return True
    lo, hi = BANDS[shape]
    return not lo <= S_true <= hi


def named_contacts(warnings):
    """Contact indices named in warnings (module docstring)."""
    found = set()
    for w in warnings or ():
        if str(w).startswith("normals turn"):
            continue
        for group in _NAMED.findall(str(w)):
            found.update(int(v) for v in re.findall(r"\d+", group))
    return found


def records(case, draws, results, clean_results=None):
    """Per-trial records of one estimator on one case (dicts of plain values)."""
    truths = _truth(case, results)
    clean_truths = _truth(case, clean_results) if clean_results is not None else None
    L = case.size * case.unit
    bad = {i for i, _ in case.outliers}
    out = []
    for t, (res, tr) in enumerate(zip(results, truths)):
        rec = dict(family=case.family, noise=case.noise_bin, layout=case.layout, kl=kl_bin(case.kl),
                   well_posed=case.well_posed, robust=bool(case.outliers), case=case.id,
                   answered=False, refused=False, truth_failed=False, n_outliers=len(bad),
                   seed=draws[t]["seed"])  # fmt: skip
        if isinstance(res, BaseException):
            rec["refused"] = True
            rec["reason"] = str(res).split(":")[0][:60]
            rec["message"] = str(res)
            out.append(rec)
            continue
        rec["answered"] = True
        if tr is None:
            rec["truth_failed"] = True
            out.append(rec)
            continue
        rec.update(_errors(res, tr, L))
        named = named_contacts(getattr(res, "warnings", ()))
        rec["found"], rec["false_pos"] = len(named & bad), len(named - bad)
        if clean_results is not None:
            c_res, c_tr = clean_results[t], clean_truths[t]
            if not isinstance(c_res, BaseException) and c_tr is not None:
                rec["clean_S_err"] = _errors(c_res, c_tr, L)["S_err"]
        out.append(rec)
    return out


def _errors(res, tr, L):
    k1, k2 = float(res.k1), float(res.k2)
    S = res.S if res.S is not None else 2 / math.pi * math.atan2(k1 + k2, k1 - k2)
    S_true = tr["S"]
    return {
        "S_err": None if S_true is None else float(S) - S_true,
        "k1_err": (k1 - tr["k1"]) * L,
        "k2_err": (k2 - tr["k2"]) * L,
        "cover_S": None if S_true is None else _inside(res.S_interval, S_true),
        "cover_k1": _inside(res.k1_interval, tr["k1"]),
        "cover_k2": _inside(res.k2_interval, tr["k2"]),
        "wrong": wrong_label(res.shape, S_true),
    }


# -- tables ------------------------------------------------------------------------------


def _rms(vals):
    v = [x for x in vals if x is not None]
    return None if not v else math.sqrt(sum(x * x for x in v) / len(v))


def _share(vals):
    v = [x for x in vals if x is not None]
    return None if not v else sum(v) / len(v)


def _f(v, spec=".4f"):
    return "-" if v is None else format(v, spec)


HEAD = [
    "patches", "answered %", "RMS S err", "RMS dk1 L", "RMS dk2 L", "cover S", "cover k1",
    "cover k2", "refused (well-posed)", "wrong labels",
]  # fmt: skip
ROBUST_HEAD = ["outliers named", "false pos", "RMS S err / w/o outliers"]


def cells(recs, robust=False):
    """The metric cells of a group of records (``HEAD``, then ``ROBUST_HEAD``)."""
    n = len(recs)
    ans = [r for r in recs if r["answered"] and not r["truth_failed"]]
    refused = [r for r in recs if r["refused"]]
    out = [
        str(n),
        _f(100 * sum(r["answered"] for r in recs) / n if n else None, ".1f"),
        _f(_rms(r["S_err"] for r in ans)),
        _f(_rms(r["k1_err"] for r in ans)),
        _f(_rms(r["k2_err"] for r in ans)),
        *(_f(_share(r[f"cover_{k}"] for r in ans), ".3f") for k in ("S", "k1", "k2")),
        f"{len(refused)} ({sum(r['well_posed'] for r in refused)})",
        str(sum(r["wrong"] for r in ans)),
    ]
    if robust:
        total = sum(r["n_outliers"] for r in ans)
        paired = [r for r in ans if r.get("clean_S_err") is not None and r["S_err"] is not None]
        with_, without = _rms(r["S_err"] for r in paired), _rms(r["clean_S_err"] for r in paired)
        out += [
            f"{sum(r['found'] for r in ans)}/{total}",
            str(sum(r["false_pos"] for r in ans)),
            f"{_f(with_)} / {_f(without)}",
        ]
    return out


def table(by_estimator, keys, robust=False):
    """Markdown: one row per group of ``keys`` (e.g. ("family", "noise", "layout")) and
    estimator, groups in order of first appearance, then an ``all`` row per estimator."""
    head = [*keys, "estimator", *HEAD, *(ROBUST_HEAD if robust else [])]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    groups = {}
    for name, recs in by_estimator.items():
        for r in recs:
            groups.setdefault(tuple(r[k] for k in keys), {}).setdefault(name, []).append(r)
    order = sorted(groups, key=lambda g: tuple(_rank(k, v) for k, v in zip(keys, g)))
    for g in order:
        for name in by_estimator:
            recs = groups[g].get(name, [])
            if recs:
                lines.append("| " + " | ".join([*g, name, *cells(recs, robust)]) + " |")
    for name, recs in by_estimator.items():
        lines.append("| " + " | ".join(["all"] * len(keys) + [name, *cells(recs, robust)]) + " |")
    return "\n".join(lines)


def _rank(key, value):
    order = {"family": families.FAMILIES, "noise": NOISE_BINS, "layout": family_layouts.KINDS,
             "kl": KL_BINS}  # fmt: skip
    seq = order.get(key, ())
    return seq.index(value) if value in seq else len(seq)


def reasons(by_estimator, top=4):
    """Markdown: per estimator, refusals and their commonest reasons (message up to its
    first ':', numbers as #), and answers whose centre line misses the true surface."""
    head = "| estimator | refused | of them well-posed | commonest reasons | no truth at centre |"
    lines = [head, "|---|---|---|---|---|"]
    for name, recs in by_estimator.items():
        why = {}
        for r in recs:
            if r["refused"]:
                key = re.sub(r"-?\d+(\.\d+)?(e[-+]?\d+)?", "#", r["reason"])
                why[key] = why.get(key, 0) + 1
        common = sorted(why.items(), key=lambda kv: -kv[1])[:top]
        refused = [r for r in recs if r["refused"]]
        lines.append(
            f"| {name} | {len(refused)} | {sum(r['well_posed'] for r in refused)} | "
            + ("; ".join(f"{k} x{v}" for k, v in common) or "-")
            + f" | {sum(r['truth_failed'] for r in recs)} |"
        )
    return "\n".join(lines)
