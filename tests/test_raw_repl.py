"""``tactile.board.raw_repl``: mpremote's transport with every wait bounded, each step one line on
failure, files written whatever their bytes."""

import os
import sys
import time
import tty

import pytest
import serial

from tactile.board import raw_repl
from tactile.errors import BoardError, MissingExtra, PortError


class Streaming:
    """A port that never stops talking (the emulator's python core on its pty)."""

    timeout = 0.05

    @property
    def in_waiting(self):
        return 100

    def read(self, size=1):
        return b"\x55" * size

    def write(self, data):
        return len(data)


def _transport(port):
    cls, _ = raw_repl._bounded_transport()
    t = cls.__new__(cls)  # no device opened: the port is the test's
    t.serial, t.in_raw_repl, t.use_raw_paste, t.mounted, t.is_pty = port, False, True, False, False
    return t


def _session(port):
    s = raw_repl.Session.__new__(raw_repl.Session)
    s.name, s.t = "/dev/ttyACM0", _transport(port)
    s._transport_error = raw_repl._bounded_transport()[1]
    return s


def test_read_until_stops_at_the_deadline_on_a_port_that_never_stops():
    t = _transport(Streaming())
    t.deadline = time.monotonic() + 0.3
    start = time.monotonic()
    data = t.read_until(1, b"\x04", timeout=10)  # mpremote's: 10 s between bytes, none overall
    assert not data.endswith(b"\x04") and time.monotonic() - start < 5.0


def test_a_step_that_runs_out_is_one_line_naming_it():
    s = _session(Streaming())
    start = time.monotonic()
    with pytest.raises(BoardError) as err:
        s.enter(0.3)  # the input flush and the banner wait, both bounded
    assert str(err.value) == "/dev/ttyACM0: entering the raw REPL: no answer within 0.3 s"
    assert time.monotonic() - start < 5.0


def test_an_error_on_the_board_is_its_last_line():
    s = _session(Streaming())
    mod = sys.modules["mpremote.transport"]
    s.t.exec = lambda code: (_ for _ in ()).throw(
        mod.TransportExecError(b"", "Traceback (most recent call last):\r\nOSError: 28\r\n")
    )
    with pytest.raises(BoardError, match=r"^/dev/ttyACM0: writing /x: OSError: 28$"):
        s.write_file("/x", b"abc", 5.0)


@pytest.mark.parametrize("b64", [True, False])
def test_files_arrive_byte_for_byte_in_chunks_each_exec_opening_or_closing_as_needed(tmp_path, b64):
    """The code sent to the board, run here: every byte value, in and across chunks."""
    data = bytes(range(256)) * 40 + b"'\"\\\r\n"
    sent, done = [], []
    s = _session(Streaming())
    s.exec = lambda code, seconds, doing: sent.append(code) or b""
    target = tmp_path / "f.mpy"
    s.write_file(str(target), data, 5.0, done.append, b64=b64)
    size = raw_repl.B64_CHUNK if b64 else raw_repl.CHUNK
    assert len(sent) == -(-len(data) // size) and sum(done) == len(data)
    assert "open(" in sent[0] and "f.close()" in sent[-1]
    assert not any("open(" in c or "close" in c for c in sent[1:-1])
    assert ("a2b_base64" in sent[0]) == b64
    scope = {}
    for code in sent:
        exec(code, scope)  # noqa: S102 - what the board would run
    assert target.read_bytes() == data


def test_an_empty_file_is_one_exec(tmp_path):
    sent = []
    s = _session(Streaming())
    s.exec = lambda code, seconds, doing: sent.append(code) or b""
    s.write_file(str(tmp_path / "e"), b"", 5.0)
    exec(sent[0], {})  # noqa: S102
    assert len(sent) == 1 and (tmp_path / "e").read_bytes() == b""


def _pty():
    master, slave = os.openpty()
    tty.setraw(slave)
    path = os.ttyname(slave)
    os.close(slave)
    return master, path


def test_a_port_in_use_says_so_in_one_line():
    master, path = _pty()
    held = serial.Serial(path, exclusive=True)
    try:
        with pytest.raises(PortError) as err:
            raw_repl.Session(path)
    finally:
        held.close()
        os.close(master)
    assert str(err.value) == (
        f"{path}: port busy (another program has it open: close it and retry)"
    )


def test_a_missing_port_says_so_in_one_line():
    with pytest.raises(PortError, match="/dev/ttyNOPE: no such port"):
        raw_repl.Session("/dev/ttyNOPE")


def test_without_mpremote_it_says_which_extra(monkeypatch):
    raw_repl._bounded_transport.cache_clear()
    monkeypatch.setitem(sys.modules, "mpremote.transport_serial", None)
    try:
        with pytest.raises(MissingExtra) as err:
            raw_repl.need_mpremote()
    finally:
        raw_repl._bounded_transport.cache_clear()
    assert str(err.value) == (
        "Flashing a board needs the 'board' extra: pip install 'tactile-shape[board]'"
    )
    assert err.value.exit_code == 2


def test_closing_a_port_that_vanished_is_quiet():
    class Gone(Streaming):
        def close(self):
            raise OSError(5, "Input/output error")

    s = _session(Gone())
    s.close()
