"""One emulator server (``tactile_sim.emulator.server``): the base owns the pty, host presence,
keep and drop and the serving thread, a core supplies step, read and write; and every test,
bench and study starts a server one way, as a context manager.

The core here is a stand-in of a few lines, so what is checked is the base's own handling."""

import re

import pytest
import serial
from conftest import ROOT

from tactile_sim.emulator import cores
from tactile_sim.emulator.server import KEEP_BYTES, Server
from tactile_sim.emulator.servers import SERVERS


class Echo(Server):
    """A core whose board says ``hello`` when a host comes, answers what it gets in capitals,
    sends ``chunk`` every step and ``early`` while no host is there; a step is 1 ms of its
    time.  ``fail_at_us``: its step raises then."""

    def __init__(self, chunk=b"", keeps=False, fail_at_us=None, **options):
        super().__init__(None, **options)
        self.chunk, self.keeps, self.fail_at_us = chunk, keeps, fail_at_us
        self.now_us, self.out, self.sent = 0, bytearray(), 0

    @property
    def t_us(self):
        return self.now_us

    @property
    def keeps_for_absent_host(self):
        return self.keeps

    def idle_s(self):
        return 0.001  # (a stand-in with nothing to wait on: do not spin)

    def opened(self):
        self.out += b"hello\n"

    def step(self, held):
        if self.fail_at_us is not None and self.now_us >= self.fail_at_us:
            raise RuntimeError("the stand-in's board broke")
        if not self.endpoint.host_present:
            self.out += b"early"
        self.out += self.chunk
        self.now_us += 1000
        return True

    def read(self):
        data = bytes(self.out)
        self.out.clear()
        self.sent += len(data)
        return data

    def write(self, data):
        self.out += data.upper()


def test_the_host_gets_the_boards_bytes_from_its_arrival_on_and_its_own_reach_the_board():
    with Echo() as server, serial.Serial(server.path, timeout=5) as port:
        port.write(b"ping\n")
        got = port.read_until(b"PING\n")
    assert got == b"hello\nPING\n"  # nothing sent before the host was announced


@pytest.mark.parametrize("keeps", [False, True])
def test_what_a_host_does_not_read_goes_nowhere_or_is_kept_to_a_bound_then_counted(keeps):
    chunk = b"x" * 65536
    with Echo(chunk, keeps, duration_s=0.05) as server:  # 50 steps, 3.2 MB, no host
        assert server.wait(30)
    assert server.now_us == 50_000 and server.sent == 50 * (len(chunk) + 5)
    if keeps:
        assert KEEP_BYTES <= len(server.to_host) < KEEP_BYTES + len(chunk) + 5
        assert len(server.to_host) + server.dropped == server.sent
    else:
        assert len(server.to_host) == server.dropped == 0


def test_leaving_the_block_stops_closes_and_raises_what_the_run_raised():
    server = Echo(fail_at_us=0)
    with pytest.raises(RuntimeError, match="board broke"), server:
        assert server.wait(10)
    assert server.endpoint.master is None and not server.serving


def test_every_core_the_emulator_serves_has_its_server():
    assert set(SERVERS) == set(cores.SERVED)


def test_every_server_is_started_one_way():
    """No test, bench, study or command starts a server's ``serve`` in a thread of its own:
    each enters the server (``with ... as server``), which serves in its thread."""
    roots = [ROOT / d for d in ("tests", "bench", "studies", "host", "sim")]
    hand_made = re.compile(r"Thread\([^)]*\bserve\b|serve_when_opened|\bserver\.serve\(")
    bad = [
        f"{p.relative_to(ROOT)}:{text[: m.start()].count(chr(10)) + 1}"
        for root in roots
        for p in root.rglob("*.py")
        if p.name != "test_emulator_server.py"
        for text in [p.read_text(encoding="utf-8")]
        for m in hand_made.finditer(text)
    ]
    assert not bad, bad
