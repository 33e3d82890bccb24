"""Reading the project's CSV files (EP2 contacts, pose logs, EP1 probes and probe logs,
a recording's frames).

One reader: ``CsvBlocks`` yields the data rows as ``Block``s of NumPy arrays, about
``BLOCK_BYTES`` of text at a time, so memory holds a block, not the file; ``read_csv`` is
those blocks gathered into one ``Table``.  Every error is an ``InputError`` (exit 2) whose
one-line message names file, line and column: the first error in file order.  A file
without a header, and the ``#`` lines, are read by ``tactile.files.csv_dialect``.

Limits (docs/cli.md, "Files the host reads"): a regular file (not a device, pipe or
directory) of at most ``MAX_FILE_BYTES``, lines of at most ``MAX_LINE_BYTES``, at most
``MAX_ROWS`` data rows; a reader of larger files (a recording's frames, streamed EP2
contacts) states its own byte and row limits.  Files are opened by
``tactile.files.bounded``; the dialect (UTF-8 lines, quotes, ``# units:`` lines, columns
named twice, ASCII decimal numbers) is ``tactile.files.csv_dialect``'s.

Two parsers, one answer.  A run of plain lines (printable ASCII without quotes, spaces or
``#``; LF or CR LF endings) is parsed by ``numpy.loadtxt`` in C, which rounds numbers as
``float`` does.  Anything else, and any run the fast parse does not take whole (an error,
a blank line, a short row, a non-finite number), goes through ``csv.reader`` line by line,
which also names the line of any error.  A quoted field that runs over the end of a run
is followed into the next one.  ``tests/test_ep2_reader.py`` holds the two equal on
hostile files.
"""

import io
from array import array
from dataclasses import dataclass

import numpy as np

from tactile.errors import InputError, where
from tactile.files.csv_dialect import (
    DECIMAL,
    MAX_FILE_BYTES,
    MAX_LINE_BYTES,
    Feed,
    Records,
    cell_at,
    count_lines,
    header_index,
    line_blocks,
    no_header,
    number_at,
)

__all__ = [
    "MAX_FILE_BYTES",
    "MAX_LINE_BYTES",
    "MAX_ROWS",
    "Block",
    "CsvBlocks",
    "Table",
    "read_csv",
]

MAX_ROWS = 1_000_000
MAX_WHOLE = 2**53  # the largest whole-number value a column may hold (floats are exact to it)
BLOCK_BYTES = 1 << 18  # bytes of text a block: ~3,500 rows of contacts (as fast as 1 MiB)
NAN = float("nan")
# bytes a plain run may hold (printable ASCII but quote, '#' and space; line breaks)
_PLAIN = bytes(b for b in range(0x21, 0x7F) if b not in b'"#') + b"\r\n"


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
        return np.column_stack([np.asarray(self.columns[n], dtype=float) for n in names])

    def within(self, names, limit):
        """The named float columns as an (n, k) array, every |value| <= ``limit``, or
        ``InputError`` naming the first offending line and column."""
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
    """``CsvBlocks`` of ``path`` gathered into a ``Table``; ``max_bytes`` and ``max_rows``
    default to ``MAX_FILE_BYTES`` and ``MAX_ROWS``."""
    blocks = CsvBlocks(
        path, required, optional_text, optional_float, blank_float,
        max_bytes=MAX_FILE_BYTES if max_bytes is None else max_bytes,
        max_rows=MAX_ROWS if max_rows is None else max_rows, end=end,
    )  # fmt: skip
    columns, lines = {}, array("q")
    for block in blocks:
        if not columns:
            columns = {c: array("d") for c in blocks.floats}
            columns.update({c: [] for c in blocks.texts})
            shared = {c: {} for c in blocks.texts}  # one str per distinct cell (ids repeat)
        for c, values in zip(blocks.floats, block.numbers.T):
            columns[c].frombytes(values.tobytes())
        for c, values in block.texts.items():
            columns[c].extend([shared[c].setdefault(t, t) for t in values.tolist()])
        lines.frombytes(block.lines.tobytes())
    return Table(path, columns, lines)


@dataclass
class Block:
    """Consecutive data rows: ``numbers`` (n, k) floats (the columns of ``CsvBlocks.floats``,
    blank cells NaN), ``texts`` one object array of stripped strings per text column
    present, ``lines`` (n,) int64."""

    numbers: np.ndarray
    texts: dict
    lines: np.ndarray


class CsvBlocks:
    """Iterate the data rows of ``path`` as ``Block``s: header row, ``#`` comment lines,
    unknown columns ignored.

    ``required`` and ``optional_float`` columns must be finite numbers; ``blank_float``
    columns (optional) too, but an empty cell there is NaN (a value not known);
    ``optional_text`` columns are kept as stripped strings.  ``end`` reads only the file's
    first ``end`` bytes.  Once the header is read, ``header_line``, ``floats`` and
    ``texts`` (the columns present) are set; ``rows`` counts the data rows read so far,
    ``bytes_read`` the bytes."""

    def __init__(
        self, path, required, optional_text=(), optional_float=(), blank_float=(), *,
        max_bytes, max_rows, end=None,
    ):  # fmt: skip
        self.path, self.required, self.end = path, tuple(required), end
        self.asked = (optional_text, optional_float, blank_float)
        self.max_bytes, self.max_rows = max_bytes, max_rows
        self.header_line, self.floats, self.blanks, self.texts, self.rows = None, (), (), (), 0
        self._index = self._feed = None

    def __iter__(self):
        feed = self._feed = Feed(self.path, self._runs())
        records = Records(self.path, feed)
        header = records.first()
        if header is None:
            raise InputError(no_header(self.path))
        self._header(*header)
        slow = _Rows(self)
        feed.put_back_rest()  # the lines after the header may be plain
        while True:
            if feed.at_end_of_run():
                if len(slow.lines):
                    yield slow.block()
                run = feed.take()
                if run is None:
                    break
                fast = self._fast(*run)
                if fast is not None:
                    yield fast
                    continue
                feed.start(*run)
            record = records.next()
            if record is None:
                break
            if record[1] is not None:
                slow.add(*record)
        if len(slow.lines):
            yield slow.block()
        if not self.rows:
            raise InputError(f"{where(self.path, self.header_line)}: no data rows after the header")

    @property
    def bytes_read(self):
        return 0 if self._feed is None else self._feed.bytes

    def _runs(self):
        return line_blocks(self.path, self.max_bytes, BLOCK_BYTES, self.end)

    def _header(self, line_no, row):
        texts, optional, blanks = self.asked
        self._index = header_index(self.path, line_no, row, self.required)
        self.header_line = line_no
        self.blanks = tuple(c for c in blanks if c in self._index)
        self.floats = (*self.required, *(c for c in optional if c in self._index), *self.blanks)
        self.texts = tuple(c for c in texts if c in self._index)

    def _fast(self, first, run):
        """The run's rows parsed by ``numpy.loadtxt``, or None (the slow parser decides)."""
        n = count_lines(run)
        if self.rows + n > self.max_rows or not _plain(run):
            return None
        k, index = len(self.floats), self._index
        dtype = [(f"f{i}", "f8") for i in range(k)] + [(c, "O") for c in self.texts]
        try:
            table = np.loadtxt(
                io.BytesIO(run), delimiter=",", comments=None, quotechar=None, dtype=dtype,
                ndmin=1, encoding="ascii", usecols=[index[c] for c in (*self.floats, *self.texts)],
                converters={index[c]: _blank_cell for c in self.blanks},
            )  # fmt: skip
        except ValueError:  # a short row, a cell that is not a number: the slow parser names it
            return None
        numbers = np.column_stack([table[f"f{i}"] for i in range(k)])
        fixed, blank = np.split(numbers, [k - len(self.blanks)], axis=1)
        if len(table) != n or not np.isfinite(fixed).all() or np.isinf(blank).any():
            return None  # NaN in ``blank`` comes only from an empty cell (``_blank_cell``)
        self.rows += n
        texts = {c: table[c] for c in self.texts}
        return Block(numbers, texts, np.arange(first, first + n, dtype=np.int64))


def _blank_cell(text):
    """A ``blank_float`` cell for the fast parser: NaN when empty, a plain decimal, or
    ``ValueError`` (the slow parser then names it)."""
    if not text:
        return NAN
    if not DECIMAL.fullmatch(text):
        raise ValueError(text)
    return float(text)


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


class _Rows:
    """Rows parsed one at a time, gathered into a ``Block``."""

    def __init__(self, owner):
        self.owner = owner
        self._reset()

    def _reset(self):
        self.columns = [array("d") for _ in self.owner.floats]
        self.texts = {c: [] for c in self.owner.texts}
        self.lines = array("q")

    def add(self, line_no, row):
        o, path = self.owner, self.owner.path
        if o.rows == o.max_rows:
            raise InputError(
                f"{where(path, line_no)}: more than {o.max_rows:,} data rows (the limit for"
                " one file; split it)"
            )
        for name, col in zip(o.floats, self.columns):
            i = o._index[name]
            empty = name in o.blanks and not cell_at(path, line_no, name, row, i)
            col.append(NAN if empty else number_at(path, line_no, name, row, i))
        for name, col in self.texts.items():
            col.append(cell_at(path, line_no, name, row, o._index[name]))
        self.lines.append(line_no)
        o.rows += 1

    def block(self):
        numbers = np.column_stack([np.frombuffer(c, float) for c in self.columns])
        texts = {c: np.array(v, dtype=object) for c, v in self.texts.items()}
        out = Block(numbers, texts, np.frombuffer(self.lines, np.int64).copy())
        self._reset()
        return out
