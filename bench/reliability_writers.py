"""Reliability probes: one writer per run folder, outputs that never overwrite what is not
theirs, and a ``record`` that never reached a board.

Each probe runs the real ``tactile`` CLI in subprocesses against the emulator (``sim://``),
real FIFOs, device nodes (made in a temporary folder as root; a symlink to /dev/null
otherwise) and the kernel's own file-size limit.  Two writers are made to meet
deterministically: the second starts once the first has made its files (it locks the
folder before it writes), or once its capture.bin has bytes.  A probe holds when the exit
code is the promised one, stderr is one line without a traceback, and every file that was
there is byte for byte as it was.
"""

import contextlib
import json
import os
import pty
import shutil
import stat
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

from reliability_disk import RECORD, good_run
from reliability_ports import CLI, _start, one_line, outcome, recording_complete, tactile

AREA = "One writer per run, and outputs that never overwrite"
PARQUET = ("--format", "parquet")
COVERED = {  # probe: the tests that make its assertions (tests/test_reliability.py)
    "probe_second_record": (
        "tests/test_record_writers.py::"
        "test_a_second_record_between_the_firsts_start_and_its_first_byte_is_refused",
    ),
    "probe_together": (
        "tests/test_record_writers.py::test_two_records_started_together_into_one_new_folder",
    ),
    "probe_export_while_recording": (
        "tests/test_export_outputs.py::test_an_export_into_a_run_another_writer_holds_is_refused",
    ),
    "probe_not_a_board": (
        "tests/test_record_writers.py::"
        "test_bytes_from_something_not_a_board_are_kept_and_the_line_says_so",
    ),
}


def _snapshot(folder):
    """{name: (kind, inode, bytes)} of every entry under ``folder``."""
    out = {}
    for root, dirs, files in os.walk(folder):
        for name in dirs + files:
            path = os.path.join(root, name)
            st = os.lstat(path)
            data = Path(path).read_bytes() if stat.S_ISREG(st.st_mode) else None
            out[os.path.relpath(path, folder)] = (stat.S_IFMT(st.st_mode), st.st_ino, data)
    return out


def _unchanged(before, folder):
    return "" if _snapshot(folder) == before else f"{folder} changed"


def _clean(out, sessions):
    """'' when the run decodes without a CRC error or a false reboot and meta.json accounts
    for every byte and row, with ``sessions`` sessions; else why."""
    from tactile.board.stream_decoder import decode_bytes

    _, c = decode_bytes((out / "capture.bin").read_bytes())
    if c.crc_errors or c.out_of_order or c.reboots != sessions - 1:
        return f"{c.crc_errors} CRC errors, {c.out_of_order} out of order, {c.reboots} reboots"
    meta = json.loads((out / "meta.json").read_text())
    if len(meta.get("sessions", [meta])) != sessions:
        return f"meta.json lists {len(meta.get('sessions', [meta]))} sessions"
    return recording_complete(out)


def _wait_for_bytes(path, more_than, proc, timeout_s=60):
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline and proc.poll() is None:
        if path.exists() and path.stat().st_size > more_than:
            return
        time.sleep(0.02)


def probe_second_record(tmp, append):
    """The first (in this process) has made its files and holds the folder, no byte yet;
    the second, another process, starts then."""
    from tactile.recording.session import Session
    from tactile_sim.urlhandler import register

    register()
    out = tmp / ("append" if append else "second")
    more = ("--append",) if append else ()
    if append:
        shutil.copytree(good_run(tmp), out)
    first = Session("sim://press", out, duration_s=0.5, append=append)
    code, _, err = tactile(*RECORD, "--duration", 0.5, "-o", out, *more)
    try:
        first.run()
        ran = ""
    except Exception as exc:  # noqa: BLE001 - the probe reports it
        ran = f"the first failed: {exc}"
    whys = [one_line(code, err, 5), ran]
    whys.append(_clean(out, 2 if append else 1) if not any(whys) else "")
    what = "`record --append` twice into one run" if append else "`record` twice into one folder"
    return (
        f"{what}, the second started after the first made its files, before its first byte",
        "the second refused, exit 5, one line; the first whole: no CRC error, meta.json"
        f" accounts for every byte and row{', both sessions listed' if append else ''} (was:"
        " both exit 0, two boards in one capture.bin)",
        outcome(*whys),
    )


def probe_together(tmp):
    out = tmp / "together" / "run"
    procs = [_start(*RECORD, "--duration", 2, "-o", out) for _ in range(2)]
    (won, _), (lost, err) = sorted((p.wait(120), p.stderr.read()) for p in procs)
    whys = [one_line(won, "", 0), "" if lost in (2, 5) else f"the other exit {lost}: {err}"]
    whys.append(_clean(out, 1) if not any(whys) else "")
    return (
        "two `record`s started together into one new folder",
        "one records, the other is refused in one line; the run is whole",
        outcome(*whys),
    )


def probe_export_over(tmp, name):
    run = tmp / f"over-{name}"
    shutil.copytree(good_run(tmp), run)
    before = _snapshot(run)
    code, _, err = tactile("export", run, *PARQUET, "-o", run / name)
    return (
        f"`export RUN -o RUN/{name}`",
        f"exit 2, one line; {name} and every file of the run unchanged (was: replaced, exit 0)",
        outcome(one_line(code, err, 2), _unchanged(before, run)),
    )


def _node(path, kind):
    if kind == "FIFO":
        os.mkfifo(path)
    elif os.geteuid() == 0:
        os.mknod(path, 0o600 | stat.S_IFCHR, os.makedev(1, 7))  # /dev/full's numbers
    else:
        os.symlink("/dev/null", path)


def probe_export_node(tmp, kind):
    folder = tmp / f"node-{kind}"
    folder.mkdir()
    _node(folder / "out", kind)
    before = _snapshot(folder)
    code, _, err = tactile("export", good_run(tmp), *PARQUET, "-o", folder / "out")
    what = {"FIFO": "a FIFO", "device": "a device node (/dev/full's numbers)"}[kind]
    if kind == "device" and os.geteuid() != 0:
        what = "a symlink to /dev/null"
    return (
        f"`export -o` {what}",
        f"exit 2, one line; still {what}, nothing beside it (was: replaced by a regular file)",
        outcome(one_line(code, err, 2), _unchanged(before, folder)),
    )


def probe_export_dir(tmp):
    folder = tmp / "adir-case"
    (folder / "adir").mkdir(parents=True)
    (folder / "adir.tmp").write_text("the user's own file")
    before = _snapshot(folder)
    code, _, err = tactile("export", good_run(tmp), *PARQUET, "-o", folder / "adir")
    named = "the message names adir.tmp" if "adir.tmp" in err else ""
    return (
        "`export -o adir`, a directory, beside the user's `adir.tmp`",
        "exit 2, one line naming adir; adir.tmp untouched and not named (was: deleted)",
        outcome(one_line(code, err, 2), named, _unchanged(before, folder)),
    )


def probe_export_fsize(tmp):
    import resource

    folder = tmp / "fsize"
    folder.mkdir()
    (folder / "x.parquet").write_bytes(b"an earlier export")

    def limit():
        resource.setrlimit(resource.RLIMIT_FSIZE, (4096, resource.RLIM_INFINITY))

    before = _snapshot(folder)
    r = subprocess.run([*CLI, "export", str(good_run(tmp)), *PARQUET, "-o",
                        str(folder / "x.parquet")], capture_output=True, text=True,
                       preexec_fn=limit, timeout=120)  # fmt: skip
    return (
        "`export` under a 4 kB file-size limit (RLIMIT_FSIZE: the kernel's EFBIG)",
        "exit 5, one line; the earlier export unchanged, no temporary (was: exit 2)",
        outcome(one_line(r.returncode, r.stderr, 5), _unchanged(before, folder)),
    )


def probe_export_while_recording(tmp):
    out = tmp / "busy"
    first = _start(*RECORD, "--duration", 3, "-o", out)
    _wait_for_bytes(out / "capture.bin", 0, first)
    code, _, err = tactile("export", out, *PARQUET)
    first.communicate(timeout=120)
    left = "an export was written" if list(out.glob("*.parquet")) else ""
    return (
        "`export RUN` (into the run) while a `record` writes it",
        "exit 5, one line; nothing written into the run",
        outcome(one_line(code, err, 5), left, one_line(first.returncode, "", 0)),
    )


def probe_no_port(tmp, append):
    if append:
        out = tmp / "no-port-append"
        shutil.copytree(good_run(tmp), out)
        before, where = _snapshot(out), out
    else:
        out = tmp / "no-port" / "a" / "run"
        (tmp / "no-port").mkdir()
        before, where = {}, tmp / "no-port"
    more = ("--append",) if append else ()
    code, _, err = tactile("record", "--port", "/dev/tactile-no-such-port", "--duration", 1,
                           "-o", out, *more)  # fmt: skip
    return (
        f"`record{' --append' if append else ''}` from a port that does not exist",
        "exit 4, one line; "
        + (
            "every file of the run byte for byte as it was (was: meta.json rewritten)"
            if append
            else "no folder left behind (was: a run whose meta.json says tared)"
        ),
        outcome(one_line(code, err, 4), _unchanged(before, where)),
    )


@contextlib.contextmanager
def _garbage_port():
    """A pty whose other end sends bytes that are never a frame."""
    master, slave = pty.openpty()
    done = threading.Event()

    def feed():
        while not done.is_set():
            with contextlib.suppress(OSError):
                os.write(master, b"garbage\0" * 8)
            done.wait(0.01)

    thread = threading.Thread(target=feed, daemon=True)
    thread.start()
    try:
        yield os.ttyname(slave)
    finally:
        done.set()
        thread.join()
        os.close(master)
        os.close(slave)


def probe_not_a_board(tmp):
    out = tmp / "garbage"
    with _garbage_port() as port:
        code, _, err = tactile("record", "--port", port, "--wait", 1, "-o", out)
    whys = [one_line(code, err, 4)]
    if not any(whys):
        meta = json.loads((out / "meta.json").read_text())
        kept = f"the {(out / 'capture.bin').stat().st_size:,} bytes received are kept"
        whys += ["" if kept in err else f"said: {err.strip()}"]
        whys += ["" if meta["tared"] is False else "meta.json says tared"]
    return (
        "`record` from a port that sends bytes but no frame",
        "exit 4, one line saying the bytes are kept and where; meta.json `tared: false`",
        outcome(*whys),
    )


def probes(skip=()):
    with tempfile.TemporaryDirectory(prefix="reliability_writers_") as tmp:
        tmp = Path(tmp)

        def run(probe, *args, **kw):  # its row, or none for a probe in ``skip``
            return [] if probe.__name__ in skip else [probe(tmp, *args, **kw)]

        yield from run(probe_second_record, append=False)
        yield from run(probe_second_record, append=True)
        yield from run(probe_together)
        for name in ("capture.bin", "frames.csv", "meta.json"):
            yield from run(probe_export_over, name)
        yield from run(probe_export_node, "FIFO")
        yield from run(probe_export_node, "device")
        yield from run(probe_export_dir)
        yield from run(probe_export_fsize)
        yield from run(probe_export_while_recording)
        yield from run(probe_no_port, append=False)
        yield from run(probe_no_port, append=True)
        yield from run(probe_not_a_board)


if __name__ == "__main__":
    sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
    from reliability import table

    print(table(AREA, list(probes())))
