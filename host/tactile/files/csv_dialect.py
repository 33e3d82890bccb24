"""The strict CSV dialect every reader of ``tactile.files.tabular`` holds a file to.

- Quotes: a quoted cell may span lines, but one still open at the end of the file (an
  unterminated quote, which would take in the rest of the file) is refused at the line it
  opened; so is a character after a closing quote (``"a"b``).
- ``# units:``: at most one, before the first row (the header); a second one, or one
  after, is refused at its line.
- Numbers: ASCII decimals only (``-1.5``, ``2e-3``); ``1_0``, digits of other scripts
  (``\u0661``, fullwidth), ``0x10``, NaN and inf are refused naming the cell.
- A column named twice in a header is refused (``tabular.header_index``).

Every refusal is an ``InputError`` naming the file and line (and the column of a cell).
"""

import math
import re

from tactile.errors import InputError, where

SHOW_CHARS = 40  # of a cell or header quoted in a message


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
