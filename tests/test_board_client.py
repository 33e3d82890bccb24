"""The host's board client and port opening (issue 7): handshake, commands, clear errors.

The handshake and CONFIG against each board (both emulated cores, a real one with
``--port``): ``test_board_suite.py``.
"""

import errno

import pytest
import serial

from tactile.board.client import BoardClient
from tactile.board.serial_port import open_port
from tactile.errors import BoardTimeout, PortError, ProtocolVersionError
from tactile_protocol import constants as C
from tactile_protocol.framing import FrameEncoder
from tactile_protocol.messages import pack_into


class FakePort:
    """A port that replays ``chunks`` (one per read) and records what the host writes."""

    def __init__(self, chunks=()):
        self.chunks = list(chunks)
        self.written = []
        self.closed = False

    @property
    def in_waiting(self):
        return len(self.chunks[0]) if self.chunks else 0

    def read(self, size=1):
        return self.chunks.pop(0) if self.chunks else b""

    def write(self, data):
        self.written.append(bytes(data))
        return len(data)

    def close(self):
        self.closed = True


class StepClock:
    def __init__(self, step=0.01):
        self.t, self.step = 0.0, step

    def __call__(self):
        self.t += self.step
        return self.t


def _frame_v(version, mtype, values, seq=0):
    """A frame as a device speaking protocol ``version`` would send it (same layout)."""
    from tactile_protocol.cobs_codec import encode
    from tactile_protocol.crc16 import crc16

    body = bytearray(C.MAX_BODY)
    n = pack_into(body, mtype, seq, 0, values)
    body[0] = version
    crc = crc16(body, 0, n)
    return encode(bytes(body[:n]) + bytes((crc & 0xFF, crc >> 8))) + b"\0"


HELLO = (0, 1, 0, C.PROTOCOL_VERSION, b"SIM", 1, 1000, 1, 0, 0, 0, 1000, 1390000, 1112000, 3, 0x0B,
         0xB0071D, 0x1234, 0, 0, 0, b"board-01")  # fmt: skip


def test_frames_arriving_while_a_command_waits_are_kept_in_order():
    client = BoardClient(open_port("sim://press"), "sim://press")
    client.handshake(1.0)
    client.read()
    client.get_info()  # the board keeps streaming SAMPLE frames meanwhile
    kept = client.read()
    samples = [m for m in kept if m.type_name == "SAMPLE"]
    assert samples, "samples streamed during the command were dropped"
    seqs = [m.seq for m in kept]
    assert seqs == sorted(seqs) and client.decoder.counters.lost_frames == 0


def test_no_hello_then_get_info_is_sent_then_a_timeout_names_the_port():
    port = FakePort()
    client = BoardClient(port, "/dev/ttyACM9", clock=StepClock())
    with pytest.raises(BoardTimeout, match=r"/dev/ttyACM9: no HELLO within 1 s"):
        client.handshake(1.0)
    from tactile.board.stream_decoder import StreamDecoder

    sent = StreamDecoder()._decode(port.written[0][:-1])
    assert len(port.written) == 1 and sent[1] == C.CMD_GET_INFO


def test_a_board_answering_only_get_info_is_found():
    info = bytes(FrameEncoder().encode(C.MSG_INFO, 0, HELLO))
    port = FakePort([b""] * 60 + [info])
    client = BoardClient(port, "pico", clock=StepClock())
    assert client.handshake(1.0).type_name == "INFO"
    assert port.written  # it asked


def test_another_protocol_version_names_both_versions():
    newer = C.PROTOCOL_VERSION + 1
    port = FakePort([_frame_v(newer, C.MSG_HELLO, HELLO)])
    client = BoardClient(port, "/dev/ttyACM0", clock=StepClock())
    expect = f"speaks protocol version {newer}, this host speaks version {C.PROTOCOL_VERSION}"
    with pytest.raises(ProtocolVersionError, match=expect):
        client.handshake(1.0)


def test_a_board_of_the_previous_version_is_refused_live_by_name():
    """Its HELLO (without board_id) decodes from a recording, but a live board of protocol 3
    cannot be talked to: the host names both versions and what to update."""
    import struct

    from tactile_protocol.cobs_codec import encode
    from tactile_protocol.crc16 import crc16

    old = (*HELLO[:3], 3, *HELLO[4:21])  # version 3's 21 fields
    body = struct.pack("<BBHIBBBB16sBH4IHiiBBI4H", 3, C.MSG_HELLO, 0, 0, *old)
    crc = crc16(body)
    port = FakePort([encode(body + bytes((crc & 0xFF, crc >> 8))) + b"\0"])
    client = BoardClient(port, "/dev/ttyACM0", clock=StepClock())
    with pytest.raises(ProtocolVersionError, match="speaks protocol version 3, .* the firmware"):
        client.handshake(1.0)


@pytest.mark.parametrize(
    "code, text, expect",
    [
        (errno.ENOENT, "No such file or directory", "no such port"),
        (errno.EACCES, "Permission denied", "permission denied; add yourself to the 'dialout'"),
        (errno.EBUSY, "Device or resource busy", "port busy"),
        (errno.EWOULDBLOCK, "Could not exclusively lock port", "port busy"),
    ],
)
def test_open_errors_become_one_line_messages(mocker, code, text, expect):
    mocker.patch.object(
        serial, "Serial", side_effect=serial.SerialException(code, f"could not open port: {text}")
    )
    with pytest.raises(PortError) as info:
        open_port("/dev/ttyACM0")
    message = str(info.value)
    assert message.startswith("/dev/ttyACM0: ") and expect in message and "\n" not in message


def test_cli_shows_permission_denied_without_a_traceback(mocker, cli):
    mocker.patch.object(
        serial, "Serial", side_effect=serial.SerialException(errno.EACCES, "Permission denied")
    )
    code, out, err = cli("info", "--port", "/dev/ttyACM0")
    assert code == 4 and out == ""
    assert err.count("\n") == 1 and "Traceback" not in err and "dialout" in err


def test_info_and_config_commands(cli):
    code, out, _ = cli("info", "--port", "sim://press", "--json")
    assert code == 0 and '"rate_hz":1000' in out and '"streams":["samples","contacts"]' in out
    code, out, _ = cli("config", "--port", "sim://press", "--rate", "250", "--gate", "3d")
    assert code == 0 and "rate          250 Hz" in out and "gate          3d" in out
    code, _, err = cli("config", "--port", "sim://press", "--rate", "0")  # checked before sending
    assert code == 2 and "--rate: 0 Hz is out of range: 1.." in err
    code, _, err = cli("config", "--port", "sim://press", "--streams", "video")
    assert code == 2 and "--streams: unknown stream 'video'" in err


def test_tare_command_waits_for_the_bias(cli):
    code, out, _ = cli("tare", "--port", "sim://ch5_plane", "--samples", "32")
    assert code == 0 and out.strip() == "tared all sensors (32 readings)"
    code, _, err = cli("tare", "--port", "sim://ch5_plane", "--sensor", "7")
    assert code == 2 and "--sensor: '7'" in err


def test_ports_lists_or_says_none(mocker, cli):
    from serial.tools import list_ports

    mocker.patch.object(list_ports, "comports", return_value=[])
    code, out, err = cli("ports")
    assert code == 1 and "no serial ports found" in err


def test_ports_prints_a_header_and_marks_ports_without_a_usb_id(mocker, cli):
    from serial.tools import list_ports

    class Port:
        def __init__(self, device, description, hwid):
            self.device, self.description, self.hwid = device, description, hwid

    ports = [
        Port("/dev/ttyACM0", "Board in FS mode", "USB VID:PID=2E8A:0005 SER=E66 LOCATION=1-1:1.0"),
        Port("/dev/ttyS0", "n/a", "n/a"),
    ]
    mocker.patch.object(list_ports, "comports", return_value=ports)
    code, out, _ = cli("ports")
    lines = out.splitlines()
    assert code == 0 and lines[0].split() == ["device", "description", "hardware", "id"]
    assert "unlikely" not in lines[1] and lines[2].endswith("(no USB id: unlikely to be a board)")
