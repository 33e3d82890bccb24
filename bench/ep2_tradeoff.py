"""EP2 error against run time: the default jet, its parts, and the thesis's spline variants.

Run: .venv/bin/python bench/ep2_tradeoff.py [--trials 60] [--noise 0.01] [--png FILE]
Data: tune-split cases of bench/ep2_trust.py (``tactile_studies.ep2.cases``): spheres r 4 and
10, cylinders r 3 and 10 (rotations 0-90 deg), saddles and quadrics r 10, 27 and 36
contacts, one noise level.  Error = RMS of S at the patch centre minus the truth there
(S from k1, k2 when a plane label leaves S null).  The defaults (``centre_jet``) are the
first row; every other row changes one thing.  Each jet variant is timed twice on the
same data, one patch at a time and batched (``analyze_patches``, results equal); then the
default at several chunk sizes, which is where ``batch.CHUNK`` comes from.
"""

import argparse
import time

import numpy as np

from tactile.ep2 import analyze_patch, analyze_patches, centre_jet
from tactile.ep2.batch import CHUNK
from tactile.errors import DataError
from tactile.plots import log_ticks
from tactile_studies.ep2 import cases

FAMILIES = ("sphere r=4 ", "sphere r=10 ", "cylinder r=3 ", "cylinder r=10 ", "saddle r=10 ")
VARIANTS = (
    ("jet (default): round or quadric, chosen", {}, {}),
    ("jet, quadric only (no round model)", {}, {"ROUND_MARGIN": np.inf}),
    ("jet, round whenever it fits better", {}, {"ROUND_MARGIN": 0.0}),
    ("jet, no intervals", {"intervals": False}, {}),
    ("spline deg 2, auto (previous default)", {"method": "spline"}, {}),
    ("spline deg 3, auto", {"method": "spline", "order": 3}, {}),
    (
        "spline deg 3, tangent (thesis §4.9)",
        {"method": "spline", "order": 3, "weighting": "tangent"},
        {},
    ),
    ("spline deg 2, position", {"method": "spline", "weighting": "position"}, {}),
)


def _cases(noise):
    picked = [
        c
        for c in cases.tune_cases()
        if c.noise == noise and any(c.id.startswith(f) for f in FAMILIES)
    ]
    return picked


def _s(res):
    k1, k2 = res.k1, res.k2
    return float(2 / np.pi * np.arctan2(k1 + k2, k1 - k2))


def batched_ms(data, kw, chunk):
    """ms per patch of ``analyze_patches`` on the same data (results equal the loop's)."""
    pairs = [(d["points"], d["normals"]) for d in data]
    t0 = time.perf_counter()
    analyze_patches(pairs, chunk=chunk, **kw)
    return 1e3 * (time.perf_counter() - t0) / len(data)


def run(trials, noise):
    data = [cases.draw(c, t) for c in _cases(noise) for t in range(trials)]
    rows = []
    for name, kw, consts in VARIANTS:
        saved = {k: getattr(centre_jet, k) for k in consts}
        for k, v in consts.items():
            setattr(centre_jet, k, v)
        err, t_used, refused = [], 0.0, 0
        for d in data:
            t0 = time.perf_counter()
            try:
                res = analyze_patch(d["points"], d["normals"], **kw)
            except DataError:  # a refusal is an answer too: counted, not scored
                refused += 1
                continue
            finally:
                t_used += time.perf_counter() - t0
            err.append(_s(res) - d["truth"]["S"])
        batch = batched_ms(data, kw, CHUNK) if kw.get("method") != "spline" else None
        for k, v in saved.items():
            setattr(centre_jet, k, v)
        rms = float(np.sqrt(np.mean(np.square(err))))
        rows.append((name, rms, 1e3 * t_used / len(data), batch, refused))
    chunks = [(c, batched_ms(data, {}, c)) for c in (1, 16, 64, 256, 1024)]
    return rows, len(data), chunks


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--trials", type=int, default=20, help="per case")
    ap.add_argument("--noise", type=float, default=0.01)
    ap.add_argument("--png")
    args = ap.parse_args()
    rows, n, chunks = run(args.trials, args.noise)
    print(f"{n} patches, noise {args.noise:g}\n")
    print(f"| variant | RMS S error (answered) | refused | ms / patch, loop | batched ({CHUNK}) |")
    print("|---|---|---|---|---|")
    for name, e, ms, batch, refused in rows:
        b = "per patch" if batch is None else f"{batch:.2f}"
        print(f"| {name} | {e:.5f} | {refused} | {ms:.2f} | {b} |")
    print("\n| chunk (patches per fit) | ms / patch, default |\n|---|---|")
    for c, ms in chunks:
        print(f"| {c} | {ms:.2f} |")
    if args.png:
        plot(rows, args.noise, args.png)


def plot(rows, noise, path):
    """RMS S error against ms per patch: filled one patch at a time, hollow batched."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7.6, 4.2), layout="constrained")
    for i, (name, e, ms, batch, _) in enumerate(rows):
        marker, colour = "os^v<>Dp"[i % 8], f"C{i % 10}"
        ax.scatter(ms, e, marker=marker, s=36, color=colour, label=name)
        if batch is not None:
            ax.plot([ms, batch], [e, e], color=colour, lw=0.7, alpha=0.6)
            ax.scatter(batch, e, marker=marker, s=36, facecolors="none", edgecolors=colour)
    ax.scatter([], [], marker="o", facecolors="none", edgecolors="k", label="(hollow: batched)")
    ax.set(xlabel="run time per patch (ms)", ylabel="RMS S error (dimensionless)")
    ax.set(xscale="log", yscale="log")
    log_ticks(ax.xaxis)
    log_ticks(ax.yaxis)
    ax.grid(True, which="major", alpha=0.3)
    ax.set_title(
        f"EP2 error against run time, noise {noise:g}\n(positions: base length unit; normals: rad)",
        fontsize=10,
    )
    ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.02, 1.0), borderaxespad=0.0)
    fig.savefig(path, dpi=100)


if __name__ == "__main__":
    main()
