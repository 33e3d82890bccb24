"""From a ``jet_estimate.JetStack`` to each patch's result fields, or the refusal in its place.

A patch is refused only when its fit says so (too few consistent contacts, one line, no
quadric through them) or when the noise covariance of its 2-jet's curvature leaves a
direction undetermined, named in world coordinates: a 95 % half-width over
``MAX_HALF_WIDTH`` / L.  The bias left widens the intervals; it refuses nothing.
Otherwise: the headline curvature, intervals and label at the patch centre
(``centre_result.summary``), the thesis's grid
statistics (§4.8.2, ``centre_result.statistics``) and the fields ``api.from_fields`` takes.
"""

import math

import numpy as np

from tactile.ep2 import centre_result, patch_frame
from tactile.ep2.centre_result import DERIVS
from tactile.ep2.geometry import principal
from tactile.ep2.jet_terms import design, exponents, mv, powers, size
from tactile.errors import DataError

MAX_HALF_WIDTH = 0.25  # of 1/L: the 2-jet's noise half-width (95 %) beyond which k is unknown


def outcomes(stack, opts, lines=None):
    """A list per patch of ``stack``: its field dict, or the ``DataError`` refusing it.
    ``lines``: per patch, how to name its contacts (``patch_input.row_names``) or None."""
    B = len(stack.scale)
    lines = [None] * B if lines is None else lines
    out = [None] * B
    _refuse_disagreeing(stack)
    live = [b for b in range(B) if stack.reason[b] is None]
    for b in range(B):
        if stack.reason[b] is not None:
            out[b] = DataError(_name_rows(stack.reason[b], lines[b]) + _left(stack, b, lines[b]))
    if live:
        for b in np.asarray(live)[_wide(stack, live)].tolist():
            why = undetermined(stack, b)
            out[b] = DataError(why + _left(stack, b, lines[b]))
    ok = np.array([b for b in live if out[b] is None], int)
    if not len(ok):
        return out
    heads = centre_result.summary(
        stack.t[ok], stack.cov[ok], None, stack.scale[ok], opts["intervals"],
        np.zeros_like(stack.cov[ok]),  # (k1, k2 as fitted: debiasing them cost RMS S)
    )  # fmt: skip
    ch, gx, gy = channels(stack, ok, opts["grid"])
    stats = {
        k: np.asarray(v).tolist() for k, v in centre_result.statistics(ch, stack.scale[ok]).items()
    }
    zx, zy, zxx, zxy, zyy = np.moveaxis(stack.coef[ok][:, 1:6], -1, 0)
    d1 = np.einsum("bi,bij->bj", np.asarray(principal(zx, zy, zxx, zxy, zyy)["dir1"], float),
                   stack.axes[ok])  # fmt: skip
    xy = stack.xy[ok] + stack.centre[ok][:, None, :]
    keep = stack.keep[ok][..., None]
    box = np.concatenate([np.where(keep, xy, np.inf).min(1), np.where(keep, xy, -np.inf).max(1)],
                         -1)[:, [0, 2, 1, 3]].tolist()  # fmt: skip
    for k, (b, head) in enumerate(zip(ok.tolist(), heads, strict=True)):
        head["warnings"] = [_name_rows(w, lines[b]) for w in stack.warnings[b]]
        head.update(centre_result.at(stats, k, float(stack.scale[b]), head["shape"] == "plane"))
        head.update(direction1=d1[k], box=tuple(box[k]))
        out[b] = _fields(stack, b, head, ([c[k] for c in ch], gx[k], gy[k]))
    return out


def _left(stack, b, names, most=2):
    """'; ' and the contacts patch b left out (the first ``most``, then how many more)."""
    left = [_name_rows(w, names) for w in stack.warnings[b]]
    more = f"; and {len(left) - most} more left out" if len(left) > most + 1 else ""
    return "".join(f"; {w}" for w in left[: most if more else None]) + more


def _refuse_disagreeing(stack):
    """Patches whose positions and normals describe different surfaces are refused
    (``disagreements``)."""
    live = np.array([b for b, why in enumerate(stack.reason) if why is None], int)
    if not len(live):
        return
    whys = disagreements(
        stack.xy[live], stack.heights[live], stack.slopes[live], stack.keep[live],
        stack.axes[live], stack.scale[live],
    )  # fmt: skip
    for b, why in zip(live.tolist(), whys, strict=True):
        stack.reason[b] = why


def _half_widths(cov):
    """(B,) the 95 % half-width of the curvature in its worst direction (cov (B, 3, 3))."""
    finite = np.all(np.isfinite(cov), axis=(1, 2))
    w = np.linalg.eigvalsh(np.where(finite[:, None, None], cov, 0.0))[:, -1]
    return np.where(finite, 1.96 * np.sqrt(np.maximum(w, 0.0)), np.inf)


def _wide(stack, idx):
    """(b,) whether the noise of the 2-jet leaves a direction's curvature undetermined."""
    return _half_widths(stack.cov_quadric[idx]) > MAX_HALF_WIDTH


def undetermined(stack, b):
    """Why patch b's curvature is not determined (its worst direction, world coordinates)."""
    cov, scale = stack.cov_quadric[b], float(stack.scale[b])
    half = _half_widths(cov[None])[0]
    # curvature along u = (cos th, sin th): a cos^2 + 2 b cos sin + c sin^2; its worst th
    th = np.linspace(0.0, np.pi, 181)[:-1]
    u = np.stack([np.cos(th) ** 2, 2 * np.cos(th) * np.sin(th), np.sin(th) ** 2])
    worst = th[int(np.argmax(np.einsum("in,ij,jn->n", u, np.nan_to_num(cov), u)))]
    d = np.cos(worst) * stack.axes[b][0] + np.sin(worst) * stack.axes[b][1]
    return (
        f"curvature along {centre_result.direction_text(d)} is not determined: its 95 %"
        f" interval is +/- {half / scale:.3g} per unit length, over {MAX_HALF_WIDTH:g}/L"
        f" (L = {scale:.4g}); the contacts do not span that direction well: sweep across it"
    )


def channels(stack, idx, n):
    """(zx, zy, zxx, zxy, zyy) of each patch's answer on an n x n grid over its contacts' box
    (frame, / L), each (b, n^2), and the grid's x, y (b, n^2)."""
    xy, keep, centre = stack.xy[idx], stack.keep[idx], stack.centre[idx]
    lo = np.where(keep[..., None], xy, np.inf).min(1)
    hi = np.where(keep[..., None], xy, -np.inf).max(1)
    xs = np.linspace(lo[:, 0], hi[:, 0], n, axis=-1)
    ys = np.linspace(lo[:, 1], hi[:, 1], n, axis=-1)
    gx, gy = np.repeat(xs, n, axis=-1), np.tile(ys, (1, n))  # about the centre
    coef = stack.grid_coef[idx]  # (the best-supported jet: ``jet_estimate._grid_coef``)
    order = _order_of(coef.shape[1])
    # on a tensor grid the jet is px C py^T, C[i, j] the coefficient of x^i y^j / (i! j!)
    C = np.zeros((len(idx), order + 3, order + 3))
    for k, (i, j) in enumerate(exponents(order)):
        C[:, i, j] = coef[:, k]
    px = np.stack(powers(xs, order), -1)
    pyT = np.swapaxes(np.stack(powers(ys, order), -1), -1, -2)
    ch = [(px @ C[:, a : a + order + 1, c : c + order + 1] @ pyT).reshape(len(idx), -1)
          for a, c in DERIVS]  # fmt: skip
    return ch, gx + centre[:, :1], gy + centre[:, 1:]


def _order_of(p):
    o = 0
    while size(o) < p:
        o += 1
    return o


def _fields(stack, b, head, grid):
    L, axes, coef = float(stack.scale[b]), stack.axes[b], stack.coef[b]
    centre = stack.centre[b]
    order = _order_of(len(coef))
    head.update(
        order=int(stack.order[b]),
        weighting="stated" if stack.stated[b].any() else "auto",
        model=_model_text(stack, b),
        noise_pos=float(stack.noise[b, 0]),
        noise_normal=float(stack.noise[b, 1]),
        frame=patch_frame.PatchFrame(stack.origin[b], axes),
        scale=L,
        surface=lambda q: design(q[:, 0] - centre[0], q[:, 1] - centre[1], order)[0] @ coef,
        grid=grid,
    )
    return head


def _model_text(stack, b):
    """One line: the jet the answer is, how far it moved from the 2-jet, what checked it."""
    w, top = float(stack.weight[b]), int(stack.top[b])
    hi = top - 1 if top >= 4 else top
    moved = f", moved {w:.2f} of the way to the {hi}-jet" if hi > 2 else ""
    return (f"2-jet of positions and normals{moved}; truncation checked against the "
            f"{top}-jet")  # fmt: skip


def _name_rows(why, names):
    """A line naming 'contact k' (k as fitted) names it as the user numbered it: ``names``
    (``patch_input.row_names``) or, None, as it is."""
    if names is not None and "contact " in why:
        k = int(why.split("contact ")[1].split()[0].rstrip(":"))
        why = why.replace(f"contact {k} ", f"{names[k]} ", 1)
        why = why.replace(f"contact {k}:", f"{names[k]}:", 1)
    return why


# --- Do a patch's positions and normals describe one surface? (thesis §4.5 fits both at
# once, and so assumes they do.)
#
# Normals given in the wrong frame, flipped, or read off a flat plate describe another surface
# than the contacts' positions, and a joint fit follows whichever rows its noise estimate trusts
# more, confidently. So the normals alone are fitted by a 2-jet of slopes, and the surface it
# describes (up to a constant) is compared with the positions in data space: they disagree where
# the positions' rms gap to it exceeds ``MIN_RATIO`` times its expected size (the positions' own
# 2-jet residual and the normals' surface's prediction noise) and ``MIN_GAP``. A data-space test
# cannot be fooled by a layout that leaves the positions' own curvature ill-determined, and a
# surface no 2-jet follows moves both fits alike. On the tune split of the families bench: 2
# consistent patches of 7,824 refused, none of 2,640 with outliers; 20 of 21 inconsistent
# reproducers refused (tests).


REDUNDANCY = 1.5  # rows per term of each fit alone
MIN_RATIO = 5.0  # the positions' rms gap to the normals' surface, in its expected sizes
MIN_GAP = 2e-3  # of L: a smaller gap is no evidence of anything
TINY = 1e-30


def disagreements(xy, heights, slopes, keep, axes, scale):
    """Per patch None, or the line saying how positions and normals disagree.  xy (B, n, 2)
    and heights (B, n) in the frame / L, slopes (B, n, 2), keep (B, n), axes (B, 3, 3),
    scale (B,) = L."""
    n_kept = keep.sum(-1)
    out = [None] * len(keep)
    idx = np.flatnonzero(REDUNDANCY * size(2) <= n_kept)
    if not len(idx):
        return out
    xy, z, s, w = xy[idx], heights[idx], slopes[idx], keep[idx].astype(float)
    V, DX, DY = design(xy[..., 0], xy[..., 1], 2)
    tp, _, rp, okp = _fit(V * w[..., None], z * w)
    A = np.concatenate([DX, DY], 1)[..., 1:] * np.tile(w, 2)[..., None]
    tn, Cn, _, okn = _fit(A, np.concatenate([s[..., 0], s[..., 1]], 1) * np.tile(w, 2))
    pred = mv(V[..., 1:], tn)  # the normals' surface at the contacts, up to a constant
    gap = (z - pred) * w
    gap = (gap - (gap.sum(-1) / n_kept[idx])[:, None]) * w
    var_p = np.sum(rp * rp, -1) / np.maximum(n_kept[idx] - size(2), 1)
    var_pred = np.einsum("bnp,bpq,bnq->bn", V[..., 1:], Cn, V[..., 1:])
    stat = np.sum(gap * gap / (var_p[:, None] + var_pred + TINY), -1) / n_kept[idx]
    rms = np.sqrt(np.sum(gap * gap, -1) / n_kept[idx])
    bad = okp & okn & (stat > MIN_RATIO**2) & (rms > MIN_GAP)
    for k in np.flatnonzero(bad):
        out[int(idx[k])] = _verdict(tp[k], tn[k], float(rms[k]), axes[idx[k]], float(scale[idx[k]]))
    return out


def _fit(A, b):
    """(coef[first 5 after any constant], cov of all coefs, residuals, determined) of
    least squares A c = b for a stack; the noise from the residuals."""
    cn = np.sqrt(np.sum(A * A, 1))
    cn = np.where(cn > 0, cn, 1.0)
    Q, R = np.linalg.qr(A / cn[:, None, :])
    d = np.abs(np.diagonal(R, axis1=-2, axis2=-1))
    tiny = ~(d > 1e-9 * d.max(-1, keepdims=True))
    R = R + np.eye(R.shape[-1]) * tiny[:, None, :]  # (a patch not determined: not compared)
    qb = (b[:, None, :] @ Q)[:, 0]
    resid = b - mv(Q, qb)
    rows = np.sum(A != 0, -1) > 0
    dof = np.maximum(rows.sum(-1) - A.shape[2], 1)
    s2 = np.sum(resid * resid, -1) / dof
    Rinv = np.linalg.inv(R) / cn[:, :, None]
    coef = mv(Rinv, qb)
    cov = Rinv @ np.swapaxes(Rinv, -1, -2) * s2[:, None, None]
    lo = A.shape[2] - 5
    return coef[:, lo:], cov[:, lo:, lo:], resid, ~tiny.any(-1)


def _verdict(tp, tn, rms, axes, L):
    """The line: where the two surfaces' curvatures differ most, or their tilt."""
    Hp, Hn = _hessian(tp), _hessian(tn)
    lam, vec = np.linalg.eigh(Hp - Hn)
    u = vec[:, int(np.argmax(np.abs(lam)))]
    kp, kn = -(u @ Hp @ u) / L, -(u @ Hn @ u) / L  # k = -z'' (convex toward +z: k > 0)
    tilt = math.degrees(math.atan(float(np.linalg.norm(tp[:2] - tn[:2]))))
    along = ", ".join(f"{v:.2f}" for v in u @ axes[:2])
    return (
        f"positions and normals disagree: the positions lie {rms:.2g} of the patch size (rms) "
        f"off the surface the normals describe (curvature along ({along}) {kp:.3g} from the "
        f"positions vs {kn:.3g} from the normals, 1/unit; tilt {tilt:.0f} deg); check the "
        "normals' sign and frame, or take a smaller patch where the surface bends this much"
    )


def _hessian(t):
    return np.array([[t[2], t[3]], [t[3], t[4]]])
