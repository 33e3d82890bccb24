"""The project's unit vocabulary: length names and factors, the ``# units:`` line, display units.

One internal unit: SI.  What the host library writes is in metres, newtons, newton-metres,
seconds and radians, and every CSV it writes starts with a ``# units: ...`` line saying so
(``line``); a reader checks that line with ``stated_length`` or ``check_stated`` (a mismatch
or an unknown unit: ``InputError`` naming file:line, exit 2).  A file written before the line
existed is read as it always was.

Display units (``--units``): a length shown in unit ``U`` is ``value * scale`` with ``scale =
length_factor(file unit) / length_factor(U)``; a curvature (1/length) is divided by it.  The
curvedness C = (2/pi) ln R (thesis §4.8.2, R in 1/length) is not a length: it *shifts*, C_U =
C - (2/pi) ln(scale) (``c_shift``), so a C means nothing without the unit R was taken in.
"""

import math
import re

from tactile.errors import InputError
from tactile.files.csv_dialect import units_line

__all__ = [
    "LENGTH_M",
    "c_shift",
    "check_stated",
    "display",
    "length_factor",
    "line",
    "parse_length",
    "stated_length",
]

# metres per unit; exact by definition (NIST SP 811, appendix B.8: the inch is 0.0254 m)
LENGTH_M = {
    "m": 1.0,
    "cm": 1e-2,
    "mm": 1e-3,
    "um": 1e-6,
    "nm": 1e-9,
    "km": 1e3,
    "in": 0.0254,
    "ft": 0.3048,
}
LENGTH_ALIASES = {"\u00b5m": "um", "\u03bcm": "um"}  # micro sign, Greek mu
SI_LENGTH = "m"
# What each file the project writes states (README, "Files"): its columns' units in order.
FRAMES = "N, N*m, us, s"  # forces, torques, board stamps, host times
CONTACTS = SI_LENGTH
PROBES = "rad"  # rotations and the fingertip's angular parameters (eq. 20)
# the words frames.csv's line may hold (an older recorder's files say "SI")
FRAME_WORDS = frozenset({"si", "n", "n*m", "nm", "n.m", "n\u00b7m", "m", "s", "us", "\u00b5s"})
# a pose or probe log: times in us (board) or s (host clocks), lengths in m, angles in rad
LOG_WORDS = frozenset({"us", "\u00b5s", "s", "m", "rad"})
LOG_WHAT = "a pose log holds times in us or s, lengths in m and angles in rad"
UNITS_KEY = "units"
ANY_SIZE = 2**62  # bytes: the units line is read from the head of a file of any size
_SPLIT = re.compile(r"[\s,;()]+")


def parse_length(text):
    """The canonical name of the length unit ``text`` (``µm`` -> ``um``), or ValueError."""
    name = text.strip()
    name = LENGTH_ALIASES.get(name, name)
    if name not in LENGTH_M:
        raise ValueError(f"unknown length unit {show_unit(text)} (known: {', '.join(LENGTH_M)})")
    return name


def length_option(text, flag="--units"):
    """``parse_length`` of an option's value: an ``InputError`` (exit 2) naming ``flag``."""
    try:
        return parse_length(text)
    except ValueError as exc:
        raise InputError(f"{flag}: {exc}") from None


def show_unit(text):
    return repr(text.strip()[:20])


def length_factor(name):
    """Metres per ``name`` (a unit ``parse_length`` knows)."""
    return LENGTH_M[parse_length(name)]


def line(spec):
    """The first line of a CSV the project writes: ``# units: SPEC``."""
    return f"# {UNITS_KEY}: {spec}\n"


def stated(path):
    """(line, the text after ``units:``) of the file's ``# units:`` line, or None.  Only the
    head is read, so any size will do: the reader of the rows applies its own limit."""
    return units_line(path, max_bytes=ANY_SIZE)


def stated_length(path, expected=None):
    """The length unit ``path``'s ``# units:`` line states, canonical, or None without one.

    ``expected`` (a unit the caller was told, e.g. ``--file-units``) must agree with it.  An
    unknown unit or a disagreement is an ``InputError`` naming file:line (exit 2)."""
    found = stated(path)
    if found is None:
        return None if expected is None else parse_length(expected)
    line_no, text = found
    words = [w for w in _SPLIT.split(text) if w]  # the length, then "1" (normals) if any
    try:
        if not words or any(w != "1" for w in words[1:]):
            raise ValueError
        unit = parse_length(words[0])
    except ValueError:
        raise InputError(
            f"{path}:{line_no}: units {show_unit(text)}: not a length unit (one of"
            f" {', '.join(LENGTH_M)}; normals may add '1': '# units: m, 1')"
        ) from None
    if expected is not None and parse_length(expected) != unit:
        raise InputError(
            f"{path}:{line_no}: units: the file is in {unit}, not {parse_length(expected)} as"
            " stated; leave the option out or correct the file"
        )
    return unit


def check_stated(path, allowed, what):
    """Check that the ``# units:`` line of ``path``, if any, names only units of ``allowed``
    (lower-case words); ``what`` says what the file holds, for the message."""
    found = stated(path)
    if found is None:
        return
    line_no, text = found
    words = [w for w in _SPLIT.split(text.lower()) if w]
    wrong = [w for w in words if w not in allowed]
    if wrong or not words:
        raise InputError(
            f"{path}:{line_no}: units {show_unit(text)}: {what}; this file says otherwise"
        )


def display(file_unit, shown=None):
    """(the unit to show, scale from the file's unit to it).  ``shown`` None: the file's.

    ``file_unit`` None (a file that states no unit): lengths are shown as they are, in
    "u", and ``shown`` cannot convert them (``InputError``)."""
    if shown is None:
        return (file_unit or "u"), 1.0
    shown = length_option(shown)
    if file_unit is None:
        raise InputError(
            f"--units {shown}: the file states no length unit, so it cannot be converted; add"
            " '# units: m' (or its unit) before its header, or give --file-units"
        )
    return shown, LENGTH_M[file_unit] / LENGTH_M[shown]


def c_shift(scale):
    """What to add to C = (2/pi) ln R when lengths are multiplied by ``scale``."""
    return -2.0 / math.pi * math.log(scale)
