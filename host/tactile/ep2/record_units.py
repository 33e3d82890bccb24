"""The unit of every number of an EP2 JSON record, and the record shown in another unit.

``analyze_patch`` works in the input's length unit (``api``: lengths in the unit, curvatures
in 1/unit).  ``in_unit(record, unit, scale)`` gives the record with lengths multiplied by
``scale`` (the file's unit -> ``unit``, ``tactile.units.display``), curvatures divided by
it, C and C_mean shifted by -(2/pi) ln(scale) (C = (2/pi) ln R, R in 1/unit, thesis §4.8.2),
and a ``units`` field naming the unit of each number.
"""

import functools

from tactile.units import c_shift

__all__ = ["DIMENSIONS", "in_unit", "units_of"]

# the power of length of each numeric field (1: a length, -1: a curvature); "C" is the
# curvedness, a log; None: no unit (S, confidence, counts), or one fixed unit (rad, deg)
DIMENSIONS = {
    "radius": 1,
    "radius_interval": 1,
    "noise_pos": 1,
    "k1": -1,
    "k2": -1,
    "k1_interval": -1,
    "k2_interval": -1,
    "k1_mean": -1,
    "k2_mean": -1,
    "k1_std": -1,
    "k2_std": -1,
    "R_mean": -1,
    "R_std": -1,
    "C": "C",
    "C_mean": "C",
}
FIXED = {"noise_normal": "rad", "direction1": "1 (unit vector)"}
DIMENSIONLESS = ("S", "S_interval", "S_mean", "S_std", "confidence")


def units_of(unit):
    """{field: its unit} for lengths in ``unit``."""
    return dict(_units_of(unit))


@functools.lru_cache(maxsize=16)
def _units_of(unit):
    out = {}
    for name, power in DIMENSIONS.items():
        if power == "C":
            out[name] = f"1 ((2/pi) ln R, R in 1/{unit})"
        else:
            out[name] = unit if power == 1 else f"1/{unit}"
    out.update(FIXED)
    out.update({name: "1" for name in DIMENSIONLESS})
    out["discontinuities.angle_deg"] = "deg"
    return out


def in_unit(record, unit, scale=1.0):
    """``record`` (a ``PatchResult.to_dict``) in ``unit``, ``scale`` lengths per file length,
    with its ``units``.  A refusal (no ``shape``) has no number with a unit: as it is."""
    if record.get("shape") is None:
        return record
    out = dict(record)
    if scale != 1.0:
        for name, power in DIMENSIONS.items():
            if out.get(name) is not None:
                out[name] = _scaled(out[name], power, scale)
    out["units"] = units_of(unit)
    return out


def _scaled(value, power, scale):
    if isinstance(value, list | tuple):
        return [_scaled(v, power, scale) for v in value]
    if power == "C":
        return value + c_shift(scale)
    return value * scale if power == 1 else value / scale
