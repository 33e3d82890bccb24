"""ATI's calibration file (``FT12345.cal``): the user-axis matrix and its units.

The file is XML (ATI DAQ F/T, ``CalFileVersion`` 1.1 and later)::

    <FTSensor Serial="FT8578" BodyStyle="Gamma" NumGages="6" ...>
      <Calibration PartNumber="SI-130-10" CalDate="3/5/2014" ForceUnits="N" TorqueUnits="N-m" ...>
        <Axis Name="Fx" values="..." max="130" scale="..."/>      (ATI's internal form)
        <BasicTransform Dx="0" Dy="0" Dz="0.012" Rx="0" Ry="0" Rz="0"/>
        <UserAxis Name="Fx" values=" -0.11562 -0.06102 ... " max="130"/>
        ... one UserAxis per axis: Fx Fy Fz Tx Ty Tz
      </Calibration>
    </FTSensor>

As ATI's own comment in the file says, the six ``UserAxis`` rows are the calibration
matrix: wrench (in ``ForceUnits`` and ``TorqueUnits``) = matrix x the bias-free gauge
voltages, in volts, gauge 0 to 5.  ``Axis`` rows are a scaled, transformed copy for ATI's
software; a file that holds only those (``CalFileVersion`` 1.0) is refused.  A file may hold
several ``Calibration`` elements (one per range); ``index`` picks one (1-based).

Parsed with the standard library's expat (what ``xml.etree`` runs on), which gives every
element its line and column for messages.  Untrusted XML is handled defensively, as
``defusedxml`` does: a document type declaration (the only place entities can be declared,
hence "billion laughs" and external entities) is refused outright, external parameter
entities are never read, and the input is at most ``files.MAX_BYTES`` and
``MAX_ELEMENTS`` elements.
"""

import math
import re
from xml.parsers import expat

from tactile.calib import MAX_ID, MatrixFile, Units, canonical_force, canonical_torque, describe
from tactile.errors import InputError, where
from tactile.files.csv_dialect import DECIMAL

__all__ = ["parse", "format_cal", "AXES"]

AXES = ("Fx", "Fy", "Fz", "Tx", "Ty", "Tz")
MAX_ELEMENTS = 10_000
MAX_DEPTH = 16


class _Element:
    __slots__ = ("name", "attrs", "line", "col", "children")

    def __init__(self, name, attrs, line, col):
        self.name, self.attrs, self.line, self.col = name, attrs, line, col
        self.children = []

    def at(self, path, attr=None):
        """``file:line: column C: <Name>`` (and ``attribute 'attr'``), for messages."""
        out = f"{where(path, self.line)}: column {self.col}: <{self.name}"
        name = self.attrs.get("Name")
        out += f' Name="{name}">' if name is not None else ">"
        return out + (f" attribute {attr!r}" if attr else "")


def _tree(path, data):
    """The root ``_Element`` of ``data``; InputError for bad or unsafe XML."""
    parser = expat.ParserCreate()
    parser.SetParamEntityParsing(expat.XML_PARAM_ENTITY_PARSING_NEVER)
    stack, count = [], [0]
    root = []

    def here():
        return f"{where(path, parser.CurrentLineNumber)}: column {parser.CurrentColumnNumber + 1}"

    def doctype(*_):
        raise InputError(f"{here()}: a <!DOCTYPE> in a calibration file is refused (entities)")

    def entity(*_):
        raise InputError(f"{here()}: an <!ENTITY> declaration is refused")

    def start(name, attrs):
        count[0] += 1
        if count[0] > MAX_ELEMENTS or len(stack) >= MAX_DEPTH:
            raise InputError(f"{here()}: too many or too deeply nested elements for a .cal")
        el = _Element(name, attrs, parser.CurrentLineNumber, parser.CurrentColumnNumber + 1)
        (stack[-1].children if stack else root).append(el)
        stack.append(el)

    def end(name):
        stack.pop()

    parser.StartDoctypeDeclHandler = doctype
    parser.EntityDeclHandler = entity
    parser.StartElementHandler = start
    parser.EndElementHandler = end
    try:
        parser.Parse(data, True)
    except expat.ExpatError as exc:
        raise InputError(
            f"{where(path, exc.lineno)}: column {exc.offset + 1}: not well-formed XML:"
            f" {expat.ErrorString(exc.code)}"
        ) from None
    return root[0]


def parse(path, data, index=None):
    """The ``MatrixFile`` of ATI calibration XML ``data`` read from ``path``."""
    root = _tree(path, data)
    if root.name != "FTSensor":
        raise InputError(f"{root.at(path)}: not an ATI calibration file (its root is <FTSensor>)")
    gages = root.attrs.get("NumGages", "6").strip()
    if gages != "6":
        raise InputError(f"{root.at(path, 'NumGages')}: {gages!r}; the board reads 6 gauges")
    cal = _pick(path, root, index)
    spec = Units(
        _unit(path, cal, "ForceUnits", canonical_force),
        _unit(path, cal, "TorqueUnits", canonical_torque),
        "V",
    )
    rows = _user_axes(path, cal)
    matrix = [rows[a][1] for a in AXES]
    places = [rows[a][0].at(path) for a in AXES]
    serial = root.attrs.get("Serial", "").strip()
    cal_id, id_from = _serial_id(serial)
    part, date = cal.attrs.get("PartNumber", "?"), cal.attrs.get("CalDate", "?")
    label = f"ATI calibration {part} of {serial or '?'} ({date}), {describe(spec)}"
    notes = []
    gain = cal.attrs.get("GainMultiplier", "1").strip()
    if _float(gain) != 1.0:
        notes.append(
            f"the file says GainMultiplier={gain}: --volts-per-count must include that gain"
        )
    return MatrixFile(path, "ATI", matrix, spec, cal_id, id_from, label, notes, places)


def _pick(path, root, index):
    cals = [c for c in root.children if c.name == "Calibration"]
    if not cals:
        raise InputError(f"{root.at(path)}: no <Calibration> element")
    if index is None and len(cals) > 1:
        parts = ", ".join(c.attrs.get("PartNumber", "?") for c in cals)
        raise InputError(
            f"{path}: {len(cals)} calibrations ({parts}): choose one with --index 1..{len(cals)}"
        )
    if index is not None and not 1 <= index <= len(cals):
        raise InputError(f"--index: {index}, but {path} holds {len(cals)} calibration(s)")
    return cals[(index or 1) - 1]


def _unit(path, cal, attr, canonical):
    if attr not in cal.attrs:
        raise InputError(f"{cal.at(path, attr)}: missing")
    try:
        return canonical(cal.attrs[attr])
    except ValueError as exc:
        raise InputError(f"{cal.at(path, attr)}: {exc}") from None


def _user_axes(path, cal):
    """{axis: (element, 6 floats)} from the UserAxis children of ``cal``."""
    found = {}
    for el in cal.children:
        if el.name != "UserAxis":
            continue
        name = el.attrs.get("Name", "")
        if name not in AXES:
            raise InputError(f"{el.at(path, 'Name')}: {name!r} is not one of {', '.join(AXES)}")
        if name in found:
            first = found[name][0].line
            raise InputError(f"{el.at(path)}: a second {name} row (the first is at line {first})")
        found[name] = (el, _values(path, el))
    if not found:
        axis = any(el.name == "Axis" for el in cal.children)
        why = (
            "only <Axis> rows, ATI's scaled internal form (CalFileVersion 1.0); use a file"
            " with UserAxis rows (1.1 or later, from ATI) or write the matrix as CSV"
            if axis
            else "no <UserAxis> rows"
        )
        raise InputError(f"{cal.at(path)}: {why}")
    missing = [a for a in AXES if a not in found]
    if missing:
        raise InputError(f"{cal.at(path)}: no UserAxis row for {', '.join(missing)} (need all six)")
    return found


def _values(path, el):
    if "values" not in el.attrs:
        raise InputError(f"{el.at(path, 'values')}: missing")
    items = el.attrs["values"].split()
    if len(items) != 6:
        raise InputError(f"{el.at(path, 'values')}: {len(items)} numbers, need 6 (gauges 0..5)")
    out = []
    for j, text in enumerate(items):
        v = _float(text)
        if v is None:
            raise InputError(
                f"{el.at(path, 'values')}: number {j + 1} (gauge {j}): {text[:40]!r} is not a"
                " finite number in ASCII decimals (digits 0-9, '.', 'e')"
            )
        out.append(v)
    return out


def _float(text):
    """``text`` as a finite float written in ASCII decimal (``tactile.files.csv_dialect``), else
    None: ``1_0`` and digits of other scripts, which ``float`` takes, are not numbers here."""
    text = text.strip()
    if not DECIMAL.fullmatch(text):
        return None
    v = float(text)
    return v if math.isfinite(v) else None


def _serial_id(serial):
    """The calibration id a serial number gives (FT8578 -> 8578), and where it came from."""
    digits = re.sub(r"\D", "", serial)
    if digits and len(digits) <= 10 and 1 <= int(digits) <= MAX_ID:
        return int(digits), f"Serial {serial}"
    return None, None


def format_cal(per_volt, serial, part="emulated", date="1/1/2026"):
    """ATI calibration XML for a 6x6 ``per_volt`` matrix (N and N-m per gauge volt): the
    writer beside ``parse``, which reads its output back to the same floats (repr)."""
    rows = "\n".join(
        f'    <UserAxis Name="{name}" values="{" ".join(repr(float(v)) for v in row)}"/>'
        for name, row in zip(AXES, per_volt)
    )
    return (
        '<?xml version="1.0" encoding="utf-8"?>\n'
        f'<FTSensor Serial="{serial}" BodyStyle="{part}" Family="DAQ" NumGages="6">\n'
        f'  <Calibration PartNumber="{part}" CalDate="{date}" ForceUnits="N"'
        ' TorqueUnits="N-m" GainMultiplier="1">\n'
        f"{rows}\n  </Calibration>\n</FTSensor>\n"
    )
