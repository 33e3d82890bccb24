"""``tactile live``: the terminal view's state and the board left as it was found."""

import pytest

from tactile.board.stream_decoder import Contact, Sample
from tactile.cli.cmd_live import LiveState
from tactile_protocol import constants as C


def test_state_follows_samples_and_contacts():
    state = LiveState()
    state.update([Sample(0, 0, 0, 0, 3_000_000, 4_000_000, 0, 0, 0, 0)])
    assert "|F|     5.000 N" in state.render()[0] and "free" in state.render()[0]
    state.update([Contact(1, 1, 0, C.PHASE_BEGIN, 7, C.FLAG_IN_CONTACT | 0x01, 0, 0, 2_000_000,
                          10_000, 0, 0)])  # fmt: skip
    line = state.render()[0]
    assert "CONTACT" in line and "contacts 1" in line and "SATURATED 0x01" in line
    assert "+0.0100" in state.render()[1]
    state.update([Contact(2, 2, 0, C.PHASE_END, 7, 0, 0, 0, 0, 0, 0, 0)])
    assert "free" in state.render()[0]


def test_live_turns_samples_on_and_restores_the_configuration(cli, mocker):
    from tactile.board.client import BoardClient

    spy = mocker.spy(BoardClient, "configure")
    code, out, err = cli("live", "--port", "sim://ch5_plane", "--duration", "0.3")
    assert code == 0, err
    assert "sensor 0  |F|" in out and "  F [" in out and "lost 0" in out
    on, restore = spy.call_args_list  # ch5 streams contacts only: SAMPLE on, then back
    assert on.args[5] & C.CFG_STREAM_SAMPLES and not restore.args[5] & C.CFG_STREAM_SAMPLES
    assert restore.args[1:5] == pytest.approx((1000, 1.39, 1.112, 1))


@pytest.mark.parametrize("sensors", [1, 2, 3, 4])
@pytest.mark.parametrize("v", [-(2**31), 2**31 - 1])
def test_every_line_fits_80_columns(sensors, v, capsys):
    """The widest values the wire carries (int32 uN and uN*m), saturation, huge counters."""
    from types import SimpleNamespace

    from tactile.cli.cmd_live import _draw

    state = LiveState()
    for s in range(sensors):
        state.update([Contact(1, 1, s, C.PHASE_BEGIN, 7, 0xFF, v, v, v, v, v, v)])
        state.sensors[s].contacts = 2**32 - 1
    counters = SimpleNamespace(frames=10**12, lost_frames=10**12, damaged=10**12)
    n = _draw(state, SimpleNamespace(decoder=SimpleNamespace(counters=counters)), 1e6, False, 0)
    lines = capsys.readouterr().out.splitlines()
    assert n == len(lines) == 2 * sensors + 1
    assert max(map(len, lines)) <= 80, max(lines, key=len)
    assert f"{v * 1e-6:+.3f}" in lines[1] and f"{v * 1e-6:+.4f}" in lines[1]
    assert "SATURATED 0x3f" in lines[0] and "CONTACT" in lines[0]  # FLAG_SAT_MASK: 6 axes


def test_live_fits_80_columns_and_says_once_that_sim_runs_fast(cli):
    code, out, err = cli("live", "--port", "sim://ep2_sweep_sphere", "--duration", "0.3")
    assert code == 0, err
    assert out.count("sensor 2  |F|") >= 1 and max(map(len, out.splitlines())) <= 80
    note = "sim://ep2_sweep_sphere runs faster than real time; add ?realtime=1"
    assert err.count(note) == 1 and err.count("\n") == 1, err


def test_a_realtime_sim_port_is_not_flagged(cli):
    code, out, err = cli("live", "--port", "sim://press?realtime=1", "--duration", "0.3")
    assert code == 0 and err == "", err
    assert "sensor 0  |F|" in out


def _info(port, streaming=None):
    """The board's settings and flags, after starting or stopping it (``streaming``)."""
    from tactile.board.client import BoardClient
    from tactile.board.serial_port import open_port

    client = BoardClient(open_port(port), port)
    try:
        client.handshake(2.0)
        if streaming is not None:
            client.start() if streaming else client.stop()
        i = client.get_info()
        return (i.rate_hz, i.enter_threshold, i.exit_threshold, i.debounce, i.flags)
    finally:
        client.close()


@pytest.mark.parametrize("streaming", [False, True])
def test_live_leaves_the_board_streaming_or_stopped_as_it_found_it(cli, streaming):
    """INFO after ``live`` is INFO before it: the settings, and whether the board streams (a
    stopped board used to be left streaming)."""
    from tactile_sim.emulator.servers import serve

    with serve("ch5_plane", realtime=False) as server:
        before = _info(server.path, streaming)
        code, out, err = cli("live", "--port", server.path, "--duration", "0.3")
        after = _info(server.path)
    assert code == 0 and "sensor 0  |F|" in out, err
    assert bool(before[4] & C.CFG_STREAMING) is streaming and after == before
