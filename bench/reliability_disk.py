"""Reliability probes: a disk that fills during ``record``, and runs killed at any moment.

Each probe runs the real ``tactile`` CLI in a subprocess against the emulator (``sim://``)
and makes the kernel itself refuse a write: a file of the run made a symlink to
``/dev/full`` (every write: ENOSPC), or the process's file-size limit (``RLIMIT_FSIZE``:
a short write, then EFBIG, as a disk that fills mid-row).  Runs cut short are made by
SIGKILL, or by the damage a kill leaves (a torn row, no meta.json).  A probe holds when the
exit code is the promised one, stderr is at most one line without a traceback, no
temporary is left, and every reader (``load_recording``, ``export``, ``decode``) gets every
reading capture.bin holds.
"""

import json
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from reliability_ports import CLI, one_line, outcome, tactile

AREA = "A full disk and runs cut short"
RECORD = ("record", "--port", "sim://press", "--quiet")
COVERED = {  # probe: the tests that make its assertions (tests/test_reliability.py)
    "probe_dev_full": ("tests/test_record_disk.py::test_a_real_enospc_from_dev_full",),
    "probe_file_size_limit": (
        "tests/test_record_disk.py::test_a_real_file_size_limit_tears_nothing",
    ),
    "probe_damaged": (
        "tests/test_record_disk.py::test_a_run_cut_short_opens_from_capture_bin_with_a_note",
    ),
    "probe_append_torn": (
        "tests/test_record_disk.py::test_append_after_a_torn_row_starts_on_a_fresh_row",
    ),
}


def _readings(out):
    from tactile.board.stream_decoder import decode_bytes

    messages, _ = decode_bytes((out / "capture.bin").read_bytes())
    return [(m.seq, m.timestamp_us) for m in messages if m.type_name in ("SAMPLE", "CONTACT")]


def readable(out, notes=0):
    """'' when no temporary is left and load_recording, export and decode give every reading
    capture.bin holds; export's stderr is ``notes`` note lines (None: at most one); else
    why."""
    import tactile as lib

    if list(out.glob("*.tmp")):
        return f"left {[p.name for p in out.glob('*.tmp')]}"
    rec = lib.load_recording(out)
    if list(zip(rec.seq.tolist(), rec.board_us.tolist())) != _readings(out):
        return f"load_recording: {len(rec)} rows, capture.bin {len(_readings(out))} readings"
    code, _, err = tactile("export", out, "--format", "parquet", "-o", out.parent / "x.parquet")
    lines = err.count("\n")
    if code != 0 or "Traceback" in err or lines != (notes if notes is not None else min(lines, 1)):
        return f"export: exit {code}: {err.strip()[-200:]}"
    code, _, err = tactile("decode", out / "capture.bin")
    return one_line(code, err, 0)


def _meta_ended(out, want):
    ended = json.loads((out / "meta.json").read_text()).get("ended")
    return "" if ended == want else f"meta.json says ended {ended!r}"


def probe_dev_full(tmp, name):
    out = tmp / f"full-{name}"
    out.mkdir()
    (out / name).symlink_to("/dev/full")
    code, _, err = tactile(*RECORD, "--duration", 5, "-o", out)
    path = out / name
    whys = [one_line(code, err, 5), "" if f"{path}: disk full" in err else f"said: {err[:200]}"]
    if name != "frames.csv":
        whys.append(_meta_ended(out, "disk full"))
    whys.append("" if not list(out.glob("*.tmp")) else "a .tmp left")
    kept = "nothing recorded" if name == "frames.csv" else "meta.json `ended: disk full`"
    return (
        f"`record`: `{name}` a symlink to /dev/full (the kernel's ENOSPC on every write)",
        f"exit 5, one line naming {path.name}; {kept}; no temporary left",
        outcome(*whys),
    )


def probe_meta_dev_full(tmp):
    """meta.json is replaced whole (tactile.files.writing): a device there is refused; its
    temporary has a name nobody can link beforehand."""
    out = tmp / "full-meta.json"
    out.mkdir()
    (out / "meta.json").symlink_to("/dev/full")
    code, _, err = tactile(*RECORD, "--duration", 5, "-o", out)
    kept = "" if sorted(p.name for p in out.iterdir()) == ["meta.json"] else "files written"
    linked = "" if os.readlink(out / "meta.json") == "/dev/full" else "the link replaced"
    return (
        "`record`: `meta.json` a symlink to /dev/full",
        "exit 2 at once, one line: not a regular file; nothing recorded, the link kept",
        outcome(one_line(code, err, 2), kept, linked),
    )


def probe_file_size_limit(tmp):
    import resource

    out = tmp / "fsize"

    def limit():
        resource.setrlimit(resource.RLIMIT_FSIZE, (150_000, resource.RLIM_INFINITY))

    r = subprocess.run([*CLI, *RECORD, "--duration", "60", "-o", str(out)], capture_output=True,
                       text=True, preexec_fn=limit, timeout=120)  # fmt: skip
    whys = [one_line(r.returncode, r.stderr, 5), "" if "kept" in r.stderr else "no 'kept'"]
    whys.append(_meta_ended(out, "file too large"))
    if not (out / "frames.csv").read_bytes().endswith(b"\n"):
        whys.append("frames.csv ends in a torn row")
    whys.append(readable(out, notes=None) if not any(whys) else "")
    return (
        "`record` under a 150 kB file-size limit (RLIMIT_FSIZE: a short write mid-row, then EFBIG)",
        "exit 5, one line with what was kept; meta.json `ended: file too large`; frames.csv"
        " ends on a whole row; every reader gets every reading capture.bin holds",
        outcome(*whys),
    )


def probe_killed(tmp):
    out = tmp / "killed"
    proc = subprocess.Popen([*CLI, *RECORD, "--duration", "60", "-o", str(out)],
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)  # fmt: skip
    deadline = time.monotonic() + 30
    while time.monotonic() < deadline and _size(out / "capture.bin") < 100_000:
        time.sleep(0.05)
    proc.send_signal(signal.SIGKILL)
    proc.wait(10)
    return (
        "`record` killed (SIGKILL) once capture.bin holds 100 kB",
        "load_recording, export and decode open it with every reading capture.bin holds",
        outcome(readable(out, notes=1)),
    )


def _size(path):
    try:
        return path.stat().st_size
    except OSError:
        return 0


def good_run(tmp):
    """A whole recording of the press scene in ``tmp`` (made once)."""
    out = tmp / "good"
    if not out.exists():
        code, _, err = tactile(*RECORD, "--contacts", 2, "-o", out)
        if code:
            raise RuntimeError(f"record failed: {err}")
    return out


def probe_damaged(tmp, damage, what):
    out = tmp / damage.replace(" ", "-")
    shutil.copytree(good_run(tmp), out)
    if damage == "torn row":
        (out / "frames.csv").write_bytes((out / "frames.csv").read_bytes()[:-25])
    elif damage == "no meta.json":
        (out / "meta.json").unlink()
    else:
        (out / "frames.csv").unlink()
    return (
        f"a run whose {what}",
        "load_recording, export and decode open it, every reading capture.bin holds; export"
        " says what was rebuilt in one note line",
        outcome(readable(out, notes=1)),
    )


def probe_append_torn(tmp):
    out = tmp / "append-torn"
    shutil.copytree(good_run(tmp), out)
    (out / "frames.csv").write_bytes((out / "frames.csv").read_bytes()[:-25])
    code, _, err = tactile(*RECORD, "--duration", 0.3, "-o", out, "--append")
    lines = (out / "frames.csv").read_text().splitlines()[1:]
    glued = [k for k, line in enumerate(lines, 2) if len(line.split(",")) != 15]
    whys = [one_line(code, err, 0), f"line {glued[0]} glued" if glued else ""]
    return (
        "`record --append` onto a run whose frames.csv ends in a torn row",
        "exit 0; the torn row completed from capture.bin first, no row glued; every reader"
        " gets every reading",
        outcome(*whys, readable(out) if not any(whys) else ""),
    )


def probes(skip=()):
    with tempfile.TemporaryDirectory(prefix="reliability_disk_") as tmp:
        tmp = Path(tmp)

        def run(probe, *args):  # its row, or none for a probe in ``skip``
            return [] if probe.__name__ in skip else [probe(tmp, *args)]

        if os.path.exists("/dev/full"):
            for name in ("frames.csv", "capture.bin"):
                yield from run(probe_dev_full, name)
            yield from run(probe_meta_dev_full)
        yield from run(probe_file_size_limit)
        yield from run(probe_killed)
        yield from run(
            probe_damaged, "torn row", "frames.csv ends in a torn row (a kill mid-write)"
        )
        yield from run(probe_damaged, "no meta.json", "meta.json is missing (killed before it)")
        yield from run(probe_damaged, "no frames.csv", "frames.csv is missing")
        yield from run(probe_append_torn)


if __name__ == "__main__":
    sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
    from reliability import table

    print(table(AREA, list(probes())))
