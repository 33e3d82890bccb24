"""``tactile.board.handover.break_in``: MicroPython's raw REPL reached, or one line on what the
port holds instead, within its bounds whatever the port does (fake ports, fake clock)."""

import pytest
from flash_fakes import BANNER, BoardPort, FakeClock

from tactile.board import handover
from tactile.board.handover import BREAK, FIRMWARE_S, RAW, RESEND_S, WINDOW_S, NoRepl
from tactile.errors import PortLost

NAME = "/dev/ttyACM0"


def _probe(kind, **kw):
    clock = FakeClock()
    port = BoardPort(kind, clock, **kw)
    start = clock()
    try:
        handover.break_in(port, NAME, clock=clock)
        return port, clock() - start, None
    except NoRepl as exc:
        return port, clock() - start, exc


def test_a_board_at_its_repl_is_broken_into_the_way_mpremote_does_it():
    port, took, err = _probe("repl")
    assert err is None and took < 1.0
    (t0, first), (t1, second) = port.writes[:2]
    assert (first, second) == (b"\x00\r\x03", b"\r\x01") == (BREAK, RAW)
    assert t1 - t0 >= handover.PAUSE_S  # the pause mpremote makes for a traceback


def test_the_firmware_exits_to_the_repl_at_cr_ctrl_c_cr_even_while_it_streams():
    port, took, err = _probe("firmware")
    assert err is None and took < 1.0
    assert port.running is False  # it saw BREAK_IN: 0x00 ended the frame, then CR ^C CR


def test_a_board_still_booting_is_asked_again():
    port, took, err = _probe("late", late_s=RESEND_S - 0.5)
    assert err is None and RESEND_S <= took < RESEND_S + 1.0
    assert [w for _, w in port.writes].count(BREAK) == 2


@pytest.mark.parametrize("kind", ["no_repl", "no_repl_quiet"])
def test_the_firmware_with_no_repl_behind_it_is_named_with_its_version(kind):
    port, took, err = _probe(kind)
    assert str(err) == (
        f"found the tactile firmware speaking its protocol on {NAME} (firmware 1.2.3, no "
        "MicroPython REPL behind it)"
    )
    assert FIRMWARE_S <= took < FIRMWARE_S + handover.INFO_S + 0.5  # not the whole window
    assert err.exit_code == 4


def test_a_port_that_says_nothing_ends_at_the_window():
    port, took, err = _probe("silent")
    assert str(err) == f"{NAME} said nothing in {WINDOW_S:g} s: is it a MicroPython board?"
    assert WINDOW_S <= took < WINDOW_S + 0.2
    assert [w for _, w in port.writes].count(BREAK) == 4  # at 0, 2.5, 5, 7.5 s


def test_bytes_that_are_no_repl_are_shown_escaped_in_one_line():
    _, took, err = _probe("noise")
    assert str(err).startswith(
        f"{NAME} answered, but not as MicroPython's REPL: ERR?\\r\\n\\x1b[31m"
    )
    assert str(err).endswith("...") and "\n" not in str(err) and "\x1b" not in str(err)
    assert took < WINDOW_S + 0.2


def test_a_port_that_dies_is_port_lost_in_one_line():
    with pytest.raises(PortLost, match="port lost while writing: Input/output error"):
        handover.break_in(BoardPort("dies"), NAME, clock=FakeClock())


def test_the_banner_is_found_across_reads_and_after_megabytes():
    heard = handover._Heard()
    for _ in range(1000):
        heard(b"\x55" * 1000)
    for i in range(0, len(BANNER), 3):
        heard(BANNER[i : i + 3])
    assert heard.banner and heard.count == 1_000_000 + len(BANNER)
    assert len(heard.tail) <= len(BANNER) and len(heard.first) == handover.SHOWN_BYTES
