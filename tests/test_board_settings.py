"""The board-settings vocabulary (``tactile_protocol.settings``) and the host's check of
it (``tactile config``'s ``problem``) against the firmware's own rule, and ``tactile config``
refusing out-of-range values with their range, before any CONFIG is sent (issue 15)."""

import pytest
from hypothesis import given
from hypothesis import strategies as st

from tactile.cli.cmd_board import problem
from tactile.cli.main import main
from tactile_fw import settings as fw
from tactile_protocol import settings as bs

MAX_RATE = 1730


@given(
    st.integers(-5, 3000),
    st.floats(-2, 20, allow_nan=False),
    st.floats(-2, 20, allow_nan=False),
    st.integers(-3, 300),
)
def test_host_check_agrees_with_the_firmware_rule(rate, enter, exit_, debounce):
    host = problem(rate, enter, exit_, debounce, MAX_RATE)
    board = fw.check(rate, bs.to_counts(enter), bs.to_counts(exit_), debounce, 0, MAX_RATE)
    assert (host is None) == (board < 0), (host, board)
    if host is not None:  # the same field, named as the user typed it
        assert host.startswith(("--rate", "--enter", "--exit", "--debounce")[board])


def test_stream_names_round_trip_and_unknown_names_are_refused():
    for names in ([], ["samples"], ["contacts"], ["samples", "contacts"]):
        assert bs.stream_names(bs.stream_flags(names)) == names
    with pytest.raises(ValueError, match="unknown stream 'foo'"):
        bs.stream_flags(["foo"])


@pytest.mark.parametrize(
    "args, text",
    [
        (["--rate", "0"], "--rate: 0 Hz is out of range: 1.."),
        (["--enter", "-1"], "--enter: -1 N is out of range: 0 N or more"),
        (["--enter", "1", "--exit", "2"], "--exit: 2 N is out of range: 0..1 N"),
        (["--debounce", "256"], "--debounce: 256 is out of range: 1..255 readings"),
    ],
)
def test_config_refuses_with_the_range_and_exit_2(args, text, capsys):
    assert main(["config", "--port", "sim://press", *args]) == 2
    err = capsys.readouterr().err.strip()
    assert text in err and len(err.splitlines()) == 1, err


def test_one_vocabulary_shared_by_the_emulator_and_the_host():
    """The scene schema's names and defaults are the module's; defaults read as typed."""
    from tactile_sim.emulator import scene_schema

    assert scene_schema.STREAMS is bs.STREAMS and scene_schema.GATES is bs.GATES
    board = scene_schema.BOARD
    assert board["enter_threshold_N"].default == bs.DEFAULTS["enter_N"] == 1.39
    assert board["exit_threshold_N"].default == bs.DEFAULTS["exit_N"] == 1.112  # not 1.11199..
    assert board["debounce"].default == bs.DEFAULTS["debounce"] == fw.DEFAULT_DEBOUNCE
    assert board["rate_hz"].default == bs.DEFAULTS["rate_hz"] == fw.DEFAULT_RATE_HZ


def test_gate_and_flags_round_trip():
    for gate in bs.GATES:
        for streams in ([], ["contacts"], ["samples", "contacts"]):
            flags = bs.config_flags(gate, streams, autostart=True)
            assert bs.gate_name(flags) == gate and bs.stream_names(flags) == streams
    assert bs.wrench_si(1_390_000, -1, 0, 10_000, 0, -(2**31)) == (
        1.39, -1e-06, 0.0, 0.01, 0.0, -2147.483648
    )  # fmt: skip
