"""EP1 simulation studies (§3.3): figs. 16, 18, 20, 21 and the dtheta choice beyond them.

Each study returns a list of dict rows (written as CSV by ``write_csv``) and has a ``plot_*``
that draws the PNG (matplotlib imported only there).  ``progress`` wraps the outer loop
(e.g. ``tqdm``); the default is no progress display.

Error measure: relative error of the estimated normal curvatures kx and ky (mean of the two
per trial, truncated at 100 % as in fig. 20), then mean over the Monte-Carlo trials.
"""

import csv

import numpy as np

from tactile.ep1.estimator import estimate_batch
from tactile.files.writing import atomic_write
from tactile_sim.ep1.probes import measure, simulate_probes, sphere_plus_probes, tile
from tactile_sim.ep1.rolling import roll
from tactile_sim.ep1.surfaces import fingertip, local, paraboloid, sphere

__all__ = [
    "FIG16",
    "FIG18",
    "FIG20",
    "study_noise",
    "study_paraboloid",
    "study_resolution",
    "study_arclength",
    "study_optimal_dtheta",
    "widest_range",
    "write_csv",
]

FIG16 = {
    "radii": (1000, 500, 50, 5, 1, 0.2, 0.05, 0.01, 0.001),
    "dthetas": (0.001, 0.01, 0.05, 0.25),
    "noises": (0, 0.0001, 0.0005, 0.001, 0.005, 0.01, 0.05),
}
FIG18 = {
    "Cs": (8, 5, 1, 0.5, 0.1, 0.01),
    "dthetas": (0.001, 0.01, 0.05, 0.25),
    "noises": (0, 0.0001, 0.0005, 0.001, 0.005, 0.01, 0.05),
    "at": (1.0, 0.1),
}
FIG20 = {
    "radii": FIG16["radii"],
    "resolutions": (0, 1e-6, 1e-5, 1e-4, 5e-4, 1e-3, 0.05),
    "dthetas": (0.25, 0.5, np.pi / 2),
}


def _identity(it, **_):
    return it


def _errors(rows, R1, k_true, resolution=0.0, sigma_theta=0.0):
    """Relative kx/ky errors (truncated at 1) and status codes for (..., 8, 4) measured rows."""
    out = estimate_batch(rows[..., :2], rows[..., 2:], R1, 0.0, resolution, sigma_theta)
    kt = np.asarray(k_true, float)
    scale = np.maximum(np.abs(kt), 1e-300)
    ex = np.abs(out["kx"] - kt[..., 0]) / scale[..., 0]
    ey = np.abs(out["ky"] - kt[..., 1]) / scale[..., 1]
    return np.minimum(0.5 * (ex + ey), 1.0), out["code"]


def study_noise(R1=1.0, trials=100, seed=0, grid=FIG16, progress=_identity):
    """Fig. 16: spheres x dtheta x angle noise, exact contact sensor, sphere fast path."""
    rng = np.random.default_rng(seed)
    radii = np.asarray(grid["radii"], float)
    rows = []
    for dth in progress(grid["dthetas"], desc="ep1-noise"):
        probes = sphere_plus_probes(R1, radii, dth)  # (n_radii, 8, ...)
        tiled = tile(probes, trials)
        k_true = np.stack([1.0 / radii, 1.0 / radii], axis=-1)
        for noise in grid["noises"]:
            meas = measure(tiled, R1, sigma_theta=noise, rng=rng)
            err, code = _errors(meas, R1, k_true, sigma_theta=noise)
            for i, r2 in enumerate(radii):
                rows.append(_row(r2, R1, dth, noise=noise, err=err[:, i], code=code[:, i]))
    return rows


def _row(r2, R1, dth, err, code, **extra):
    return {
        "radius": float(r2),
        "rcr": float(r2 / R1),
        "dtheta": float(dth),
        **{k: float(v) for k, v in extra.items()},
        "mean_rel_error": float(np.mean(err)),
        "median_rel_error": float(np.median(err)),
        "p90_rel_error": float(np.quantile(err, 0.9)),
        "ok_fraction": float(np.mean(code == 0)),
        "flat_fraction": float(np.mean(code == 1)),
        "unresolved_fraction": float(np.mean(code >= 2)),
    }


def paraboloid_truth(C, at):
    """Curvature of the eq. 36 paraboloid along u (kx) and v (ky) at ``at``, derived here, and
    the thesis's eq. 37 / table 4 value for comparison."""
    g = local(paraboloid(C), *at)
    u, v = at
    thesis = 2 * C / ((1 + 4 * C * C * u * u) ** 1.5 * np.sqrt(1 + 4 * C * C * v * v))
    return g.K[0, 0], g.K[1, 1], thesis


def study_paraboloid(R1=1.0, trials=100, seed=0, grid=FIG18, progress=_identity, **roll_kw):
    """Fig. 18: paraboloids (eq. 36) at (1.0, 0.1), ODE probes, angle noise; error along u."""
    rng = np.random.default_rng(seed)
    finger = fingertip(R1)
    rows = []
    for C in progress(grid["Cs"], desc="ep1-paraboloid"):
        kx, ky, thesis = paraboloid_truth(C, grid["at"])
        obj = paraboloid(C)
        for dth in grid["dthetas"]:
            pr = simulate_probes(finger, obj, (0.0, 0.0), grid["at"], dth, **roll_kw)
            tiled = tile(pr, trials)
            for noise in grid["noises"]:
                meas = measure(tiled, R1, sigma_theta=noise, rng=rng)
                out = estimate_batch(meas[..., :2], meas[..., 2:], R1, 0.0, 0.0, noise)
                err = np.minimum(np.abs(out["kx"] - kx) / abs(kx), 1.0)
                rows.append(
                    {
                        "C": float(C),
                        "radius_u": float(1 / kx),
                        "radius_u_thesis_table4": float(1 / thesis),
                        "dtheta": float(dth),
                        "noise": float(noise),
                        "mean_rel_error_u": float(np.mean(err)),
                        "median_rel_error_u": float(np.median(err)),
                        "arc_length": float(np.mean(pr.ds)),
                        "roll_status": ";".join(sorted(set(pr.status))),
                    }
                )
    return rows


def study_resolution(
    R1=1.0, trials=100, seed=0, grid=FIG20, sensors=("bias", "array", "gauss"), progress=_identity
):
    """Fig. 20: spheres x contact-sensor resolution x dtheta for each sensor model (§3.3.3).

    'array' draws a random grid offset per trial (the start point is anywhere on an element).
    """
    rng = np.random.default_rng(seed)
    radii = np.asarray(grid["radii"], float)
    k_true = np.stack([1.0 / radii, 1.0 / radii], axis=-1)
    rows = []
    for dth in progress(grid["dthetas"], desc="ep1-resolution"):
        pr = sphere_plus_probes(R1, radii, dth)
        tiled = tile(pr, trials)
        for sensor in sensors:
            for res in grid["resolutions"]:
                offset = rng.uniform(-0.5, 0.5, (trials, 1, 1, 2))
                meas = measure(tiled, R1, 0.0, res, sensor, rng, offset=offset)
                err, code = _errors(meas, R1, k_true, resolution=res)
                for i, r2 in enumerate(radii):
                    rows.append(
                        _row(r2, R1, dth, err[:, i], code[:, i], resolution=res)
                        | {"sensor": sensor}
                    )
    return rows


def study_arclength(R1=1.0, dtheta=np.pi / 2, n=121, check_ode=(0.01, 1.0, 100.0)):
    """Fig. 21: arc length on the finger for a dtheta roll on spheres, RCR 1e-4 .. 2.5e4.

    Closed form s = R1 dtheta RCR / (1 + RCR) (eq. 28 with eq. 38); a few RCRs are checked
    against the ODE (column ``ds_ode``).
    """
    rcr = np.logspace(-4, np.log10(2.5e4), n)
    s = R1 * dtheta * rcr / (1 + rcr)
    rows = [{"rcr": float(r), "radius": float(r * R1), "ds": float(v)} for r, v in zip(rcr, s)]
    if check_ode:
        for r in check_ode:
            res = roll(fingertip(R1), sphere(r * R1), (0, 0), (0, 0), 0.0, (dtheta, 0.0, 0.0))
            rows.append({"rcr": r, "radius": r * R1, "ds": float(res.y[5]), "source": "ode"})
    return rows


def study_optimal_dtheta(
    R1=1.0,
    sigma_theta=0.005,
    resolution=0.05,
    sensor="array",
    radii=None,
    dthetas=None,
    trials=200,
    seed=0,
    tolerance=0.25,
    dtheta0=0.5,
):
    """Beyond the thesis: choose dtheta per estimate for one sensor (spheres, R1 = 1 scale).

    1. Expected error table E(dtheta, radius) by Monte Carlo.
    2. Per trial: a first EP1 at ``dtheta0`` gives a radius estimate; dtheta is then chosen
       from the table smoothed over +-0.2 decades of radius (the first estimate is
       uncertain, and the array sensor's error has sharp dips where dp is a whole number of
       elements); a second EP1 at that dtheta gives the reported estimate (fresh noise).
    Returns (rows per radius, summary of the widest radius ranges within ``tolerance``:
    adaptive, oracle best-per-true-radius, and every fixed dtheta).
    """
    rng = np.random.default_rng(seed)
    radii = np.logspace(-3, 3, 61) if radii is None else np.asarray(radii, float)
    dthetas = np.linspace(0.05, 1.5, 30) if dthetas is None else np.asarray(dthetas, float)
    k_true = np.stack([1.0 / radii, 1.0 / radii], axis=-1)

    def trial_errors(dth):
        """EP1 at dtheta (scalar or (trials, radii)); returns (error, estimated radius)."""
        pr = (
            tile(sphere_plus_probes(R1, radii, dth), trials)
            if np.ndim(dth) == 0
            else (sphere_plus_probes(R1, radii, dth))
        )
        offset = rng.uniform(-0.5, 0.5, (trials, 1, 1, 2))
        meas = measure(pr, R1, sigma_theta, resolution, sensor, rng, offset=offset)
        out = estimate_batch(meas[..., :2], meas[..., 2:], R1, 0.0, resolution, sigma_theta)
        k = 0.5 * (out["kx"] + out["ky"])
        err = np.minimum(
            0.5
            * (np.abs(out["kx"] - k_true[:, 0]) + np.abs(out["ky"] - k_true[:, 1]))
            / k_true[:, 0],
            1.0,
        )
        return err, np.where(k > 0, 1.0 / np.maximum(k, 1e-300), np.inf)

    table = np.array([trial_errors(d)[0].mean(axis=0) for d in dthetas])
    kernel = np.ones(5) / 5.0
    padded = np.pad(table, ((0, 0), (2, 2)), mode="edge")
    smooth = np.array([np.convolve(row, kernel, mode="valid") for row in padded])
    _, r_hat = trial_errors(dtheta0)
    log_r = np.log(radii)
    idx = np.clip(
        np.searchsorted(log_r, np.log(np.clip(r_hat, radii[0], radii[-1]))), 0, len(radii) - 1
    )
    chosen = dthetas[smooth.argmin(axis=0)][idx]  # (trials, radii)
    adaptive, _ = trial_errors(chosen)
    adaptive_mean = adaptive.mean(axis=0)
    oracle = table.min(axis=0)
    rows = [
        {
            "radius": float(r),
            "adaptive_error": float(adaptive_mean[i]),
            "adaptive_mean_dtheta": float(chosen[:, i].mean()),
            "oracle_error": float(oracle[i]),
            "oracle_dtheta": float(dthetas[table[:, i].argmin()]),
            **{f"err_dtheta_{d:.3g}": float(table[j, i]) for j, d in enumerate(dthetas)},
        }
        for i, r in enumerate(radii)
    ]
    summary = {
        "adaptive": widest_range(radii, adaptive_mean, tolerance),
        "oracle": widest_range(radii, oracle, tolerance),
    }
    for j, d in enumerate(dthetas):
        summary[f"{d:.3g}"] = widest_range(radii, table[j], tolerance)
    return rows, summary


def widest_range(radii, err, tolerance=0.25):
    """Widest contiguous (in log radius) run of radii with error <= tolerance, or None."""
    good = np.asarray(err) <= tolerance
    best, start = None, None
    for i, g in enumerate(np.append(good, False)):
        if g and start is None:
            start = i
        elif not g and start is not None:
            lo, hi = radii[start], radii[i - 1]
            if best is None or hi / lo > best[1] / best[0]:
                best = (float(lo), float(hi))
            start = None
    return best


UNITS = "lengths in fingertip radii (R1 = 1), curvatures 1/R1, angles rad, errors relative"


def write_csv(path, rows, units=UNITS):
    """Write dict rows (union of keys, in first-seen order) as CSV under a ``# units:``
    line; never NaN/inf."""
    keys = list(dict.fromkeys(k for row in rows for k in row))
    with atomic_write(path, text=True, newline="") as fh:
        fh.write(f"# units: {units}\n")
        writer = csv.DictWriter(fh, fieldnames=keys)
        writer.writeheader()
        for row in rows:
            writer.writerow({k: _cell(row.get(k, "")) for k in keys})


def _cell(v):
    if isinstance(v, float) and not np.isfinite(v):
        return ""
    return v
