"""The centre jet's two models of equal size (``centre_jet`` step 4), for a stack of patches.

``quadric``: the 3-jet (Taylor polynomial), one linear solve.  ``round_model``: its
quadratic part replaced by the closed form exact for spheres and cylinders
(``jet_basis.round_excess``), by Gauss-Newton from a start kept inside the closed form's
rim.
"""

from dataclasses import dataclass

import numpy as np

from tactile.ep2 import batch_lstsq, jet_basis, jet_rows

GN_MAX_STEPS = 12  # Gauss-Newton steps for 'round' at most; it stops once every step is tiny
GN_TOL = 1e-12  # ... relative to the coefficients
START_Q2 = 0.8  # a start beyond the closed form's rim is scaled to reach this Q2 at most


@dataclass
class Model:
    sol: batch_lstsq.Solution
    jac: np.ndarray  # (B, 3n, p) design (round: linearised at the solution)
    ok: np.ndarray  # (B,) usable (round: every contact inside the closed form's rim)


def both(rows, mask, start=None):
    """The quadric and the round model on the same rows (round from ``start`` or the quadric)."""
    quad = quadric(rows)
    return quad, round_model(rows, mask, quad.sol.coef if start is None else start)


def quadric(rows):
    return Model(batch_lstsq.solve(rows.A, rows.b, rows.w), rows.A, np.ones(len(rows.b), bool))


def round_model(rows, mask, coef):
    """Gauss-Newton on the 'round' model from ``coef``, per patch until every step is below
    ``GN_TOL`` (at most ``GN_MAX_STEPS``): a patch that has converged leaves the batch, so it
    gets the iterations it would get alone; its last solve only linearises at its final
    iterate.  The iterates of a patch its contacts do not determine (two points, say) may
    overflow: ``batch_lstsq`` gives it NaN, ``ok`` is False, and it is refused later."""
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        return _gauss_newton(rows, mask, coef)


def _gauss_newton(rows, mask, coef):
    x, y, b, w, A = rows.x, rows.y, rows.b, rows.w, rows.A
    cols = list(jet_basis.HESSIAN)
    coef = _inside_rim(coef, x, y, mask, START_Q2)
    todo = np.arange(len(coef))
    parts, J_all, r_all = [], np.empty_like(A), np.empty_like(b)
    for step in range(GN_MAX_STEPS + 1):
        xs, ys, c, T = x[todo], y[todo], coef[todo], rows.T[todo]
        H = jet_basis.hessian(c)
        J = A[todo]  # a copy: the residual first, then the round part's columns added
        excess, jac = jet_basis.round_rows_jacobian(xs, ys, H)
        r = b[todo] - np.einsum("bmp,bp->bm", J, c) - rows.whiten(excess, T)
        J[..., cols] += rows.whiten(jac, T)
        sol = batch_lstsq.solve(J, r, w[todo])
        tiny = np.abs(sol.coef) <= GN_TOL * np.maximum(np.abs(c), 1.0)
        done = np.all(tiny | ~np.isfinite(sol.coef), axis=1) | (step == GN_MAX_STEPS)
        parts.append((todo[done], batch_lstsq.take(sol, done)))
        J_all[todo[done]], r_all[todo[done]] = J[done], r[done]
        go = ~done
        coef[todo[go]] = _step(c[go], sol.coef[go], xs[go], ys[go], mask[todo[go]])
        todo = todo[go]
        if not todo.size:
            break
    sol = batch_lstsq.merge(parts, len(coef))
    # the last solve only linearises at the iterate: keep the iterate and its own residual
    sol.coef, sol.residual = coef, r_all * w
    sol.rss = np.einsum("bm,bm->b", sol.residual, sol.residual)
    ok = jet_basis.round_valid(x, y, jet_basis.hessian(coef), mask) & np.all(np.isfinite(coef), 1)
    return Model(sol, J_all, ok)


def _inside_rim(coef, x, y, mask, limit):
    """Scale the Hessian of a start whose closed form passes the rim (a quadric fit of a
    tight cylinder overestimates its curvature) so the contacts reach Q2 = ``limit``."""
    q = jet_basis.max_q2(x, y, jet_basis.hessian(coef), mask)
    beyond = ~(q < jet_basis.ROUND_MAX_Q2)
    shrink = np.where(beyond, np.sqrt(limit / np.maximum(q, 1e-300)), 1.0)
    out = coef.copy()
    out[:, list(jet_basis.HESSIAN)] *= shrink[:, None]
    return out


def _step(coef, step, x, y, mask):
    """coef + step, the step halved (up to 8 times) where it would cross the rim."""
    scale = np.ones(len(coef))
    for _ in range(8):
        trial = coef + scale[:, None] * step
        bad = ~(jet_basis.max_q2(x, y, jet_basis.hessian(trial), mask) < jet_basis.ROUND_MAX_Q2)
        if not bad.any():
            break
        scale = np.where(bad, 0.5 * scale, scale)
    return coef + scale[:, None] * step


def refit_rows(p, nrm, mask, sig):
    """Rows of the current frame whitened with the geometry of a first quadric fit."""
    rows = jet_rows.make(p, nrm, mask, sig)
    return jet_rows.make(p, nrm, mask, sig, jet_rows.geometry(rows, quadric(rows).sol.coef))
