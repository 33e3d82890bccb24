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
LINEARISE_TOL = 1e-6  # a final step taken without the solve after it is at most this large
START_Q2 = 0.8  # a start beyond the closed form's rim is scaled to reach this Q2 at most


@dataclass
class Model:
    sol: batch_lstsq.Solution
    jac: np.ndarray  # (B, 3n, p) design (round: linearised at the solution)
    ok: np.ndarray  # (B,) usable (round: every contact inside the closed form's rim)


def both(rows, mask, start=None, tol=GN_TOL):
    """The quadric and the round model on the same rows (round from ``start`` or the quadric,
    to ``tol``)."""
    quad = quadric(rows)
    return quad, round_model(rows, mask, quad.sol.coef if start is None else start, tol)


def quadric(rows):
    return Model(batch_lstsq.solve(rows.A, rows.b, rows.w), rows.A, np.ones(len(rows.b), bool))


def round_model(rows, mask, coef, tol=GN_TOL):
    """Gauss-Newton on the 'round' model from ``coef``, per patch until it has converged to
    ``tol`` (at most ``GN_MAX_STEPS``): a patch that has converged leaves the batch, so it
    gets the iterations it would get alone.  Converged: a step below ``tol``, or one whose
    contraction from the step before says what is left after it is (``_left``): that last
    step is taken, and its solve's linearised residual is the residual (exact to the step's
    square); the solution's covariance parts are linearised one step before the final
    iterate, a step below ``LINEARISE_TOL``.  This saves the solve that only confirmed
    convergence (one in four).  The iterates of a patch its contacts do not determine (two
    points, say) may overflow: ``batch_lstsq`` gives it NaN, ``ok`` is False, and it is
    refused later."""
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        return _gauss_newton(rows, mask, coef, tol)


def _gauss_newton(rows, mask, coef, tol):
    x, y, b, w, A = rows.x, rows.y, rows.b, rows.w, rows.A
    cols = list(jet_basis.HESSIAN)
    coef = _inside_rim(coef, x, y, mask, START_Q2)
    todo = np.arange(len(coef))
    parts, J_all, r_all = [], np.empty_like(A), np.empty_like(b)
    last = np.full(len(coef), np.inf)  # each patch's previous step (relative size)
    for step in range(GN_MAX_STEPS + 1):
        xs, ys, c, T = x[todo], y[todo], coef[todo], rows.T[todo]
        H = jet_basis.hessian(c)
        J = A[todo]  # a copy: the residual first, then the round part's columns added
        excess, jac = jet_basis.round_rows_jacobian(xs, ys, H)
        r = b[todo] - np.einsum("bmp,bp->bm", J, c) - rows.whiten(excess, T)
        J[..., cols] += rows.whiten(jac, T)
        sol = batch_lstsq.solve(J, r, w[todo])
        rel = np.where(np.isfinite(sol.coef), np.abs(sol.coef) / np.maximum(np.abs(c), 1.0), 0)
        size = np.max(rel, axis=1)
        tiny = size <= tol
        near = ~tiny & (_left(size, last[todo]) <= tol) & (size <= LINEARISE_TOL)
        near &= np.all(np.isfinite(sol.coef), axis=1)
        last[todo] = size
        done = tiny | near | (step == GN_MAX_STEPS)
        parts.append((todo[done], batch_lstsq.take(sol, done)))
        J_all[todo[done]], r_all[todo[done]] = J[done], r[done]
        if near.any():  # the last step taken: its residual is the solve's, linearised
            idx = todo[near]
            coef[idx] = _step(c[near], sol.coef[near], xs[near], ys[near], mask[idx])
            r_all[idx] -= np.einsum("bmp,bp->bm", J[near], coef[idx] - c[near])
        go = ~done
        coef[todo[go]] = _step(c[go], sol.coef[go], xs[go], ys[go], mask[todo[go]])
        todo = todo[go]
        if not todo.size:
            break
    sol = batch_lstsq.merge(parts, len(coef))
    # the last solve only linearises: keep the iterate and its residual (``round_model``)
    sol.coef, sol.residual = coef, r_all * w
    sol.rss = np.einsum("bm,bm->b", sol.residual, sol.residual)
    ok = jet_basis.round_valid(x, y, jet_basis.hessian(coef), mask) & np.all(np.isfinite(coef), 1)
    return Model(sol, J_all, ok)


def _left(size, before):
    """What is left to the limit after a step of ``size`` when the one before was ``before``:
    size r / (1 - r) for a contraction r = size / before below 1/2 (linear convergence; under
    quadratic convergence it overstates what is left), inf otherwise."""
    rate = size / before
    return np.where(rate < 0.5, size * rate / np.maximum(1.0 - rate, 0.5), np.inf)


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
