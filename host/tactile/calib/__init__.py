"""Calibration matrices onto a board: ``tactile calibrate`` (issue 14, part 4).

- here: force, torque and gauge units and their SI factors, and ``MatrixFile``;
- ``files``: reading a file (bounded) into a ``MatrixFile``: CSV and JSON here, ATI's
  ``.cal`` XML in ``ati``;
- ``board_matrix``: the matrix in the board's convention (N and N*m per ADC count,
  float32), refused when singular or ill-conditioned; SET_CAL, then INFO read back to
  verify the id and the matrix's checksum.

The convention and the checks: docs/calibration.md.  ``MatrixFile``, what every reader
returns, is here, below the readers.
"""

import re
from collections import namedtuple

from tactile.units import LENGTH_M  # the one length vocabulary

MAX_ID = 0xFFFFFFFF  # cal_id is a u32; 0 means "no calibration"

MatrixFile = namedtuple(
    "MatrixFile",
    "path kind matrix units cal_id id_from label notes places",
    defaults=((),),
)
MatrixFile.__doc__ = """A matrix as a file states it.

``matrix``: 6 lists of 6 floats; ``units``: ``units.Units``; ``cal_id``: int or None;
``id_from``: where the id came from; ``label``: one line saying what the file is;
``notes``: lines worth telling the user; ``places``: per row, its location for messages.
"""


STANDARD_GRAVITY = 9.80665  # m/s^2
POUND_KG = 0.45359237
_LBF = POUND_KG * STANDARD_GRAVITY

FORCE_N = {
    "N": 1.0,
    "kN": 1e3,
    "mN": 1e-3,
    "lbf": _LBF,
    "klbf": 1e3 * _LBF,
    "ozf": _LBF / 16,
    "kgf": STANDARD_GRAVITY,
    "gf": 1e-3 * STANDARD_GRAVITY,
}
# ATI's DAQ F/T library spells the mass-named units without the f: "lb", "klb", "kg", "g".
FORCE_ALIASES = {"lb": "lbf", "klb": "klbf", "oz": "ozf", "kg": "kgf", "g": "gf"}
GAUGE_V = {"count": None, "V": 1.0, "mV": 1e-3}  # None: the ADC code itself
GAUGE_ALIASES = {"counts": "count"}

Units = namedtuple("Units", "force torque gauge")
SI = Units("N", "N-m", "count")  # what SET_CAL carries (PROTOCOL.md §4)

_SEPARATORS = re.compile(r"\s*[-*.\u00b7 ]\s*")


def _force(name):
    name = FORCE_ALIASES.get(name, name)
    return name if name in FORCE_N else None


def force_factor(name):
    """Newtons per ``name``, or None for a unit not known here."""
    canon = _force(name.strip())
    return None if canon is None else FORCE_N[canon]


def _torque(text):
    """``text`` as a canonical ``FORCE-LENGTH``, or None."""
    text = text.strip()
    if text in ("Nm", "Nmm"):
        text = "N-" + text[1:]
    parts = _SEPARATORS.split(text)
    if len(parts) != 2:
        return None
    force = _force(parts[0])
    if force is None or parts[1] not in LENGTH_M:
        return None
    return f"{force}-{parts[1]}"


def torque_factor(name):
    """Newton-metres per ``name``, or None for a unit not known here."""
    canon = _torque(name)
    if canon is None:
        return None
    force, length = canon.split("-")
    return FORCE_N[force] * LENGTH_M[length]


def gauge_factor(name):
    """Volts per ``name`` (None for ``count``); KeyError for a unit not known here."""
    return GAUGE_V[GAUGE_ALIASES.get(name, name)]


def known(kind):
    """The units of ``kind`` (force, torque, gauge) for an error message."""
    if kind == "force":
        return ", ".join(FORCE_N)
    if kind == "torque":
        return "FORCE-LENGTH with LENGTH one of " + ", ".join(LENGTH_M) + " (N-m, lbf-in ...)"
    return ", ".join(GAUGE_V)


def canonical_force(name):
    canon = _force(name.strip())
    if canon is None:
        raise ValueError(f"unknown force unit {name.strip()!r} (known: {known('force')})")
    return canon


def canonical_torque(name):
    canon = _torque(name)
    if canon is None:
        raise ValueError(f"unknown torque unit {name.strip()!r} ({known('torque')})")
    return canon


def canonical_gauge(name):
    name = GAUGE_ALIASES.get(name.strip(), name.strip())
    if name not in GAUGE_V:
        raise ValueError(f"unknown gauge unit {name!r} (known: {known('gauge')})")
    return name


def parse(text):
    """``"lbf, lbf-in per V"`` -> Units; ``per GAUGE`` defaults to ``count``.

    ValueError with a message for a spec that does not parse or names an unknown unit.
    """
    head, sep, gauge = text.partition(" per ")
    parts = [p for p in head.split(",")]
    if len(parts) != 2 or not all(p.strip() for p in parts):
        raise ValueError(f"{text.strip()!r} is not 'FORCE, TORQUE [per GAUGE]' (e.g. 'N, N-m')")
    return Units(
        canonical_force(parts[0]),
        canonical_torque(parts[1]),
        canonical_gauge(gauge) if sep else "count",
    )


def describe(units):
    """``Units`` as the spec ``parse`` reads back: ``lbf, lbf-in per V``."""
    return f"{units.force}, {units.torque} per {units.gauge}"
