"""Contacts gated again on the compensated wrench (tactile.payload.compensator): the weight
makes none, and hides none."""

import numpy as np
from conftest import load_bench

from tactile.board.stream_decoder import decode_bytes
from tactile.payload import Compensator, Orientations, Tool
from tactile.payload.apply import ANY
from tactile_protocol import constants as C

synth = load_bench("payload_synth")
RATE = 500
HEAVY = Tool(0.1, [0.03, 0.0, 0.0])  # 100 g, its centre of mass 30 mm out
DEVICE = {**synth.DEVICE, "gate": "3d"}  # enter 1.39 N, exit 1.112 N, debounce 3


def turn(rpy=((0, 0, 0), (180, 0, 0)), hold_s=2.0):
    return synth.Poses(rpy, hold_s=hold_s, move_s=1.0)


def frames(poses, tool, device=DEVICE, press=None, sd=0.02, seed=0):
    """Decoded frames of a board that tared at the first pose, and the poses' orientations."""
    t = np.arange(0.0, poses.duration_s, 1.0 / RATE)
    contact = None if press is None else press(t)
    W = synth.readings(t, poses.at(t), tool.mass_kg, tool.com_m, 0.0, 0.0,
                       np.r_[[sd] * 3, [sd / 20] * 3], contact, seed)  # fmt: skip
    msgs, _ = decode_bytes(synth.board_frames(t, W, device, tare_at=0.2))
    orient = Orientations({ANY: (np.rint(poses.t0 * 1e6), np.rint(poses.t1 * 1e6), poses.rot)})
    return msgs, orient


def contacts(msgs, sensor=0):
    return {m.contact_id for m in msgs if m.type_code == C.MSG_CONTACT and m.sensor == sensor}


def compensated(msgs, orient, tool, device=DEVICE):
    comp = Compensator(tool, orient, device)
    rows = [m for m in msgs if m.type_code in (C.MSG_SAMPLE, C.MSG_CONTACT)]
    W = np.array([(m.fx, m.fy, m.fz, m.tx, m.ty, m.tz) for m in rows]) * 1e-6
    t = np.array([m.timestamp_us for m in rows])
    comp.prime(np.zeros(len(rows), int), [m.type_code == C.MSG_SAMPLE for m in rows], t, W)
    out, index = comp.messages(msgs)
    return out, index, comp


def test_a_100_g_tool_turned_over_makes_contacts_on_the_board_and_none_on_the_host():
    msgs, orient = frames(turn(), HEAVY)
    assert len(contacts(msgs)) >= 1  # the board's gate sees 2 N of weight turned over
    out, index, comp = compensated(msgs, orient, HEAVY)
    assert contacts(out) == set() and comp.report()[0]["contacts"] == 0
    samples = np.array([(m.fx, m.fy, m.fz) for m in out if m.type_code == C.MSG_SAMPLE])
    assert np.abs(samples * 1e-6).max() < 0.2  # 2 N of weight gone, turning included


def test_a_press_the_weight_hides_from_the_board_is_a_contact_on_the_host():
    """A 60 g tool tared upright and turned over: its weight moves 1.18 N (under the 1.39 N
    gate) and pulls against a 2 N press, so the board sees 0.82 N and the host 2 N."""
    poses, tool = turn(), Tool(0.06, [0.03, 0.0, 0.0])

    def press(t):
        out = np.zeros((len(t), 6))
        out[(t > poses.t0[1] + 0.5) & (t < poses.t1[1] - 0.5), 2] = -2.0
        return out

    msgs, orient = frames(poses, tool, press=press)
    assert contacts(msgs) == set()
    out, index, _ = compensated(msgs, orient, tool)
    assert len(contacts(out)) == 1
    force = [m.fz * 1e-6 for m in out if m.type_code == C.MSG_CONTACT and m.phase == C.PHASE_IN]
    assert abs(np.median(force) + 2.0) < 0.02


def test_frames_keep_their_order_and_other_sensors_pass_untouched():
    msgs, orient = frames(turn(), HEAVY)
    other = [m._replace(sensor=1) for m in msgs if m.type_code == C.MSG_SAMPLE][:50]
    out, index, _ = compensated(other + msgs, orient, HEAVY)
    assert out[:50] == other and list(index[:50]) == list(range(50))
    assert np.all(np.diff(index) >= 0)
    stamps = [m.timestamp_us for m in out if m.type_code == C.MSG_SAMPLE and m.sensor == 0]
    assert len(stamps) == sum(m.type_code == C.MSG_SAMPLE for m in msgs)


def test_a_contacts_only_stream_keeps_only_the_boards_true_contacts():
    """Without SAMPLE frames the host can only drop the board's contacts: the weight's are
    dropped, and no bias can be taken (the tool's identified one is used)."""
    device = {**DEVICE, "streams": ["contacts"]}
    msgs, orient = frames(turn(), HEAVY, device)
    assert contacts(msgs) and not any(m.type_code == C.MSG_SAMPLE for m in msgs)
    out, _, comp = compensated(msgs, orient, HEAVY, device)
    assert contacts(out) == set()
    assert comp.report()[0]["bias_from"] == "the tool's identified bias"
