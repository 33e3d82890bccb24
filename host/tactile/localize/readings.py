"""Which CONTACT frames are readings (§5.1), as arrays for localisation.

§5.1 takes a sample "when the x-y force exceeds 5 units", two per probed point.  ``Readings``
is that rule one frame at a time, so that a live view localising frames as they arrive keeps
what contacts.csv keeps (``tactile.commands.derive``); ``contact_frames`` applies it to a
list of decoded frames and returns the times, sensors and wrenches (N, N*m) that
``tactile.localize.posed`` places in the world.
"""

import numpy as np

from tactile_protocol import constants as C
from tactile_protocol import settings as board_settings

__all__ = ["Readings", "contact_frames", "SCARA_PER_CONTACT"]

SCARA_PER_CONTACT = 2  # §5.1: two samples per probed point


class Readings:
    """``contact_frames``'s rule one frame at a time (``take``)."""

    def __init__(self, per_contact=None, above_N=None, gate="xy"):
        self.per_contact, self.gate, self.taken = per_contact, gate, {}
        self.floor = None if above_N is None else above_N * board_settings.COUNTS_PER_N

    @classmethod
    def for_log(cls, kind, per_contact, threshold, gate):
        """The rule for a pose log of ``kind`` ("scara": §5.1's, the first
        ``SCARA_PER_CONTACT`` readings above the gate; "pose": every reading)."""
        if kind == "scara":
            n = SCARA_PER_CONTACT if per_contact is None else per_contact
            return cls(n, threshold, gate)
        return cls(per_contact)

    def take(self, m):
        """Whether the CONTACT frame ``m`` is a reading (BEGIN or IN, above the floor, within
        the first ``per_contact`` of its contact)."""
        if m.type_code != C.MSG_CONTACT or m.phase == C.PHASE_END:
            return False
        if self.floor is not None:
            fz2 = m.fz * m.fz if self.gate == "3d" else 0
            if m.fx * m.fx + m.fy * m.fy + fz2 <= self.floor * self.floor:
                return False
        key = (m.sensor, m.contact_id)
        if m.phase == C.PHASE_BEGIN or (self.floor is not None and key not in self.taken):
            self.taken[key] = 0
        k = self.taken.get(key)
        if k is None or (self.per_contact is not None and k >= self.per_contact):
            return False
        self.taken[key] = k + 1
        return True


def contact_frames(messages, per_contact=None, above_N=None, gate="xy", times=None, rule=None):
    """CONTACT readings (BEGIN and IN; END is already outside the gate).

    ``per_contact``: keep only the first N readings of each contact (per sensor);
    ``above_N``: only readings whose gated force (x-y or 3-D magnitude) exceeds it, as
    §5.1 takes a sample "when the x-y force exceeds 5 units" (inside a contact, the
    firmware's hysteresis lets the force dip to the exit threshold).
    ``times`` (one int64 us per message) replaces the board's stamps (a host clock's).
    ``rule``: a ``Readings`` that replaces the three above.
    Returns (times_us int64, sensor, wrench (n, 6) in N and N*m, contact ids).
    """
    rule = rule or Readings(per_contact, above_N, gate)
    rows = [
        (i, m.sensor, m.contact_id, m.fx, m.fy, m.fz, m.tx, m.ty, m.tz)
        for i, m in enumerate(messages)
        if rule.take(m)
    ]
    a = np.array(rows, dtype=np.int64).reshape(-1, 9)
    wrench = a[:, 3:] * np.array(board_settings.WRENCH_LSB)
    index = a[:, 0]
    if times is None:
        t = np.array([messages[i].timestamp_us for i in index], dtype=np.int64)
    else:
        t = np.asarray(times, dtype=np.int64)[index]
    return t, a[:, 1].astype(int), wrench, a[:, 2].astype(int)
