"""Sequence accounting across reboots and reorderings (PROTOCOL.md §3, issue 12)."""

from tactile.board.stream_decoder import StreamDecoder
from tactile_protocol import constants as C
from tactile_protocol.framing import encode_frame

INFO = (0, 1, 0, C.PROTOCOL_VERSION, b"FT6", 1, 1730, 7, 0, 0, 0, 1000, 1390000, 1112000, 3, 0x2B)


def hello(seq, ts, boot_id, mtype=C.MSG_HELLO):
    return encode_frame(mtype, seq, ts, INFO + (boot_id, 0x1234, 0, 0, 0, b"board-01"))


def sample(seq, ts):
    return encode_frame(C.MSG_SAMPLE, seq, ts, (0, 0, seq, 0, 0, 0, 0, 0))


def decode(data):
    decoder = StreamDecoder()
    return [m.seq for m in decoder.feed(data)], decoder.counters


def test_two_adjacent_frames_swapped_count_two_lost_and_one_out_of_order():
    """Nothing was lost; the rule stays simple because serial links do not reorder."""
    seqs, c = decode(sample(0, 0) + sample(2, 2000) + sample(1, 1000) + sample(3, 3000))
    assert seqs == [0, 2, 1, 3]
    assert (c.lost_frames, c.seq_gaps, c.out_of_order, c.reboots) == (2, 2, 1, 0)


def test_a_board_rebooted_behind_the_port_is_a_reboot_not_17191_lost_frames():
    """The issue's numbers: the old board's last frame was seq 48345; the new board's boot
    HELLO (seq 0) went to nobody, so the host's first frame of it is HELLO seq 1."""
    before = hello(48344, 10_000, 0xAAAA0001) + sample(48345, 48_000_000)
    _, c = decode(before + hello(1, 50_000, 0xBBBB0002) + sample(2, 51_000))
    assert (c.reboots, c.lost_frames, c.out_of_order) == (1, 0, 0)
    # the same boot id and a clock that went on: a port reopened, and the gap is loss
    _, c = decode(before + hello(1, 48_050_000, 0xAAAA0001))
    assert (c.reboots, c.lost_frames) == (0, 17191)


def test_info_carries_the_boot_id_too():
    _, c = decode(hello(0, 0, 1) + sample(1, 1000) + hello(7, 9000, 2, C.MSG_INFO))
    assert (c.reboots, c.lost_frames) == (1, 0)


def test_a_hello_whose_clock_went_back_is_a_reboot_even_with_the_same_id():
    _, c = decode(hello(0, 0, 5) + sample(1, 7_000_000) + hello(1, 50_000, 5) + sample(2, 51_000))
    assert (c.reboots, c.lost_frames) == (1, 0)


def test_a_clock_that_wrapped_is_not_a_reboot():
    """u32 microseconds wrap after 71.6 min: forward across the wrap is not backwards."""
    late = (1 << 32) - 1000
    _, c = decode(hello(0, 0, 5) + sample(1, late) + hello(3, 4000, 5))
    assert (c.reboots, c.lost_frames) == (0, 1)
