"""Reliability probes: a recorder that stands still, and a port that comes back as another
board.

Each probe runs the real ``tactile record`` in a subprocess on a real pty served by
``tactile emulate`` in real time: the recorder is stopped with SIGSTOP and continued (as
Ctrl-Z then ``fg`` does), or its emulator is killed and another board started behind the
same ``--link``.  A probe holds when the exit code is the promised one, stderr says what
it must (one line for an error), and the recording on disk accounts for every byte and
reading.
"""

import json
import os
import signal
import sys
import tempfile
import time
from pathlib import Path

from reliability_ports import _start, _wait_for, emulator, one_line, outcome, recording_complete

AREA = "A recorder that stands still, a port that comes back as another board"
COVERED = {  # probe: the tests that make its assertions (tests/test_reliability.py)
    "probe_stopped": (
        "tests/test_record_pause.py::test_a_host_that_stood_still_reads_what_waited_and_goes_on",
    ),
    "probe_clock_back": (
        "tests/test_record_pause.py::test_a_host_clock_that_steps_back_never_gives_negative_elapsed_time",
    ),
    "probe_other_board": (
        "tests/test_record_pty.py::test_another_board_behind_the_link_ends_the_run_in_one_line",
        "tests/test_record_identity.py::"
        "test_another_board_on_the_port_ends_the_run_in_one_line_with_everything_kept",
    ),
}


def _meta(out):
    return json.loads((out / "meta.json").read_text())


def probe_stopped(tmp):
    """SIGSTOP for 6 s one second into a 10 s run: it ended 'board silent', exit 4."""
    link, out = tmp / "ttySTOP", tmp / "stopped"
    with emulator("press", link):
        rec = _start("record", "--port", link, "--duration", 10, "-o", out, "--quiet")
        _wait_for(out / "meta.json")
        time.sleep(1.0)
        os.kill(rec.pid, signal.SIGSTOP)
        time.sleep(6.0)
        os.kill(rec.pid, signal.SIGCONT)
        _, err = rec.communicate(timeout=30)
    why = one_line(rec.returncode, err, 0) or recording_complete(out)
    if not why:
        meta = _meta(out)
        steps = [p["clock_step_s"] for p in meta["pauses"]]
        if meta["ended"] != "duration" or not any(s >= 5.5 for s in steps):
            why = f"ended {meta['ended']!r}, stalls {steps}"
        elif meta["device_time_s"] < 9.0:
            why = f"device_time_s {meta['device_time_s']} of 10 s"
    return (
        "`record --duration 10`: stopped (SIGSTOP) 1 s in for 6 s, then continued",
        "exit 0, ended by its duration; the stall in meta.json's `pauses`; the board's time"
        " covers the run; everything read kept (was: exit 4 'board silent', 1.2 s of 20)",
        outcome(why),
    )


def probe_clock_back(tmp):
    """The host's monotonic clock steps back 18.8 s (a VM restored): elapsed_s went -18.8."""
    from tactile.recording.session import Session
    from tactile_sim.urlhandler import register

    register()
    start = time.monotonic()

    def clock():  # 18.8 s back once the run is 1 s old
        now = time.monotonic()
        return now - 18.8 if now - start > 1.0 else now

    seen = []
    session = Session("sim://press?realtime=1", tmp / "back", duration_s=3.0, clock=clock,
                      on_progress=lambda s: seen.append(s.meta()["elapsed_s"]))  # fmt: skip
    meta = session.run()
    why = "" if min(seen) >= 0 and seen == sorted(seen) else f"elapsed_s went {min(seen)}"
    if not why and not 2.9 <= meta["elapsed_s"] <= 3.5:
        why = f"elapsed_s {meta['elapsed_s']} for a 3 s run"
    return (
        "`record --duration 3` (in process, a board in real time): the host's monotonic clock"
        " steps back 18.8 s 1 s in",
        "elapsed_s never below 0 and never going back; the run lasts its 3 s (was: -18.8 s)",
        outcome(why, recording_complete(tmp / "back")),
    )


def _across(tmp, name, *again, quiet=True):
    """Record behind a --link whose emulator is killed 1 s in and another one started."""
    link, out = tmp / f"tty{name}", tmp / name
    with emulator("press", link) as first:
        rec = _start("record", "--port", link, "--duration", 3, "-o", out,
                     "--reconnect", 10, *(["--quiet"] if quiet else []))  # fmt: skip
        _wait_for(out / "meta.json")
        time.sleep(1.0)
        first.send_signal(signal.SIGKILL)
        first.wait(5)
        with emulator("press", link, *again):
            _, err = rec.communicate(timeout=30)
    return rec.returncode, err, out


def probe_other_board(tmp):
    code, err, out = _across(tmp, "other", "--board-id", "0badb0a2d0000001")
    why = one_line(code, err, 4) or recording_complete(out)
    if not why and "another board answered after the port was lost" not in err:
        why = f"said: {err.strip()}"
    if not why:
        meta = _meta(out)
        if (meta["ended"], meta["reboots"]) != ("other board", 0):
            why = f"ended {meta['ended']!r}, reboots {meta['reboots']}"
        elif not meta["gaps"][0].get("other_board", {}).get("bytes_refused"):
            why = "the other board's bytes were not held out"
    return (
        "`record` behind `--link`: its board's emulator killed 1 s in, another board"
        " (another board id) started behind the same link",
        "exit 4, one line naming both board ids; none of the other board's bytes in the files;"
        " everything of its own kept (was: went on recording the other board, 'reboots: 1')",
        outcome(why),
    )


def probe_waiting_said(tmp):
    code, err, out = _across(tmp, "said", quiet=False)
    why = "" if code == 0 and "Traceback" not in err else f"exit {code}: {err.strip()[-200:]}"
    lost = [ln for ln in err.replace("\r", "\n").splitlines() if "port lost at" in ln]
    back = [ln for ln in err.replace("\r", "\n").splitlines() if "port back at" in ln]
    if not why and not (lost and lost[0].endswith("s; waiting up to 10 s for it to come back")):
        why = f"no waiting line: {lost}"
    if not why and not (back and "the same board (rebooted)" in back[0]):
        why = f"no line on its return: {back}"
    return (
        "`record` (not `--quiet`) behind `--link`: its emulator killed 1 s in and started again",
        "stderr says `port lost at 1.x s; waiting up to 10 s ...` at once, then `port back at"
        " ... the same board (rebooted)`; exit 0 (was: 30 s without a word)",
        outcome(why, recording_complete(out)),
    )


def probes(skip=()):
    with tempfile.TemporaryDirectory(prefix="reliability_recorder_") as tmp:
        tmp = Path(tmp)
        for probe in (probe_stopped, probe_clock_back, probe_other_board, probe_waiting_said):
            if probe.__name__ not in skip:
                yield probe(tmp)


if __name__ == "__main__":
    sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
    from reliability import table

    print(table(AREA, list(probes())))
