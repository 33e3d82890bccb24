"""A library's log lines (``foxglove-sdk``'s) go through the project's logging: shown only
with ``-v``, at most ``LINES`` per ``INTERVAL_S``, escaped (``tactile.output.text``).

Unit tests on an injected clock; then the real thing: ``tactile record --foxglove`` in a
process of its own (so that ``logging``'s last resort writes to a real stderr, as for a
user), and a client that sends ops named with a terminal escape, hundreds of times.
"""

import json
import logging
import subprocess
import sys
import time

import pytest

from tactile.output.text import INTERVAL_S, LINES, Escaped, RateLimit, adopt


class Clock:
    def __init__(self, t=0.0):
        self.t = t

    def __call__(self):
        return self.t


def record(msg="x"):
    return logging.LogRecord("lib", logging.ERROR, __file__, 1, msg, None, None)


def test_the_rate_limit_passes_n_per_interval_and_counts_the_rest():
    clock = Clock(100.0)
    limit = RateLimit(lines=3, interval_s=10.0, clock=clock)
    passed = [limit.filter(record()) for _ in range(8)]
    assert passed == [True] * 3 + [False] * 5
    clock.t = 109.9
    assert not limit.filter(record())  # still the same interval: 6 held
    clock.t = 110.0
    first = record()
    assert limit.filter(first) and first.suppressed == 6  # told with the next line let through
    assert limit.take_suppressed() == 0
    assert [limit.filter(record()) for _ in range(3)] == [True, True, False]
    assert limit.take_suppressed() == 1 and limit.take_suppressed() == 0


def test_a_clock_that_goes_back_starts_a_new_interval():
    clock = Clock(50.0)
    limit = RateLimit(lines=1, interval_s=10.0, clock=clock)
    assert limit.filter(record()) and not limit.filter(record())
    clock.t = 20.0  # back 30 s: not an interval that never ends
    r = record()
    assert limit.filter(r) and r.suppressed == 1


class Collect(logging.Handler):
    def __init__(self):
        super().__init__()
        self.lines = []

    def emit(self, record):
        self.lines.append((record.levelname, self.format(record)))


@pytest.fixture
def adopted():
    """A library logger ``fakelib`` adopted into ``tactile.test_logs`` (INFO, collected)."""
    source, target = logging.getLogger("fakelib"), logging.getLogger("tactile.test_logs")
    seen = Collect()
    target.addHandler(seen)
    target.setLevel(logging.INFO)
    clock = Clock()
    handler = adopt("fakelib", "tactile.test_logs", lines=4, interval_s=5.0, clock=clock)
    yield logging.getLogger("fakelib.server"), seen, clock, handler
    source.removeHandler(handler)
    source.propagate = True
    source.setLevel(logging.NOTSET)
    target.removeHandler(seen)
    target.handlers.clear()
    target.setLevel(logging.NOTSET)


def test_an_adopted_library_logs_escaped_and_rate_limited(adopted):
    lib, seen, clock, handler = adopted
    assert adopt("fakelib", "tactile.test_logs") is handler  # once per process
    for i in range(20):
        lib.error("unknown op `%s` (%d)", "\x1b[31m\n", i)
    assert [text for _, text in seen.lines] == [
        f"server: unknown op `\\x1b[31m\\n` ({i})" for i in range(4)
    ]
    clock.t = 5.0
    lib.warning("again")
    assert seen.lines[4:] == [
        ("WARNING", "... 16 lines suppressed (at most 4 per 5 s)"),
        ("WARNING", "server: again"),
    ]
    for _ in range(7):
        lib.error("more")
    handler.flush()  # as the server stops: what was held back is told
    assert seen.lines[-1] == ("WARNING", "... 4 lines suppressed (at most 4 per 5 s)")
    assert not logging.getLogger("fakelib").propagate


def test_an_adopted_library_logs_only_what_the_project_shows(adopted):
    lib, seen, _, _ = adopted
    lib.debug("a frame")  # tactile at INFO: not even formatted
    assert seen.lines == []
    assert logging.getLogger("fakelib").level == logging.INFO
    assert any(
        isinstance(h, logging.NullHandler) for h in logging.getLogger("tactile.test_logs").handlers
    )


def test_the_cli_log_formatter_keeps_a_line_one_line():
    r = logging.LogRecord(
        "tactile.board", logging.INFO, __file__, 1, "port %s", ("a\x1b[2J\nb",), None
    )
    assert Escaped("tactile %(name)s: %(message)s").format(r) == (
        "tactile tactile.board: port a\\x1b[2J\\nb"
    )


# -- the real SDK, in a process of its own -------------------------------------------------

pytest.importorskip("foxglove")
pytest.importorskip("websockets.sync.client")
BAD = 300  # messages the client sends


def _record_with_a_hostile_client(tmp_path, *flags):
    """Run ``tactile record --foxglove FLAGS`` while a client sends ``BAD`` ops named with a
    terminal escape; return (stderr, seconds the process ran)."""
    from test_foxglove_live import Client, free_port

    port = free_port()
    argv = [
        sys.executable, "-m", "tactile", "record", "--port", "sim://press?realtime=1",
        "-o", tmp_path / "run", "--duration", "2", "--foxglove", "--foxglove-port", port, *flags,
    ]  # fmt: skip
    start = time.monotonic()
    proc = subprocess.Popen(list(map(str, argv)), stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    try:
        client = Client(port)
        for _ in range(BAD):
            client.ws.send(json.dumps({"op": "\x1b[31m"}))
        _, err = proc.communicate(timeout=120)
    finally:
        proc.kill()
    assert proc.returncode == 0, err
    return err.decode(), time.monotonic() - start


def assert_no_raw_control(text):
    bad = sorted({ch for ch in text if not (ch.isprintable() or ch == "\n")})
    assert not bad, f"raw control characters {bad!r} in {text!r}"


def test_without_v_the_library_says_nothing(tmp_path):
    err, _ = _record_with_a_hostile_client(tmp_path, "-q")
    assert_no_raw_control(err)
    lines = err.splitlines()
    assert all(line.startswith("foxglove: ") for line in lines), err  # our own two lines
    assert len(lines) == 2


def test_with_v_its_lines_are_escaped_and_rate_limited(tmp_path):
    err, took_s = _record_with_a_hostile_client(tmp_path, "-q", "-v")
    assert_no_raw_control(err)
    sdk = [line for line in err.splitlines() if line.startswith("tactile tactile.foxglove: ")]
    bad_op = [line for line in sdk if "Invalid message" in line]
    assert bad_op and all("`\\x1b[31m`" in line for line in bad_op)
    intervals = 1 + int(took_s // INTERVAL_S)
    told = [line for line in sdk if "suppressed" not in line]
    assert len(told) <= LINES * intervals
    held = sum(int(line.split("... ")[1].split()[0]) for line in sdk if "suppressed" in line)
    assert len(bad_op) + held >= BAD  # nothing dropped unsaid
