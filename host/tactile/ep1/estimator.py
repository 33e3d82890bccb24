"""EP1 curvature estimator (§3.2.3, eqs. 29-33; principal curvatures after §6.2.1, eq. 64), and
``next_roll``: the direction the next roll tells most from (closed-loop EP1, docs/explore.md).

Each probe i gives, from eq. 29 with the fingertip metric of eq. 20,

    b_i = M1 dp_i = S a_i,  a_i = [-dtheta_y, dtheta_x]^T,  S = (K1 + K2~)^-1 = [[k1, k2], [k2, k3]]

i.e. two rows [a_x, a_y, 0] and [0, a_x, a_y] of a linear system in (k1, k2, k3) (eq. 33).  The
stack is solved by orthogonalisation, never the normal equations of eq. 32: NumPy's batched
Householder QR in ``estimate_batch``, which ``estimate`` calls with a stack of one point.
Data near under/overflow are scaled by exact powers of two first.  K1 = I / R1 is
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

import math
from typing import NamedTuple

import numpy as np

__all__ = ["Estimate", "estimate", "estimate_batch", "euler_principal", "next_roll", "STATUSES",
           "EXIT_OK"]  # fmt: skip

STATUSES = ("ok", "flat", "near_singular", "below_resolution", "inconsistent", "underdetermined")
EXIT_OK = ("ok", "flat")
OK, FLAT, NEAR_SINGULAR, BELOW_RES, INCONSISTENT, UNDERDET = range(6)
RANK_TOL = 1e-6  # pivot of R relative to ||A||_F below which A counts as rank deficient
CANCEL_TOL = 1e-9
MIN_THETA = 1e-12  # rad RMS: smaller probe rotations determine nothing (and underflow)


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
    ea, eb = _exponent(dtheta), _exponent(dp * [1.0, np.cos(u0)])
    m = max(dtheta.shape[-2], 1)
    theta = np.sqrt(np.sum(np.ldexp(dtheta, ea[..., None, None]) ** 2, (-2, -1)) / m)
    theta = np.ldexp(theta, -ea)  # the RMS rotation (0 for no probes)
    A, b = _systems(
        np.ldexp(dtheta, ea[..., None, None]), np.ldexp(dp, eb[..., None, None]), R1, u0
    )
    m2 = A.shape[-2]
    if m2 < 3:  # fewer than two probes: zero rows make R square, and rank deficient
        A = np.concatenate([A, np.zeros(A.shape[:-2] + (3 - m2, 3))], axis=-2)
        b = np.concatenate([b, np.zeros(b.shape[:-1] + (3 - m2,))], axis=-1)
    Q, Rm = np.linalg.qr(A)
    qb = np.einsum("...ij,...i->...j", Q, b)
    diag = np.abs(np.diagonal(Rm, axis1=-2, axis2=-1))
    # Pivots against ||A||_F (not against the largest pivot: without column pivoting an
    # all-but-zero column can leave every pivot tiny while R's off-diagonal holds the size).
    norm_a = np.sqrt(np.einsum("...ij,...ij->...", A, A))
    rank_ok = diag.min(axis=-1) > RANK_TOL * np.maximum(norm_a, 1e-300)
    Rs = np.where(rank_ok[..., None, None], Rm, np.eye(3))
    k = np.linalg.solve(Rs, qb[..., None])[..., 0]
    k = np.where(rank_ok[..., None], k, 0.0)
    res = b - np.einsum("...ij,...j->...i", A, k)
    rss = np.einsum("...i,...i->...", res, res)
    with np.errstate(over="ignore"):  # (scaled back: beyond 1e300 is clipped)
        k = np.ldexp(k, (ea - eb)[..., None])
        residual = np.minimum(np.ldexp(np.sqrt(rss / max(m2, 1)), -eb), 1e300)
        sigma_res = np.ldexp(np.sqrt(rss / max(m2 - 3, 1)), -eb) if m2 > 3 else 0.0 * rss
    rank_ok = rank_ok & (theta >= MIN_THETA)
    return _from_s(k, R1, theta, sigma_res, residual, rank_ok, resolution, sigma_theta)


def _exponent(x):
    """Per point (x (..., m, 2)), the power of two that brings its largest entry to about 1
    where that is outside 1e-100..1e100 (else 0: nothing changes), so no square under- or
    overflows."""
    big = np.max(np.abs(x), axis=(-2, -1), initial=0.0)
    e = -np.frexp(big)[1]
    return np.where((big == 0.0) | ((big >= 1e-100) & (big <= 1e100)), 0, e)


def _from_s(k, R1, theta, sigma_res, residual, rank_ok, resolution, sigma_theta):
    """Principal values of S, curvatures, intervals and status codes (NumPy, any shape)."""
    k = np.clip(k, -1e300, 1e300)  # absurd inputs (dtheta ~ 1e-320) stay finite
    k1, k2, k3 = k[..., 0], k[..., 1], k[..., 2]
    mean = 0.5 * (k1 + k3)
    half = np.hypot(0.5 * (k1 - k3), k2)
    angle_hi = 0.5 * np.arctan2(2.0 * k2, k1 - k3)
    noise_b = np.maximum(sigma_res, 0.5 * resolution)
    theta_safe = np.maximum(theta, 1e-300)
    out = {"residual": residual, "theta": theta, "S": k}
    for name, s in (("hi", mean + half), ("lo", mean - half)):  # s_hi: smaller curvature
        with np.errstate(over="ignore", divide="ignore"):  # theta ~ 1e-300: ds = inf
            ds = (noise_b + sigma_theta * np.abs(s)) / theta_safe + 1e-13 * (np.abs(s) + R1)
            lo, hi = s - ds, s + ds
            k_lo = 1.0 / np.where(hi > 0.0, hi, 1.0) - 1.0 / R1  # curvature lower bound
            k_hi = 1.0 / np.where(lo > 0.0, lo, 1.0) - 1.0 / R1
        k_lo, k_hi = np.minimum(k_lo, 1e300), np.minimum(k_hi, 1e300)
        kappa = 1.0 / np.where(np.abs(s) < 1e-150, 1e-150, s) - 1.0 / R1
        code = np.full(np.shape(s), OK)
        code = np.where((k_lo <= 0.0) & (k_hi >= 0.0), FLAT, code)
        code = np.where(
            (lo > 0.0) & (R1 / np.maximum(lo, 1e-300) < CANCEL_TOL), NEAR_SINGULAR, code
        )
        code = np.where((lo <= 0.0) & (hi >= R1), NEAR_SINGULAR, code)
        code = np.where((lo <= 0.0) & (hi > 0.0) & (hi < R1), BELOW_RES, code)
        code = np.where(hi <= 0.0, INCONSISTENT, code)
        if resolution > 0.0:
            code = np.where(s * theta <= resolution, BELOW_RES, code)
        code = np.where(rank_ok, code, UNDERDET)
        out["s_" + name], out["kappa_" + name], out["code_" + name] = s, kappa, code
        out["klo_" + name], out["khi_" + name] = k_lo, k_hi
        out["dkappa_" + name] = np.where(lo > 0.0, 0.5 * (k_hi - k_lo), 1e300)
    c, sn = np.cos(angle_hi), np.sin(angle_hi)
    ka, kb = out["kappa_hi"], out["kappa_lo"]
    out["kx"] = ka * c * c + kb * sn * sn  # Euler's equation (eq. 64)
    out["ky"] = ka * sn * sn + kb * c * c
    out["kxy"] = (ka - kb) * c * sn
    out["k1"], out["k2"] = kb, ka  # k1 >= k2: the larger curvature belongs to the smaller s
    out["angle1"] = angle_hi + 0.5 * np.pi  # direction of k1 (of s_lo)
    out["code"] = np.maximum(out["code_hi"], out["code_lo"])  # harder failures are larger
    return out


def _direction(angle):
    return [math.cos(angle), math.sin(angle)]


def _probes(a):
    """An (m, 2) array-like as a float array (other shapes read as rows of two)."""
    a = np.asarray(a, float)
    return a if a.ndim == 2 and a.shape[1] == 2 else a.reshape(-1, 2)


def estimate(dtheta, dp, finger_radius, u0=0.0, resolution=0.0, sigma_theta=0.0):
    """Estimate K2~ from probes ``dtheta`` (m, 2) and ``dp`` = (du, dv) (m, 2) (eqs. 29-33).

    ``resolution`` (arc length on the fingertip) and ``sigma_theta`` (rad) describe the
    sensors; with both zero the uncertainty comes from the residual alone.  ``estimate_batch``
    of a stack of one point (``bench/ep1_speed.py`` times a call).
    """
    finger_radius, u0 = float(finger_radius), float(u0)
    if finger_radius <= 0.0:
        raise ValueError("finger radius must be positive")
    th, dp = _probes(dtheta), _probes(dp)
    n = len(th)
    if len(dp) != n:
        raise ValueError(f"dtheta has {n} probes but dp has {len(dp)}")
    if n < 2:
        return _underdetermined(n, "need probes in at least two independent directions")
    out = estimate_batch(th[None], dp[None], finger_radius, u0, resolution, sigma_theta)
    if out["code"][0] == UNDERDET:
        return _underdetermined(n, "probe directions span fewer than two independent directions")
    return _result({k: v[0].tolist() for k, v in out.items()}, finger_radius, resolution, n)


def _result(out, R1, resolution, n):
    """The ``Estimate`` of one point of ``estimate_batch`` (Python numbers): s_hi belongs to
    the smaller curvature k2, s_lo to k1."""
    hi, lo = (
        tuple(out[f"{key}_{side}"] for key in ("s", "kappa", "code", "klo", "khi", "dkappa"))
        for side in ("hi", "lo")
    )
    code, theta = out["code"], out["theta"]
    bounds, notes = {}, []
    for label, side in (("k1", lo), ("k2", hi)) if code else ():
        note = _bound(label, side, theta, R1, resolution)
        if note:
            bounds[label] = note
            notes.append(note["text"])
    ka, kb = hi[1], lo[1]
    resolved = code <= FLAT
    kx, ky, kxy = (out[f] if resolved else None for f in ("kx", "ky", "kxy"))
    umbilic = abs(kb - ka) <= hi[5] + lo[5]
    d1 = _direction(out["angle1"]) if resolved and not umbilic else None
    d2 = _direction(out["angle1"] + 0.5 * math.pi) if d1 else None
    k = out["S"]
    return Estimate(
        STATUSES[code],
        "; ".join(notes) if notes else "curvature determined",
        kx,
        ky,
        [[kx, kxy], [kxy, ky]] if resolved else None,
        kb if lo[2] <= FLAT else None,
        ka if hi[2] <= FLAT else None,
        d1,
        d2,
        [[k[0], k[1]], [k[1], k[2]]],
        out["residual"],
        n,
        bounds,
    )


def _bound(label, side, theta, R1, resolution):
    s, _, code, k_lo, k_hi, _ = side
    if code == FLAT:
        rmin = 1.0 / max(abs(k_lo), abs(k_hi), 1e-300)
        return {
            "curvature_range": [k_lo, k_hi],
            "radius_min": rmin,
            "text": f"{label}: flat within noise (|radius| above {_fmt(rmin)})",
        }
    if code == NEAR_SINGULAR:
        rmin = 1.0 / -k_lo if k_lo < 0 else None
        return {
            "curvature_min": k_lo,
            "concave_radius_min": rmin,
            "text": f"{label}: K1 + K2~ indistinguishable from singular (the object may "
            f"nearly fit the finger): curvature above {_fmt(k_lo)}"
            + (f", a concave radius above {_fmt(rmin)}" if rmin else ""),
        }
    if code == BELOW_RES:
        theta = max(theta, 1e-300)
        if resolution > 0 and s * theta <= resolution:
            # measured at most one step: the true displacement is below s theta + r / 2
            k_min = 1.0 / max(max(s, 0.0) + 0.5 * resolution / theta, 1e-300) - 1.0 / R1
        else:
            k_min = k_lo
        rmax = 1.0 / k_min if k_min > 0 else None
        step = f"one sensor step ({_fmt(resolution)})" if resolution > 0 else "the noise"
        text = f"{label}: contact displacement at or below {step}" + (
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


# --- The next roll (closed-loop EP1, §6.2.1): where the probes so far know least.


def next_roll(dtheta, dp, finger_radius, u0=0.0):
    """The next EP1 roll: (phi, motion, why).  ``phi`` the commanded rotation axis's angle in
    the probe's contact frame (``tactile_sim.ep1.probes``' convention), ``motion`` the unit
    (x, y) the contact moves along (= (-sin phi, cos phi)).

    With fewer than two independent directions: x, then the direction across those rolled.
    Otherwise along a principal direction of the current estimate (eqs. 29-33; §6.2.1: two
    directions give eq. 64's principal curvatures): the one whose roll leaves the least total
    variance of the two principal curvatures, the design's A-optimal choice.  Probe i's rows
    of eq. 33 give S = (K1 + K2~)^-1 the covariance s^2 (A^T A)^-1; a principal value
    s_w = w^T S w the variance g^T C g, g = (w_x^2, 2 w_x w_y, w_y^2); kappa = 1/s - 1/R1 that
    over s^4.  A roll along w adds eq. 33's rows for a = |a| w, measuring S w.
    """
    th = np.asarray(dtheta, float).reshape(-1, 2)
    p = np.asarray(dp, float).reshape(-1, 2)
    a = np.column_stack([-th[:, 1], th[:, 0]])  # each probe's motion direction x angle
    if len(a) == 0:
        return _roll(np.array([1.0, 0.0]), "seed: along x")
    norms = np.linalg.norm(a, axis=1)
    dirs = a[norms > 0] / norms[norms > 0, None]
    if len(dirs) < 2 or np.linalg.svd(dirs, compute_uv=False)[-1] < 1e-3:
        base = dirs[0] if len(dirs) else np.array([0.0, 1.0])
        return _roll(np.array([-base[1], base[0]]), "seed: across the directions rolled")
    A = _eq33_rows(a)
    b = np.concatenate([finger_radius * p[:, 0], finger_radius * math.cos(u0) * p[:, 1]])
    k, *_ = np.linalg.lstsq(A, b, rcond=None)
    s, vec = np.linalg.eigh(np.array([[k[0], k[1]], [k[1], k[2]]]))
    g = np.stack([vec[0] ** 2, 2 * vec[0] * vec[1], vec[1] ** 2]) / np.maximum(s**2, 1e-300)
    rolls = (np.vstack([A, _eq33_rows(np.mean(norms) * vec[:, j][None])]) for j in (0, 1))
    total = [np.einsum("ij,ik,kj->", g, np.linalg.pinv(m.T @ m), g) for m in rolls]
    best = int(np.argmin(total))  # (the total variance of kappa_1, kappa_2 after each roll)
    kappa = 1.0 / s[best] - 1.0 / finger_radius if s[best] != 0 else math.inf
    return _roll(vec[:, best], f"along the principal direction that tells most (curvature"
                 f" {kappa:.3g})")  # fmt: skip


def _eq33_rows(a):
    """Eq. 33's two rows per probe, a = (-dtheta_y, dtheta_x) (k, 2), in (k1, k2, k3)."""
    return np.concatenate([np.pad(a, ((0, 0), (0, 1))), np.pad(a, ((0, 0), (1, 0)))])


def _roll(motion, why):
    m = np.asarray(motion, float) / np.linalg.norm(motion)
    m = -m if m[0] < 0 or (m[0] == 0 and m[1] < 0) else m  # (a direction, not a sense)
    return math.atan2(-m[0], m[1]), (float(m[0]), float(m[1])), why
