"""``tactile explore``'s planner against the thesis's fixed 3 x 6 plan, in process.

Run: OPENBLAS_NUM_THREADS=1 .venv/bin/python bench/explore.py [--split tune|holdout]
     [--seeds 20] [--plots DIR (out/explore)] [--ep1] [--flat 0.03] [--s-width W] [--lattice]

``--flat`` (1/cm) is the plane's flatness (``Explorer.flat``), ``--s-width`` the second
operating point's stop (``Explorer.s_width``: fewer touches against a lower RMS S),
``--lattice`` the third's first 9 touches (``Explorer.lattice``: the square's 3 x 3 lattice).

Objects: the EP2 families (``tactile_sim.ep2.objects``: sphere, cylinder, concave cylinder,
pit, saddle, plane) in the tables 5-7 setup of docs/ep2_thesis.md (lengths in cm: a 5 x 6 cm patch,
noise 0.05 cm on positions and 0.03 rad on normals, stated to the fit).  ``tune`` holds
the objects the planner was tuned on (seeds 0..); ``holdout`` other radii, rotations and
noise (seeds 1000..), for the final table only.

- **fixed**: the thesis's plan, 3 passes 2.5 cm apart x 6 points over 6 cm (18 touches,
  ``tactile_sim.ep2.sweep``), analysed once.
- **explore**: ``tactile.explore.Explorer`` over the same square (half-size 3 cm), budget 18;
  each touch comes along the planned direction until the fingertip's contact point meets the
  surface (the geometry of the emulated arm), then the contact is noised as the sweep's.

Per object: touches to a confident correct label (median, max; "-" never), the share within 9,
confident wrong labels, and RMS S error at the end against the truth at each one's patch
centre.  ``--plots DIR`` (out/explore): per object, S with its interval against touches (the
first seed), ``explore_SPLIT_OBJECT.png``.
``--ep1``: EP1's next roll (``tactile.explore.next_roll``) against the fixed "+" pattern on
the rolling model (``tactile_sim.ep1``).
"""

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import argparse  # noqa: E402
import math  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
from bench_args import add_split, check_split  # noqa: E402

from tactile.ep1.estimator import next_roll  # noqa: E402
from tactile.ep2.geometry import S_NAMES, s_class  # noqa: E402
from tactile.explore import Explorer, Region, fit_of  # noqa: E402
from tactile_sim.ep2.objects import make  # noqa: E402
from tactile_sim.ep2.sweep import _tilt_normals, sweep  # noqa: E402

HALF, STANDOFF, BUDGET = 3.0, 1.5, 18
FLAT = 0.03  # 1/cm: a plane, curvatures within +-1/33 cm (under half the R 15 pit's 1/15 cm)
# name: (kind, radius cm, rotation deg, k for quadrics, noise_pos cm, noise_normal rad[, slope])
SPLITS = {
    "tune": {
        "sphere": ("sphere", 10.0, 0.0, None, 0.05, 0.03),
        "cylinder": ("cylinder", 6.6, 30.0, None, 0.05, 0.03),
        "concave_cylinder": ("concave_cylinder", 11.25, 30.0, None, 0.05, 0.03),
        "pit": ("pit", 15.0, 0.0, None, 0.05, 0.03),
        "saddle": ("quadric", 10.0, 20.0, (0.1, -0.1), 0.05, 0.03),
        "plane": ("plane", 10.0, 0.0, None, 0.05, 0.03),
        "band_edge": ("quadric", 10.0, 40.0, (0.1, 0.0414), 0.05, 0.03),  # S 0.75 at the centre
    },
    "holdout": {
        "sphere_r8": ("sphere", 8.0, 0.0, None, 0.03, 0.02),
        "cylinder_r9_rot70": ("cylinder", 9.0, 70.0, None, 0.05, 0.03),
        "concave_r8_rot-40": ("concave_cylinder", 8.0, -40.0, None, 0.04, 0.03),
        "pit_r12": ("pit", 12.0, 0.0, None, 0.05, 0.03),
        "saddle_0.07_-0.12": ("quadric", 10.0, 55.0, (0.07, -0.12), 0.05, 0.03),
        "ellipsoid_0.12_0.05": ("quadric", 10.0, 15.0, (0.12, 0.05), 0.05, 0.03),
        "plane_slope": ("plane", 10.0, 0.0, None, 0.05, 0.03, (0.3, 0.1)),
    },
}
SEED0 = {"tune": 0, "holdout": 1000}


def build(spec):
    kind, radius, rot, k = spec[:4]
    slope = spec[6] if len(spec) > 6 else (0.0, 0.0)
    return make(kind, radius=radius, rotation_deg=rot, centre=(0.0, 0.0), k=k, slope=slope)


def true_s(obj, x, y, h=1e-4):
    """The object's shape index at (x, y) (height-field curvature, convex toward +z > 0)."""

    def grad(a, b):
        _, gx, gy = obj.eval(np.array([a]), np.array([b]))
        return np.array([gx[0], gy[0]])

    g = grad(x, y)
    H = np.column_stack([(grad(x + h, y) - grad(x - h, y)) / (2 * h),
                         (grad(x, y + h) - grad(x, y - h)) / (2 * h)])  # fmt: skip
    first = np.eye(2) + np.outer(g, g)
    k = np.linalg.eigvals(-np.linalg.solve(first, H) / math.sqrt(1 + g @ g)).real
    k1, k2 = max(k), min(k)
    if abs(k1) < 1e-12 and abs(k2) < 1e-12:
        return None
    return 2 / math.pi * math.atan2(k1 + k2, k1 - k2)


def touch(obj, plan, rng, noise_pos, noise_normal):
    """The contact a touch along ``plan`` finds (bisection on the height), noised; None: miss."""
    s, d = np.array(plan.start), np.array(plan.direction)

    def above(t):
        p = s + t * d
        return p[2] - obj.height(np.array([p[0]]), np.array([p[1]]))[0]

    lo, hi = 0.0, plan.max_travel
    if above(hi) > 0:
        return None, None
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if above(mid) > 0 else (lo, mid)
    p = s + hi * d
    n = obj.normals(np.array([p[0]]), np.array([p[1]]))
    return p + noise_pos * rng.standard_normal(3), _tilt_normals(n, noise_normal, rng)[0]


def truth_label(obj, r):
    """The band of the true S at the fit's patch centre (the label's point)."""
    s = centre_s(obj, r)
    return "plane" if s is None else S_NAMES[int(s_class(s))]


def centre_s(obj, res):
    """The truth at the fit's patch centre."""
    x0, x1, y0, y1 = res.domain_box()
    c = res.surface_world(np.array([[0.5 * (x0 + x1), 0.5 * (y0 + y1)]]))[0]
    return true_s(obj, c[0], c[1])


def run_explore(obj, spec, seed, flat=None, s_width=None, lattice=False):
    """(touches to a confident correct label or None, a confident wrong label, S error at
    the stop, S error after the whole budget, the trace)."""
    rng = np.random.default_rng(seed)
    opts = {"noise_pos": spec[4], "noise_normal": spec[5]}
    ex = Explorer(Region((0.0, 0.0, 0.0), (0.0, 0.0, 1.0), HALF, STANDOFF), max_touches=BUDGET,
                  flat=flat, s_width=s_width, lattice=lattice, options=opts)  # fmt: skip
    first, wrong, at_stop, trace = None, False, None, []
    while ex.touches < BUDGET:  # on past the stop: the error after the same budget as fixed
        plan = ex.plan()
        p, n = touch(obj, plan, rng, spec[4], spec[5])
        fit = ex.add(p, n, plan)
        r = fit.result
        trace.append((ex.touches, r.S if r else None, r.S_interval if r else None, fit.label))
        if ex.done() == "label" and first is None and not wrong:
            good = fit.label == truth_label(obj, r)
            first, wrong = (ex.touches, False) if good else (None, True)
            at_stop = s_error(obj, r)
    return first, wrong, at_stop, s_error(obj, ex.fit.result), trace


def s_error(obj, r):
    if r is None or r.S is None or (t := centre_s(obj, r)) is None:
        return None
    return r.S - t


def run_fixed(obj, spec, seed, flat=None):
    d = sweep(obj, fingers=3, spacing=2.5, length=6.0, samples=6, repeats=1,
              origin=(-2.5, -3.0), noise_pos=spec[4], noise_normal=spec[5], seed=seed)  # fmt: skip
    fit = fit_of(d["points"], d["normals"], flat=flat, noise_pos=spec[4], noise_normal=spec[5])
    ok = fit.result is not None and fit.label not in ("uncertain",) and fit.confidence >= 0.95
    want = truth_label(obj, fit.result) if fit.result is not None else None
    return (18 if ok and fit.label == want else None), ok and fit.label != want, s_error(obj,
            fit.result)  # fmt: skip


def rms(v):
    v = [x for x in v if x is not None]
    return math.sqrt(sum(x * x for x in v) / len(v)) if v else None


def table(split, seeds, plots, flat=None, s_width=None, only=None, lattice=False):
    rows = []
    print("| object | explore: touches to a confident correct label, median / max (runs) |"
          " within 9 | confident wrong | RMS S at the stop | RMS S after 18 |"
          " fixed 3x6: confident correct | confident wrong | RMS S |")  # fmt: skip
    print("|---|---|---|---|---|---|---|---|---|")
    for name, spec in SPLITS[split].items():
        if only and name not in only:
            continue
        obj = build(spec)
        ex = [run_explore(obj, spec, SEED0[split] + i, flat, s_width, lattice)
              for i in range(seeds)]  # fmt: skip
        fx = [run_fixed(obj, spec, SEED0[split] + i, flat) for i in range(seeds)]
        got = [e[0] for e in ex if e[0] is not None]
        med = f"{int(np.median(got))} / {max(got)}" if got else "-"
        within = sum(1 for g in got if g <= 9) / seeds
        fr = sum(1 for f in fx if f[0] is not None) / seeds
        cells = [f"{med} ({len(got)}/{seeds})", f"{within:.2f}", sum(e[1] for e in ex),
                 _num(rms([e[2] for e in ex])), _num(rms([e[3] for e in ex])), f"{fr:.2f}",
                 sum(f[1] for f in fx), _num(rms([f[2] for f in fx]))]  # fmt: skip
        line = f"| {name} | " + " | ".join(str(c) for c in cells) + " |"
        print(line, flush=True)
        rows.append(line)
        if plots:
            plot(Path(plots) / f"explore_{split}_{name}.png", name, ex[0][4], obj)
    return rows


def _num(x):
    return "-" if x is None else f"{x:.4f}"


def plot(path, name, trace, obj):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    path.parent.mkdir(parents=True, exist_ok=True)
    fig, ax = plt.subplots(figsize=(6, 3.5))
    pts = [(t, s, iv) for t, s, iv, _ in trace if s is not None]
    if pts:
        t, s, iv = zip(*pts, strict=True)
        lo = [v[0] if v else x for v, x in zip(iv, s, strict=True)]
        hi = [v[1] if v else x for v, x in zip(iv, s, strict=True)]
        ax.fill_between(t, lo, hi, alpha=0.3, label="95 % interval", step=None)
        ax.plot(t, s, "o-", label="S at the patch centre")
    truth = true_s(obj, 0.0, 0.0)
    if truth is not None:
        ax.axhline(truth, color="k", lw=0.8, ls="--", label="true S at the region's centre")
    ax.axvline(9, color="r", lw=0.8, ls=":", label="9 touches (half of 3 x 6)")
    ax.set(xlabel="touches (count)", ylabel="shape index S (1)", ylim=(-1.05, 1.05),
           xlim=(0, BUDGET + 0.5), title=f"explore: {name}")  # fmt: skip
    ax.legend(fontsize=7, loc="lower right")
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def ep1_bench(trials):
    """Adaptive third roll vs a fixed third roll at 45 deg: error of k1, k2 (6 probes each),
    and the fixed '+' (8 probes), on rotated ellipsoids, noise 0.001 rad."""
    from tactile.ep1.estimator import estimate
    from tactile_sim.ep1.probes import measure, simulate_probes
    from tactile_sim.ep1.rolling import true_curvature
    from tactile_sim.ep1.surfaces import fingertip
    from tactile_sim.ep1.surfaces import make as surface

    finger = fingertip(1.0)
    errs = {"adaptive (6 probes)": [], "fixed 0/90/45 deg (6 probes)": [], "fixed + (8)": []}
    rng = np.random.default_rng(7)
    for i in range(trials):
        obj = surface("ellipsoid", a=1.6, b=0.9, c=1.2)
        at = (0.1 + 0.1 * (i % 3), 0.2)
        t = true_curvature(obj, at, psi=0.0)
        truth = (t["k2"], t["k1"])
        for name, phis in (("fixed + (8)", [0.0, np.pi, 0.5 * np.pi, 1.5 * np.pi]),):
            rows = measure(simulate_probes(finger, obj, (0, 0), at, 0.05, phis), 1.0, 1e-3,
                           rng=rng)  # fmt: skip
            errs[name].append(_k_err(estimate(rows[:, :2], rows[:, 2:], 1.0), truth))
        for name in ("adaptive (6 probes)", "fixed 0/90/45 deg (6 probes)"):
            rows = np.zeros((0, 4))
            for step in range(3):
                if name.startswith("adaptive") or step < 2:
                    phi = next_roll(rows[:, :2], rows[:, 2:], 1.0)[0]
                else:
                    phi = 0.25 * np.pi
                new = measure(simulate_probes(finger, obj, (0, 0), at, 0.05, [phi]), 1.0, 1e-3,
                              rng=rng)  # fmt: skip
                rows = np.vstack([rows, new])
            errs[name].append(_k_err(estimate(rows[:, :2], rows[:, 2:], 1.0), truth))
    print("| EP1 design | RMS error of k1, k2 (1/R1) |")
    print("|---|---|")
    for name, v in errs.items():
        print(f"| {name} | {rms([x for x in v if x is not None]):.4f} |")


SCENES = ("explore_sphere", "explore_cylinder", "explore_saddle", "explore_pit")
SCENE_LABELS = {"explore_sphere": "sphere", "explore_cylinder": "cylinder",
                "explore_saddle": "saddle", "explore_pit": "concave_sphere"}  # fmt: skip


def emulated_bench(runs):
    """``tactile explore`` itself on the shipped commanded scenes: the emulated board (the
    firmware, the F/T sensor's noise, the tool's weight) and the emulated arm, in process."""
    import contextlib
    import io
    import json
    import tempfile

    from tactile.cli.main import main as tactile
    from tactile_sim.emulator.device import EmulatedBoard
    from tactile_sim.emulator.robot_server import EmulatedArm, RobotServer, board_waiter
    from tactile_sim.emulator.scene import load_scene
    from tactile_sim.emulator.servers import server_for

    print("| scene (emulated board and arm) | label: right / runs | touches median / max |"
          " S (mean) | wall s / run |")  # fmt: skip
    print("|---|---|---|---|---|")
    for name in SCENES:
        got, touches, s_values, wall = 0, [], [], time.perf_counter()
        for _ in range(runs):
            board = EmulatedBoard(load_scene(name))
            arm = EmulatedArm(board.motion, lambda b=board: b.t_us,
                              board_waiter(lambda b=board: b.t_us))  # fmt: skip
            server = server_for(board, realtime=False, when_opened=False, replay=False)
            server.prepare()
            out, err = io.StringIO(), io.StringIO()
            with RobotServer(arm, "127.0.0.1", 0) as robot, server, tempfile.TemporaryDirectory(
            ) as tmp, contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):  # fmt: skip
                tactile(["explore", "--port", server.path, "--robot", robot.address, "-o",
                         f"{tmp}/run", "--json", "-q"])  # fmt: skip
            r = json.loads(out.getvalue() or "{}")
            got += r.get("label") == SCENE_LABELS[name] and r.get("ended") == "label"
            touches.append(r.get("touches", 0))
            s_values += [r["S"]] if r.get("S") is not None else []
        s_mean = f"{np.mean(s_values):.3f}" if s_values else "-"
        print(
            f"| {name} | {got} / {runs} | {int(np.median(touches))} / {max(touches)} |"
            f" {s_mean} | {(time.perf_counter() - wall) / runs:.1f} |",
            flush=True,
        )


def _k_err(est, truth):
    if est.k1 is None or est.k2 is None:
        return None
    return math.hypot(est.k1 - truth[1], est.k2 - truth[0]) / math.sqrt(2)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    add_split(ap, SPLITS)
    ap.add_argument("--seeds", type=int, default=20)
    ap.add_argument(
        "--plots",
        default="out/explore",
        help="folder for the per-object plots (PNG; out/explore); '' for none",
    )
    ap.add_argument("--ep1", action="store_true", help="also the EP1 roll-direction table")
    ap.add_argument(
        "--emulated",
        type=int,
        default=0,
        metavar="RUNS",
        help="also tactile explore on the emulated board and arm, RUNS per scene",
    )
    ap.add_argument("--flat", type=float, default=FLAT,
                    help=f"a plane's flatness (1/cm; {FLAT})")  # fmt: skip
    ap.add_argument("--s-width", type=float, default=None,
                    help="also stop only once the S interval is this narrow (1)")  # fmt: skip
    ap.add_argument("--lattice", action="store_true",
                    help="the first 9 touches on the square's 3 x 3 lattice")  # fmt: skip
    ap.add_argument("--only", nargs="*", help="these objects only (tuning)")
    args = ap.parse_args()
    check_split(ap, args)
    t0 = time.process_time()
    table(args.split, args.seeds, args.plots, args.flat, args.s_width, args.only, args.lattice)
    if args.ep1:
        ep1_bench(args.seeds)
    if args.emulated:
        emulated_bench(args.emulated)
    print(f"\n({time.process_time() - t0:.0f} CPU s)")


if __name__ == "__main__":
    main()
