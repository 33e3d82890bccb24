"""Contact gate (thesis §5.1): hysteresis and debounce on synthetic force profiles."""

import random

import pytest
from fw_rig import Rig, name

from tactile_fw.gate import BEGIN, END, IN, NONE, ContactGate

ENTER = 5_000
EXIT = 4_000


def run(gate, profile):
    """Feed (fx, fy, fz) samples; return the list of (index, event) for BEGIN/END."""
    events = []
    for k, (fx, fy, fz) in enumerate(profile):
        e = gate.update(fx, fy, fz)
        if e in (BEGIN, END):
            events.append((k, e))
    return events


def test_step_begins_and_ends_after_debounce():
    g = ContactGate(ENTER, EXIT, 3)
    profile = [(0, 0, 0)] * 10 + [(6_000, 0, 0)] * 20 + [(0, 0, 0)] * 10
    assert run(g, profile) == [(12, BEGIN), (32, END)]
    assert g.contact_id == 1


def test_exit_is_strict_and_enter_is_strict():
    g = ContactGate(ENTER, EXIT, 1)
    assert g.update(ENTER, 0, 0) == NONE  # |F| == enter: not above
    assert g.update(ENTER + 1, 0, 0) == BEGIN
    assert g.update(EXIT, 0, 0) == IN  # |F| == exit: not below
    assert g.update(EXIT - 1, 0, 0) == END


def test_ramp_crosses_once_each_way():
    g = ContactGate(ENTER, EXIT, 2)
    up = [(f, 0, 0) for f in range(0, 10_001, 100)]
    down = [(f, 0, 0) for f in range(10_000, -1, -100)]
    events = run(g, up + down)
    # enter: first value > 5000 is 5100 (index 51), debounce 2 -> 52
    # exit: first value < 4000 on the way down is 3900 (index 101 + 61), debounce -> +1
    assert events == [(52, BEGIN), (101 + 62, END)]


@pytest.mark.parametrize("seed", range(5))
def test_noise_around_threshold_does_not_chatter(seed):
    """Noise of +-400 about either level: one BEGIN and one END per contact."""
    rng = random.Random(seed)
    g = ContactGate(ENTER, EXIT, 3)
    profile = []
    for level in (EXIT - 300, ENTER + 100, (ENTER + EXIT) // 2, ENTER + 400, EXIT - 800):
        profile += [(level + rng.uniform(-400, 400), 0, 0) for _ in range(200)]
    events = run(g, profile)
    assert [e for _, e in events] == [BEGIN, END]
    assert 202 <= events[0][0] < 260  # 3 in a row above enter; P(above) = 5/8
    assert events[1][0] == 802  # the last level is always below exit


def test_single_threshold_would_chatter_on_the_same_noise():
    """Reference: without hysteresis or debounce, the noise above makes many contacts."""
    rng = random.Random(0)
    g = ContactGate(ENTER, ENTER, 1)
    profile = [(ENTER + rng.uniform(-400, 400), 0, 0) for _ in range(1000)]
    assert len(run(g, profile)) > 100


def test_spikes_shorter_than_debounce_are_ignored():
    g = ContactGate(ENTER, EXIT, 3)
    profile = ([(0, 0, 0)] * 5 + [(9_000, 0, 0)] * 2) * 10
    assert run(g, profile) == []
    profile = [(9_000, 0, 0)] * 10 + ([(9_000, 0, 0)] * 5 + [(0, 0, 0)] * 2) * 10
    g = ContactGate(ENTER, EXIT, 3)
    assert run(g, profile) == [(2, BEGIN)]


def test_xy_magnitude_versus_3d():
    """The thesis gates on |F| in the x-y plane; fz alone opens only the 3-D gate."""
    xy = ContactGate(ENTER, EXIT, 1)
    d3 = ContactGate(ENTER, EXIT, 1, three_d=True)
    assert xy.update(0, 0, 9_000) == NONE
    assert d3.update(0, 0, 9_000) == BEGIN
    # 3-4-5: |(3000, 4000)| = 5000 is not above ENTER; 5000.1 is.
    assert xy.update(3_000, 4_000, 0) == NONE
    assert xy.update(3_000, 4_001, 0) == BEGIN


def test_bad_levels_are_refused():
    with pytest.raises(ValueError):
        ContactGate(4_000, 5_000, 1)
    with pytest.raises(ValueError):
        ContactGate(5_000, 4_000, 0)


def test_board_emits_begin_in_end_with_contact_ids():
    rig = Rig()
    rig.board.boot()
    rig.config(rate=1000, enter=1_000_000, exit_=500_000, debounce=2, flags=0x02)
    rig.command(0x44)  # START

    def profile(t):  # a 20 ms press at 1.5 N along x, then release; twice
        f = 1_500_000 if (50_000 <= t % 100_000 < 70_000) else 0
        return (f, 0, 0, 0, 0, 0)

    rig.set_codes(0, profile)
    rig.run(200_000)
    contacts = [f for f in rig.frames() if name(f) == "CONTACT"]
    phases = [f[3][1] for f in contacts]
    begins = [f for f in contacts if f[3][1] == 0]
    ends = [f for f in contacts if f[3][1] == 2]
    assert len(begins) == 2 and len(ends) == 2
    assert [f[3][2] for f in begins] == [1, 2]
    assert phases.count(1) == 2 * 19  # 20 samples above: BEGIN on the 2nd, 18 IN; END +1
    for f in begins:  # begins on the second sample above enter (debounce 2)
        assert f[2] % 100_000 in range(51_000, 53_001)
    for f in contacts:
        assert f[3][4] in (0, 1_500_000)


@pytest.mark.parametrize("three_d", [False, True])
def test_integer_bounds_agree_with_the_exact_magnitude(three_d):
    """The fast integer path gives the same answer as the squared magnitude everywhere."""
    rng = random.Random(3)
    g = ContactGate(ENTER, EXIT, 1, three_d)
    for _ in range(20_000):
        f = [rng.choice((1, -1)) * rng.randint(0, 7_000) for _ in range(3)]
        if rng.random() < 0.1:  # exact ties on the level
            f = [ENTER, 0, 0] if rng.random() < 0.5 else [3_000, -4_000, 0]
        m2 = f[0] ** 2 + f[1] ** 2 + (f[2] ** 2 if three_d else 0)
        want = (m2 > ENTER**2) - (m2 < ENTER**2)
        assert g._cmp(f[0], f[1], f[2], ENTER, float(ENTER) ** 2) == want, f
