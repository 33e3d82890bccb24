"""What the default fit's answer may miss beyond its noise (``local_jet``, item 6 of its
docstring): the Wald test of two jets' difference, the positive part of a measured bias,
and the size of the terms a jet leaves out, from a sphere's or cylinder's of the measured
curvature.  Functions of the fit ``local_jet.JetFit`` (``Q``, ``Rinv``, ``cn``, ``Aw``)."""

import numpy as np

from tactile.ep2.jet_terms import mv, size, vm


def wald(d, V):
    """d^T V^+ d and V's rank, per patch (V symmetric positive semi-definite)."""
    w, U = np.linalg.eigh(V)
    big = w > 1e-9 * np.maximum(w[:, -1:], 1e-300)
    proj = vm(d, U)
    return np.sum(np.where(big, proj * proj / np.where(big, w, 1.0), 0.0), -1), big.sum(-1)


def positive(M):
    """M's positive part (symmetric): its negative eigenvalues set to 0."""
    w, U = np.linalg.eigh(0.5 * (M + np.swapaxes(M, -1, -2)))
    return (U * np.maximum(w, 0.0)[:, None, :]) @ np.swapaxes(U, -1, -2)


def omitted(f, coefs, cov, top):
    """(B, 5): how the jet's (zx, zy, zxx, zxy, zyy) would move were the order above the top
    in the data, its coefficients as large as a sphere or cylinder of the measured
    curvature makes them: a circle's derivatives are k, 3 k^3, 45 k^5, so the order
    beyond 4 is 5 z4^2 / z2 (z_j: the rms of the j-th derivatives, their noise taken out)
    and beyond 3 it is 3 z2^3."""
    B = len(top)
    out = np.zeros((B, 5))
    z2 = signal(coefs[2][:, 3:6], cov[2][:, 2:5, 2:5])
    for o in np.unique(top):
        sel = top == o
        nxt = o + 1
        cols = slice(size(o), size(nxt))
        if o >= 4:
            c4 = coefs[o][sel][:, size(3) : size(4)]
            F4 = fit_cov(f, o, sel)[:, size(3) : size(4), size(3) : size(4)]
            z4 = signal(c4, F4)
            tau = 5.0 * z4 * np.minimum(z4 / np.maximum(z2[sel], 1e-12), 12.0)
        else:
            tau = 3.0 * z2[sel] ** 3
        G = regress_omitted(f, o, cols, sel)  # (b, p_o, q)
        out[sel] = tau[:, None] * np.sqrt(np.sum(G[:, 1:6] ** 2, -1))
    return out


def round_bias(f, coefs, cov):
    """(B, 5): how far the 2-jet's values move from those of the surface whose shape operator
    is the measured Hessian H everywhere, its quartic left out: to fourth order that surface
    is z = p + p r / 8, p = x^T H x, r = x^T H^2 x (exact for spheres and cylinders; the
    spline's ``uncertainty.model_bias`` uses the same surface).  Its quartic, mapped through
    the 2-jet's regression on the omitted columns, is the shift."""
    zxx, zxy, zyy = np.moveaxis(coefs[2][:, 3:6], -1, 0)
    p20, p11, p02 = zxx, 2.0 * zxy, zyy
    r20, r11, r02 = zxx * zxx + zxy * zxy, 2.0 * zxy * (zxx + zyy), zxy * zxy + zyy * zyy
    quartic = np.stack([  # derivatives at 0 (x^i y^j / (i! j!) columns) of p r / 8
        24.0 * p20 * r20, 6.0 * (p20 * r11 + p11 * r20),
        4.0 * (p20 * r02 + p11 * r11 + p02 * r20), 6.0 * (p11 * r02 + p02 * r11),
        24.0 * p02 * r02,
    ], -1) / 8.0  # fmt: skip
    G = regress_omitted(f, 2, slice(size(3), size(4)), np.ones(len(zxx), bool))
    if G.shape[-1] < 5:  # (too few contacts for a 3-jet: no quartic columns built)
        return np.zeros((len(zxx), 5))
    return np.abs(mv(G[:, 1:6], quartic))


def signal(c, C):
    """The rms of coefficients c (b, q) with their noise (cov C (b, q, q)) taken out."""
    noise = np.trace(C, axis1=-2, axis2=-1) / c.shape[-1]
    return np.sqrt(np.maximum(np.mean(c * c, -1) - noise, 0.0))


def fit_cov(f, o, sel):
    p = size(o)
    F = f.Rinv[sel][:, :p, :p] / f.cn[sel][:, :p, None]
    return F @ np.swapaxes(F, -1, -2)


def regress_omitted(f, o, cols, sel):
    """Coefficients of the omitted columns ``cols`` regressed on the order-o jet's, (b, p_o, q):
    how each omitted term, were it there with coefficient 1, moves the fit."""
    p = size(o)
    Rinv, cn = f.Rinv[sel][:, :p, :p], f.cn[sel]
    X = np.swapaxes(f.Q[sel][..., :p], -1, -2) @ f.Aw[sel][..., cols]
    return Rinv @ X / cn[:, :p, None]
