"""``tactile.board.handover``: after the reset, the port again and the firmware's HELLO or
INFO within the bound, asking only when asking is safe; one line when nothing answers
(fake ports and clock)."""

import pytest
import serial
from flash_fakes import FakeClock
from lying_device import GOOD_INFO, frame

from tactile.board import handover
from tactile.board.handover import ASK_GONE_S, ASK_STAYED_S, answer
from tactile.board.stream_decoder import StreamDecoder
from tactile.errors import BoardTimeout, PortError
from tactile_protocol import constants as C

NAME = "/dev/ttyACM0"


class Booting:
    """The firmware after a reset: HELLO at ``hello_at`` (None: lost), INFO when asked;
    ``says``: text, and no firmware (a REPL); ``dies_after``: reads before it vanishes."""

    def __init__(self, clock, hello_at=None, says=None, dies_after=None):
        self.clock, self.hello_at, self.dies_after = clock, hello_at, dies_after
        self.firmware = says is None
        says = says or b""
        self.out = bytearray(says)
        self.asked = []  # clock at each GET_INFO
        self.commands = StreamDecoder(check_limits=False)
        self.timeout = 0.05

    @property
    def in_waiting(self):
        return len(self.out)

    def read(self, size=1):
        if self.dies_after is not None:
            if self.dies_after == 0:
                raise serial.SerialException(
                    "device reports readiness to read but returned no data"
                )
            self.dies_after -= 1
        if self.hello_at is not None and self.clock() >= self.hello_at:
            self.out += frame(C.MSG_HELLO, GOOD_INFO)
            self.hello_at = None
        if not self.out:
            self.clock.sleep(self.timeout)
            return b""
        data = bytes(self.out[:size])
        del self.out[:size]
        return data

    def write(self, data):
        for m in self.commands.feed(bytes(data)):
            if m.type_code == C.CMD_GET_INFO and self.firmware:
                self.asked.append(self.clock())
                self.out += frame(C.MSG_INFO, GOOD_INFO, seq=1)
                self.out += frame(C.MSG_ACK, (m.type_code, m.seq), seq=2)
        return len(data)

    def close(self):
        pass


def _opener(clock, ports, gone=0):
    """Opens ``gone`` times as a port that is not there, then each of ``ports`` in turn."""
    calls = []

    def opener(name):
        calls.append(clock())
        if len(calls) <= gone:
            raise PortError(f"{name}: no such port")
        return ports[min(len(calls) - gone - 1, len(ports) - 1)]

    return opener


def _answer(ports, gone=0, wait_s=20.0):
    clock = FakeClock()
    ports = [p(clock) for p in ports]
    start = clock()
    info = answer(NAME, wait_s, opener=_opener(clock, ports, gone), clock=clock, sleep=clock.sleep)
    return info, ports, clock() - start, start


def test_a_pty_that_stayed_is_left_to_send_its_hello():
    info, (port,), took, _ = _answer([lambda c: Booting(c, hello_at=c() + 3.0)])
    assert info.type_code == C.MSG_HELLO and port.asked == []
    assert 3.0 <= took < 3.5


def test_a_pty_whose_hello_was_lost_is_asked_only_after_main_py_turned_ctrl_c_off():
    info, (port,), took, start = _answer([Booting])
    assert info.type_code == C.MSG_INFO and len(port.asked) == 1
    assert port.asked[0] - start >= ASK_STAYED_S


def test_a_port_that_went_and_came_back_is_asked_soon():
    info, (port,), took, start = _answer([Booting], gone=3)
    assert info.type_code == C.MSG_INFO
    assert port.asked[0] - start < ASK_STAYED_S and took < ASK_GONE_S + 2.0


def test_a_port_opened_before_it_vanished_is_opened_again():
    dead = lambda c: Booting(c, dies_after=2)  # noqa: E731 - the old device node
    info, (old, new), took, _ = _answer([dead, Booting])
    assert info.type_code == C.MSG_INFO and new.asked and not old.asked


def test_no_firmware_is_one_line_with_the_last_thing_the_board_said():
    repl = b"Traceback (most recent call last):\r\nImportError: no module named 'x'\r\n"
    repl += b"MicroPython v1.29.0 on 2026-11-26; Raspberry Pi Pico with RP2040\r\n>>> "
    with pytest.raises(BoardTimeout) as err:
        _answer([lambda c: Booting(c, says=repl)], wait_s=12.0)
    assert str(err.value) == (
        f"{NAME}: the copy finished and the board was reset, but the firmware did not answer "
        "within 12 s; the last it said: ImportError: no module named 'x'"
    )


def test_silence_is_said_and_the_bound_kept():
    clock = FakeClock()
    start = clock()
    with pytest.raises(BoardTimeout, match="did not answer within 20 s; it said nothing$"):
        answer(
            NAME, 20.0, opener=lambda name: Booting(clock, says=b""), clock=clock, sleep=clock.sleep
        )
    assert 20.0 <= clock() - start < 20.5


def test_what_answered_in_one_line():
    (info,) = StreamDecoder().feed(frame(C.MSG_HELLO, GOOD_INFO))
    assert handover.describe(info) == (
        f"tactile firmware 1.2.3 (protocol {C.PROTOCOL_VERSION}), 1 sensor FT6, 1000 Hz"
        " (ceiling 1730 Hz)"
    )
