"""scipy's FITPACK as an EP2 peer: what a user without this package would pick.

Per patch, in ``jet2``'s frame (mean normal, box middle, lengths / L): a bicubic smoothing
spline of the heights alone (``scipy.interpolate.bisplrep``, weights 1/sigma_p, smoothing
s = n, the expected chi^2), its derivatives at the box middle through ``bisplev``, and
k1, k2, S from them (``jet2.curvatures``).  sigma_p is the stated noise, or ``jet2``'s
REML estimate where none is stated (FITPACK has no noise model of its own).  No
intervals: the scorer counts its errors and labels, not its coverage.  A patch FITPACK
cannot fit (too few points for a bicubic, a singular system) is a ``DataError``.
"""

import warnings

import numpy as np

from tactile.errors import DataError
from tactile_studies.ep2 import jet2


def analyze(patches):
    """[Jet2Result or DataError] (intervals None) for the ``jet2.analyze`` patch dicts."""
    base = jet2.analyze(patches)  # (its frame and noise estimate, timed with it: a few %)
    return [_one(d, b) for d, b in zip(patches, base, strict=True)]


def _one(d, base):
    from scipy.interpolate import bisplev, bisplrep

    if isinstance(base, BaseException):
        return base
    P = np.asarray(d["points"], float)
    q = (P - base.frame.origin) @ base.frame.rot.T / base.scale
    x0, x1, y0, y1 = base.box
    x, y, z = q[:, 0] - 0.5 * (x0 + x1), q[:, 1] - 0.5 * (y0 + y1), q[:, 2]
    sigma = max(base.noise_pos / base.scale, 1e-9)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            tck = bisplrep(x, y, z, w=np.full(len(z), 1.0 / sigma), s=float(len(z)), kx=3, ky=3)
        d5 = [float(bisplev(0.0, 0.0, tck, dx=a, dy=b)) for a, b in _DERIVS]
    except (ValueError, TypeError, OverflowError) as exc:
        return DataError(f"FITPACK: {exc}")
    if not np.all(np.isfinite(d5)):
        return DataError("FITPACK: no finite surface at the centre")
    k1, k2 = (float(v) / base.scale for v in jet2.curvatures(np.array(d5)))
    S = float(2 / np.pi * np.arctan2(k1 + k2, k1 - k2))
    shape = next((n for n, (lo, hi) in jet2.BANDS.items() if lo <= S <= hi), "uncertain")
    return jet2.Jet2Result(
        S=S, k1=k1, k2=k2, S_interval=None, k1_interval=None, k2_interval=None, shape=shape,
        confidence=0.0, frame=base.frame, box=base.box, scale=base.scale, centre=base.centre,
        noise_pos=base.noise_pos, noise_normal=base.noise_normal,
    )  # fmt: skip


_DERIVS = ((1, 0), (0, 1), (2, 0), (1, 1), (0, 2))
