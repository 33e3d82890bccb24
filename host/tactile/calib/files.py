"""Reading a calibration file: bounded, then by its content (ATI XML, JSON or CSV).

``read(path)`` returns a ``MatrixFile``: the 6x6 matrix exactly as the file states it (rows
fx fy fz tx ty tz, columns gauges g0..g5), its units, its id if it carries one, and where
each row came from, for messages.  The format is decided by the first character that is
not white space (``<`` XML, ``{`` or ``[`` JSON, anything else CSV), not by the file's
name.  Every error is an ``InputError`` (exit 2) naming file, line or row, and column or
field.

CSV (read by ``tactile.files.csv_dialect``): six lines of six numbers separated by commas (or by
white space), no header; ``#`` lines are comments, except ``# units: FORCE, TORQUE [per
GAUGE]`` (default ``N, N-m per count``) and ``# id: N``.  JSON: ``{"id": N, "matrix":
[[six numbers] x 6], "units": "N, N-m per count"}``, ``id`` and ``units`` optional, no
other keys.
"""

import json
import math

from tactile.calib import MAX_ID, SI, MatrixFile, ati, describe, parse
from tactile.errors import InputError, where
from tactile.files import bounded, csv_dialect
from tactile.files.csv_dialect import DECIMAL, number, show

__all__ = ["MatrixFile", "read", "ROWS", "GAUGES", "MAX_BYTES", "MAX_ID"]

MAX_BYTES = 1 << 20  # a calibration file is a few kB
ROWS = ("fx", "fy", "fz", "tx", "ty", "tz")
GAUGES = ("g0", "g1", "g2", "g3", "g4", "g5")
JSON_KEYS = ("id", "matrix", "units")


def read(path, index=None):
    """The ``MatrixFile`` at ``path``; ``index`` picks one of several ATI calibrations (1-based)."""
    data = read_bounded(path)
    first = data.lstrip(b"\xef\xbb\xbf \t\r\n")[:1]
    if first == b"<":
        return ati.parse(path, data, index)
    if index is not None:
        raise InputError(f"--index: {path} is not an ATI .cal (only those hold several matrices)")
    if first in (b"{", b"["):
        return _json(path, data)
    return _csv(path)


def read_bounded(path, limit=MAX_BYTES):
    """The bytes of a regular file of at most ``limit`` bytes (``tactile.files.bounded``)."""
    data = bounded.read_bytes(path, limit, "a calibration", "a calibration is a few kB")
    if not data.strip():
        raise InputError(f"{path}: empty file")
    return data


def check_id(value, what):
    """``value`` as a calibration id (1..2^32-1) or InputError naming ``what``."""
    if isinstance(value, bool) or not isinstance(value, int) or not 1 <= value <= MAX_ID:
        raise InputError(
            f"{what}: {value!r} is not a calibration id (a whole number 1..{MAX_ID}; 0 means none)"
        )
    return value


def _cell_place(path, line, r, j):
    return f"{where(path, line)}: row {r + 1} ({ROWS[r]}), column {j + 1} ({GAUGES[j]})"


# --- CSV -------------------------------------------------------------------------------------


def _csv(path):
    spec, cal_id, id_from = SI, None, None
    for line, text in csv_dialect.comment_lines(path, MAX_BYTES):
        key, sep, value = text.lstrip("#").partition(":")
        key = key.strip().lower()
        if not sep or key not in ("units", "unit", "id"):
            continue
        if key == "id":
            try:
                whole = int(value.strip())
            except ValueError:
                raise InputError(
                    f"{where(path, line)}: id: not a whole number: {show(value.strip())}"
                ) from None
            cal_id = check_id(whole, f"{where(path, line)}: id")
            id_from = f"line {line}"
        else:
            try:
                spec = parse(value)
            except ValueError as exc:
                raise InputError(f"{where(path, line)}: units: {exc}") from None
    matrix, places = [], []
    for line, cells in csv_dialect.rows(path, MAX_BYTES):
        r = len(matrix)
        if r == 6:
            raise InputError(f"{where(path, line)}: a 7th row; the matrix has 6 ({' '.join(ROWS)})")
        if len(cells) == 1 and len(cells[0].split()) > 1:
            cells = cells[0].split()  # white-space separated (numpy.savetxt's default)
        while len(cells) > 6 and not cells[-1].strip():
            cells = cells[:-1]  # a trailing comma
        if len(cells) != 6:
            raise InputError(
                f"{where(path, line)}: row {r + 1} ({ROWS[r]}) has {len(cells)} value"
                f"{'s' * (len(cells) != 1)}, need 6 (gauges {' '.join(GAUGES)})"
            )
        row = []
        for j, cell in enumerate(cells):
            place = _cell_place(path, line, r, j)
            if r == 0 and j == 0 and not _is_number(cell):
                place += " (a calibration CSV has no header row)"
            row.append(number(cell.strip(), place))
        matrix.append(row)
        places.append(f"{where(path, line)}: row {r + 1} ({ROWS[r]})")
    if len(matrix) < 6:
        raise InputError(
            f"{path}: {len(matrix)} row{'s' * (len(matrix) != 1)} of numbers, need 6"
            f" ({' '.join(ROWS)}, one per line)"
        )
    label = f"CSV matrix, {describe(spec)}"
    return MatrixFile(path, "CSV", matrix, spec, cal_id, id_from, label, [], places)


def _is_number(text):
    return DECIMAL.fullmatch(text.strip()) is not None


# --- JSON ------------------------------------------------------------------------------------


def _json(path, data):
    doc = bounded.parse_json(path, data, object_pairs_hook=_no_dupes(path), parse_int=_json_int)
    if not isinstance(doc, dict):
        raise InputError(f"{path}: the JSON must be an object with 'matrix' (and 'id', 'units')")
    extra = [k for k in doc if k not in JSON_KEYS]
    if extra:
        raise InputError(
            f"{path}: field {extra[0]!r}: unknown (a calibration JSON has {', '.join(JSON_KEYS)})"
        )
    if "matrix" not in doc:
        raise InputError(f"{path}: field 'matrix': missing (6 lists of 6 numbers)")
    spec = SI
    if "units" in doc:
        if not isinstance(doc["units"], str):
            raise InputError(f"{path}: field 'units': must be text like 'N, N-m per count'")
        try:
            spec = parse(doc["units"])
        except ValueError as exc:
            raise InputError(f"{path}: field 'units': {exc}") from None
    cal_id = check_id(doc["id"], f"{path}: field 'id'") if "id" in doc else None
    matrix = _json_matrix(path, doc["matrix"])
    places = [f"{path}: field matrix[{r}] ({ROWS[r]})" for r in range(6)]
    label = f"JSON matrix, {describe(spec)}"
    id_from = "field 'id'" if cal_id is not None else None
    return MatrixFile(path, "JSON", matrix, spec, cal_id, id_from, label, [], places)


def _six(field, v, what, need):
    """``v`` when it is a list of six, else InputError naming ``field``: how many ``what`` it
    holds (or its type), and ``need``."""
    if not isinstance(v, list) or len(v) != 6:
        n = _count(v, what) if isinstance(v, list) else type(v).__name__
        raise InputError(f"{field}: {n}, need {need}")
    return v


def _json_matrix(path, m):
    _six(f"{path}: field 'matrix'", m, "row", f"a list of 6 rows ({' '.join(ROWS)})")
    out = []
    for r, row in enumerate(m):
        field = f"{path}: field matrix[{r}] ({ROWS[r]})"
        _six(field, row, "value", f"a list of 6 numbers (gauges {' '.join(GAUGES)})")
        values = []
        for j, v in enumerate(row):
            place = f"{path}: field matrix[{r}][{j}] ({ROWS[r]}, {GAUGES[j]})"
            if isinstance(v, bool) or not isinstance(v, (int, float)):
                raise InputError(f"{place}: not a number: {show(json.dumps(v))}")
            v = float(v)
            if not math.isfinite(v):
                raise InputError(f"{place}: not a finite number")
            values.append(v)
        out.append(values)
    return out


def _count(items, noun):
    return f"{len(items)} {noun}{'s' * (len(items) != 1)}"


def _json_int(digits):
    """A JSON integer: as an int when short, else as a float (inf beyond float's range,
    refused as not finite at its field), never through Python's integer digit limit."""
    return int(digits) if len(digits) <= 20 else float(digits)


def _no_dupes(path):
    def pairs(items):
        seen = {}
        for k, v in items:
            if k in seen:
                raise InputError(f"{path}: field {k!r}: given twice")
            seen[k] = v
        return seen

    return pairs
