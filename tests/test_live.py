"""``tactile live``: the terminal view's state and the board left as it was found."""

import pytest

from tactile.live_view import LiveState
from tactile.messages import Contact, Sample
from tactile_protocol import constants as C


def test_state_follows_samples_and_contacts():
    state = LiveState()
    state.update([Sample(0, 0, 0, 0, 3_000_000, 4_000_000, 0, 0, 0, 0)])
    assert "|F|   5.000" in state.render()[0] and "free" in state.render()[0]
    state.update([Contact(1, 1, 0, C.PHASE_BEGIN, 7, C.FLAG_IN_CONTACT | 0x01, 0, 0, 2_000_000,
                          10_000, 0, 0)])  # fmt: skip
    line = state.render()[0]
    assert "CONTACT" in line and "contacts 1" in line and "SATURATED 0x01" in line
    assert "+0.0100" in line
    state.update([Contact(2, 2, 0, C.PHASE_END, 7, 0, 0, 0, 0, 0, 0, 0)])
    assert "free" in state.render()[0]


def test_live_turns_samples_on_and_restores_the_configuration(cli, mocker):
    from tactile.board_client import BoardClient

    spy = mocker.spy(BoardClient, "configure")
    code, out, err = cli("live", "--port", "sim://ch5_plane", "--duration", "0.3")
    assert code == 0, err
    assert "sensor 0  F [" in out and "lost 0" in out
    on, restore = spy.call_args_list  # ch5 streams contacts only: SAMPLE on, then back
    assert on.args[5] & C.CFG_STREAM_SAMPLES and not restore.args[5] & C.CFG_STREAM_SAMPLES
    assert restore.args[1:5] == pytest.approx((1000, 1.39, 1.112, 1))
