"""The strict CSV dialect every CSV reader holds a file to, and the readers that need no
table: ``rows`` (a file without a header, a calibration matrix), ``preamble``,
``units_line`` and ``comment_lines`` (the ``#`` lines some formats carry).  Tables are
``tactile.files.tabular``'s.

- Lines: UTF-8, with or without the byte-order mark Excel's "CSV UTF-8" writes; LF, CR LF
  or CR endings; at most ``MAX_LINE_BYTES`` each.  A byte that is not UTF-8 is refused at
  its line, UTF-16 at line 1; a file is read within its byte limit
  (``tactile.files.bounded``: a regular file, a FIFO refused without waiting for a writer).
- Quotes: a quoted cell may span lines, but one still open at the end of the file (an
  unterminated quote, which would take in the rest of the file) is refused at the line it
  opened; so is a character after a closing quote (``"a"b``).
- ``# units:``: at most one, before the first row (the header); a second one, or one
  after, is refused at its line.
- Numbers: ASCII decimals only (``-1.5``, ``2e-3``); ``1_0``, digits of other scripts
  (``\u0661``, fullwidth), ``0x10``, NaN and inf are refused naming the cell.
- Headers and cells: a column named twice is refused, and so are a required column
  missing and a row too short for a column read (``header_index``, ``cell_at``).

Every refusal is an ``InputError`` naming the file and line (and the column of a cell).
"""

import contextlib
import csv
import math
import re

from tactile.errors import InputError, where
from tactile.files import bounded

SHOW_CHARS = 40  # of a cell or header quoted in a message
MAX_LINE_BYTES = 64 * 1024
MAX_FILE_BYTES = 64 * 1024 * 1024  # of a CSV read whole (a reader may state its own)
RUN_BYTES = 1 << 16  # read at a time by the line readers here
_BOM = b"\xef\xbb\xbf"


def show(text, limit=SHOW_CHARS, quote=True):
    """``text`` for a one-line message: quoted (or, with ``quote=False``, left bare when it
    is printable), control characters escaped, long text cut."""
    cut = len(text) > limit
    text = text[:limit]
    if quote or not text.isprintable():
        text = repr(text)
    return text + ("..." if cut else "")


def skipped(row):
    """A CSV row no reader takes as data: empty, only blanks, or a ``#`` comment."""
    return not row or not "".join(row).strip() or row[0].lstrip().startswith("#")


def csv_error(path, line_no, start, exc):
    """The ``InputError`` for ``csv.Error`` ``exc`` at ``line_no`` (a record from ``start``)."""
    if "unexpected end of data" in str(exc):
        return InputError(
            f"{where(path, start)}: a quote opened on this line is never closed (an"
            " unterminated quoted cell takes in the rest of the file)"
        )
    return InputError(f"{where(path, line_no)}: not valid CSV: {exc}")


class UnitsRule:
    """The one ``# units:`` line of a file, if any, comes before its first row (the header,
    or the data of a file without one): a second one, or one after, is refused."""

    def __init__(self, path):
        self.path, self.first, self.started = path, None, False

    def data(self, line_no, row):
        """True for a row a reader takes (header or data), False for one it skips."""
        if not skipped(row):
            self.started = True
            return True
        if not is_units(row):
            return False
        if self.started:
            raise InputError(
                f"{where(self.path, line_no)}: a '# units:' line after the first row (it"
                " must come before the header)"
            )
        if self.first is not None:
            raise InputError(
                f"{where(self.path, line_no)}: a second '# units:' line (the first is line"
                f" {self.first}; a file states its units once)"
            )
        self.first = line_no
        return False


def is_units(row):
    """Whether a skipped row is a ``# units:`` (or ``# unit:``) line."""
    first = row[0].lstrip() if row else ""
    key, sep, _ = first[1:].partition(":")
    return first.startswith("#") and bool(sep) and key.strip().lower() in ("units", "unit")


DECIMAL = re.compile(r"[+-]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?")


def number(text, place):
    """``text`` as a finite float written in ASCII decimal (``-1.5e3``), or ``InputError``
    at ``place``: not ``1_0``, digits of other scripts, ``nan`` or ``inf``, which Python's
    ``float`` would take."""
    try:
        value = float(text)
    except ValueError:
        raise InputError(f"{place}: not a number: {show(text)}") from None
    if not math.isfinite(value):
        raise InputError(f"{place}: not a finite number: {show(text)}")
    if not DECIMAL.fullmatch(text):
        raise InputError(
            f"{place}: not a plain decimal number: {show(text)} (ASCII digits 0-9, '.', 'e')"
        )
    return value


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
    return number(cell_at(path, line_no, name, row, i), where(path, line_no, name))


# --- bytes into lines --------------------------------------------------------------------


def line_blocks(path, max_bytes, size, end=None):
    """Yield (number of its first line, bytes) of runs of whole lines, in file order: each
    run ends at a line break (LF, CR LF or CR) or at the end of the file.

    About ``size`` bytes a run; a line longer than ``MAX_LINE_BYTES`` is refused at its
    line number before more of it is read.  ``end``: stop after that many bytes."""
    split = "the limit for one file; split it"
    with bounded.open_regular(path, max_bytes, "a CSV", split) as fh:
        carry, line_no, total = b"", 0, 0
        while True:
            if len(carry) > MAX_LINE_BYTES + 1:
                raise InputError(_too_long(path, line_no + 1))
            chunk = fh.read(size if end is None else max(0, min(size, end - total)))
            total += len(chunk)
            if total > max_bytes:
                raise InputError(bounded.too_big(path, max_bytes, split))
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
    try:
        return raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise InputError(
            f"{where(path, line_no)}: not UTF-8 text (byte 0x{raw[exc.start]:02x} at byte"
            f" {exc.start + 1} of the line); save it as 'CSV UTF-8'"
        ) from None


def _too_long(path, line_no):
    return f"{where(path, line_no)}: line longer than {MAX_LINE_BYTES} bytes (the limit)"


# --- lines into records ------------------------------------------------------------------


class Feed:
    """Decoded lines for ``csv.reader``, one run of lines at a time.  A record still open
    at the end of a run (a quoted field over a line break) takes lines from the next."""

    def __init__(self, path, runs):
        self.path, self.runs = path, runs
        self.first, self.raw, self.i, self.line = 1, [], 0, 0
        self.bytes = 0  # taken from the file so far
        self.back = None  # a run put back, taken first

    def take(self):
        """The next run of lines, (first line, bytes), or None at the end of the file."""
        if self.back is not None:
            run, self.back = self.back, None
            return run
        run = next(self.runs, None)
        if run is not None:
            self.bytes += len(run[1])
            self.line = run[0] - 1  # the last line given out (a fast parse took the run before)
        return run

    def start(self, first, run):
        self.first, self.raw, self.i = first, run.splitlines(keepends=True), 0

    def put_back_rest(self):
        """The lines of this run not yet read become a run of their own, taken next."""
        if self.i < len(self.raw):
            self.back = self.line + 1, b"".join(self.raw[self.i :])
        self.raw, self.i = [], 0

    def at_end_of_run(self):
        return self.i >= len(self.raw)

    def __iter__(self):
        return self

    def __next__(self):
        if self.at_end_of_run():
            run = self.take()
            if run is None:
                raise StopIteration
            self.start(*run)
        self.line = self.first + self.i
        self.i += 1
        return line_text(self.path, self.line, self.raw[self.i - 1])


class Records:
    """``csv.reader`` over a ``Feed``, in the strict dialect: ``next()`` is the next record
    as (its last line, cells), cells None for a row no reader takes (``UnitsRule``), or
    None at the end of the file."""

    def __init__(self, path, feed):
        self.path, self.feed = path, feed
        self.reader = csv.reader(feed, strict=True)
        self.comments = UnitsRule(path)

    def next(self):
        start = self.feed.line + 1  # the line the next record begins on
        try:
            row = next(self.reader)
        except StopIteration:
            return None
        except csv.Error as exc:
            raise csv_error(self.path, self.feed.line, start, exc) from None
        return self.feed.line, row if self.comments.data(self.feed.line, row) else None

    def first(self):
        """The first record taken (header or data), or None."""
        while (record := self.next()) is not None and record[1] is None:
            pass
        return record


# --- files without a table: a header-less matrix, the ``#`` lines -----------------------


def rows(path, max_bytes=None):
    """Yield (line number, cells) of every row of a CSV without a header (a calibration
    matrix): blank and ``#`` lines skipped; the limits and messages of ``tabular.read_csv``
    (``max_bytes`` as for ``preamble``)."""
    runs = line_blocks(path, MAX_FILE_BYTES if max_bytes is None else max_bytes, RUN_BYTES)
    with contextlib.closing(runs):
        records = Records(path, Feed(path, runs))
        while (record := records.next()) is not None:
            if record[1] is not None:
                yield record


def preamble(path, max_bytes=None):
    """(``#`` lines before the header as [(line, stripped text)], header line, header row).
    Only the lines up to the header are read, of a file of at most ``max_bytes``
    (default ``MAX_FILE_BYTES``)."""
    comments = []
    with contextlib.closing(_text_lines(path, max_bytes)) as lines:
        for line_no, text in lines:
            s = text.strip()
            if s.startswith("#"):
                comments.append((line_no, s))
            elif s:
                try:
                    return comments, line_no, next(csv.reader([s]))
                except csv.Error as exc:
                    raise InputError(f"{where(path, line_no)}: not valid CSV: {exc}") from None
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


def comment_lines(path, max_bytes=None):
    """Every ``#`` line of the file as [(line, stripped text)], in file order."""
    with contextlib.closing(_text_lines(path, max_bytes)) as lines:
        return [(n, t.strip()) for n, t in lines if t.lstrip().startswith("#")]


def _text_lines(path, max_bytes=None):
    """Yield (line number, text with its line ending) of every physical line, decoded."""
    max_bytes = MAX_FILE_BYTES if max_bytes is None else max_bytes
    for first, run in line_blocks(path, max_bytes, RUN_BYTES):
        for line_no, raw in enumerate(run.splitlines(keepends=True), first):
            yield line_no, line_text(path, line_no, raw)
