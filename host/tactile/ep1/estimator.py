"""EP1 curvature estimator (§3.2.3, eqs. 29-33; principal curvatures after §6.2.1, eq. 64).

Each probe i gives, from eq. 29 with the fingertip metric of eq. 20,

    b_i = M1 dp_i = S a_i,  a_i = [-dtheta_y, dtheta_x]^T,  S = (K1 + K2~)^-1 = [[k1, k2], [k2, k3]]

i.e. two rows [a_x, a_y, 0] and [0, a_x, a_y] of a linear system in (k1, k2, k3) (eq. 33).  The
stack is solved by Householder QR (never the normal equations of eq. 32).  K1 = I / R1 is
isotropic, so K2~ has the eigenvectors of S and eigenvalues kappa = 1/s - 1/R1: the
principal curvatures come straight from S's closed-form eigen-decomposition (atan2/hypot),
and kx, ky, kxy follow from Euler's equation (eq. 64) without inverting a near-singular
matrix.  Convex is positive (object normal pointing out of the material).

Every principal direction gets a status with the bound the data support:

- ``ok``;
- ``flat``: |kappa| below its uncertainty; the numbers are kept and ``radius_min`` says how
  flat the data allow (|radius| above it);
- ``near_singular``: K1 + K2~ is indistinguishable from singular (a concave object nearly
  fitting the finger): curvature in [-1/R1, bound], no number;
- ``below_resolution``: the displacement is at or below one sensor step: the object is
  sharper than the sensor resolves, ``radius_max`` bounds it;
- ``inconsistent``: K1 + K2~ came out indefinite, impossible for a stable contact;
- ``underdetermined``: fewer than two independent probe directions.
"""

from typing import NamedTuple

import numpy as np

__all__ = ["Estimate", "estimate", "estimate_batch", "euler_principal", "STATUSES", "EXIT_OK"]

STATUSES = ("ok", "flat", "near_singular", "below_resolution", "inconsistent", "underdetermined")
EXIT_OK = ("ok", "flat")
OK, FLAT, NEAR_SINGULAR, BELOW_RES, INCONSISTENT, UNDERDET = range(6)
RANK_TOL = 1e-9  # relative size of R's smallest pivot below which A is rank deficient
CANCEL_TOL = 1e-9  # |1/s| * R1 below this: K1 + K2~ singular to double precision


class Estimate(NamedTuple):
    """Result of ``estimate``; curvature fields are None where the data do not determine them."""

    status: str
    message: str
    kx: float | None
    ky: float | None
    K: list | None  # K2~, 2x2, in the probe's contact frame
    k1: float | None  # larger principal curvature
    k2: float | None
    direction1: list | None  # unit vector (x, y) of k1; None at an umbilic or if unresolved
    direction2: list | None
    S: list  # (K1 + K2~)^-1 as solved
    residual: float  # RMS of M1 dp - S a over all equations (arc length units)
    n_probes: int
    bounds: dict

    def as_dict(self):
        return self._asdict()


def _systems(dtheta, dp, R1, u0):
    """Rows of eq. 33 and right-hand sides, shape (..., 2m, 3) and (..., 2m)."""
    ax, ay = -dtheta[..., 1], dtheta[..., 0]
    zero = np.zeros_like(ax)
    rows_x = np.stack([ax, ay, zero], axis=-1)
    rows_y = np.stack([zero, ax, ay], axis=-1)
    A = np.concatenate([rows_x, rows_y], axis=-2)
    b = np.concatenate([R1 * dp[..., 0], R1 * np.cos(u0) * dp[..., 1]], axis=-1)
    return A, b


def estimate_batch(dtheta, dp, R1, u0=0.0, resolution=0.0, sigma_theta=0.0):
    """Vectorised estimator: ``dtheta``, ``dp`` of shape (..., m, 2) -> dict of arrays (...).

    Keys: kx, ky, kxy, k_a, k_b (principal, k_a <= k_b... see ``k1``/``k2``), angle (of k1's
    direction from x), code (per estimate, index into STATUSES), code1, code2, s1, s2,
    dkappa1, dkappa2, residual.  Curvatures are always finite (raw values, whatever the code).
    """
    dtheta = np.asarray(dtheta, float)
    dp = np.asarray(dp, float)
    A, b = _systems(dtheta, dp, R1, u0)
    m2 = A.shape[-2]
    Q, Rm = np.linalg.qr(A)
    qb = np.einsum("...ij,...i->...j", Q, b)
    diag = np.abs(np.diagonal(Rm, axis1=-2, axis2=-1))
    rank_ok = diag.min(axis=-1) > RANK_TOL * np.maximum(diag.max(axis=-1), 1e-300)
    Rs = np.where(rank_ok[..., None, None], Rm, np.eye(3))
    k = np.linalg.solve(Rs, qb[..., None])[..., 0]
    k = np.where(rank_ok[..., None], k, 0.0)
    res = b - np.einsum("...ij,...j->...i", A, k)
    rss = np.einsum("...i,...i->...", res, res)
    residual = np.sqrt(rss / m2)
    sigma_res = np.sqrt(rss / max(m2 - 3, 1)) if m2 > 3 else np.zeros_like(rss)
    theta = np.sqrt(np.mean(np.einsum("...i,...i->...", dtheta, dtheta), axis=-1))
    return _from_s(k, R1, theta, sigma_res, residual, rank_ok, resolution, sigma_theta)


def _from_s(k, R1, theta, sigma_res, residual, rank_ok, resolution, sigma_theta):
    k1, k2, k3 = k[..., 0], k[..., 1], k[..., 2]
    mean = 0.5 * (k1 + k3)
    half = np.hypot(0.5 * (k1 - k3), k2)
    s_hi, s_lo = mean + half, mean - half  # s_hi <-> smaller curvature
    angle_hi = 0.5 * np.arctan2(2.0 * k2, k1 - k3)
    theta_safe = np.maximum(theta, 1e-300)
    noise_b = np.maximum(sigma_res, 0.5 * resolution)
    out = {"residual": residual, "theta": theta, "S": k}
    codes = []
    for name, s in (("hi", s_hi), ("lo", s_lo)):
        ds = (noise_b + sigma_theta * np.abs(s)) / theta_safe + 1e-13 * (np.abs(s) + R1)
        s_safe = np.where(np.abs(s) < 1e-150, 1e-150, s)
        kappa = 1.0 / s_safe - 1.0 / R1
        with np.errstate(over="ignore"):
            inv_s_err = np.minimum(ds / s_safe / s_safe, 1e300)  # finite even for s ~ 0
        code = np.full(s.shape, OK)
        code = np.where(np.abs(kappa) <= inv_s_err, FLAT, code)
        singular = (np.abs(1.0 / s_safe) <= inv_s_err) | (np.abs(R1 / s_safe) < CANCEL_TOL)
        code = np.where(singular & (code == OK), NEAR_SINGULAR, code)
        code = np.where((s < 0.0) & ~singular, INCONSISTENT, code)
        if resolution > 0.0:
            code = np.where(s * theta <= resolution, BELOW_RES, code)
        code = np.where(rank_ok, code, UNDERDET)
        out["s_" + name], out["kappa_" + name], out["dkappa_" + name] = s, kappa, inv_s_err
        out["code_" + name] = code
        codes.append(code)
    # k1 >= k2: the larger curvature belongs to the smaller s.
    c, sn = np.cos(angle_hi), np.sin(angle_hi)
    ka, kb = out["kappa_hi"], out["kappa_lo"]
    out["kx"] = ka * c * c + kb * sn * sn  # Euler's equation (eq. 64)
    out["ky"] = ka * sn * sn + kb * c * c
    out["kxy"] = (ka - kb) * c * sn
    out["k1"], out["k2"] = kb, ka
    out["angle1"] = angle_hi + 0.5 * np.pi  # direction of k1 (of s_lo)
    out["code"] = np.maximum(*codes)
    # FLAT never outranks a harder failure; harder codes are larger.
    return out


def _direction(angle):
    return [float(np.cos(angle)), float(np.sin(angle))]


def estimate(dtheta, dp, finger_radius, u0=0.0, resolution=0.0, sigma_theta=0.0):
    """Estimate K2~ from probes ``dtheta`` (m, 2) and ``dp`` = (du, dv) (m, 2) (eqs. 29-33).

    ``resolution`` (arc length on the fingertip) and ``sigma_theta`` (rad) describe the
    sensors; with both zero the uncertainty comes from the residual alone.
    """
    if finger_radius <= 0.0:
        raise ValueError("finger radius must be positive")
    dtheta = np.asarray(dtheta, float).reshape(-1, 2)
    dp = np.asarray(dp, float).reshape(-1, 2)
    n = len(dtheta)
    if n < 2:
        return _underdetermined(n, "need probes in at least two independent directions")
    r = estimate_batch(dtheta, dp, finger_radius, u0, resolution, sigma_theta)
    k = r.pop("S")
    f = {key: float(val) for key, val in r.items()}
    S = [[float(k[0]), float(k[1])], [float(k[1]), float(k[2])]]
    code_hi, code_lo = int(f["code_hi"]), int(f["code_lo"])
    code = max(code_hi, code_lo)
    status = STATUSES[code]
    if code == UNDERDET:
        return _underdetermined(n, "probe directions span fewer than two independent directions")
    bounds, notes = {}, []
    for label, which, c in (("k1", "lo", code_lo), ("k2", "hi", code_hi)):
        note = _bound(
            label,
            c,
            f["s_" + which],
            f["kappa_" + which],
            f["dkappa_" + which],
            finger_radius,
            f["theta"],
            resolution,
        )
        if note:
            bounds[label] = note
            notes.append(note["text"])
    resolved = code in (OK, FLAT)
    k1 = f["k1"] if code_lo in (OK, FLAT) else None
    k2 = f["k2"] if code_hi in (OK, FLAT) else None
    umbilic = abs(f["k1"] - f["k2"]) <= f["dkappa_hi"] + f["dkappa_lo"]
    d1 = _direction(f["angle1"]) if resolved and not umbilic else None
    d2 = _direction(f["angle1"] + 0.5 * np.pi) if d1 else None
    message = "; ".join(notes) if notes else "curvature determined"
    return Estimate(
        status,
        message,
        f["kx"] if resolved else None,
        f["ky"] if resolved else None,
        [[f["kx"], f["kxy"]], [f["kxy"], f["ky"]]] if resolved else None,
        k1,
        k2,
        d1,
        d2,
        S,
        f["residual"],
        n,
        bounds,
    )


def _bound(label, code, s, kappa, dkappa, R1, theta, resolution):
    if code == FLAT:
        rmin = 1.0 / dkappa if dkappa > 0 else None
        return {
            "radius_min": rmin,
            "text": f"{label}: flat within noise (|radius| above {_fmt(rmin)})",
        }
    if code == NEAR_SINGULAR:
        upper = -1.0 / R1 + abs(1.0 / s) + dkappa
        rmax = -1.0 / upper if upper < 0 else None
        return {
            "curvature_range": [-1.0 / R1, upper],
            "concave_radius_range": [R1, rmax],
            "text": f"{label}: K1 + K2~ near singular: concave radius between {_fmt(R1)} "
            f"and {_fmt(rmax)} (the object nearly fits the finger)",
        }
    if code == BELOW_RES:
        s_up = (max(s, 0.0) * theta + 0.5 * resolution) / max(theta, 1e-300)
        k_low = 1.0 / s_up - 1.0 / R1
        rmax = 1.0 / k_low if k_low > 0 else None
        text = f"{label}: contact displacement at or below one sensor step ({_fmt(resolution)})" + (
            f": radius below {_fmt(rmax)}" if rmax else ": increase dtheta"
        )
        return {"radius_max": rmax, "text": text}
    if code == INCONSISTENT:
        return {
            "text": f"{label}: K1 + K2~ came out indefinite (s = {_fmt(s)}): probes "
            "inconsistent with rolling contact"
        }
    return None


def _fmt(x):
    return "unbounded" if x is None else f"{x:.3g}"


def _underdetermined(n, why):
    return Estimate(
        "underdetermined",
        why,
        None,
        None,
        None,
        None,
        None,
        None,
        None,
        [[0.0, 0.0], [0.0, 0.0]],
        0.0,
        n,
        {},
    )


def euler_principal(angles, kn):
    """Principal curvatures from normal curvatures in >= 3 directions (Euler, eq. 64).

    kn(phi) = k1 cos^2(phi - phi1) + k2 sin^2(phi - phi1) = H + D cos 2(phi - phi1), solved
    as a linear least-squares problem in (H, D cos 2 phi1, D sin 2 phi1).  Returns
    (k1, k2, phi1) with k1 >= k2, or None if the directions (mod pi) are fewer than three.
    """
    angles = np.asarray(angles, float)
    kn = np.asarray(kn, float)
    A = np.column_stack([np.ones_like(angles), np.cos(2 * angles), np.sin(2 * angles)])
    sv = np.linalg.svd(A, compute_uv=False)
    if len(sv) < 3 or sv[-1] <= RANK_TOL * sv[0]:
        return None
    H, c, s = np.linalg.lstsq(A, kn, rcond=None)[0]
    D = np.hypot(c, s)
    return float(H + D), float(H - D), float(0.5 * np.arctan2(s, c))
