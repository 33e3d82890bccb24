"""From a ``local_jet.JetStack`` to each patch's result fields, or the refusal in its place.

A patch is refused only when its fit says so (too few consistent contacts, one line, no
quadric through them) or when the noise covariance of its 2-jet's curvature leaves a
direction undetermined, named in world coordinates: a 95 % half-width over
``MAX_HALF_WIDTH`` / L.  The bias left widens the intervals; it refuses nothing.
Otherwise: the headline curvature, intervals and label at the patch centre
(``centre_result.summary``), the thesis's grid
statistics (§4.8.2, ``grid_batch``) and the fields ``patch_result.from_fields`` takes.
"""

import numpy as np

from tactile.ep2 import centre_result, consistency, grid_batch, patch_frame
from tactile.ep2.grid_batch import DERIVS
from tactile.ep2.jet_terms import design, exponents, powers, size
from tactile.ep2.surface_geometry import principal
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
        k: np.asarray(v).tolist() for k, v in grid_batch.statistics(ch, stack.scale[ok]).items()
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
        head.update(grid_batch.at(stats, k, float(stack.scale[b]), head["shape"] == "plane"))
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
    (``consistency``)."""
    live = np.array([b for b, why in enumerate(stack.reason) if why is None], int)
    if not len(live):
        return
    whys = consistency.disagreements(
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
    coef = stack.coef[idx]
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
