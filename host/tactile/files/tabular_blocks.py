"""Reading a large CSV in blocks of rows, in bounded memory (EP2 contacts at scale, issue 13).

``CsvBlocks(path, required, optional_text)`` yields the data rows as ``Block``s of NumPy
arrays, a block at a time, under the rules and with the one-line errors of
``tabular.read_csv`` (header row, ``#`` lines, unknown columns ignored, BOM, line endings,
UTF-8, finite numbers), the first error in file order.  The limits on bytes and rows are
the caller's; lines are at most ``tabular.MAX_LINE_BYTES`` as everywhere.

Two parsers, one answer.  A run of plain lines (printable ASCII without quotes, spaces or
``#``; LF or CR LF endings) is parsed by ``numpy.loadtxt`` in C, which rounds numbers as
``float`` does.  Anything else, and any run the fast parse does not take whole (an error,
a blank line, a short row, a non-finite number), goes through ``tabular``'s own
line-by-line reader, which also names the line of any error.  A quoted field that runs
over the end of a run is followed into the next one.  ``tests/test_ep2_reader.py`` holds
both parsers equal to ``read_csv`` on hostile files.
"""

import csv
import io
from array import array
from dataclasses import dataclass

import numpy as np

from tactile.errors import InputError, where
from tactile.files.csv_dialect import UnitsRule, csv_error
from tactile.files.tabular import (
    MAX_LINE_BYTES,
    cell_at,
    count_lines,
    header_index,
    line_blocks,
    line_text,
    no_header,
    number_at,
)

BLOCK_BYTES = 1 << 18  # bytes of text a block: ~3,500 rows of contacts (as fast as 1 MiB)
# bytes a plain run may hold (printable ASCII but quote, '#' and space; line breaks)
_PLAIN = bytes(b for b in range(0x21, 0x7F) if b not in b'"#') + b"\r\n"


@dataclass
class Block:
    """Consecutive data rows: ``numbers`` (n, k) floats in the order asked, ``texts`` one
    object array of stripped strings per text column present, ``lines`` (n,) int64."""

    numbers: np.ndarray
    texts: dict
    lines: np.ndarray


class CsvBlocks:
    """Iterate the data rows of ``path`` as ``Block``s.  Once the header is read,
    ``header_line`` and ``texts`` (the ``optional_text`` columns present) are set;
    ``rows`` counts the data rows read so far, ``bytes_read`` the bytes."""

    def __init__(self, path, required, optional_text=(), *, max_bytes, max_rows):
        self.path, self.required, self.optional_text = path, tuple(required), optional_text
        self.max_bytes, self.max_rows = max_bytes, max_rows
        self.header_line, self.texts, self.rows = None, (), 0
        self._index = self._feed = None

    def __iter__(self):
        feed = self._feed = _Feed(self.path, line_blocks(self.path, self.max_bytes, BLOCK_BYTES))
        reader = csv.reader(feed, strict=True)
        comments = UnitsRule(self.path)
        slow = None  # rows parsed one at a time, from the header on
        while True:
            if feed.at_end_of_run():
                if slow is not None and len(slow.lines):
                    yield slow.block()
                run = feed.take()
                if run is None:
                    break
                fast = self._fast(*run)
                if fast is not None:
                    yield fast
                    continue
                feed.start(*run)
            start = feed.first + feed.i  # the line the next record begins on
            try:
                row = next(reader)
            except StopIteration:
                break
            except csv.Error as exc:
                raise csv_error(self.path, feed.line, start, exc) from None
            if not comments.data(feed.line, row):
                continue
            if slow is not None:
                slow.add(feed.line, row)
                continue
            self._header(feed.line, row)
            slow = _Rows(self)
            feed.put_back_rest()  # the lines after the header may be plain
        if slow is not None and len(slow.lines):
            yield slow.block()
        if self._index is None:
            raise InputError(no_header(self.path))

    @property
    def bytes_read(self):
        return 0 if self._feed is None else self._feed.bytes

    def _header(self, line_no, row):
        self._index = header_index(self.path, line_no, row, self.required)
        self.header_line = line_no
        self.texts = tuple(c for c in self.optional_text if c in self._index)

    def _fast(self, first, run):
        """The run's rows parsed by ``numpy.loadtxt``, or None (the slow parser decides)."""
        n = count_lines(run)
        if self._index is None or self.rows + n > self.max_rows or not _plain(run):
            return None
        k = len(self.required)
        dtype = [(f"f{i}", "f8") for i in range(k)] + [(c, "O") for c in self.texts]
        try:
            table = np.loadtxt(
                io.StringIO(run.decode("ascii")), delimiter=",", comments=None,
                quotechar=None, dtype=dtype, ndmin=1,
                usecols=[self._index[c] for c in (*self.required, *self.texts)],
            )  # fmt: skip
        except ValueError:  # a short row, a cell that is not a number: the slow parser names it
            return None
        numbers = np.column_stack([table[f"f{i}"] for i in range(k)])
        if len(table) != n or not np.isfinite(numbers).all():
            return None
        texts = {c: table[c] for c in self.texts}
        self.rows += n
        return Block(numbers, texts, np.arange(first, first + n, dtype=np.int64))


def _plain(run):
    """True when every line of ``run`` is one record the fast parser reads as the slow one
    does: printable ASCII but quote, '#' and space; not blank; LF or CR LF; within the
    line limit."""
    if run.translate(None, _PLAIN) or run.startswith((b"\n", b"\r")):
        return False
    if b"\n\n" in run or b"\n\r\n" in run:
        return False
    if b"\r" in run and run.count(b"\r") != run.count(b"\r\n"):
        return False
    return _longest_line(run) <= MAX_LINE_BYTES


def _longest_line(run):
    """Length in bytes of the longest line of ``run`` (lines end in LF), or a number at
    most ``MAX_LINE_BYTES`` when none is longer: such a line would span a whole aligned
    window of half that size without a line break, and there are only a few windows."""
    half = MAX_LINE_BYTES // 2
    if all(run.find(b"\n", p, p + half) >= 0 for p in range(0, len(run) - half + 1, half)):
        return min(len(run), MAX_LINE_BYTES)
    ends = np.flatnonzero(np.frombuffer(run, np.uint8) == 10)
    return int(np.diff(ends, prepend=-1, append=len(run) - 1).max())


class _Feed:
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
        self.bytes += 0 if run is None else len(run[1])
        return run

    def start(self, first, run):
        self.first, self.raw, self.i = first, run.splitlines(keepends=True), 0

    def put_back_rest(self):
        """The lines of this run not yet read become a run of their own, taken next."""
        if self.i < len(self.raw):
            self.back = self.first + self.i, b"".join(self.raw[self.i :])
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


class _Rows:
    """Rows parsed one at a time (``tabular``'s rules), gathered into a ``Block``."""

    def __init__(self, owner):
        self.owner = owner
        self._reset()

    def _reset(self):
        self.columns = [array("d") for _ in self.owner.required]
        self.texts = {c: [] for c in self.owner.texts}
        self.lines = array("q")

    def add(self, line_no, row):
        o = self.owner
        if o.rows == o.max_rows:
            raise InputError(
                f"{where(o.path, line_no)}: more than {o.max_rows:,} data rows (the limit for"
                " one file; split it)"
            )
        for name, col in zip(o.required, self.columns):
            col.append(number_at(o.path, line_no, name, row, o._index[name]))
        for name, col in self.texts.items():
            col.append(cell_at(o.path, line_no, name, row, o._index[name]))
        self.lines.append(line_no)
        o.rows += 1

    def block(self):
        numbers = np.column_stack([np.frombuffer(c, float) for c in self.columns])
        texts = {c: np.array(v, dtype=object) for c, v in self.texts.items()}
        out = Block(numbers, texts, np.frombuffer(self.lines, np.int64).copy())
        self._reset()
        return out
