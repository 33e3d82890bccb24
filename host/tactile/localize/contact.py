"""The result of localising contacts from F/T readings and its status codes; the line of
action of a force; which CONTACT frames are readings.

Every localiser returns a ``Contact`` of arrays with one row per reading, never NaN:

- ``point`` (..., 3): the contact point, in the frame of the wrench (the sensor frame);
- ``normal`` (..., 3): the OBJECT's outward unit normal at the contact, i.e. pointing from the
  object toward the probe (the EP2 contacts-CSV convention, §5.1.2).  The probe's own outward
  normal (its Gauss map at the contact, §5.1.1) is ``-normal``;
- ``status`` (...,) int8, one of ``STATUS`` below; only ``usable`` rows are contacts;
- ``residual`` (...,): distance by which the line of action misses the probe (0 on a hit);
- ``friction`` (...,): angle (rad, in [0, pi/2]) between the force and the normal; 0 for a
  frictionless contact, atan(mu) on the edge of a Coulomb cone;
- ``force`` (...,): the normal component of the force (what presses the probe onto the object).

Rows that are not contacts (status ``no_contact``) hold zeros.

**The line of action** of a force from a force/moment reading (§5.1.1, principle of
transmissibility; Tsujimura & Yabuta, §3.3.3).

A point force F applied at p gives the moment M = (p - O) x F about the sensor origin O, so p
lies on the line {p : (p - O) x F = M}.  Its point closest to O is

    p0 = O + (F x M) / |F|^2,

since (F x M) x F = M |F|^2 - F (F . M) and F . M = 0 for a point force.  A measured M has a
component along F too (noise, or a torque the contact can transmit, as with a soft finger);
it cannot move the line and is reported as ``twist = M . F/|F|``.

**Which CONTACT frames are readings** (§5.1), as arrays for localisation.

§5.1 takes a sample "when the x-y force exceeds 5 units", two per probed point.  ``Readings``
is that rule one frame at a time, so that a live view localising frames as they arrive keeps
what contacts.csv keeps (``tactile.commands.derive``); ``contact_frames`` applies it to a
list of decoded frames and returns the times, sensors and wrenches (N, N*m) that
``tactile.localize.posed`` places in the world.
"""

from typing import NamedTuple

import numpy as np

from tactile_protocol import constants as C
from tactile_protocol import settings as board_settings

__all__ = [
    "Contact",
    "STATUS",
    "OK",
    "NO_CONTACT",
    "NEAR_MISS",
    "MISS",
    "OFF_PROBE",
    "DEGENERATE",
    "line_of_action",
    "entry_root",
    "Readings",
    "contact_frames",
    "SCARA_PER_CONTACT",
]

OK = 0  # the line of action meets the probe inside its usable surface
NO_CONTACT = 1  # force below the gate threshold: not a contact (§5.1, "5 units")
NEAR_MISS = 2  # the line misses the probe by <= tol (noise): closest point, usable, flagged
MISS = 3  # the line misses the probe by > tol: closest point, not usable
OFF_PROBE = 4  # the point lies outside the probe's usable surface (beyond the wheel's rim/arc)
DEGENERATE = 5  # the data cannot locate a point (e.g. force along the wheel's axis)
STATUS = ("ok", "no_contact", "near_miss", "miss", "off_probe", "degenerate")


class Contact(NamedTuple):
    point: np.ndarray
    normal: np.ndarray
    status: np.ndarray
    residual: np.ndarray
    friction: np.ndarray
    force: np.ndarray

    @property
    def usable(self):
        """Boolean mask of the rows that are contacts (``ok`` or ``near_miss``)."""
        return (self.status == OK) | (self.status == NEAR_MISS)

    def status_names(self):
        """The status of each row as text (flattened)."""
        return [STATUS[s] for s in np.ravel(self.status)]

    def counts(self):
        """{status name: number of rows}, only for statuses that occur."""
        values, n = np.unique(self.status, return_counts=True)
        return {STATUS[v]: int(k) for v, k in zip(values, n)}


def line_of_action(force, moment, origin=(0.0, 0.0, 0.0)):
    """Return (p0, u, norm, twist): closest point to ``origin``, unit direction of F, |F| and
    the moment component along F.  Rows with F = 0 give u = 0, p0 = origin (gate them first)."""
    F = np.asarray(force, dtype=float)
    M = np.asarray(moment, dtype=float)
    norm = np.linalg.norm(F, axis=-1)
    safe = np.where(norm > 0.0, norm, 1.0)[..., None]
    u = F / safe
    p0 = np.asarray(origin, dtype=float) + np.cross(u, M) / safe
    twist = np.einsum("...i,...i->...", M, u)
    return p0, u, norm, twist


def entry_root(a, b, c):
    """Smaller root of a t^2 + 2 b t + c = 0 (a > 0), and the discriminant b^2 - a c.

    The smaller root is where a line running along +F first meets a convex surface: the
    point where the force presses INTO the probe.  Computed without cancellation (the
    product of the roots is c/a).  Where the discriminant is negative the root is the
    line's closest approach, -b/a.
    """
    disc = b * b - a * c
    root = np.sqrt(np.maximum(disc, 0.0))
    # b > 0: -b - root has no cancellation.  b <= 0: the larger root (-b + root)/a is stable
    # and the smaller one is c / (-b + root).
    big = -b + root
    safe_big = np.where((b <= 0.0) & (big != 0.0), big, 1.0)  # only the branch that is used
    t = np.where(b > 0.0, (-b - root) / a, np.where(big != 0.0, c / safe_big, 0.0))
    t = np.where(disc >= 0.0, t, -b / a)
    return t, disc


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
