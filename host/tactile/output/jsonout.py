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
    """One compact JSON line; raises ValueError rather than emit NaN.

    The same text as ``json.dumps(clean(obj))``, without copying ``obj`` first where
    that cannot change it: when every dict key is a ``str``, ``json`` writes ``obj``
    itself and calls ``clean`` only on what it cannot write (NumPy values, bytes); a
    non-finite float makes it stop, and ``clean`` then writes it as null."""
    if _str_keys(obj):
        try:
            return _ENCODE(obj)
        except ValueError:  # a NaN or inf: ``clean``'s copy has null there
            pass
    return json.dumps(clean(obj), allow_nan=False, separators=(",", ":"))


_ENCODE = json.JSONEncoder(allow_nan=False, separators=(",", ":"), default=clean).encode


def _str_keys(obj):
    """Whether every dict in ``obj`` (through dicts, lists and tuples) has only ``str`` keys,
    which ``json`` writes as ``clean`` does (not so None, True, 1.0 or a NumPy key).  A
    subclass of dict, list or tuple says no: ``clean`` takes it the careful way."""
    kind = type(obj)
    if kind is dict:
        for k, v in obj.items():
            if type(k) is not str or (type(v) not in _LEAVES and not _str_keys(v)):
                return False
        return True
    if kind is list or kind is tuple:
        return all(type(v) in _LEAVES or _str_keys(v) for v in obj)
    return not isinstance(obj, dict | list | tuple)  # else ``json`` asks ``clean``


_LEAVES = frozenset((str, int, float, bool, type(None)))
