"""Reliability probes: ports that die and boards that reboot (issue 12).

Each probe runs the real ``tactile`` CLI in a subprocess against a real pty: an emulator
whose pty closes at the host's first command (``tactile_sim.emulator.dying``), or
``tactile emulate`` processes killed and restarted behind ``--link``.  A probe holds when
the exit code is the promised one, stderr is at most one line without a traceback, and the
recording on disk accounts for every byte and reading.
"""

import contextlib
import json
import os
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

AREA = "Ports that die and reboots"
COVERED = {  # probe: the tests that make its assertions (tests/test_reliability.py)
    "probe_reboot": (
        "tests/test_record_pty.py::"
        "test_a_board_killed_and_restarted_behind_link_is_one_reboot_and_nothing_lost",
    ),
    "probe_nobody_reads": (
        "tests/test_emulator_stops.py::test_a_run_nobody_reads_ends_at_its_duration",
        "tests/test_emulator_stops.py::test_a_qemu_run_nobody_reads_ends_at_its_duration",
    ),
    "probe_silent_board": (
        "tests/test_device_lies.py::test_record_gives_up_on_a_board_silent_after_hello_with_exit_4",
    ),
}
CLI = [sys.executable, "-m", "tactile.cli.main"]


def tactile(*args, timeout=30):
    """Run the CLI; (exit code, stdout, stderr)."""
    r = subprocess.run([*CLI, *map(str, args)], capture_output=True, text=True, timeout=timeout)
    return r.returncode, r.stdout, r.stderr


def _start(*args):
    return subprocess.Popen(
        [*CLI, *map(str, args)], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
    )


@contextlib.contextmanager
def emulator(scene, link, *more):
    """``tactile emulate SCENE --link LINK [MORE]`` until the block ends (or it is killed)."""
    proc = _start("emulate", scene, "--link", link, "--duration", 60, *more)
    try:
        if not proc.stdout.readline().strip():
            raise RuntimeError(f"emulate did not start: {proc.stderr.read().strip()}")
        yield proc
    finally:
        if proc.poll() is None:
            proc.kill()
        proc.wait(5)


def _wait_for(path, timeout_s=10):
    deadline = time.monotonic() + timeout_s
    while not Path(path).exists() and time.monotonic() < deadline:
        time.sleep(0.05)


def one_line(code, err, want):
    """'' when the exit code is ``want`` and stderr one line without a traceback, else why."""
    if "Traceback" in err:
        return "a traceback reached the user"
    if code != want:
        return f"exit {code}, wanted {want}: {err.strip()[-200:]}"
    if want and err.count("\n") != 1:
        return f"{err.count(chr(10))} lines on stderr"
    return ""


def recording_complete(out):
    """'' when meta.json's totals match capture.bin and frames.csv, and the capture decodes
    to exactly the rows written; else why."""
    from tactile.board.stream_decoder import decode_bytes

    meta = json.loads((out / "meta.json").read_text())
    capture = (out / "capture.bin").read_bytes()
    rows = len((out / "frames.csv").read_text().splitlines()) - 2  # units line, header
    readings = sum(m.type_name in ("SAMPLE", "CONTACT") for m in decode_bytes(capture)[0])
    if meta["bytes"] != len(capture):
        return f"meta.json says {meta['bytes']} bytes, capture.bin holds {len(capture)}"
    if not meta["samples"] == rows == readings:
        return f"meta {meta['samples']}, frames.csv {rows}, capture {readings} readings"
    return ""


def outcome(*whys):
    bad = [w for w in whys if w]
    return f"FAILED: {bad[0]}" if bad else "held"


def _dying_command(args, tmp):
    from tactile_sim.emulator.dying import DyingBoard

    with DyingBoard() as board:
        code, _, err = tactile(*args, "--port", board.path)
    why = one_line(code, err, 4) or ("" if "port lost while" in err else f"said: {err.strip()}")
    if why or args[0] != "record":
        return outcome(why)
    return outcome(recording_complete(tmp / "run"))


def probe_commands(tmp):
    commands = {
        "info": ["info"],
        "tare": ["tare"],
        "config": ["config", "--rate", "500"],
        "live": ["live", "--duration", "5"],
        "record": ["record", "--duration", "5", "--quiet", "-o", tmp / "run"],
    }
    for name, args in commands.items():
        yield (
            f"`{name}`: board unplugged while it waits for the answer to its first command",
            "exit 4, one line `port lost while reading`, no traceback"
            + ("; capture, frames.csv and meta.json agree" if name == "record" else ""),
            _dying_command(args, tmp),
        )


def probe_live_killed(tmp):
    link = tmp / "ttyLIVE"
    with emulator("ch5_plane", link) as emu:
        live = _start("live", "--port", link, "--duration", 10)
        time.sleep(1.5)
        emu.send_signal(signal.SIGKILL)
        _, err = live.communicate(timeout=15)
    return (
        "`live` (SAMPLE stream switched on, a restore owed): `tactile emulate` killed after 1.5 s",
        "exit 4, one line, no restore attempted through the dead port",
        outcome(one_line(live.returncode, err, 4)),
    )


def _record_across(tmp, name, restart, reconnect_s):
    """Record behind a --link while the emulator is killed after 1 s, and maybe restarted."""
    link, out = tmp / f"tty{name}", tmp / name
    with emulator("press", link) as first:
        rec = _start("record", "--port", link, "--duration", 3, "-o", out, "--quiet",
                     "--reconnect", reconnect_s)  # fmt: skip
        _wait_for(out / "meta.json")
        time.sleep(1.0)
        first.send_signal(signal.SIGKILL)
        first.wait(5)
        with emulator("press", link) if restart else contextlib.nullcontext():
            _, err = rec.communicate(timeout=30)
    return rec.returncode, err, out


def probe_reboot(tmp):
    code, err, out = _record_across(tmp, "reboot", restart=True, reconnect_s=10)
    why = one_line(code, err, 0) or recording_complete(out)
    if not why:
        meta = json.loads((out / "meta.json").read_text())
        d = meta["decoder"]
        if (meta["reboots"], d["lost_frames"], d["out_of_order"]) != (1, 0, 0):
            why = f"reboots {meta['reboots']}, lost {d['lost_frames']}, "
            why += f"out of order {d['out_of_order']}"
    return (
        "`record` behind `--link`: `tactile emulate` killed after 1 s and started again",
        "exit 0; the gap recorded; `reboots: 1`, 0 frames lost, 0 out of order",
        outcome(why),
    )


def probe_never_back(tmp):
    code, err, out = _record_across(tmp, "gone", restart=False, reconnect_s=0.5)
    why = one_line(code, err, 4) or recording_complete(out)
    if not why and json.loads((out / "meta.json").read_text())["ended"] != "port lost":
        why = "meta.json does not say 'port lost'"
    return (
        "`record --reconnect 0.5`: `tactile emulate` killed after 1 s, never back",
        "exit 4, one line; everything received kept; meta.json `ended: port lost`",
        outcome(why),
    )


def probe_append(tmp):
    out = tmp / "appended"
    whys = []
    for extra in ([], ["--append"]):
        code, _, err = tactile("record", "--port", "sim://press", "--duration", 0.3, "-o", out,
                               "--quiet", *extra)  # fmt: skip
        whys.append(one_line(code, err, 0))
    whys.append(recording_complete(out))
    sessions = json.loads((out / "meta.json").read_text()).get("sessions", [])
    whys.append("" if len(sessions) == 2 else f"{len(sessions)} sessions in meta.json")
    return (
        "`record` twice into one directory with `--append`",
        "meta.json: one entry per session, `bytes` and `samples` equal to the files",
        outcome(*whys),
    )


def probe_swap(tmp):
    from tactile_protocol.constants import MSG_SAMPLE
    from tactile_protocol.framing import encode_frame

    path = tmp / "swapped.bin"
    values = (0, 0, 1, 2, 3, 4, 5, 6)
    path.write_bytes(b"".join(encode_frame(MSG_SAMPLE, s, 1000 * s, values) for s in (0, 2, 1, 3)))
    code, out, err = tactile("decode", path, "--json")
    got = json.loads(out.splitlines()[-1])["summary"] if code == 0 else {}
    counts = tuple(got.get(k) for k in ("frames", "lost_frames", "out_of_order"))
    return (
        "`decode`: two adjacent frames swapped (seq 0 2 1 3)",
        "all 4 delivered; `lost_frames=2 out_of_order=1`, as PROTOCOL.md §3 documents",
        outcome(one_line(code, err, 0), "" if counts == (4, 2, 1) else f"counted {counts}"),
    )


def probe_nobody_reads(tmp):
    """An emulator as fast as possible with nobody on its pty ran forever."""
    whys = []
    for core in ("python", "qemu"):
        try:
            code, _, err = tactile("emulate", "press", "--core", core, "--fast", "--duration", 1,
                                   "--now", timeout=60)  # fmt: skip
        except subprocess.TimeoutExpired:
            whys.append(f"{core}: still running after 60 s")
            continue
        if "qemu" in err and code == 2:  # no cross-compiler or QEMU here: not this probe's
            continue
        whys.append(one_line(code, err, 0) and f"{core}: {one_line(code, err, 0)}")
    return (
        "`emulate press --fast --duration 1 --now` with nobody on the pty (python, qemu core)",
        "ends at its duration within seconds (was: ran forever, printing nothing)",
        outcome(*whys),
    )


def probe_silent_board(tmp):
    """A board that sends HELLO and then nothing, not even an ACK: a hung firmware."""
    from tactile_sim.emulator.dying import DyingBoard

    board = DyingBoard(at_command=10**9)  # never dies: it hangs instead
    emulated, said, opened = board.board, board.board.read_host, []
    open_port = emulated.host_opened
    emulated.host_opened = lambda: (opened.append(emulated.t_us), open_port())
    # 0.3 s after the host came (HELLO, its setup, a few readings), nothing more leaves it
    emulated.read_host = lambda: b"" if opened and emulated.t_us > opened[0] + 3e5 else said()
    out = tmp / "silent"
    with board:
        code, _, err = tactile("record", "--port", board.path, "--duration", 30, "--no-tare",
                               "-o", out, "--quiet", timeout=60)  # fmt: skip
    why = one_line(code, err, 4) or ("" if "said nothing for 5 s" in err else err.strip())
    return (
        "`record` from a board that hangs after HELLO and its setup: no frame, no PING reply",
        "exit 4 within seconds, one line (was: exit 0, '0 readings' and a drift figure)",
        outcome(why),
    )


def probes(skip=()):
    with tempfile.TemporaryDirectory(prefix="reliability_ports_") as tmp:
        tmp = Path(tmp)
        yield from probe_commands(tmp)
        for probe in (probe_live_killed, probe_reboot, probe_never_back, probe_append, probe_swap,
                      probe_nobody_reads, probe_silent_board):  # fmt: skip
            if probe.__name__ not in skip:
                yield probe(tmp)


if __name__ == "__main__":
    sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
    from reliability import table

    print(table(AREA, list(probes())))
