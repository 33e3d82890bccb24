"""JSON output that never contains NaN or Infinity.

Non-finite floats become ``null``; NumPy scalars and arrays become plain
Python numbers and lists.  ``dumps`` is what every ``--json`` flag prints.
"""

import json
import math


def clean(obj):
    """Return ``obj`` with NumPy types converted and non-finite floats as None."""
    if isinstance(obj, dict):
        return {str(k): clean(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [clean(v) for v in obj]
    if isinstance(obj, bool) or obj is None or isinstance(obj, (int, str)):
        return obj
    if isinstance(obj, float):
        return obj if math.isfinite(obj) else None
    if isinstance(obj, (bytes, bytearray)):
        return obj.decode("ascii", "replace")
    tolist = getattr(obj, "tolist", None)  # NumPy scalar or array
    if tolist is not None:
        return clean(tolist())
    raise TypeError(f"cannot write {type(obj).__name__} as JSON")


def dumps(obj):
    """One compact JSON line; raises ValueError rather than emit NaN."""
    return json.dumps(clean(obj), allow_nan=False, separators=(",", ":"))
