"""Reading the project's CSV files (EP2 contacts, pose logs, EP1 probes and probe logs).

This is the one place a CSV is read: ``read_csv`` for the rows, ``preamble``,
``comment_lines`` and ``units_line`` for the ``#`` lines some formats carry.  Every error is
an ``InputError`` (exit 2) whose one-line message names file, line and column.

Limits (docs/cli.md, "Files the host reads"): a regular file (not a device, pipe or directory) of
at most ``MAX_FILE_BYTES``, lines of at most ``MAX_LINE_BYTES``, at most ``MAX_ROWS`` data
rows.  UTF-8, with or without the byte-order mark Excel's "CSV UTF-8" writes; lines end in
LF, CR LF or CR.  A byte that is not UTF-8 is reported at its line.  A reader of the
project's own larger files (a recording's frames.csv) may raise the byte and row limits.
Files are opened by ``tactile.files.bounded``; the dialect (quotes, ``# units:`` lines, columns
named twice, ASCII decimal numbers) is ``tactile.files.csv_dialect``'s.
"""

import contextlib
import csv
from array import array

from tactile.errors import InputError, where
from tactile.files import bounded
from tactile.files.csv_dialect import UnitsRule, csv_error, number, show

__all__ = [
    "MAX_FILE_BYTES",
    "MAX_LINE_BYTES",
    "MAX_ROWS",
    "Table",
    "comment_lines",
    "preamble",
    "read_csv",
    "rows",
    "show",
    "units_line",
]

MAX_LINE_BYTES = 64 * 1024
MAX_FILE_BYTES = 64 * 1024 * 1024
MAX_ROWS = 1_000_000
NAN = float("nan")
MAX_WHOLE = 2**53  # the largest whole-number value a column may hold (floats are exact to it)

_CHUNK = 1 << 16
_SPLIT = "the limit for one file; split it"
_BOM = b"\xef\xbb\xbf"


class Table:
    """Columns by name (float arrays or lists of strings) and the line each row came from
    (an ``array('q')``: a few bytes a row, not one Python object per cell)."""

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

    def within(self, names, limit):
        """The named float columns as an (n, k) array, every |value| <= ``limit``, or
        ``InputError`` naming the first offending line and column."""
        import numpy as np

        a = self.array(*names)
        bad = np.argwhere(np.abs(a) > limit)
        if bad.size:
            i, j = (int(v) for v in bad[0])
            raise InputError(
                f"{where(self.path, self.lines[i], names[j])}: must be within +-{limit:g},"
                f" got {float(a[i, j])!r}"
            )
        return a

    def whole(self, name, low=0, high=MAX_WHOLE):
        """The float column ``name`` as int64, every value a whole number in [low, high]
        (``high`` at most 2**53, where floats still hold every integer), or ``InputError``
        naming the first offending line."""
        import numpy as np

        v = np.asarray(self.columns[name], dtype=float)
        bad = np.flatnonzero((v != np.round(v)) | (v < low) | (v > high))
        if bad.size:
            i = int(bad[0])
            raise InputError(
                f"{where(self.path, self.lines[i], name)}: must be a whole number in"
                f" {low}..{high}, got {float(v[i])!r}"
            )
        return v.astype(np.int64)


def read_csv(
    path,
    required,
    optional_text=(),
    optional_float=(),
    blank_float=(),
    *,
    max_bytes=None,
    max_rows=None,
    end=None,
):
    """Read ``path``: header row, ``#`` comment lines, unknown columns ignored.

    ``required`` and ``optional_float`` columns must be finite numbers; ``blank_float``
    columns (optional) too, but an empty cell there is NaN (a value not known);
    ``optional_text`` columns are kept as stripped strings.  ``max_bytes`` and ``max_rows``
    replace ``MAX_FILE_BYTES`` and ``MAX_ROWS`` for this file; ``end`` reads only the
    file's first ``end`` bytes (whole lines: a torn last row left out).
    """
    max_rows = MAX_ROWS if max_rows is None else max_rows
    with contextlib.closing(_rows(path, max_bytes, end)) as rows:
        try:
            header_line, header = next(rows)
        except StopIteration:
            raise InputError(no_header(path)) from None
        index = header_index(path, header_line, header, required)
        floats = [c for c in (*required, *optional_float) if c in index]
        blanks = [c for c in blank_float if c in index]
        texts = [c for c in optional_text if c in index]
        columns = {c: array("d") for c in (*floats, *blanks)}
        columns.update({c: [] for c in texts})
        shared = {c: {} for c in texts}  # one str object per distinct cell (patch ids repeat)
        lines = array("q")
        for line_no, row in rows:
            if len(lines) == max_rows:
                raise InputError(
                    f"{where(path, line_no)}: more than {max_rows:,} data rows (the limit for"
                    " one file; split it)"
                )
            for name in floats:
                columns[name].append(number_at(path, line_no, name, row, index[name]))
            for name in blanks:
                i = index[name]
                empty = not cell_at(path, line_no, name, row, i)
                columns[name].append(NAN if empty else number_at(path, line_no, name, row, i))
            for name in texts:
                text = cell_at(path, line_no, name, row, index[name])
                columns[name].append(shared[name].setdefault(text, text))
            lines.append(line_no)
    if not lines:
        raise InputError(f"{where(path, header_line)}: no data rows after the header")
    return Table(path, columns, lines)


def rows(path):
    """Yield (line number, cells) of every row of a CSV without a header (a calibration
    matrix): blank and ``#`` lines skipped, the same limits and messages as ``read_csv``."""
    with contextlib.closing(_rows(path)) as found:
        yield from found


def preamble(path, max_bytes=None):
    """(``#`` lines before the header as [(line, stripped text)], header line, header row).
    Only the lines up to the header are read; ``max_bytes`` as for ``read_csv``."""
    comments = []
    with contextlib.closing(_text_lines(path, max_bytes)) as lines:
        for line_no, text in lines:
            s = text.strip()
            if s.startswith("#"):
                comments.append((line_no, s))
            elif s:
                return comments, line_no, _parse_one(path, line_no, s)
    raise InputError(no_header(path))


def no_header(path):
    """The one-line message for a file without a header row."""
    return f"{where(path, 1)}: no header row (the file is empty or only comments)"


def units_line(path, max_bytes=None):
    """The ``# units: ...`` line among the ``#`` lines before the header, as (line, the text
    after the colon, stripped), or None when the file states no unit."""
    comments, _, _ = preamble(path, max_bytes)
    for line_no, text in comments:
        key, _, value = text[1:].partition(":")
        if key.strip().lower() == "units":
            return line_no, value.strip()
    return None


def comment_lines(path):
    """Every ``#`` line of the file as [(line, stripped text)], in file order."""
    with contextlib.closing(_text_lines(path)) as lines:
        return [(n, t.strip()) for n, t in lines if t.lstrip().startswith("#")]


# --- reading bytes into lines --------------------------------------------------------------


def _open(path, max_bytes=None):
    """A binary handle on a regular file within ``max_bytes`` (default ``MAX_FILE_BYTES``),
    or ``InputError`` (``tactile.files.bounded``: a FIFO is refused without waiting for a
    writer)."""
    max_bytes = MAX_FILE_BYTES if max_bytes is None else max_bytes
    return bounded.open_regular(path, max_bytes, "a CSV", _SPLIT)


def _too_big(path, max_bytes):
    return bounded.too_big(path, max_bytes, _SPLIT)


def _text_lines(path, max_bytes=None, end=None):
    """Yield (line number, text with its line ending) of every physical line, decoded.

    At most ``MAX_LINE_BYTES`` per line and ``max_bytes`` in all are ever held or read.
    """
    for first, block in line_blocks(path, max_bytes, end=end):
        for line_no, raw in enumerate(block.splitlines(keepends=True), first):
            yield line_no, line_text(path, line_no, raw)


def line_blocks(path, max_bytes=None, size=_CHUNK, end=None):
    """Yield (number of its first line, bytes) of runs of whole lines, in file order: each
    run ends at a line break (LF, CR LF or CR) or at the end of the file.

    About ``size`` bytes a run; a line longer than ``MAX_LINE_BYTES`` is refused at its
    line number before more of it is read.  ``end``: stop after that many bytes."""
    max_bytes = MAX_FILE_BYTES if max_bytes is None else max_bytes
    with _open(path, max_bytes) as fh:
        carry, line_no, total = b"", 0, 0
        while True:
            if len(carry) > MAX_LINE_BYTES + 1:
                raise InputError(_too_long(path, line_no + 1))
            chunk = fh.read(size if end is None else max(0, min(size, end - total)))
            total += len(chunk)
            if total > max_bytes:
                raise InputError(_too_big(path, max_bytes))
            if total == len(chunk) and chunk.startswith((b"\xff\xfe", b"\xfe\xff")):
                raise InputError(f"{where(path, 1)}: UTF-16 text; save it as 'CSV UTF-8'")
            data = carry + chunk
            # a CR at the very end may be the first half of a CR LF: it waits for the chunk
            cut = (
                max(data.rfind(b"\n"), data.rfind(b"\r", 0, len(data) - 1)) + 1
                if chunk
                else len(data)
            )
            block, carry = data[:cut], data[cut:]
            if block:
                yield line_no + 1, block
                line_no += count_lines(block)
            if not chunk:
                return


def count_lines(block):
    """Lines in ``block`` as ``bytes.splitlines`` counts them (LF, CR LF or CR)."""
    n = block.count(b"\n")
    if b"\r" in block:
        n += block.count(b"\r") - block.count(b"\r\n")
    return n + (not block.endswith((b"\n", b"\r")))


def line_text(path, line_no, raw):
    """One physical line decoded (the BOM dropped from line 1), or ``InputError``."""
    if len(raw) > MAX_LINE_BYTES and len(raw.rstrip(b"\r\n")) > MAX_LINE_BYTES:
        raise InputError(_too_long(path, line_no))
    if line_no == 1 and raw.startswith(_BOM):
        raw = raw[len(_BOM) :]
    return _decode(path, line_no, raw)


def _too_long(path, line_no):
    return f"{where(path, line_no)}: line longer than {MAX_LINE_BYTES} bytes (the limit)"


def _decode(path, line_no, raw):
    try:
        return raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise InputError(
            f"{where(path, line_no)}: not UTF-8 text (byte 0x{raw[exc.start]:02x} at byte"
            f" {exc.start + 1} of the line); save it as 'CSV UTF-8'"
        ) from None


# --- lines into rows and cells -------------------------------------------------------------


def _rows(path, max_bytes=None, end=None):
    """Yield (line number, cells) of the header and data rows; blank and ``#`` lines skipped."""
    with contextlib.closing(_text_lines(path, max_bytes, end)) as lines:
        numbered = _Numbered(lines)
        reader = csv.reader(numbered, strict=True)
        comments = UnitsRule(path)
        while True:
            start = numbered.line + 1  # where the next record begins
            try:
                row = next(reader)
            except StopIteration:
                return
            except csv.Error as exc:
                raise csv_error(path, numbered.line, start, exc) from None
            if comments.data(numbered.line, row):
                yield numbered.line, row


class _Numbered:
    """Iterator over the text of (line, text) pairs that remembers the last line number."""

    def __init__(self, lines):
        self.lines = lines
        self.line = 0

    def __iter__(self):
        return self

    def __next__(self):
        self.line, text = next(self.lines)
        return text


def _parse_one(path, line_no, text):
    try:
        return next(csv.reader([text]))
    except csv.Error as exc:
        raise InputError(f"{where(path, line_no)}: not valid CSV: {exc}") from None


def header_index(path, line_no, header, required):
    """{column name: index} of a header row; ``InputError`` naming a required column
    that is missing or a column named twice."""
    index = {}
    for i, name in enumerate(header):
        name = name.strip()
        if name and name in index:
            raise InputError(
                f"{where(path, line_no, name)}: named twice in the header (columns"
                f" {index[name] + 1} and {i + 1})"
            )
        index[name] = i
    missing = [c for c in required if c not in index]
    if missing:
        names = ", ".join(show(h.strip(), 20, quote=False) for h in header[:20])
        more = f" and {len(header) - 20} more" if len(header) > 20 else ""
        raise InputError(
            f"{where(path, line_no)}: missing required column(s) {', '.join(missing)}"
            f" (header has: {names}{more})"
        )
    return index


def cell_at(path, line_no, name, row, i):
    """Cell ``i`` (column ``name``) of a row, stripped; ``InputError`` if the row is short."""
    if i >= len(row):
        raise InputError(f"{where(path, line_no, name)}: missing value (row is short)")
    return row[i].strip()


def number_at(path, line_no, name, row, i):
    """Cell ``i`` as a float; ``InputError`` naming file, line and column otherwise."""
    text = cell_at(path, line_no, name, row, i)
    return number(text, where(path, line_no, name))
