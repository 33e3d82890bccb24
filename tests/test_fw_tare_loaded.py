"""TARE refuses a loaded sensor (NAK_LOADED, detail = the sensor) and keeps every bias.

A bias taken under load shifts every later reading by that load: the EP2 sweep's fingers
then read -5 N once they let go, and the gate never closes (issue 14).  Identity
calibration marked present: 1 count = 1 uN, so a code of 2,000,000 on gauge 0 is fx = 2 N,
above the default 1.39 N gate.
"""

import pytest
from fw_rig import Rig, name, replies

from tactile_fw import calibration
from tactile_protocol.constants import (
    CFG_STREAM_CONTACTS,
    CFG_STREAM_SAMPLES,
    CMD_START,
    CMD_TARE,
    NAK_LOADED,
)

LOADED = (2_000_000, 0, 0, 0, 0, 0)  # fx = 2 N
OFFSET = (300_000, -200_000, 100_000, 50, 60, 70)  # an unloaded sensor's own offset (0.36 N)


def _rig(n=1, calibrated=True):
    rig = Rig(n=n)
    rig.board.boot()
    if calibrated:
        for i in range(n):
            rig.board.cals[i] = calibration.Calibration(calibration.identity(), 7)
    rig.frames()
    return rig


def _answer(rig, seq, us=200_000):
    rig.run(us)
    (reply,) = replies(rig.frames(), seq)
    return name(reply), reply[3]


def _biases(rig):
    return [c.bias_counts() for c in rig.board.cals]


def test_an_unloaded_sensor_is_tared_to_its_offset():
    rig = _rig()
    rig.set_codes(0, OFFSET)
    kind, _ = _answer(rig, rig.send(CMD_TARE, (0, 20)))
    assert kind == "ACK" and rig.board.cals[0].bias_counts() == [float(c) for c in OFFSET]


def test_tare_of_a_loaded_idle_board_is_refused_by_its_own_samples():
    rig = _rig()
    rig.set_codes(0, LOADED)
    before = _biases(rig)
    seq = rig.send(CMD_TARE, (0xFF, 50))
    kind, values = _answer(rig, seq)
    assert kind == "NAK" and values == (CMD_TARE, seq, NAK_LOADED, 0)
    assert _biases(rig) == before and rig.board.tare_mask == 0


def test_tare_while_the_gate_has_a_contact_is_refused_at_once():
    rig = _rig()
    rig.config(rate=1000, enter=1_390_000, exit_=1_112_000, debounce=3, flags=CFG_STREAM_CONTACTS)
    rig.command(CMD_START)
    rig.set_codes(0, LOADED)
    rig.run(10_000)
    assert rig.board.gates[0].in_contact
    seq = rig.send(CMD_TARE, (0, 50))
    rig.run(100)  # one poll: the answer does not wait for samples
    (reply,) = replies(rig.frames(), seq)
    assert reply[3] == (CMD_TARE, seq, NAK_LOADED, 0)
    assert rig.board.cals[0].bias_counts() == [0.0] * 6


def test_the_loaded_sensor_is_named_and_no_bias_changes():
    rig = _rig(n=3)
    for i in range(3):
        rig.set_codes(i, OFFSET)
    rig.set_codes(2, lambda t: LOADED if t > 30_000 else OFFSET)  # loaded mid-tare
    seq = rig.send(CMD_TARE, (0xFF, 60))
    kind, values = _answer(rig, seq)
    assert kind == "NAK" and values == (CMD_TARE, seq, NAK_LOADED, 2)
    assert _biases(rig) == [[0.0] * 6] * 3  # sensors 0 and 1 were not half-tared


def test_a_spike_shorter_than_the_debounce_does_not_refuse():
    rig = _rig()
    rig.config(rate=1000, enter=1_390_000, exit_=1_112_000, debounce=3, flags=CFG_STREAM_SAMPLES)
    rig.set_codes(0, lambda t: LOADED if 10_000 <= t < 12_000 else OFFSET)  # two samples
    kind, _ = _answer(rig, rig.send(CMD_TARE, (0, 40)))
    assert kind == "ACK"


@pytest.mark.parametrize("why", ["uncalibrated", "no gate"])
def test_not_checked_without_calibration_or_gate(why):
    rig = _rig(calibrated=why != "uncalibrated")
    if why == "no gate":
        rig.config(rate=1000, enter=0, exit_=0, debounce=1, flags=CFG_STREAM_CONTACTS)
    rig.set_codes(0, LOADED)
    kind, _ = _answer(rig, rig.send(CMD_TARE, (0, 20)))
    assert kind == "ACK" and rig.board.cals[0].bias_counts()[0] == float(LOADED[0])


def test_after_a_refusal_the_next_tare_works_once_unloaded():
    rig = _rig()
    rig.set_codes(0, LOADED)
    assert _answer(rig, rig.send(CMD_TARE, (0, 20)))[0] == "NAK"
    rig.set_codes(0, OFFSET)
    assert _answer(rig, rig.send(CMD_TARE, (0, 20)))[0] == "ACK"
    assert rig.board.cals[0].bias_counts() == [float(c) for c in OFFSET]
