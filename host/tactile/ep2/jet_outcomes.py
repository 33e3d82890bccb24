"""The analysis after the centre-jet fit, on a whole stack of patches: the
positions-versus-normals test (``agreement``), determination, intervals and labels
(``centre_result``), the grid statistics (``grid_batch``); a refusal becomes the patch's
``DataError`` in its place.  Only the assembly of each patch's fields is per patch.
"""

import math
from dataclasses import dataclass

import numpy as np

from tactile.ep2 import agreement, centre_result, grid_batch, jet_basis, patch_frame
from tactile.ep2.surface_geometry import principal
from tactile.errors import DataError


@dataclass
class OutcomeInputs:
    """What ``outcomes`` needs of a whole ``centre_jet.fit`` stack, computed for the
    stack at once (``inputs``): Cov widening, the contacts' spread, the grid."""

    widen: np.ndarray
    spread: tuple
    grid: tuple
    stats: dict  # Python lists (``grid_batch.at`` reads them per patch)
    direction1: np.ndarray
    box: np.ndarray  # (B, 4) x min, x max, y min, y max of the contacts (/ L)
    score: list  # per patch, its models' scores


def inputs(fits, n_grid):
    """``OutcomeInputs`` of every patch of ``fits`` (an N x N grid)."""
    ch, gx, gy = grid_batch.channels(fits.coef, fits.model, fits.xy, fits.mask, n_grid)
    zx, zy, zxx, zxy, zyy = (fits.coef[:, k] for k in jet_basis.CHANNELS)
    d1 = np.asarray(principal(zx, zy, zxx, zxy, zyy)["dir1"], float)
    x, y, inside = fits.xy[..., 0], fits.xy[..., 1], fits.mask
    low = [np.where(inside, v, np.inf).min(axis=-1) for v in (x, y)]
    high = [np.where(inside, v, -np.inf).max(axis=-1) for v in (x, y)]
    stats = grid_batch.statistics(ch, fits.scale)
    return OutcomeInputs(
        widen=centre_result.widen(fits.dof),
        spread=centre_result.spread_eigen(fits.xyz_mean, fits.mask),
        grid=(ch, gx, gy),
        stats={k: np.asarray(v).tolist() for k, v in stats.items()},
        direction1=np.einsum("bi,bij->bj", d1, fits.axes),
        box=np.stack([low[0], high[0], low[1], high[1]], axis=-1),
        score=np.asarray(fits.score, float).tolist(),
    )


def outcomes(fits, opts, pre, lines=None):
    """The analysis of every patch of a ``centre_jet.fit`` stack: a list of field dicts, or
    the ``DataError`` that refuses a patch in its place.  ``pre`` = ``inputs`` of the
    stack; ``lines`` per patch (its CSV line per row, or None) name rows in messages.  The
    tests, intervals and labels run on the whole stack at once; only the assembly of each
    patch's fields is per patch."""
    lines = [None] * len(fits.reason) if lines is None else lines
    out = [None] * len(fits.reason)
    live = []
    for i, why in enumerate(fits.reason):
        if why is None:
            live.append(i)
        else:
            out[i] = DataError(_name_rows(why, lines[i]))
    idx = np.array(live, int)
    if not live:
        return out
    split = tuple((d[idx], c[idx], (z[0][idx], z[1][idx])) for d, c, z in fits.split)
    checks = agreement.consistency(split, fits.dof[idx], fits.scale[idx], fits.axes[idx])
    cov = fits.cov[idx] * pre.widen[idx][:, None, None]
    spread = tuple(v[idx] for v in pre.spread), fits.mean_axes[idx]
    undetermined = centre_result.determination_many(
        cov, fits.axes[idx], fits.scale[idx], spread, fits.noise[idx, 0]
    )
    ok = []
    for k, i in enumerate(live):
        refusal = checks[k][0] or undetermined[k]
        if refusal is not None:
            out[i] = DataError(refusal)
        else:
            ok.append(k)
    ok = np.array(ok, int)
    # a mild disagreement: intervals about the joint estimate that reach both sides' (gap/2
    # as one more sd in its direction: with the 95 % radius, about the whole gap)
    gap = np.array([checks[k][2] for k in ok]).reshape(-1, 3)
    j = idx[ok]
    heads = centre_result.summary_many(
        fits.t[j], cov[ok] + gap[:, :, None] * gap[:, None, :] / 4, fits.bias[j],
        fits.scale[j], opts["intervals"], fits.cov_noise[j],
    )  # fmt: skip
    for k, i, head in zip(ok, j, heads, strict=True):
        head["warnings"] = [] if checks[k][1] is None else [checks[k][1]]
        out[i] = _jet_fields(fits, i, head, pre)
    return out


def _name_rows(why, lines):
    """A refusal naming 'contact k' names its CSV line instead, where lines are known."""
    if lines is not None and "contact " in why:
        k = int(why.split("contact ")[1].split()[0])
        why = why.replace(f"contact {k} ", f"line {lines[k]} ")
    return why


def _jet_fields(fits, i, out, pre):
    """Patch ``i``'s result fields: ``out`` (its ``summary``) and what the fit holds."""
    L, axes = float(fits.scale[i]), fits.axes[i]
    coef, model = fits.coef[i], int(fits.model[i])
    out.update(grid_batch.at(pre.stats, i, L, out["shape"] == "plane"))
    ch, gx, gy = pre.grid
    out.update(
        order=int(fits.order[i]),
        weighting="auto" if not any(fits.stated) else "stated",
        model=_model_text(pre.score[i], model, int(fits.order[i]), float(fits.weight[i])),
        noise_pos=float(fits.noise[i, 0]),
        noise_normal=float(fits.noise[i, 1]),
        frame=patch_frame.PatchFrame(fits.origin[i], axes),
        scale=L,
        surface=lambda q: _jet_height(coef, model, q),
        grid=([c[i] for c in ch], gx[i], gy[i]),
        direction1=pre.direction1[i],
        box=tuple(pre.box[i]),
    )
    return out


def _jet_height(coef, model, xy):
    z = jet_basis.design(xy[:, 0], xy[:, 1], jet_basis.order_of(len(coef)), ((0, 0),)) @ coef
    if model == 1:
        z = z + jet_basis.round_excess(xy[:, 0], xy[:, 1], jet_basis.hessian(coef))[0]
    return z


def _model_text(score, model, order=3, weight=1.0):
    """One line: which model, of which order, and why (its AIC lead over the runner-up,
    ``centre_jet``); a blend of the 3-jet and its 2-jet (``centre_jet._lower_order``) says
    the 3-jet's share."""
    names = {0: f"quadric {order}-jet", 1: f"round {order}-jet (sphere/cylinder closed form)"}
    other = 5 - order  # the blend's other jet: 2 <-> 3
    blend = f" blended with its {other}-jet (3-jet weight {weight:.2f})" if 0 < weight < 1 else ""
    rest = [k for k in range(len(score)) if k != model and math.isfinite(score[k])]
    if not rest:
        return f"{names[model]}{blend}: the only model that fits"
    runner = min(rest, key=lambda k: score[k])
    lead = float(score[runner] - score[model])
    return f"{names[model]}{blend}: chi2 + 2 dof {lead:.3g} below the {names[runner]}"
