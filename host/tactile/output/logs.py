"""Log lines as the host shows them: escaped, and a library's at a bounded rate.

A library that logs through Python's ``logging`` (``foxglove-sdk``'s Rust core does, under
``foxglove.*``) with no handler of its own reaches stderr through ``logging``'s last
resort: every warning, at any rate, even under ``-q``, and raw, so a line that echoes what
a network client sent ("unknown op `\\x1b[31m`") writes a terminal escape.  ``adopt``
takes such a logger over:

- its records go to a project logger (``tactile.…``) instead, shown where the project's
  own are (``tactile -v``; nowhere without it: the project logger holds a
  ``NullHandler``, so the last resort is never used);
- their text is escaped (``tactile.output.textout.printable``);
- at most ``LINES`` of them per ``INTERVAL_S`` (``RateLimit``); the first line let through
  after some were held back is preceded by "... K lines suppressed", and ``Adopted.flush``
  says the same of any still untold (a server calls it as it stops).

``Escaped`` is the formatter of the CLI's own log handler: each log line one line, escaped.
"""

import logging
import threading
import time

from tactile.output.textout import printable

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
