"""The patch frame, the jet's terms, and the differential geometry of a height field.

**Frame** (§4.1 step 2, §5.1.2): z is the outward mean normal (normals point from the
object toward the finger), the origin the contacts' centroid, x the world x axis projected
onto the tangent plane (world y if x is nearly normal).  In that frame the slopes
dz/dx = -nx/nz, dz/dy = -ny/nz stay finite.

**Jet terms**: monomials x^i y^j / (i! j!) by degree and their rows (value, d/dx, d/dy),
shared by the default fit (``local_jet``), its answers and its consistency test, and the
batched matrix-vector products they use.

**Geometry of z = f(x, y)** (§2.2, eqs. 5-16).  Sign convention (§5.1.2): curvatures are
POSITIVE where the surface is convex toward the finger.  With the textbook second
fundamental form L = f_xx / W taken against the +z normal a cap z = -r^2/(2R) has
curvature -1/R, so here L, M, N are taken against the inward normal: L = -f_xx / W.
Principal curvatures come from the shape operator written as a symmetric 2x2 matrix
P = C^-1 II C^-T in an orthonormal tangent basis (C the Cholesky factor of the first
fundamental form I = C C^T).  Its eigenvalues k = m +/- hypot((a - c)/2, b), m = (a + c)/2,
are exact at umbilics and planes: no k1 - k2 division, no square root of a negative
round-off.

**Grid statistics** (§4.8.2, ``grid_stats``): means and sds of k1, k2, R, S and C over the
N x N grid, for both methods.
"""

import functools
from dataclasses import dataclass

import numpy as np

from tactile.errors import DataError


def principal(zx, zy, zxx, zxy, zyy):
    """Curvature quantities of z = f(x, y) from its partial derivatives.

    All inputs broadcast together.  Returns a dict of arrays: ``k1 >= k2``
    (principal curvatures), ``H`` (mean), ``K`` (Gaussian), ``dir1`` (unit 3-D
    direction of k1 in the same frame, last axis x, y, z), ``E, F, G`` and
    ``L, M, N`` (fundamental forms, eqs. 5-9).
    """
    a, b, c, basis = shape_operator(zx, zy, zxx, zxy, zyy)
    m = 0.5 * (a + c)
    h = np.hypot(0.5 * (a - c), b)
    k1 = m + h
    k2 = m - h
    theta = 0.5 * np.arctan2(2.0 * b, a - c)  # angle of k1's eigenvector of P
    e1, e2 = basis
    d = np.cos(theta)[..., None] * e1 + np.sin(theta)[..., None] * e2
    return {"k1": k1, "k2": k2, "H": m, "K": k1 * k2, "dir1": d}


def shape_operator(zx, zy, zxx, zxy, zyy):
    """Symmetric shape-operator entries (a, b, c) and its orthonormal 3-D basis.

    The tangent vectors are X_x = (1, 0, zx) and X_y = (0, 1, zy).  With
    I = [[E, F], [F, G]] = C C^T, C = [[sqrt E, 0], [F/sqrt E, W/sqrt E]]
    (W^2 = EG - F^2 = 1 + zx^2 + zy^2), the orthonormal basis is
    e1 = X_x / sqrt E and e2 = (E X_y - F X_x) / (sqrt E W).
    """
    zx, zy, zxx, zxy, zyy = np.broadcast_arrays(
        *(np.asarray(v, float) for v in (zx, zy, zxx, zxy, zyy))
    )
    E = 1.0 + zx * zx
    F = zx * zy
    W2 = E + zy * zy
    W = np.sqrt(W2)
    L = -zxx / W
    M = -zxy / W
    N = -zyy / W
    sE = np.sqrt(E)
    # C^-1 = [[1/sE, 0], [-F/(sE W), sE/W]];  P = C^-1 II C^-T
    a = L / E
    b = (E * M - F * L) / (E * W)
    c = (F * F * L - 2.0 * E * F * M + E * E * N) / (E * W2)
    one = np.ones_like(zx)
    zero = np.zeros_like(zx)
    e1 = np.stack([one, zero, zx], axis=-1) / sE[..., None]
    xy = np.stack([-F, E, E * zy - F * zx], axis=-1)
    e2 = xy / (sE * W)[..., None]
    return a, b, c, (e1, e2)


def curvatures(zx, zy, zxx, zxy, zyy):
    """Only (k1, k2) - the fast path used on the grid."""
    return eigen(*shape_entries(zx, zy, zxx, zxy, zyy))


def eigen(a, b, c):
    """(k1, k2) of the symmetric matrix [[a, b], [b, c]]: m +/- sqrt(((a - c)/2)^2 + b^2).

    The root of a sum of squares is never negative, so umbilics (a = c, b = 0)
    give k1 = k2 exactly.  (np.hypot would also guard overflow beyond 1e154,
    which normalised patch curvatures never reach, at four times the cost.)
    """
    m = 0.5 * (a + c)
    d = 0.5 * (a - c)
    h = np.sqrt(d * d + b * b)
    return m + h, m - h


def shape_entries(zx, zy, zxx, zxy, zyy):
    """Entries (a, b, c) of the symmetric shape operator P (see ``shape_operator``).

    a = L/E, b = (E M - F L)/(E W), c = (F^2 L - 2 E F M + E^2 N)/(E W^2) with
    L, M, N = -(zxx, zxy, zyy)/W, written with few temporaries (hot path).
    """
    E = 1.0 + zx * zx
    F = zx * zy
    W2 = E + zy * zy
    q = 1.0 / (E * np.sqrt(W2))  # 1/(E W)
    a = -zxx * q
    q /= W2  # 1/(E W^3)
    Fzxx = F * zxx
    b = (Fzxx - E * zxy) * (q * np.sqrt(W2))
    c = -(F * (Fzxx - 2.0 * E * zxy) + E * E * zyy) * q
    return a, b, c


# --- Koenderink's shape index S, curvedness R and C, and the HK sign labels (§2.4).
#
# With k1 >= k2 and curvature positive where convex toward the finger, S = (2/pi) atan2(k1 + k2,
# k1 - k2): sphere +1, cylinder +0.5, symmetric saddle 0, concave cylinder -0.5, pit -1. atan2
# needs no division by k1 - k2 (which is 0 at umbilics). Thesis eq. 17 writes S = -(2/pi)
# atan((kmax+kmin)/(kmax-kmin)): the opposite sign, because its curvatures are negative on convex
# surfaces, and its R is garbled; here R = sqrt((k1^2 + k2^2)/2) and C = (2/pi) ln R (eq. 18).


TWO_OVER_PI = 2.0 / np.pi

# Table 2 (eight primitives).  Keys: (sign K, sign H) with signs in {-1, 0, 1}.
HK_TABLE2 = {
    (-1, -1): "saddle_valley",
    (-1, 0): "minimal_saddle",
    (-1, 1): "saddle_ridge",
    (0, -1): "valley",
    (0, 0): "flat",
    (0, 1): "ridge",
    (1, -1): "pit",
    (1, 1): "peak",
}
# Table 1 (four primitives, no zero band).
HK_TABLE1 = {
    (-1, -1): "saddle_valley",
    (-1, 1): "saddle_ridge",
    (1, -1): "concave",
    (1, 1): "convex",
}


def shape_index(k1, k2):
    """S in [-1, 1] (eq. 17, sign as above).  Undefined (returned 0) at planes."""
    return TWO_OVER_PI * np.arctan2(k1 + k2, k1 - k2)


def curvedness_r(k1, k2):
    """R = sqrt((k1^2 + k2^2) / 2) without overflow (eq. 17)."""
    return np.hypot(k1, k2) * np.sqrt(0.5)


def curvedness_c(r):
    """C = (2/pi) ln R (eq. 18); only call with R > 0."""
    return TWO_OVER_PI * np.log(r)


def hk_labels(K, H, eps_k=0.0, eps_h=0.0, table=2):
    """HK primitive names (table 1 or 2) for arrays of K and H (0-d for one pair).

    With table 2, K > 0 with H = 0 cannot occur (K <= H^2); a sign pattern
    the table lacks (round-off, or table 1 with a zero sign) reads "flat".
    """
    names = _HK_NAMES[table == 2]
    if np.ndim(K) == 0 and np.ndim(H) == 0:  # one pair (a patch's label): Python floats
        return np.array(hk_label(K, H, eps_k, eps_h, table), dtype=object)
    sk = (K > eps_k).astype(int) - (K < -eps_k)  # signs with zero bands |K| <= eps_k ...
    sh = (H > eps_h).astype(int) - (H < -eps_h)  # ... and |H| <= eps_h
    return names[3 * sk + sh + 4]


def hk_label(K, H, eps_k=0.0, eps_h=0.0, table=2):
    """``hk_labels`` of one pair, a str (Python floats: no array for one patch's label)."""
    k, h, ek, eh = float(K), float(H), float(eps_k), float(eps_h)
    return str(_HK_NAMES[table == 2][3 * ((k > ek) - (k < -ek)) + (h > eh) - (h < -eh) + 4])


_HK_NAMES = tuple(
    np.array([t.get((k, h), "flat") for k in (-1, 0, 1) for h in (-1, 0, 1)], dtype=object)
    for t in (HK_TABLE1, HK_TABLE2)
)


# S regions (6.2.4, fig. 50): the S axis cut into Koenderink's named bands.
S_REGIONS = (
    (-1.0, -0.75, "concave_sphere"),
    (-0.75, -0.25, "concave_cylinder"),
    (-0.25, 0.25, "saddle"),
    (0.25, 0.75, "cylinder"),
    (0.75, 1.0, "sphere"),
)
S_EDGES = np.array([-0.75, -0.25, 0.25, 0.75])
S_NAMES = tuple(name for _, _, name in S_REGIONS)


def s_class(s):
    """Index into ``S_NAMES`` of each S value."""
    return np.searchsorted(S_EDGES, s, side="right")


def s_region_map(s):
    """Array of S-region names for a map of S values (fig. 50)."""
    names = np.array(S_NAMES, dtype=object)
    return names[s_class(np.asarray(s))]


MAX_NORMAL_ANGLE_DEG = 80.0


@dataclass(frozen=True)
class PatchFrame:
    """Rigid frame: ``rot`` rows are the patch x, y, z axes in world coordinates."""

    origin: np.ndarray
    rot: np.ndarray

    def to_patch(self, points):
        return (np.asarray(points, float) - self.origin) @ self.rot.T

    def to_patch_dirs(self, vectors):
        return np.asarray(vectors, float) @ self.rot.T

    def to_world(self, points):
        return np.asarray(points, float) @ self.rot + self.origin

    def to_world_dirs(self, vectors):
        return np.asarray(vectors, float) @ self.rot

    def rotated_about_z(self, angle):
        """The same frame turned by ``angle`` (rad) about its own z axis (§4.10 refit)."""
        c, s = np.cos(angle), np.sin(angle)
        turn = np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])
        return PatchFrame(self.origin, turn @ self.rot)


def unit_normals(normals):
    """Normalise rows; zero-length rows raise ``DataError`` naming the row index."""
    n, ok = unit_rows(normals)
    bad = np.flatnonzero(~ok)
    if bad.size:
        raise DataError(f"normal of contact {bad[0]} has zero length")
    return n


def unit_rows(normals):
    """(rows (..., 3) made unit, (...) whether each was non-zero: a zero or non-finite row
    is left as it is).  A row far from unit length (1e-300 or 1e300) is first divided by
    its largest component, so the squares in its norm neither overflow nor underflow."""
    n = np.asarray(normals, float)
    big = np.max(np.abs(n), axis=-1) if n.size else np.zeros(n.shape[:-1])
    ok = (big > 0) & (big < np.inf)
    big = np.where(ok, big, 1.0)[..., None]
    n = np.where((big > 1e-100) & (big < 1e100), n, n / big)
    norm = np.linalg.norm(n, axis=-1)[..., None]
    return np.where(ok[..., None], n / np.where(ok[..., None], norm, 1.0), n), ok


def frame_from_contacts(points, normals):
    """Patch frame from contacts and UNIT normals (z = normalised mean normal)."""
    mean = normals.mean(axis=0)
    norm = np.linalg.norm(mean)
    if norm < 1e-6:
        raise DataError(
            "normals inconsistent with one patch: they cancel out (mean normal is zero)"
        )
    ez = mean / norm
    ref = np.array([1.0, 0.0, 0.0]) if abs(ez[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    ex = ref - (ref @ ez) * ez
    ex /= np.linalg.norm(ex)
    ey = np.cross(ez, ex)
    return PatchFrame(np.asarray(points, float).mean(axis=0), np.vstack([ex, ey, ez]))


def slopes(normals_patch, max_angle_deg=MAX_NORMAL_ANGLE_DEG, lines=None):
    """dz/dx = -nx/nz, dz/dy = -ny/nz (§4.5.1) for unit normals in the patch frame.

    A normal more than ``max_angle_deg`` from the patch z axis makes the
    height-field model unusable there: ``DataError`` naming the contact.
    """
    nz = normals_patch[:, 2]
    limit = np.cos(np.radians(max_angle_deg))
    bad = np.flatnonzero(nz < limit)
    if bad.size:
        i = bad[0]
        angle = np.degrees(np.arccos(np.clip(nz[i], -1.0, 1.0)))
        where = f"line {lines[i]}" if lines is not None else f"contact {i}"
        raise DataError(
            f"normals inconsistent with one patch: {where} is {angle:.1f} deg from the mean normal"
            f" (limit {max_angle_deg:g} deg; split the sweep or check the normals' sign)"
        )
    return -normals_patch[:, 0] / nz, -normals_patch[:, 1] / nz


def exponents(order):
    """(i, j) of the jet's monomials x^i y^j, by degree (the column order)."""
    return [(i, d - i) for d in range(order + 1) for i in range(d, -1, -1)]


def size(order):
    return (order + 1) * (order + 2) // 2


def rows(x, y, order, dx=0, dy=0):
    """Rows of d^(dx+dy)/dx^dx dy^dy of the jet sum c_ij x^i y^j / (i! j!), (..., p): with
    this scaling a derivative only shifts the exponents (zero where they would go negative),
    and the coefficients are the jet's derivatives at the centre."""
    px, py = powers(x, order), powers(y, order)
    zero = np.zeros_like(x)
    out = [px[i - dx] * py[j - dy] if i >= dx and j >= dy else zero for i, j in exponents(order)]
    return np.stack(out, -1)


def powers(x, order):
    """[x^k / k!] for k = 0..order."""
    out = [np.ones_like(x)]
    for k in range(1, order + 1):
        out.append(out[-1] * x / k)
    return out


def design(x, y, order):
    """Rows of the jet's value, d/dx and d/dy: three (..., n, p) arrays for x, y (..., n)
    (views of ``stacked_design``'s)."""
    A, n = stacked_design(x, y, order), np.shape(x)[-1]
    return A[..., :n, :], A[..., n : 2 * n, :], A[..., 2 * n :, :]


def stacked_design(x, y, order):
    """(..., 3n, p): ``rows`` of the value, d/dx and d/dy of points x, y (..., n), one above
    the other.  Each term is the product of one power of x and one of y, as in ``rows``; a
    derivative's column is the value's column of the shifted exponents (or 0), so every
    product is taken once."""
    x, y = np.asarray(x, float), np.asarray(y, float)
    i, j, dx, dy = _terms(order)
    n, p = x.shape[-1], len(i)
    px, py = np.stack(powers(x, order), -1), np.stack(powers(y, order), -1)
    value = np.empty((*x.shape, p + 1))
    value[..., p] = 0.0  # (the column a shifted exponent below 0 reads)
    np.multiply(px[..., i], py[..., j], out=value[..., :p])
    A = np.empty((*x.shape[:-1], 3 * n, p))
    A[..., :n, :] = value[..., :p]
    A[..., n : 2 * n, :] = value[..., dx]
    A[..., 2 * n :, :] = value[..., dy]
    return A


@functools.lru_cache(maxsize=16)
def _terms(order):
    """The exponents (i, j) of ``exponents(order)`` as two index arrays, and per term the
    column of the same jet holding x^(i-1) y^j (d/dx) and x^i y^(j-1) (d/dy): p for none."""
    ex = exponents(order)
    at = {e: k for k, e in enumerate(ex)}
    p = len(ex)
    i, j = (np.array(v) for v in zip(*ex, strict=True))
    dx = np.array([at[(a - 1, b)] if a else p for a, b in ex])
    dy = np.array([at[(a, b - 1)] if b else p for a, b in ex])
    return i, j, dx, dy


def mv(M, v):
    """Batched matrix times vector: (B, m, p) @ (B, p) -> (B, m)."""
    return (M @ v[..., None])[..., 0]


def vm(v, M):
    """Batched vector times matrix: (B, m) @ (B, m, p) -> (B, p)."""
    return (v[:, None, :] @ M)[:, 0]


def unit(v):
    n = np.linalg.norm(v, axis=-1, keepdims=True)
    return v / np.where(n > 0, n, 1.0)


def pick(by_order, which):
    """Per patch, the entry of ``by_order`` (order -> (B, ...)) at that patch's order."""
    out = np.array(next(iter(by_order.values())), copy=True)
    for o, v in by_order.items():
        sel = which == o
        if sel.any():
            out[sel] = v[sel]
    return out


# --- The thesis's grid statistics (§4.8.2) for a whole stack of centre-jet fits at once.
#
# Per patch: the fitted surface's (z_x, z_y, z_xx, z_xy, z_yy) on an N x N grid over the contacts'
# box (final frame, / L), then mean and sd of k1, k2, R, S and C over the grid points where the
# surface is finite (a steep fit can overflow far from the centre).  The spline's one patch is
# a stack of one.


@dataclass
class GridStats:
    """The thesis's statistics over the N x N grid (§4.8.2, ``grid_stats``), input unit; S
    and C None for a plane, all None where no grid point is finite."""

    R_mean: float | None = None
    R_std: float | None = None
    k1_mean: float | None = None
    k2_mean: float | None = None
    k1_std: float | None = None
    k2_std: float | None = None
    S_mean: float | None = None
    S_std: float | None = None
    C_mean: float | None = None


DERIVS = ((1, 0), (0, 1), (2, 0), (1, 1), (0, 2))
KEYS = ("R_mean", "R_std", "k1_mean", "k2_mean", "k1_std", "k2_std", "S_mean", "S_std", "C_mean")


def grid_stats(ch, scale, planes):
    """[``GridStats``] per patch of a stack: ch the (zx, zy, zxx, zxy, zyy) channels on the
    grid (each (B, N^2), in units of the patch), scale (B,) L, planes (B,) whether the
    patch is labelled a plane.  Means and sds over the grid points where the surface is
    finite; C_mean over those with R > 0."""
    with np.errstate(over="ignore", invalid="ignore"):
        k1, k2 = eigen(*shape_entries(*ch))
    ok = np.isfinite(k1) & np.isfinite(k2)
    k1, k2 = np.where(ok, k1, 0.0), np.where(ok, k2, 0.0)
    r = curvedness_r(k1, k2)
    m = {}
    for name, v in (("k1", k1), ("k2", k2), ("R", r), ("S", shape_index(k1, k2))):
        m[name + "_mean"], m[name + "_std"] = _mean_sd(v, ok)
    pos = ok & (r > 0)
    c = np.where(pos, curvedness_c(np.where(pos, r, 1.0) / scale[:, None]), 0.0)
    m["C_mean"], _ = _mean_sd(c, pos)
    per_length = (np.stack([m[k] for k in KEYS[:6]], -1) / scale[:, None]).tolist()
    m = {k: np.asarray(m[k]).tolist() for k in KEYS[6:]}
    out = []
    for i, (any_ok, any_pos, plane) in enumerate(zip(ok.any(-1), pos.any(-1), planes, strict=True)):
        if not any_ok:
            out.append(GridStats())
            continue
        d = GridStats(*per_length[i])  # (``KEYS``' order: the first six, over L)
        if not plane:
            d.S_mean, d.S_std = float(m["S_mean"][i]), float(m["S_std"][i])
            d.C_mean = float(m["C_mean"][i]) if any_pos else None
        out.append(d)
    return out


def _mean_sd(v, ok):
    """Mean and population sd of ``v`` over ``ok`` along the last axis (two passes)."""
    count = np.maximum(ok.sum(axis=-1), 1)
    mean = np.where(ok, v, 0.0).sum(axis=-1) / count
    dev = np.where(ok, v - mean[..., None], 0.0)
    return mean, np.sqrt((dev * dev).sum(axis=-1) / count)


# Student's t 97.5 % quantile for 1-10 degrees of freedom (Cornish-Fisher beyond)
_T975 = (12.706, 4.303, 3.182, 2.776, 2.571, 2.447, 2.365, 2.306, 2.262, 2.228)
Z975 = 1.959964  # the normal's 97.5 % quantile


def t975(dof):
    """Student's t 97.5 % quantile for ``dof`` (array or number, at least 1): the table to
    10, Cornish-Fisher beyond (within 0.1 %); ``Z975`` at infinity."""
    dof = np.maximum(np.asarray(dof, float), 1.0)
    z = Z975
    cf = z + (z**3 + z) / (4 * dof) + (5 * z**5 + 16 * z**3 + 3 * z) / (96 * dof**2)
    small = np.take(_T975, np.minimum(np.where(np.isfinite(dof), dof, 10), 10).astype(int) - 1)
    return np.where(dof <= 10, small, cf)
