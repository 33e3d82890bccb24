"""What the host prints: a library's log lines and names from outside, on the terminal.

A Foxglove client that sends hundreds of ops named ``ESC[31m`` to ``record --foxglove``
(run as a process of its own, so that stderr is a real one): nothing of the SDK's under
``-q``, and with ``-v`` its lines escaped and rate-limited (``tactile.output.text``).  A
folder named with ``ESC[31m`` and a newline through the commands that print the files they
wrote, and an unknown option holding an escape: each line escaped
(``tactile.output.text.printable``).  ``bench/reliability.py`` prints the table;
``tests/test_reliability.py`` requires every probe to hold.
"""

import contextlib
import io
import json
import os
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from reliability_numbers import run

AREA = "What the host prints: library logs and names from outside"
EVIL = "ev\x1b[31mil\nx"
SHOWN = r"ev\x1b[31mil\nx"
BAD_OPS = 300
COVERED = {  # probes: the tests that make their assertions (tests/test_reliability.py)
    "_logs": (
        "tests/test_library_logs.py::test_without_v_the_library_says_nothing",
        "tests/test_library_logs.py::test_with_v_its_lines_are_escaped_and_rate_limited",
    ),
}
TIMEOUT_S = 120


def _raw(text):
    return sorted({repr(ch) for ch in text if not (ch.isprintable() or ch == "\n")})


def _free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _hostile_client(port):
    """Connect to ``port`` (once it is bound) and send ``BAD_OPS`` ops named ESC[31m."""
    from websockets.sync.client import connect

    deadline = time.monotonic() + 30
    while True:
        try:
            ws = connect(f"ws://127.0.0.1:{port}", subprotocols=["foxglove.sdk.v1"])
            break
        except OSError:
            if time.monotonic() > deadline:
                raise
            time.sleep(0.05)
    with ws:
        for _ in range(BAD_OPS):
            ws.send(json.dumps({"op": "\x1b[31m"}))


def _record_foxglove(tmp, *flags):
    """(exit code, stderr, seconds) of ``record --foxglove FLAGS`` beside a hostile client."""
    port = _free_port()
    cmd = [
        sys.executable, "-m", "tactile", "record", "--port", "sim://press?realtime=1",
        "-o", tmp / f"run{len(flags)}", "--duration", "2", "--foxglove", "--foxglove-port",
        port, *flags,
    ]  # fmt: skip
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(sys.path))
    t0 = time.monotonic()
    proc = subprocess.Popen(
        list(map(str, cmd)), stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env
    )
    try:
        _hostile_client(port)
        _, err = proc.communicate(timeout=TIMEOUT_S)
    finally:
        proc.kill()
    return proc.returncode, err.decode(errors="replace"), time.monotonic() - t0


def _logs(tmp):
    from tactile.output.text import INTERVAL_S, LINES

    code, err, _ = _record_foxglove(tmp, "-q")
    others = [line for line in err.splitlines() if not line.startswith("foxglove: ")]
    yield (
        f"`record --foxglove -q`, a client sending {BAD_OPS} ops named ESC[31m",
        "exit 0; nothing of the Foxglove library on stderr (was 614 lines in 25 s, raw)",
        "FAILED: raw " + " ".join(_raw(err)) if _raw(err)
        else f"FAILED: exit {code}" if code != 0
        else f"FAILED: {len(others)} other lines: {others[0][:80]}" if others
        else "held",
    )  # fmt: skip
    code, err, took = _record_foxglove(tmp, "-q", "-v")
    sdk = [line for line in err.splitlines() if line.startswith("tactile tactile.foxglove: ")]
    told = [line for line in sdk if "suppressed" not in line]
    bound = LINES * (1 + int(took // INTERVAL_S))
    yield (
        "the same with `-v`",
        f"exit 0; the library's lines escaped, at most {LINES} per {INTERVAL_S:g} s, the rest"
        " counted in a '... K lines suppressed' line",
        "FAILED: raw " + " ".join(_raw(err)) if _raw(err)
        else f"FAILED: exit {code}" if code != 0
        else f"FAILED: {len(told)} lines, more than {bound}" if len(told) > bound
        else "FAILED: no 'suppressed' line" if not any("suppressed" in s for s in sdk)
        else "held",
    )  # fmt: skip


def _names(tmp):
    folder = tmp / EVIL
    folder.mkdir()
    shown = f"{tmp}/{SHOWN}"
    checks = [
        ("`record -o` a folder named ESC[31m and a newline", "its summary line",
         ("record", "--port", "sim://press", "-o", folder / "run", "-q", "--duration", "0.3"),
         0, f"-> {shown}/run"),
        ("`export -o` a file in that folder (MCAP)", "its 'wrote' line",
         ("export", folder / "run", "-o", folder / "r.mcap"), 0, f"wrote {shown}/r.mcap"),
        ("`export --format parquet -o` a file in that folder", "its 'wrote' line",
         ("export", folder / "run", "--format", "parquet", "-o", folder / "r.parquet"), 0,
         f"wrote {shown}/r.parquet"),
        ("`sim ep2 -o` a file in that folder", "its 'wrote' line",
         ("sim", "ep2", "--object", "cylinder", "-o", folder / "c.csv"), 0,
         f"wrote {shown}/c.csv"),
        ("`plot` that file into that folder", "each PNG's line",
         ("plot", folder / "c.csv", "--what", "contacts", "-o", folder / "png"), 0,
         f"{shown}/png/"),
        ("`ep2 analyze` a missing file in that folder", "its error line",
         ("ep2", "analyze", folder / "none.csv"), 2, f"{shown}/none.csv"),
    ]  # fmt: skip
    for probe, what, args, code, says in checks:
        got, out, err, _ = run(*args)
        raw = _raw(out + err)
        yield (
            probe,
            f"exit {code}; {what} names it escaped, no raw control character",
            "FAILED: raw " + " ".join(raw) if raw
            else f"FAILED: exit {got}: {err[:80]!r}" if got != code
            else f"FAILED: no {says!r}" if says not in out + err
            else "held",
        )  # fmt: skip


def _option(_):
    from tactile.cli.main import main

    err, got = io.StringIO(), None
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        try:
            main(["export", "run", "--\x1b[31m"])
        except SystemExit as exc:  # argparse's way out
            got = exc.code
    err = err.getvalue()
    yield (
        "an unknown option holding ESC[31m",
        "exit 2, one line, escaped (argparse quoted it raw)",
        "FAILED: raw " + " ".join(_raw(err)) if _raw(err)
        else f"FAILED: exit {got}" if got != 2
        else "FAILED: not one line" if err.count("\n") != 1
        else "held",
    )  # fmt: skip


def probes(skip=()):
    with tempfile.TemporaryDirectory() as name:
        tmp = Path(name)
        for group in (_logs, _names, _option):
            if group.__name__ not in skip:
                yield from group(tmp)


if __name__ == "__main__":
    for row in probes():
        print(" | ".join(row))
