"""Text the host prints: safe for a terminal, and the same numbers as JSON.

Nothing from outside is trusted: a device's strings (``sensor_model``), a file's text, a
path the user gave (a folder may be named ``"\\x1b[31m\\n"``).  One carrying ESC sequences
or a newline would repaint the user's terminal or forge output lines.
``printable`` escapes every non-printable character (``\\x1b``, ``\\n``, ``\\x7f``,
``\\u2028``...) of a line; ``printable_lines`` does so line by line.  ``value`` applies the
project's one rule for numbers as well: a non-finite float is ``null`` in text as in
``--json`` (``clean``).  Every line the CLI prints goes through
here (``tests/test_escaped_output.py`` reads the sources for it); JSON output is escaped
by ``json`` itself.

JSON output never contains NaN or Infinity: ``clean`` turns non-finite floats into
``null`` and NumPy scalars and arrays into plain Python numbers and lists; ``dumps`` is what
every ``--json`` flag prints.

Log lines as the host shows them: escaped, and a library's at a bounded rate.  A library
that logs through Python's ``logging`` (``foxglove-sdk``'s Rust core does, under
``foxglove.*``) with no handler of its own reaches stderr through ``logging``'s last
resort: every warning, at any rate, even under ``-q``, and raw, so a line that echoes what
a network client sent ("unknown op `\\x1b[31m`") writes a terminal escape.  ``adopt``
takes such a logger over:

- its records go to a project logger (``tactile.…``) instead, shown where the project's
  own are (``tactile -v``; nowhere without it: the project logger holds a
  ``NullHandler``, so the last resort is never used);
- their text is escaped (``printable``);
- at most ``LINES`` of them per ``INTERVAL_S`` (``RateLimit``); the first line let through
  after some were held back is preceded by "... K lines suppressed", and ``Adopted.flush``
  says the same of any still untold (a server calls it as it stops).

``Escaped`` is the formatter of the CLI's own log handler: each log line one line, escaped.
"""

import json
import logging
import math
import threading
import time


def printable(text):
    """``text`` (a ``str``, or any value such as a path, as ``str``) with every non-printable
    character written as a Python escape: one line, whatever it holds."""
    if not isinstance(text, str):
        text = str(text)
    if text.isprintable():
        return text
    return "".join(ch if ch.isprintable() else ch.encode("unicode_escape").decode() for ch in text)


def printable_lines(lines):
    """``lines`` (an iterable of one-line texts) joined by newlines, each one escaped: a
    newline inside a line is shown as ``\\n``, not obeyed."""
    return "\n".join(printable(line) for line in lines)


def value(v):
    """One value as text: strings escaped, non-finite floats ``null`` (as in JSON)."""
    v = clean(v)
    if v is None:
        return "null"
    if isinstance(v, str):
        return printable(v)
    if isinstance(v, list):
        return "[" + ", ".join(value(x) for x in v) + "]"
    return str(v)


def count(n, what, plural="s"):
    """``n`` ``what`` in words: ``1 frame``, ``2,048 frames``."""
    return f"{n:,} {what}{plural * (n != 1)}"


def fields(d, skip=("type",)):
    """``key=value`` pairs of a message dictionary, space separated."""
    return " ".join(f"{k}={value(v)}" for k, v in d.items() if k not in skip)


def clean(obj):
    """Return ``obj`` with NumPy types converted and non-finite floats as None."""
    if isinstance(obj, dict):
        return {str(k): clean(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [clean(v) for v in obj]
    if isinstance(obj, bool) or obj is None or isinstance(obj, (int, str)):
        return obj
    if isinstance(obj, float):
        return obj if math.isfinite(obj) else None
    if isinstance(obj, (bytes, bytearray)):
        return obj.decode("ascii", "replace")
    tolist = getattr(obj, "tolist", None)  # NumPy scalar or array
    if tolist is not None:
        return clean(tolist())
    raise TypeError(f"cannot write {type(obj).__name__} as JSON")


def dumps(obj):
    """One compact JSON line; raises ValueError rather than emit NaN.

    The same text as ``json.dumps(clean(obj))``, without copying ``obj`` first where
    that cannot change it: when every dict key is a ``str``, ``json`` writes ``obj``
    itself and calls ``clean`` only on what it cannot write (NumPy values, bytes); a
    non-finite float makes it stop, and ``clean`` then writes it as null."""
    if _str_keys(obj):
        try:
            return _ENCODE(obj)
        except ValueError:  # a NaN or inf: ``clean``'s copy has null there
            pass
    return json.dumps(clean(obj), allow_nan=False, separators=(",", ":"))


_ENCODE = json.JSONEncoder(allow_nan=False, separators=(",", ":"), default=clean).encode


def _str_keys(obj):
    """Whether every dict in ``obj`` (through dicts, lists and tuples) has only ``str`` keys,
    which ``json`` writes as ``clean`` does (not so None, True, 1.0 or a NumPy key).  A
    subclass of dict, list or tuple says no: ``clean`` takes it the careful way."""
    kind = type(obj)
    if kind is dict:
        for k, v in obj.items():
            if type(k) is not str or (type(v) not in _LEAVES and not _str_keys(v)):
                return False
        return True
    if kind is list or kind is tuple:
        return all(type(v) in _LEAVES or _str_keys(v) for v in obj)
    return not isinstance(obj, dict | list | tuple)  # else ``json`` asks ``clean``


_LEAVES = frozenset((str, int, float, bool, type(None)))


LINES = 10  # a library's log lines shown per interval
INTERVAL_S = 10.0


class RateLimit(logging.Filter):
    """Passes at most ``lines`` records per ``interval_s`` of ``clock`` (s) and counts the
    rest.  A record passed after some were held back carries their number as
    ``record.suppressed``; ``take_suppressed`` returns (and forgets) the count not yet told.
    Thread-safe: a library logs from its own threads."""

    def __init__(self, lines=LINES, interval_s=INTERVAL_S, clock=time.monotonic):
        super().__init__()
        self.lines, self.interval_s, self.clock = lines, interval_s, clock
        self._lock = threading.Lock()
        self._start = None
        self._passed = self._held = 0

    def filter(self, record):
        with self._lock:
            now = self.clock()
            if self._start is None or not 0 <= now - self._start < self.interval_s:
                self._start, self._passed = now, 0  # a new interval (or the clock went back)
            if self._passed >= self.lines:
                self._held += 1
                return False
            self._passed += 1
            record.suppressed, self._held = self._held, 0
            return True

    def take_suppressed(self):
        with self._lock:
            held, self._held = self._held, 0
            return held


class Adopted(logging.Handler):
    """A library logger's handler: each record re-logged on ``target`` at its level as
    ``"name: text"`` (``name`` without the library's prefix), the text escaped."""

    def __init__(self, source, target, limit):
        super().__init__()
        self.prefix = source.name + "."
        self.target, self.limit = target, limit
        self.addFilter(limit)

    def emit(self, record):
        try:
            text = printable(record.getMessage())
        except Exception:  # a library's bad format arguments: its line is lost, not ours
            return
        held = getattr(record, "suppressed", 0)
        if held:
            self._say_suppressed(held)
        name = record.name.removeprefix(self.prefix)
        self.target.log(record.levelno, "%s: %s", printable(name), text)

    def flush(self):
        held = self.limit.take_suppressed()
        if held:
            self._say_suppressed(held)

    def _say_suppressed(self, held):
        rate = f"at most {self.limit.lines} per {self.limit.interval_s:g} s"
        self.target.warning("... %d line%s suppressed (%s)", held, "s" * (held != 1), rate)


def adopt(name, target, lines=LINES, interval_s=INTERVAL_S, clock=time.monotonic):
    """Take over the logger ``name`` (a library's): its records go to the logger ``target``
    (a name), escaped and rate-limited, and no longer propagate.  The library logs what
    ``target`` would show now (its level follows ``target``'s).  Once per process: a later
    call only follows the level again.  Returns the ``Adopted`` handler."""
    source, into = logging.getLogger(name), logging.getLogger(target)
    if not any(isinstance(h, logging.NullHandler) for h in into.handlers):
        into.addHandler(logging.NullHandler())  # never logging's last resort
    source.setLevel(into.getEffectiveLevel())
    for h in source.handlers:
        if isinstance(h, Adopted):
            return h
    handler = Adopted(source, into, RateLimit(lines, interval_s, clock))
    source.addHandler(handler)
    source.propagate = False
    return handler


class Escaped(logging.Formatter):
    """A formatter whose every line is one line, escaped: a log line may quote a path, a
    device's words or a file's text."""

    def format(self, record):
        return printable(super().format(record))
