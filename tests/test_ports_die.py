"""Ports that die (issue 12): a board unplugged or an emulator killed while a board command
runs gives one line and exit 4, never a traceback; ``record`` still waits for the port.

Two routes: a real pty whose emulator goes away (the OS's own failures), and a table of
pyserial failures injected with pytest-mock under every board command.
"""

import errno
import json

import pytest
import serial

from tactile.board.stream_decoder import decode_bytes
from tactile_sim.emulator.dying import DyingBoard

pytestmark = pytest.mark.realtime  # on the wall clock: bench/realtime_soak.py

NO_DATA = (
    "device reports readiness to read but returned no data "
    "(device disconnected or multiple access on port?)"
)


def _one_line_exit_4(code, err, doing="reading"):
    assert code == 4, err
    assert err.count("\n") == 1 and "Traceback" not in err, err
    assert f"port lost while {doing}" in err, err


PTY_COMMANDS = {
    "info": ["info"],
    "tare": ["tare"],
    "config": ["config", "--rate", "500"],
    "live": ["live", "--duration", "5"],
}


@pytest.mark.parametrize("command", list(PTY_COMMANDS))
def test_a_board_gone_while_a_command_waits_is_one_line(cli, command):
    with DyingBoard() as board:
        code, _, err = cli(*PTY_COMMANDS[command], "--port", board.path)
    _one_line_exit_4(code, err)


def test_live_with_the_emulator_gone_mid_stream_restores_nothing_and_says_it_once(cli):
    """ch5_plane streams contacts only, so live switched SAMPLE on and owes a restore."""
    with DyingBoard("ch5_plane", at_command=2, after_s=1.2) as board:  # GET_INFO, CONFIG
        code, out, err = cli("live", "--port", board.path, "--duration", "5")
    _one_line_exit_4(code, err)
    assert "sensor 0  |F|" in out and "  F [" in out  # drawn once a second: it was streaming


def test_record_whose_board_dies_at_its_tare_is_one_line_and_keeps_the_bytes(cli, tmp_path):
    with DyingBoard() as board:
        code, _, err = cli("record", "--port", board.path, "--duration", "5", "-o", tmp_path,
                           "--quiet")  # fmt: skip
    _one_line_exit_4(code, err)
    meta = json.loads((tmp_path / "meta.json").read_text())
    assert meta["ended"] == "error" and meta["device"]["sensor_model"] == "FT6/ADS122C04x6"
    capture = (tmp_path / "capture.bin").read_bytes()
    assert meta["bytes"] == len(capture) > 0
    # the readings that came while the TARE waited are in frames.csv too, not only the capture
    readings = sum(m.type_name in ("SAMPLE", "CONTACT") for m in decode_bytes(capture)[0])
    rows = (tmp_path / "frames.csv").read_text().splitlines()[2:]  # below units, header
    assert len(rows) == meta["samples"] == readings > 0


def test_record_whose_board_dies_mid_stream_waits_then_keeps_everything(cli, tmp_path):
    with DyingBoard(after_s=0.5) as board:  # the TARE is answered; half a second of stream
        code, _, err = cli("record", "--port", board.path, "--duration", "10", "-o", tmp_path,
                           "--reconnect", "0.5", "--quiet")  # fmt: skip
    assert code == 4 and err.count("\n") == 1 and "Traceback" not in err
    assert "port lost and not back within 0.5 s" in err
    meta = json.loads((tmp_path / "meta.json").read_text())
    (gap,) = meta["gaps"]
    assert meta["ended"] == "port lost" and "port lost while reading" in gap["why"]
    capture = (tmp_path / "capture.bin").read_bytes()
    messages, _ = decode_bytes(capture)
    rows = (tmp_path / "frames.csv").read_text().splitlines()[2:]  # below units, header
    assert len(rows) == sum(m.type_name in ("SAMPLE", "CONTACT") for m in messages) > 0
    stamps = [m.timestamp_us for m in messages if m.type_name == "SAMPLE"]
    assert stamps[-1] - stamps[0] >= 450_000  # half a second of the board's stream, all kept


# -- the table: every board command x every way pyserial reports a dead port -------------


class DyingPort:
    """A sim:// port that dies after ``writes`` commands went through and ``reads`` more reads.

    ``kind`` is how pyserial reports the death: a read that finds no data after select()
    said readable, a read (or ``in_waiting``) failing with EIO, or a write failing with
    EIO.  A dead port stays dead; writes fail whatever the kind.
    """

    def __init__(self, port, kind, writes, reads):
        self._port, self.kind = port, kind
        self.writes_left, self.reads_left = writes, reads
        self.delivered = bytearray()

    @property
    def dead(self):
        return self.writes_left <= 0 and self.reads_left <= 0

    @property
    def in_waiting(self):
        if self.dead and self.kind == "read EIO":
            raise OSError(errno.EIO, "Input/output error")  # what TIOCINQ gives on a dead pty
        return self._port.in_waiting

    def read(self, size=1):
        if self.dead and self.kind == "read no data":
            raise serial.SerialException(NO_DATA)
        if self.dead and self.kind == "read EIO":
            raise serial.SerialException("read failed: [Errno 5] Input/output error")
        if self.writes_left <= 0:
            self.reads_left -= 1
        data = self._port.read(size)
        self.delivered += data
        return data

    def write(self, data):
        if self.dead:
            raise serial.SerialException("write failed: [Errno 5] Input/output error")
        self.writes_left -= 1
        return self._port.write(data)

    def close(self):
        self._port.close()


@pytest.fixture
def dying(mocker):
    """Make every sim:// port opened from now on a DyingPort; a reopen finds no port."""
    real = serial.serial_for_url
    opened = []

    def arm(kind, writes, reads=0):
        def open_(url, *args, **kwargs):
            if opened:  # the board is gone for good
                raise serial.SerialException(errno.ENOENT, f"could not open port {url}")
            opened.append(DyingPort(real(url, *args, **kwargs), kind, writes, reads))
            return opened[-1]

        mocker.patch.object(serial, "serial_for_url", side_effect=open_)
        return opened

    return arm


KINDS = ("read no data", "read EIO", "write EIO")
TABLE = {
    "info": ["info", "--port", "sim://press"],
    "tare": ["tare", "--port", "sim://press"],
    "config": ["config", "--port", "sim://press", "--rate", "500"],
    "live": ["live", "--port", "sim://ch5_plane", "--duration", "0.5"],
    "record": ["record", "--port", "sim://press", "--duration", "2", "--quiet"],
}


@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("command", list(TABLE))
def test_a_port_dying_at_the_first_command_is_one_line_exit_4(cli, dying, tmp_path, command, kind):
    dying(kind, writes=0 if kind == "write EIO" else 1)
    extra = ["-o", tmp_path / "run"] if command == "record" else []
    code, _, err = cli(*TABLE[command], *extra)
    _one_line_exit_4(code, err, "writing" if kind == "write EIO" else "reading")


@pytest.mark.parametrize("kind", ["read no data", "read EIO"])
def test_record_dying_mid_stream_waits_then_keeps_every_byte(cli, dying, tmp_path, kind):
    ports = dying(kind, writes=1, reads=100)  # the TARE goes through, then 100 reads
    code, _, err = cli(*TABLE["record"], "-o", tmp_path, "--reconnect", "0.3")
    assert code == 4 and err.count("\n") == 1 and "Traceback" not in err, err
    assert "port lost and not back within 0.3 s" in err
    assert (tmp_path / "capture.bin").read_bytes() == bytes(ports[0].delivered)
    meta = json.loads((tmp_path / "meta.json").read_text())
    assert meta["ended"] == "port lost" and meta["gaps"][0]["back_at_s"] is None


@pytest.mark.parametrize("kind", KINDS)
def test_live_dying_mid_stream_is_one_line_exit_4(cli, dying, kind):
    """GET_INFO and CONFIG (SAMPLE on) go through; then reads fail, or the restore's write
    does: either way one line, not one traceback per attempt."""
    ports = dying(kind, writes=2, reads=0 if kind == "write EIO" else 100)
    code, _, err = cli(*TABLE["live"])
    _one_line_exit_4(code, err, "writing" if kind == "write EIO" else "reading")
    assert ports[0].delivered.count(0) > 100  # frames were streaming when it died
