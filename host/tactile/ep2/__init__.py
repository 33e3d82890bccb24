"""EP2: patch fit from contact points and normals, shape analysis and classification (ch. 4).

API::

    from tactile.ep2 import analyze_patch
    res = analyze_patch(points, normals)          # (n, 3) world-frame arrays
    res.shape, res.confidence, res.S_mean, res.S_interval, res.radius
    res.to_dict()                                 # the JSON record of ``tactile ep2 analyze``

See docs/ep2.md for the math, conventions and benchmarks.
"""

from tactile.ep2.api import PatchResult, analyze_patch, analyze_sweep
from tactile.ep2.batch import analyze_patches
from tactile.ep2.patch_input import JetOptions, SplineOptions

__all__ = [
    "JetOptions",
    "PatchResult",
    "SplineOptions",
    "analyze_patch",
    "analyze_patches",
    "analyze_sweep",
]
