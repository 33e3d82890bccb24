"""Local jets about the patch centre, and the closed-form surface of constant curvature.

A jet of order q is the Taylor polynomial z = sum c_ij x^i y^j / (i! j!) over
i + j <= q, so its coefficients ARE the partial derivatives at the centre:
c_10 = z_x, c_01 = z_y, c_20 = z_xx, c_11 = z_xy, c_02 = z_yy (``CHANNELS``,
columns 1-5 for every order >= 2).  Rows come in the thesis's three kinds
(§4.6): positions z, and the slopes dz/dx, dz/dy read off the normals (§4.5.1).

``round_excess`` is what the constant-curvature surface adds to the quadric.
In the frame whose z axis is the surface normal at the origin, a sphere or a
cylinder of any axis (and radius 1/k) is exactly

    z = Q1 / (1 + sqrt(1 - Q2)),   Q1 = d^T H d,  Q2 = d^T H^2 d,

with H the Hessian at the origin (H = -k I for a sphere convex toward +z,
-k e e^T for a cylinder across e).  Check: a sphere gives
-k r^2 / (1 + sqrt(1 - k^2 r^2)) = -(1/k)(1 - sqrt(1 - k^2 r^2)).  Its Taylor
series is Q1/2 + Q1 Q2/8 + Q1 Q2^2/16 + ..., which is the model-bias surface of
the previous version (docs/ep2.md) carried to all orders.  Everything here
broadcasts over leading (batch) axes.
"""

import numpy as np

CHANNELS = (1, 2, 3, 4, 5)  # columns of z_x, z_y, z_xx, z_xy, z_yy in every jet of order >= 2
HESSIAN = (3, 4, 5)  # columns of z_xx, z_xy, z_yy
ROUND_MAX_Q2 = 0.999  # Q2 = |H d|^2 = sin^2 of the normal's turn; beyond this the closed form ends
_STEP = 1e-20  # complex step


def monomials(order):
    """Exponents (i, j) by total degree, x first: (0,0), (1,0), (0,1), (2,0), (1,1), (0,2), ..."""
    return [(i, d - i) for d in range(order + 1) for i in range(d, -1, -1)]


def n_coef(order):
    return (order + 1) * (order + 2) // 2


def order_of(p):
    """Jet order with ``p`` coefficients."""
    q = 0
    while n_coef(q) < p:
        q += 1
    return q


def design(x, y, order, derivs=((0, 0), (1, 0), (0, 1))):
    """Rows of the order-``order`` jet at (x, y) for each derivative in ``derivs``.

    x, y: (..., n).  Returns (..., len(derivs) * n, p): the blocks stacked in
    the order of ``derivs`` (default: positions, x-slopes, y-slopes).
    """
    x, y = np.asarray(x, float), np.asarray(y, float)
    mons = monomials(order)
    top = order + 1
    xp, yp = _scaled_powers(x, top), _scaled_powers(y, top)  # x^k / k!
    n = x.shape[-1]
    out = np.zeros(x.shape[:-1] + (len(derivs) * n, len(mons)))
    for b, (dx, dy) in enumerate(derivs):
        rows = out[..., b * n : (b + 1) * n, :]
        for col, (i, j) in enumerate(mons):
            if i >= dx and j >= dy:
                rows[..., col] = xp[i - dx] * yp[j - dy]
    return out


def _scaled_powers(v, top):
    """[v^k / k! for k < top] (Taylor basis: the jet's columns are products of two)."""
    out = [np.ones_like(v)]
    for k in range(1, top):
        out.append(out[-1] * v / k)
    return out


def hessian(coef):
    """(..., 2, 2) Hessian at the centre from jet coefficients (..., p)."""
    a, b, c = (coef[..., k] for k in HESSIAN)
    return np.stack([np.stack([a, b], -1), np.stack([b, c], -1)], -2)


def round_excess(x, y, H):
    """(excess z, its x-slope, its y-slope) of the constant-curvature surface over the quadric.

    x, y: (..., n); H: (..., 2, 2).  Q2 is clamped below ``ROUND_MAX_Q2`` (past the
    surface's rim).  With u = a x + b y, v = b x + c y (H d = (u, v)): Q1 = x u + y v,
    Q2 = u^2 + v^2, H^2 d = (a u + b v, b u + c v).
    """
    a, b, c = (H[..., 0, 0, None], H[..., 0, 1, None], H[..., 1, 1, None])
    u, v = a * x + b * y, b * x + c * y
    q1, q2 = x * u + y * v, u * u + v * v
    root = np.sqrt(1.0 - np.minimum(q2, ROUND_MAX_Q2))
    inv = 1.0 / (1.0 + root)
    # d z = d Q1 / (1 + s) + Q1 d Q2 / (2 s (1 + s)^2), s = sqrt(1 - Q2)
    k = q1 * inv * inv / (2.0 * root)
    wx, wy = a * u + b * v, b * u + c * v
    zx = 2 * u * inv + 2 * k * wx
    zy = 2 * v * inv + 2 * k * wy
    return q1 * inv - 0.5 * q1, zx - u, zy - v


def round_second(x, y, H):
    """(z_xx, z_xy, z_yy) of ``round_excess`` at (x, y): complex steps of its slopes."""
    _, zx, _ = round_excess(x + 1j * _STEP, y.astype(complex), H.astype(complex))
    _, zx_y, zy_y = round_excess(x.astype(complex), y + 1j * _STEP, H.astype(complex))
    return zx.imag / _STEP, zx_y.imag / _STEP, zy_y.imag / _STEP
