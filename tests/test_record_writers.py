"""One writer per run folder, and a ``record`` that never reached a board leaves nothing.

Two ``record``\\ s into one folder are made deterministic: the second starts while the
first is known to hold the folder (its capture.bin has bytes: it locks before it writes),
or the test holds the lock itself, as a first writer would."""

import fcntl
import functools
import json
import os
import subprocess
import sys
import time

import pytest
from lying_device import LyingPort, lying_ports

from tactile.board.client import BoardClient
from tactile.board.stream_decoder import decode_bytes
from tactile.recording.session import Session
from tactile_protocol import constants as C

RECORD = ("record", "--port", "sim://press", "--quiet")
CLI = (sys.executable, "-m", "tactile.cli.main")


def _start(*args):
    return subprocess.Popen([*CLI, *map(str, args)], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)  # fmt: skip


def _wait_for_bytes(path, more_than, proc, timeout_s=60):
    """Until ``path`` holds more than ``more_than`` bytes (its writer holds the lock)."""
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline and proc.poll() is None:
        if path.exists() and path.stat().st_size > more_than:
            return
        time.sleep(0.02)
    raise AssertionError(f"{path} never grew: {proc.communicate()}")


def _agree(out, sessions):
    """capture.bin decodes cleanly and meta.json accounts for every byte and row of it."""
    capture = (out / "capture.bin").read_bytes()
    messages, counters = decode_bytes(capture)
    meta = json.loads((out / "meta.json").read_text())
    rows = (out / "frames.csv").read_text().splitlines()[2:]
    assert counters.crc_errors == 0 and counters.out_of_order == 0
    assert counters.reboots == sessions - 1  # each sim:// session is a fresh board
    assert meta["bytes"] == len(capture) and meta["samples"] == len(rows)
    assert len(rows) == sum(m.type_name in ("SAMPLE", "CONTACT") for m in messages)
    assert len(meta.get("sessions", [meta])) == sessions
    return meta


def _refused(code, err):
    assert code == 5 and err.count("\n") == 1 and "Traceback" not in err, (code, err)
    assert "another tactile process is writing there" in err, err


def _entries(folder):
    return sorted(os.listdir(folder))


@pytest.mark.parametrize("append", [False, True])
def test_a_second_record_between_the_firsts_start_and_its_first_byte_is_refused(tmp_path, append):
    """The first has made its files and holds the folder, no byte recorded yet: the second
    (another process) is refused, and the first then records a whole run.  Before the
    lock, the second found an empty capture and recorded too, into the same files."""
    out = tmp_path / "run"
    more = ("--append",) if append else ()
    if append:
        assert subprocess.run([*CLI, *RECORD, "--contacts", "1", "-o", str(out)]).returncode == 0
    first = Session("sim://press", out, duration_s=0.5, append=append)
    second = subprocess.run([*CLI, *RECORD, "--duration", "0.5", "-o", str(out), *more],
                            capture_output=True, text=True, timeout=120)  # fmt: skip
    first.run()
    _refused(second.returncode, second.stderr)
    _agree(out, sessions=2 if append else 1)


def test_a_second_append_while_the_first_records_is_refused(cli, tmp_path):
    out = tmp_path / "run"
    code, _, err = cli(*RECORD, "--contacts", "1", "-o", out)
    assert code == 0, err
    size = (out / "capture.bin").stat().st_size
    first = _start(*RECORD, "--duration", "3", "-o", out, "--append")
    _wait_for_bytes(out / "capture.bin", size, first)
    code, _, err = cli(*RECORD, "--duration", "1", "-o", out, "--append")
    _refused(code, err)
    _, stderr = first.communicate(timeout=120)
    assert first.returncode == 0, stderr
    _agree(out, sessions=2)


def test_two_records_started_together_into_one_new_folder(tmp_path):
    """Whichever wins, one records and the other is refused (exit 5 while it records, or
    exit 2 once its capture is there), and the folder holds one clean recording."""
    out = tmp_path / "new" / "run"
    procs = [_start(*RECORD, "--duration", "2", "-o", out) for _ in range(2)]
    results = sorted((p.wait(120), p.stderr.read()) for p in procs)
    (won, _), (lost, err) = results
    assert won == 0 and lost in (2, 5) and err.count("\n") == 1, results
    assert ("already holds a recording" if lost == 2 else "another tactile") in err
    _agree(out, sessions=1)


def test_a_record_into_a_locked_folder_touches_nothing(cli, tmp_path):
    """The test holds the lock, as a first writer would: the record is refused at once."""
    out = tmp_path / "run"
    out.mkdir()
    fd = os.open(out, os.O_RDONLY)
    fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    try:
        for append in ((), ("--append",)):
            code, _, err = cli(*RECORD, "--duration", "1", "-o", out, *append)
            _refused(code, err)
            assert _entries(out) == []
    finally:
        os.close(fd)
    code, _, err = cli(*RECORD, "--duration", "0.2", "-o", out)
    assert code == 0, err


# --- a record that never reached a board ----------------------------------------------------


def _no_port(cli, out, *more):
    code, _, err = cli("record", "--port", "/dev/tactile-no-such-port", "--duration", "1",
                       "-o", out, *more)  # fmt: skip
    assert code == 4 and err.count("\n") == 1 and "no such port" in err, err
    return err


def test_a_failed_record_leaves_no_folder_it_made(cli, tmp_path):
    _no_port(cli, tmp_path / "a" / "b" / "run")
    assert _entries(tmp_path) == []


def test_a_failed_record_leaves_a_users_folder_as_it_was(cli, tmp_path):
    (tmp_path / "notes.txt").write_text("mine")
    _no_port(cli, tmp_path)
    assert _entries(tmp_path) == ["notes.txt"]


def test_a_failed_append_leaves_the_recording_as_it_was(cli, tmp_path):
    out = tmp_path / "run"
    code, _, err = cli(*RECORD, "--contacts", "1", "-o", out)
    assert code == 0, err
    before = {p.name: p.read_bytes() for p in out.iterdir()}
    _no_port(cli, out, "--append")
    assert {p.name: p.read_bytes() for p in out.iterdir()} == before


class _Garbage:
    """A port that sends bytes, never a frame."""

    in_waiting = 8

    def read(self, size=1):
        time.sleep(0.001)
        return b"garbage\0"[:size]

    def write(self, data):
        return len(data)

    def close(self):
        pass


def test_bytes_from_something_not_a_board_are_kept_and_the_line_says_so(cli, tmp_path):
    out = tmp_path / "run"
    with lying_ports(_Garbage):
        code, _, err = cli("record", "--port", "/dev/ttyX", "--wait", "0.3", "-o", out)
    assert code == 4 and err.count("\n") == 1 and "no HELLO" in err, err
    size = (out / "capture.bin").stat().st_size
    assert size > 0 and f"the {size:,} bytes received are kept in {out}" in err
    meta = json.loads((out / "meta.json").read_text())
    assert meta["tared"] is False and meta["device"] is None and meta["bytes"] == size


class _NoTare(LyingPort):
    """A board that answers HELLO and GET_INFO but never acknowledges a TARE."""

    def write(self, data):
        if any(m.type_code == C.CMD_TARE for m in StreamPeek(data)):
            return len(data)
        return super().write(data)


def StreamPeek(data):  # noqa: N802 - the commands in ``data``
    from tactile.board.stream_decoder import StreamDecoder

    return StreamDecoder(check_limits=False).feed(bytes(data))


@pytest.mark.parametrize("no_tare", [False, True])
def test_meta_json_says_tared_only_for_a_tare_the_board_acknowledged(
    cli, tmp_path, no_tare, monkeypatch
):
    out = tmp_path / "run"  # a TARE unanswered for 0.3 s is as unanswered as for its 5 s
    monkeypatch.setattr(BoardClient, "tare", functools.partialmethod(BoardClient.tare, timeout=0.3))
    with lying_ports(_NoTare):
        code, _, err = cli("record", "--port", "/dev/ttyX", "--duration", "0.3", "-o", out,
                           *(["--no-tare"] if no_tare else []))  # fmt: skip
    meta = json.loads((out / "meta.json").read_text())
    if no_tare:  # nothing asked: the stream is recorded, and meta.json claims no TARE
        assert code == 0 and meta["tared"] is False, err
    else:  # asked, never acknowledged
        assert code == 4 and meta["tared"] is False and meta["ended"] == "error", err
