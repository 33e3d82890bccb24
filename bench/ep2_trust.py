"""EP2 trust bench: an estimator against the 2-jet with normals, case by case.

Run: OPENBLAS_NUM_THREADS=1 .venv/bin/python bench/ep2_trust.py --split tune [--trials 100]
     [--estimator default|stated|jet|module:function] [--families sphere cylinder] [--match TEXT]
     [--jobs 2] [--json out.json] [--quick] [--batch]

``--batch`` fits each case's trials in one ``analyze_patches`` call (default and stated
only): the same numbers to round-off, several times faster; the us column is then each
patch's share of the call.

Cases come from ``tactile_studies.ep2.cases`` (tune / holdout / holdout2-5 / degenerate;
a holdout split is for final evaluation only).  Per case, on the SAME draws: RMS S error of the
estimator and of the peer ``tactile_studies.ep2.peers.jet(..., with_normals=True)`` (given
the true noise, floored at 1e-6 of the base unit; curvature at the patch centre) and their
paired ratio with a bootstrap 95 % interval (``paired_ratio``); max |S error| on
noise-free cases; coverage of the S, k1, k2 intervals; confidently wrong labels;
null S and refusals with their reasons; us per patch of both.  Truth is the true
surface's curvature at the patch centre (``tactile_studies.ep2.truth``).

An estimator is ``f(points, normals, finger)`` returning a dict with ``S`` (a float even
when not reported), ``S_reported``, ``S_interval``, ``k1``, ``k2``, ``k1_interval``,
``k2_interval`` (None when absent), ``shape``, ``confidence``; ``tactile.errors.DataError``
is a refusal.  A function with a ``noise`` parameter is also given the true
(sigma_pos, sigma_normal): an oracle, for peers only.

A label is confidently wrong when it is not ``uncertain``, its confidence is >= 0.95
and the true S lies outside both the label's band and the reported S interval.  A
``plane`` is wrong when the true k1 or k2 lies outside its reported interval or
max|k| L >= ``PLANE_KL`` (L = the patch's larger side); a curved label on a true plane
when 0 lies outside a reported k interval (or none is reported).  On ``inconsistent``
data (normals contradicting the positions) every confident label counts as wrong.
"""

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import argparse  # noqa: E402
import importlib  # noqa: E402
import inspect  # noqa: E402
import json  # noqa: E402
import math  # noqa: E402
import multiprocessing  # noqa: E402
import random  # noqa: E402
import re  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from collections import Counter  # noqa: E402

import numpy as np  # noqa: E402

from tactile.ep2 import analyze_patch, analyze_patches  # noqa: E402
from tactile.errors import DataError  # noqa: E402
from tactile_studies.ep2 import cases as casegen  # noqa: E402
from tactile_studies.ep2 import peers  # noqa: E402

BANDS = {  # geometry.S_REGIONS: sphere > 0.75 > cylinder > 0.25 > saddle > -0.25 > ...
    "sphere": (0.75, 1.0),
    "cylinder": (0.25, 0.75),
    "saddle": (-0.25, 0.25),
    "concave_cylinder": (-0.75, -0.25),
    "concave_sphere": (-1.0, -0.75),
}
CONFIDENT = 0.95
PLANE_KL = 0.1  # max|k| L at which a 'plane' label is wrong whatever its intervals
NOISE_FLOOR = 1e-6
QUICK_CASES = 24
RESOLVED_NULL = 0.1  # 'S reported' cases: null S in at most this share of the answers
_WARM = set()


def shape_index(k1, k2):
    return float(2.0 / math.pi * math.atan2(k1 + k2, k1 - k2))


def default(points, normals, finger, **kw):
    """``analyze_patch``, summarised by ``summarise``."""
    return summarise(analyze_patch(points, normals, finger=finger, **kw))


def summarise(res):
    """A ``PatchResult`` as the bench scores it: S at the centre (from k1, k2 when S itself
    is null: a plane), whether S was reported, the intervals, the label."""
    k1, k2 = float(res.k1), float(res.k2)
    return {
        "S": shape_index(k1, k2),
        "S_reported": res.S is not None,
        "S_interval": res.S_interval,
        "k1": k1,
        "k2": k2,
        "k1_interval": res.k1_interval,
        "k2_interval": res.k2_interval,
        "shape": res.shape,
        "confidence": res.confidence,
    }


def stated(points, normals, finger, noise):
    """The default told the true noise (``--noise-pos``/``--noise-normal``): the same
    information as the peer, which is always given it."""
    return default(points, normals, finger, noise_pos=noise[0], noise_normal=noise[1])


def jet(points, normals, finger, noise):
    """The peer as an estimator (no label, no intervals): ``--estimator jet`` gives ratio 1."""
    k1, k2 = (float(v[0]) for v in peers.jet(points, normals, *noise, with_normals=True))
    return {
        "S": shape_index(k1, k2),
        "S_reported": True,
        "S_interval": None,
        "k1": k1,
        "k2": k2,
        "k1_interval": None,
        "k2_interval": None,
        "shape": "uncertain",
        "confidence": 0.0,
    }


ESTIMATORS = {"default": default, "stated": stated, "jet": jet}


def resolve(spec):
    """Estimator function from a name in ``ESTIMATORS`` or ``module:function``."""
    if spec in ESTIMATORS:
        return ESTIMATORS[spec]
    module, _, name = spec.partition(":")
    if not name:
        raise SystemExit(f"--estimator {spec!r}: use {', '.join(ESTIMATORS)} or module:function")
    return getattr(importlib.import_module(module), name)


def _inside(iv, v):
    return iv is not None and iv[0] <= v <= iv[1]


def rms(v):
    return float(np.sqrt(np.mean(np.square(v))))


def paired_ratio(a, b, n_boot=400):
    """RMS(a) / RMS(b) over paired trials, with a bootstrap 95 % interval."""
    rng = np.random.default_rng(0)
    idx = rng.integers(0, a.size, (n_boot, a.size))
    boot = np.sqrt(np.mean(a[idx] ** 2, axis=1) / np.mean(b[idx] ** 2, axis=1))
    return rms(a) / rms(b), np.percentile(boot, [2.5, 97.5])


def wrong_label(out, tr, inconsistent=False):
    """Confidently wrong (module docstring)."""
    shape = out["shape"]
    if shape == "uncertain" or not out["confidence"] >= CONFIDENT:
        return False
    if inconsistent:
        return True
    k_ivs = ((out["k1_interval"], tr["k1"]), (out["k2_interval"], tr["k2"]))
    if shape == "plane":
        if max(abs(tr["k1"]), abs(tr["k2"])) * tr["size"] >= PLANE_KL:
            return True
        return any(iv is not None and not _inside(iv, v) for iv, v in k_ivs)
    if tr["S"] is None:
        return not all(_inside(iv, 0.0) for iv, _ in k_ivs)
    lo, hi = BANDS[shape]
    return not lo <= tr["S"] <= hi and not _inside(out["S_interval"], tr["S"])


def reason(err):
    """Short form of a refusal message: text before the first ':', numbers as '#'."""
    text = str(err).split(":")[0]
    return re.sub(r"\d+(\.\d+)?", "#", text)[:60]


def _call(fn, d, noise, takes_noise):
    """(output or None, refusal reason or None, crash or None, seconds)."""
    kw = {"noise": noise} if takes_noise else {}
    t0 = time.perf_counter()
    try:
        out = fn(d["points"], d["normals"], d["finger"], **kw)
    except DataError as err:
        return None, reason(err), None, getattr(fn, "share", time.perf_counter() - t0)
    except Exception as err:  # a crash is a finding, not a reason to stop the bench
        crash = f"{type(err).__name__}: {reason(err)}"
        return None, None, crash, getattr(fn, "share", time.perf_counter() - t0)
    dt = getattr(fn, "share", time.perf_counter() - t0)
    if not math.isfinite(out["S"]):
        return None, None, "non-finite S", dt
    return out, None, None, dt


def run_case(task):
    """Metrics of one case (dict of plain numbers, lists and None; no NaN)."""
    case, trials, spec, batch = task
    fn = resolve(spec)
    takes_noise = "noise" in inspect.signature(fn).parameters
    _warm_up(spec, fn, takes_noise)
    floor = max(case.noise, NOISE_FLOOR)
    noise = (floor * case.unit, max(case.noise * case.normal_ratio, NOISE_FLOOR))
    n = 1 if case.noise == 0 and not case.random_layout else trials
    rec = {"err": [], "jet_err": [], "cover": {"S": [], "k1": [], "k2": []}, "wrong": 0}
    rec.update(kerr=[], kerr_jet=[])
    rec.update(null=0, refusals=Counter(), crashes=Counter(), jet_failed=0, truth_failed=0)
    rec.update(t_ours=0.0, t_jet=0.0, answered=0)
    draws = []
    for t in range(n):
        try:
            draws.append(casegen.draw(case, t))
        except (ValueError, DataError):  # no truth at the patch centre for this draw
            rec["truth_failed"] += 1
    if batch and spec in BATCHED:
        fn = _batched(draws, BATCHED[spec], noise)
    for d in draws:
        _trial(rec, case, d, fn, noise, takes_noise)
    return _case_summary(case, n, rec)


BATCHED = {"default": {}, "stated": None}  # None: the true noise, stated


def _batched(draws, kw, noise):
    """``--batch``: every draw of a case through one ``analyze_patches`` call (results equal
    ``analyze_patch``'s to round-off), given back one at a time as the estimator, each
    charged an equal share of the call's time."""
    if kw is None:
        kw = {"noise_pos": noise[0], "noise_normal": noise[1]}
    patches = [
        {"points": d["points"], "normals": d["normals"], "finger": d["finger"]} for d in draws
    ]
    t0 = time.perf_counter()
    results = analyze_patches(patches, **kw)
    share = (time.perf_counter() - t0) / max(len(draws), 1)
    done = {id(d["points"]): r for d, r in zip(draws, results, strict=True)}

    def estimator(points, normals, finger, noise=None):
        res = done[id(points)]
        if isinstance(res, Exception):
            raise res
        return summarise(res)

    estimator.share = share  # ``_call`` charges this, not the look-up
    return estimator


def _warm_up(spec, fn, takes_noise):
    """One untimed call per estimator and process (first calls fill caches)."""
    if spec not in _WARM:
        d = casegen.draw(casegen.new("sphere", radius=10.0, noise=0.01))
        _call(fn, d, (0.01, 0.01), takes_noise)
        _call(jet, d, (0.01, 0.01), True)
        _WARM.add(spec)


def _trial(rec, case, d, fn, noise, takes_noise):
    tr = d["truth"]
    out, why, crash, dt = _call(fn, d, noise, takes_noise)
    rec["t_ours"] += dt
    ref, _, _, dt = _call(jet, d, noise, True)
    rec["t_jet"] += dt
    rec["jet_failed"] += ref is None
    if why or crash:
        (rec["refusals"] if why else rec["crashes"])[why or crash] += 1
        return
    rec["answered"] += 1
    rec["null"] += not out["S_reported"]
    rec["wrong"] += wrong_label(out, tr, case.inconsistent)
    if tr["S"] is not None and ref is not None:
        rec["err"].append(out["S"] - tr["S"])
        rec["jet_err"].append(ref["S"] - tr["S"])
        kt = max(abs(tr["k1"]), abs(tr["k2"]))
        for key, est in (("kerr", out), ("kerr_jet", ref)):
            rec[key].append(max(abs(est["k1"]), abs(est["k2"])) / kt - 1.0)
    if tr["S"] is not None and out["S_reported"] and out["S_interval"] is not None:
        rec["cover"]["S"].append(_inside(out["S_interval"], tr["S"]))
    for key in ("k1", "k2"):
        if out[f"{key}_interval"] is not None:
            rec["cover"][key].append(_inside(out[f"{key}_interval"], tr[key]))


def _case_summary(case, n, rec):
    err, jerr = np.array(rec["err"]), np.array(rec["jet_err"])
    out = {
        "id": case.id,
        "group": case.group,
        "noise": case.noise,
        "trials": n,
        "answered": rec["answered"],
        "rms": rms(err) if err.size else None,
        "rms_jet": rms(jerr) if jerr.size else None,
        "ratio": None,
        "ci": None,
        "max_err": None,
        "max_err_jet": None,
    }
    if case.noise > 0 and err.size > 1 and rms(jerr) > 0:
        with np.errstate(divide="ignore", invalid="ignore"):
            r, (lo, hi) = paired_ratio(err, jerr)
        finite = math.isfinite(lo) and math.isfinite(hi)
        out.update(ratio=r, ci=(float(lo), float(hi)) if finite else None)
    if case.noise == 0 and err.size:
        out.update(max_err=float(np.abs(err).max()), max_err_jet=float(np.abs(jerr).max()))
    for key, hits in rec["cover"].items():
        out[f"cover_{key}"] = float(np.mean(hits)) if hits else None
        out[f"n_cover_{key}"] = len(hits)
    tried = max(n - rec["truth_failed"], 1)
    out.update(
        wrong=rec["wrong"],
        null=rec["null"],
        refused=sum(rec["refusals"].values()),
        reasons=dict(rec["refusals"] + rec["crashes"]),
        crashed=sum(rec["crashes"].values()),
        jet_failed=rec["jet_failed"],
        truth_failed=rec["truth_failed"],
        us=1e6 * rec["t_ours"] / tried,
        us_jet=1e6 * rec["t_jet"] / tried,
        s_err=[float(v) for v in err],
        s_err_jet=[float(v) for v in jerr],
        rms_k=rms(np.array(rec["kerr"])) if rec["kerr"] else None,
        rms_k_jet=rms(np.array(rec["kerr_jet"])) if rec["kerr_jet"] else None,
    )
    return out


def select(args):
    """The cases of ``--split``, filtered by ``--families``/``--match``, thinned by ``--quick``."""
    chosen = casegen.split(args.split)
    if args.families:
        chosen = [c for c in chosen if c.family in args.families]
    if args.match:
        chosen = [c for c in chosen if args.match in c.id]
    if args.quick and len(chosen) > QUICK_CASES:
        keep = sorted(random.Random(0).sample(range(len(chosen)), QUICK_CASES))
        chosen = [chosen[i] for i in keep]
    return chosen


def run(chosen, trials, spec, jobs, batch=False):
    """Per-case results in input order (``jobs`` > 1: a process pool)."""
    tasks = [(c, trials, spec, batch) for c in chosen]
    if jobs <= 1:
        return [run_case(t) for t in tasks]
    with multiprocessing.get_context("fork").Pool(jobs) as pool:
        return pool.map(run_case, tasks, chunksize=max(1, min(8, len(tasks) // (4 * jobs))))


def _fmt(v, spec=".4f"):
    return "-" if v is None else format(v, spec)


def _pooled(results, key):
    """(hits / trials over the cases, worst case with >= 10 trials) of a coverage."""
    n = sum(r[f"n_cover_{key}"] for r in results)
    hits = sum(r[f"cover_{key}"] * r[f"n_cover_{key}"] for r in results if r[f"n_cover_{key}"])
    worst = [r[f"cover_{key}"] for r in results if r[f"n_cover_{key}"] >= 10]
    return (hits / n if n else None), (min(worst) if worst else None)


def _pooled_ratio(results):
    """sqrt(sum of ours' squared S errors / the jet's) over the cases' paired trials."""
    num = sum(r["rms"] ** 2 * len(r["s_err"]) for r in results)
    den = sum(r["rms_jet"] ** 2 * len(r["s_err"]) for r in results)
    return math.sqrt(num / den) if den > 0 else None


def _short(case_id):
    return re.sub(r"\(.*?\)", "", case_id.split(" ", 1)[-1])


def group_row(name, results):
    """One markdown line of the family summary."""
    answered = sum(r["answered"] for r in results)
    trials = sum(r["trials"] - r["truth_failed"] for r in results)
    rated = [r for r in results if r["ratio"] is not None]
    resolved = [r for r in rated if r["null"] <= RESOLVED_NULL * r["answered"]]
    worst = max(rated, key=lambda r: r["ratio"]) if rated else None
    ci = "-" if worst is None else f"{worst['ci'][0]:.3f}-{worst['ci'][1]:.3f}"
    covers = []
    for key in ("S", "k1", "k2"):
        pooled, low = _pooled(results, key)
        covers.append(f"{_fmt(pooled, '.3f')} ({_fmt(low, '.2f')})")
    free = [r for r in results if r["max_err"] is not None]
    nf = "-"
    if free:
        nf = f"{max(r['max_err'] for r in free):.2g} / {max(r['max_err_jet'] for r in free):.2g}"
    reasons = Counter()
    for r in results:
        reasons.update(r["reasons"])
    krel = "-"
    kr = [r for r in rated if r["rms_k"] is not None]
    if kr:
        num = math.sqrt(sum(r["rms_k"] ** 2 for r in kr) / len(kr))
        den = math.sqrt(sum(r["rms_k_jet"] ** 2 for r in kr) / len(kr))
        krel = f"{num:.3f} / {den:.3f}"
    top = "; ".join(f"{k} x{v}" for k, v in reasons.most_common(2)) or "-"
    cells = [
        name,
        str(len(results)),
        str(trials),
        _fmt(_pooled_ratio(rated), ".3f"),
        _fmt(_pooled_ratio(resolved), ".3f"),
        _fmt(worst and worst["ratio"], ".3f"),
        ci,
        "-" if worst is None else _short(worst["id"]),
        *covers,
        f"{sum(r['wrong'] for r in results)} / {answered}",
        nf,
        krel,
        _fmt(sum(r["null"] for r in results) / answered if answered else None, ".3f"),
        _fmt(sum(r["refused"] + r["crashed"] for r in results) / max(trials, 1), ".3f"),
        top,
    ]
    return "| " + " | ".join(cells) + " |"


SUMMARY_HEAD = (
    "| family | cases | trials | pooled ratio | pooled, S reported | worst ratio | its 95 % CI"
    " | worst case | S cover (worst) | k1 cover (worst) | k2 cover (worst) | wrong labels"
    " | max noise-free S err ours / jet | RMS kmax rel. err ours / jet | null S | refused"
    " | reasons |"
)
CASE_HEAD = (
    "| case | trials | RMS S | RMS S jet | ratio | 95 % CI | max nf err / jet | cover S | k1 | k2"
    " | wrong | null | refused | reasons | us | us jet |"
)


def case_row(r):
    ci = "-" if r["ci"] is None else f"{r['ci'][0]:.3f}-{r['ci'][1]:.3f}"
    nf = "-" if r["max_err"] is None else f"{r['max_err']:.2g} / {r['max_err_jet']:.2g}"
    why = "; ".join(f"{k} x{v}" for k, v in r["reasons"].items()) or "-"
    cells = [
        r["id"],
        str(r["trials"]),
        _fmt(r["rms"], ".5f"),
        _fmt(r["rms_jet"], ".5f"),
        _fmt(r["ratio"], ".3f"),
        ci,
        nf,
        *(_fmt(r[f"cover_{k}"], ".2f") for k in ("S", "k1", "k2")),
        str(r["wrong"]),
        str(r["null"]),
        str(r["refused"] + r["crashed"]),
        why,
        f"{r['us']:.0f}",
        f"{r['us_jet']:.0f}",
    ]
    return "| " + " | ".join(cells) + " |"


def report(results, head):
    """The markdown: a header line, the family summary, then every case."""
    groups = {}
    for r in results:
        groups.setdefault(r["group"], []).append(r)
    lines = [head, "", SUMMARY_HEAD, "|" + "---|" * SUMMARY_HEAD.count(" | ") + "---|"]
    lines += [group_row(g, rs) for g, rs in groups.items()]
    lines.append(group_row("all", results))
    lines += ["", CASE_HEAD, "|" + "---|" * (CASE_HEAD.count(" | ") + 1)]
    lines += [case_row(r) for r in results]
    return "\n".join(lines)


def _parser():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument(
        "--split",
        default="tune",
        choices=("tune", "holdout", *(f"holdout{i}" for i in range(2, 6)), "degenerate", "all"),
    )
    ap.add_argument(
        "--estimator", default="default", help="default, stated, jet or module:function"
    )
    ap.add_argument("--trials", type=int, default=100, help="per case (1 when noise-free)")
    ap.add_argument("--families", nargs="*", help="only these families (cases.FAMILIES)")
    ap.add_argument("--match", help="only cases whose id contains this text")
    ap.add_argument("--jobs", type=int, default=2, help="worker processes (results in order)")
    ap.add_argument("--json", help="write the raw per-case numbers here")
    ap.add_argument("--quick", action="store_true", help="smoke run: 24 cases, <= 5 trials")
    ap.add_argument(
        "--batch",
        action="store_true",
        help="default/stated: each case's trials in one analyze_patches call (us: its share)",
    )
    return ap


def main(argv=None):
    args = _parser().parse_args(argv)
    resolve(args.estimator)  # fail before the pool starts
    trials = min(args.trials, 5) if args.quick else args.trials
    chosen = select(args)
    t0 = time.perf_counter()
    results = run(chosen, trials, args.estimator, args.jobs, args.batch)
    wall = time.perf_counter() - t0
    head = (
        f"split {args.split}, estimator {args.estimator}, {len(chosen)} cases,"
        f" {trials} trials per case (1 when noise-free), {wall:.1f} s wall, {args.jobs} jobs"
        + (", batched per case" if args.batch else "")
    )
    print(report(results, head))
    if args.json:
        with open(args.json, "w", encoding="utf-8") as fh:
            json.dump({"head": head, "cases": results}, fh, allow_nan=False)
    return 0


if __name__ == "__main__":
    sys.exit(main())
