"""Contact localisation: error against sensor noise and friction, time per reading, the EP1
F/T path, and the ch. 5 replica in process (docs/localize.md).

    .venv/bin/python bench/localize_accuracy.py [--quick]

Prints Markdown tables.  Noise is the thesis's sensor accuracy (§5.1.3) times a factor;
the sample force is the schedule's default (1.3 x the 5 oz gate = 1.81 N).
"""

import argparse
import time

import numpy as np

from tactile.localize import (
    rim_contact,
    scara_contacts,
    sphere_contact,
    sphere_contact_frictionless,
    wheel_contact,
)
from tactile_sim.rig.geometry import FREDDY
from tactile_sim.rig.objects import ch5_object
from tactile_sim.rig.schedule import probe_schedule
from tactile_sim.rig.sensor import GATE_N, SIGMA_F, SIGMA_M
from tactile_studies import replica

LENGTHS = (FREDDY.L1, FREDDY.L2, FREDDY.L3, FREDDY.L4)
THESIS = replica.THESIS  # tables 5-7, kept once in tactile_studies.replica


def _rms(x):
    return float(np.sqrt(np.mean(np.square(x)))) if len(x) else float("nan")


def _f(v, digits=4):
    return f"{v:.{digits}f}" if np.isfinite(v) else "null"


def _score(r, method):
    """Localise a schedule's readings; (usable fraction, point errors m, normal errors deg)."""
    c, _ = scara_contacts(
        r["force"], r["moment"], r["q"], LENGTHS, GATE_N, method,
        FREDDY.half_thickness, FREDDY.arc_limit,
    )  # fmt: skip
    ok = c.usable & r["recorded"]
    used = ok.sum() / max(r["recorded"].sum(), 1)
    return (
        used,
        np.linalg.norm(c.point - r["point"], axis=1)[ok],
        _angle_deg(c.normal, r["normal"])[ok],
    )


def _angle_deg(a, b):
    return np.degrees(np.arccos(np.clip(np.einsum("ij,ij->i", a, b), -1.0, 1.0)))


def wheel_noise_table(seeds):
    print("\n### Wheel probe (ch. 5 rig, convex cylinder): error vs sensor noise, mu = 0\n")
    print(
        "| noise x thesis | method | usable | RMS point error (mm) | p95 (mm) | "
        "RMS normal error (deg) |"
    )
    print("|---|---|---|---|---|---|")
    for factor in (0.5, 1.0, 2.0, 4.0):
        for method in ("force", "moment"):
            pe, ne, used = [], [], []
            for seed in range(seeds):
                r = probe_schedule(
                    ch5_object("convex"),
                    seed=seed,
                    sigma_f=factor * SIGMA_F,
                    sigma_m=factor * SIGMA_M,
                )
                u, p_err, n_err = _score(r, method)
                used.append(u)
                pe.append(p_err)
                ne.append(n_err)
            pe, ne = np.concatenate(pe), np.concatenate(ne)
            print(
                f"| {factor:g} | {method} | {np.mean(used):.3f} | {1e3 * _rms(pe):.3f} | "
                f"{1e3 * np.percentile(pe, 95):.3f} | {_rms(ne):.2f} |"
            )


def wheel_friction_table(seeds):
    print("\n### Wheel probe: error vs friction coefficient (thesis noise, convex cylinder)\n")
    print("| mu | method | usable | RMS point error (mm) | max (mm) | RMS normal error (deg) |")
    print("|---|---|---|---|---|---|")
    for mu in (0.0, 0.1, 0.3, 0.5):
        for method in ("force", "moment"):
            pe, ne, used = [], [], []
            for seed in range(seeds):
                r = probe_schedule(ch5_object("convex"), seed=seed, mu=mu)
                u, p_err, n_err = _score(r, method)
                used.append(u)
                pe.append(p_err)
                ne.append(n_err)
            pe, ne = np.concatenate(pe), np.concatenate(ne)
            print(
                f"| {mu:g} | {method} | {np.mean(used):.3f} | {1e3 * _rms(pe):.3f} | "
                f"{1e3 * pe.max():.3f} | "
                f"{_rms(ne):.2f} |"
            )


def sphere_table(n):
    print(
        "\n### Spherical fingertip on a wrist sensor (offset 5 cm): error vs force, radius, "
        "friction (thesis noise)\n"
    )
    print(
        "| radius (mm) | F (N) | mu | method | usable | RMS point error (mm) | "
        "RMS normal error (deg) |"
    )
    print("|---|---|---|---|---|---|---|")
    rng = np.random.default_rng(0)
    for R1 in (0.01, 0.02):
        for fn in (1.5, 5.0, 20.0):
            for mu in (0.0, 0.3):
                m = rng.standard_normal((n, 3))
                m[:, 0] = np.abs(m[:, 0]) + 0.5  # the front of the fingertip
                m /= np.linalg.norm(m, axis=1, keepdims=True)
                centre = np.array([0.05, 0.0, 0.0])
                p, nrm = centre + R1 * m, -m
                t = np.cross(nrm, rng.standard_normal((n, 3)))
                t /= np.linalg.norm(t, axis=1, keepdims=True)
                F = fn * (nrm + mu * rng.uniform(0, 1, (n, 1)) * t)
                M = np.cross(p, F)
                Fm = F + rng.standard_normal(F.shape) * SIGMA_F
                Mm = M + rng.standard_normal(M.shape) * SIGMA_M
                for method in ("moment", "force"):
                    if method == "moment":
                        c = sphere_contact(Fm, Mm, centre, R1, axis=(1, 0, 0))
                    else:
                        c = sphere_contact_frictionless(Fm, centre, R1, axis=(1, 0, 0))
                    ok = c.usable
                    pe = np.linalg.norm(c.point - p, axis=1)[ok]
                    ne = _angle_deg(c.normal, nrm)[ok]
                    print(
                        f"| {1e3 * R1:g} | {fn:g} | {mu:g} | {method} | {ok.mean():.3f} | "
                        f"{1e3 * _rms(pe):.2f} | {_rms(ne):.2f} |"
                    )


def speed_table(n):
    print(f"\n### Time per reading, vectorised over {n} readings (this machine)\n")
    print("| function | total (ms) | per reading (us) |")
    print("|---|---|---|")
    rng = np.random.default_rng(1)
    F = rng.standard_normal((n, 3))
    M = rng.standard_normal((n, 3)) * 0.01
    q = rng.uniform(-1, 1, (n, 4))
    runs = {
        "wheel_contact (eqs. 60-61)": lambda: wheel_contact(F, (0.12, 0, 0), 0.015),
        "rim_contact (force + moment)": lambda: rim_contact(F, M, (0.12, 0, 0), 0.015, 0.004),
        "sphere_contact": lambda: sphere_contact(F, M, (0.05, 0, 0), 0.01),
        "scara_contacts (force, to world)": lambda: scara_contacts(F, M, q, LENGTHS),
    }
    for name, fn in runs.items():
        fn()
        best = min(_timed(fn) for _ in range(5))
        print(f"| {name} | {1e3 * best:.2f} | {1e6 * best / n:.3f} |")


def _timed(fn):
    t0 = time.perf_counter()
    fn()
    return time.perf_counter() - t0


def ep1_table(trials):
    from tactile.ep1.estimator import estimate
    from tactile_sim.ep1.probes import sphere_plus_probes
    from tactile_studies.ep1.ft_measure import measure_ft

    print(
        "\n### EP1 through the F/T path: sphere R2 = 2 R1, dtheta = pi/3, thesis noise, "
        f"{trials} trials\n"
    )
    print("| R1 (mm) | F (N) | method | estimates | median rel. k error | p90 |")
    print("|---|---|---|---|---|---|")
    rng = np.random.default_rng(2)
    for R1 in (0.01, 0.02, 0.05):
        probes = sphere_plus_probes(R1, 2 * R1, np.pi / 3)
        k_true = 1.0 / (2 * R1)
        for fn in (1.5, 5.0, 20.0):
            for method in ("moment", "force"):
                errs = []
                for _ in range(trials):
                    rows, ok = measure_ft(probes, R1, normal_force=fn, rng=rng, method=method)
                    if ok.sum() < 4:
                        continue
                    est = estimate(rows[ok, :2], rows[ok, 2:], R1)
                    ks = [k for k in (est.k1, est.k2) if k is not None]
                    if est.k1 is not None and est.k2 is not None:
                        errs.extend(abs(k - k_true) / k_true for k in ks)
                got = len(errs) // 2
                med = f"{np.median(errs):.3f}" if errs else "-"
                p90 = f"{np.percentile(errs, 90):.3f}" if errs else "-"
                print(f"| {1e3 * R1:g} | {fn:g} | {method} | {got}/{trials} | {med} | {p90} |")


def ch5_table(seeds):
    from tactile.ep2.api import analyze_patch

    print(f"\n### Ch. 5 replica in process (rig -> localise -> EP2), mean over {seeds} seeds\n")
    print(
        "| surface | fit | S (thesis) | S | sd S (thesis) | sd S | R (thesis) | R | "
        "radius cm (thesis) | radius cm | shape labels |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for kind in ("plane", "convex", "concave"):
        for weighting in ("tangent", "position"):
            rows, labels = [], {}
            for seed in range(seeds):
                r = probe_schedule(ch5_object(kind), seed=seed)
                c, _ = scara_contacts(
                    r["force"],
                    r["moment"],
                    r["q"],
                    LENGTHS,
                    GATE_N,
                    "force",
                    FREDDY.half_thickness,
                    FREDDY.arc_limit,
                )
                ok = c.usable & r["recorded"]
                res = analyze_patch(
                    100 * c.point[ok],
                    c.normal[ok],
                    method="spline",
                    weighting=weighting,
                    finger=r["finger"][ok],
                )
                rows.append((res.S_mean, res.S_std, res.R_mean, res.radius))
                labels[res.shape] = labels.get(res.shape, 0) + 1
            vals = np.array([[np.nan if v is None else v for v in row] for row in rows], float)
            mean = [np.nanmean(col) if np.isfinite(col).any() else np.nan for col in vals.T]
            th = THESIS[kind][weighting]
            lab = ", ".join(f"{k} {v}" for k, v in sorted(labels.items()))
            print(
                f"| {kind} | {weighting} | {th[0]} | {_f(mean[0])} | {th[1]} | {_f(mean[1])} | "
                f"{th[2]} | {_f(mean[2])} | {th[4] or '-'} | {_f(mean[3], 2)} | {lab} |"
            )


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="fewer trials")
    args = ap.parse_args()
    seeds = 5 if args.quick else 40
    wheel_noise_table(seeds)
    wheel_friction_table(seeds)
    sphere_table(2000 if args.quick else 20000)
    speed_table(100_000)
    ep1_table(20 if args.quick else 200)
    ch5_table(5 if args.quick else 40)


if __name__ == "__main__":
    main()
