"""EP2 where a real object differs from a smooth patch (``tactile_studies.ep2.edge_cases``).

Run: OPENBLAS_NUM_THREADS=1 .venv/bin/python bench/ep2_edges.py --split holdout --final
     [--per-kind 200] [--kinds ridge,valley,join,drift,tilt,small]

``--split tune`` is for tuning; ``--split holdout`` is FOR FINAL EVALUATION ONLY
(``--final``).  Every patch goes through ``tactile.ep2.analyze_patch`` (with its finger
labels, and its noise where the case states it).  Figures (docs/ep2.md, "Edges, joins, drift,
tilt"):

- creases (``ridge``, ``valley``): patches labelled ``plane``; refused naming the edge
  (``EdgeError``), with the right kind; the dihedral interval's coverage and RMS error; the
  edge's distance from the true edge line (in L) and its direction's error; the share of
  edges whose stated direction half-angle holds the true direction, and its median;
- ``join``: answered patches whose k1 interval holds the truth or whose label is
  ``uncertain``;
- ``drift``, ``tilt``, ``small``: answered share, coverage of S, k1, k2 (``family_score``),
  confidently wrong labels; for ``tilt`` the tilt named in a warning and its error.
"""

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import argparse  # noqa: E402
import math  # noqa: E402
import re  # noqa: E402
import sys  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_args import add_split, check_split, positive_int  # noqa: E402

from tactile.ep2 import analyze_patch  # noqa: E402
from tactile.ep2.edges import EdgeError  # noqa: E402
from tactile.errors import DataError  # noqa: E402
from tactile_studies.ep2 import edge_cases, family_score  # noqa: E402

_TILT = re.compile(r"normals tilted ([0-9.]+)")


def run(data):
    kw = {}
    if data["stated"]:
        kw = {"noise_pos": data["noise_pos"], "noise_normal": data["noise_normal"]}
    try:
        return analyze_patch(data["points"], data["normals"], finger=data["finger"], **kw)
    except DataError as exc:
        return exc


def _share(vals):
    vals = [v for v in vals if v is not None]
    return "-" if not vals else f"{sum(vals) / len(vals):.3f}"


def _rms(vals):
    vals = [v for v in vals if v is not None]
    return "-" if not vals else f"{math.sqrt(sum(v * v for v in vals) / len(vals)):.3g}"


def _median(vals):
    return "-" if not vals else f"{float(np.median(vals)):.3g}"


def crease_row(cases, results):
    plane = sum(getattr(r, "shape", None) == "plane" for r in results)
    found = [(c, r.edge) for c, r in zip(cases, results) if isinstance(r, EdgeError)]
    cover, err, dist, turn, kind, dcover, half = [], [], [], [], [], [], []
    for c, e in found:
        t = c["truth"]
        lo, hi = e.dihedral_interval
        cover.append(lo <= t["dihedral_deg"] <= hi)
        err.append(e.dihedral_deg - t["dihedral_deg"])
        d = t["direction"][0]
        off = e.point - t["point"][0]
        dist.append(np.linalg.norm(off - (off @ d) * d) / c["unit"])
        turn.append(math.degrees(math.acos(min(1.0, abs(float(e.direction @ d))))))
        dcover.append(turn[-1] <= e.direction_err_deg)
        half.append(e.direction_err_deg)
        kind.append(e.kind == t["kind"])
    return [len(cases), plane, len(found), _share(kind), _share(cover), _rms(err), _rms(dist),
            _rms(turn), _share(dcover), _median(half)]  # fmt: skip


def join_row(cases, results):
    ok, unc, answered = [], 0, 0
    for c, r in zip(cases, results):
        if isinstance(r, DataError):
            continue
        answered += 1
        k1, _, _ = edge_cases.join_truth(c, family_score.centre_line(r)[0])
        unc += r.shape == "uncertain"
        lo, hi = r.k1_interval
        ok.append(r.shape == "uncertain" or lo <= k1 <= hi)
    return [len(cases), answered, unc, _share(ok)]


def smooth_row(cases, results):
    recs, named = [], []
    for c, r in zip(cases, results):
        case = c["case"]
        recs += family_score.records(case, [c], [r])
        m = None if isinstance(r, DataError) else _TILT.search(" ".join(r.warnings))
        if "tilt_deg" in c["truth"]:
            named.append(None if m is None else abs(float(m.group(1)) - c["truth"]["tilt_deg"]))
    ans = [x for x in recs if x["answered"] and not x["truth_failed"]]
    row = [len(cases), f"{len(ans) / max(len(recs), 1):.3f}"]
    row += [_share([x[k] for x in ans]) for k in ("cover_S", "cover_k1", "cover_k2")]
    row.append(sum(bool(x.get("wrong")) for x in ans))
    if named:
        within = [v is not None and v <= 1.0 for v in named]
        row += [_share(within)]
    return row


def table(head, rows):
    out = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    out += ["| " + " | ".join(str(v) for v in r) + " |" for r in rows]
    return "\n".join(out)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    add_split(ap, edge_cases.SPLITS)
    ap.add_argument("--per-kind", type=positive_int, default=200)
    ap.add_argument("--kinds", default=",".join(edge_cases.KINDS))
    args = ap.parse_args(argv)
    check_split(ap, args)
    kinds = [k for k in args.kinds.split(",") if k]
    crease, join, smooth = [], [], []
    for kind in kinds:
        cases = edge_cases.cases(args.split, args.per_kind, (kind,))
        results = [run(c) for c in cases]
        if kind in ("ridge", "valley"):
            crease.append([kind, *crease_row(cases, results)])
            for lay in edge_cases.CREASE_LAYOUTS:
                sel = [(c, r) for c, r in zip(cases, results) if c["layout"] == lay]
                crease.append([f"{kind} {lay}", *crease_row(*zip(*sel))])
        elif kind == "join":
            join.append([kind, *join_row(cases, results)])
        else:
            smooth.append([kind, *smooth_row(cases, results)])
    print(f"split {args.split}, {args.per_kind} cases a kind\n")
    if crease:
        head = ["creases", "patches", "plane", "edge named", "kind right", "dihedral cover",
                "RMS dihedral err (deg)", "RMS edge offset (L)", "RMS dir. err (deg)", "dir. cover",
                "median dir. half-angle (deg)"]  # fmt: skip
        print(table(head, crease) + "\n")
    if join:
        print(table(["joins", "patches", "answered", "uncertain", "k1 cover or uncertain"], join))
        print()
    if smooth:
        head = ["smooth", "patches", "answered", "cover S", "cover k1", "cover k2", "wrong labels",
                "tilt named within 1 deg"]  # fmt: skip
        print(table(head, [r + [""] * (len(head) - len(r) - 1) for r in smooth]))


if __name__ == "__main__":
    main()
