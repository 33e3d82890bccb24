"""Reading the project's CSV contracts (EP1 probes, EP2 contacts) with exact error locations.

``read_csv`` returns float columns plus each row's source line number.
Every error is an ``InputError`` whose message names file, line and column.
"""

import csv
import math

from tactile.errors import InputError, where


class Table:
    """Columns by name (lists of floats or strings) and the line each row came from."""

    def __init__(self, path, columns, lines):
        self.path = path
        self.columns = columns
        self.lines = lines

    def __len__(self):
        return len(self.lines)

    def array(self, *names):
        """Stack the named float columns into an (n, len(names)) NumPy array."""
        import numpy as np

        return np.column_stack([np.asarray(self.columns[n], dtype=float) for n in names])


def read_csv(path, required, optional_text=(), optional_float=()):
    """Read ``path``: header row, ``#`` comment lines, unknown columns ignored.

    ``required`` and ``optional_float`` columns must be finite numbers;
    ``optional_text`` columns are kept as stripped strings.
    """
    try:
        handle = open(path, newline="", encoding="utf-8")
    except OSError as exc:
        raise InputError(f"{path}: cannot read: {exc.strerror}") from None
    with handle:
        rows = _data_rows(path, handle)
        try:
            header_line, header = next(rows)
        except StopIteration:
            raise InputError(f"{path}: empty file, expected a header row") from None
        index = _header_index(path, header_line, header, required)
        floats = [c for c in (*required, *optional_float) if c in index]
        texts = [c for c in optional_text if c in index]
        columns = {c: [] for c in (*floats, *texts)}
        lines = []
        for line_no, row in rows:
            for name in floats:
                columns[name].append(_number(path, line_no, name, row, index[name]))
            for name in texts:
                columns[name].append(_cell(path, line_no, name, row, index[name]))
            lines.append(line_no)
    if not lines:
        raise InputError(f"{path}: no data rows after the header")
    return Table(path, columns, lines)


def _data_rows(path, handle):
    reader = csv.reader(handle)
    try:
        for row in reader:
            if not row or not "".join(row).strip() or row[0].lstrip().startswith("#"):
                continue
            yield reader.line_num, row
    except (csv.Error, UnicodeDecodeError) as exc:
        raise InputError(f"{where(path, reader.line_num)}: not valid CSV: {exc}") from None


def _header_index(path, line_no, header, required):
    index = {}
    for i, name in enumerate(header):
        index.setdefault(name.strip(), i)
    missing = [c for c in required if c not in index]
    if missing:
        raise InputError(
            f"{where(path, line_no)}: missing required column(s) {', '.join(missing)}"
            f" (header has: {', '.join(h.strip() for h in header)})"
        )
    return index


def _cell(path, line_no, name, row, i):
    if i >= len(row):
        raise InputError(f"{where(path, line_no, name)}: missing value (row is short)")
    return row[i].strip()


def _number(path, line_no, name, row, i):
    text = _cell(path, line_no, name, row, i)
    try:
        value = float(text)
    except ValueError:
        raise InputError(f"{where(path, line_no, name)}: not a number: {text!r}") from None
    if not math.isfinite(value):
        raise InputError(f"{where(path, line_no, name)}: not a finite number: {text!r}")
    return value
