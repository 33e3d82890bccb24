"""Steady-state sampling allocates nothing that stays (CPython tracemalloc proxy)."""

import math
import tracemalloc

import pytest
from fw_rig import Rig

from tactile_protocol.constants import CFG_STREAM_CONTACTS, CFG_STREAM_SAMPLES, CMD_START


class DiscardLink:
    """A host that reads everything at once."""

    def readinto(self, buf):
        return None

    def write(self, mv):
        return len(mv)

    def opened(self):
        return False


@pytest.mark.slow
def test_ten_thousand_samples_leave_no_allocation_behind():
    rig = Rig()
    rig.board.boot()
    rig.config(
        rate=1000,
        enter=1_000_000,
        exit_=500_000,
        debounce=2,
        flags=CFG_STREAM_SAMPLES | CFG_STREAM_CONTACTS,
    )
    rig.command(CMD_START)
    rig.board.link = rig.board.tx.link = DiscardLink()

    def press(t):  # contacts begin and end all the time: every code path runs
        f = int(2_000_000 * (1 + math.sin(t * 2e-4)))
        return (f, -f // 2, 1000, 20, -30, 40)

    rig.set_codes(0, press)
    rig.run(200_000)  # warm up: every buffer allocated, every branch taken
    filters = [
        tracemalloc.Filter(True, "*tactile_fw*"),
        tracemalloc.Filter(True, "*tactile_protocol*"),
    ]
    tracemalloc.start()
    snaps = [tracemalloc.take_snapshot().filter_traces(filters)]
    counts = [rig.board.samples]
    for _ in range(2):
        rig.run(5_000_000, step=250)
        snaps.append(tracemalloc.take_snapshot().filter_traces(filters))
        counts.append(rig.board.samples)
    tracemalloc.stop()
    assert [b - a for a, b in zip(counts, counts[1:])] == [5_000, 5_000]
    for a, b in zip(snaps, snaps[1:]):
        stats = b.compare_to(a, "filename")
        size = sum(d.size_diff for d in stats)
        blocks = sum(d.count_diff for d in stats)
        # What may differ is which int objects hold the current state (the latest counts,
        # F/T values, tick times: a few dozen), never anything per sample.
        assert size <= 1024 and blocks <= 40, "\n".join(map(str, stats))
