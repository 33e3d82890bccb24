"""The result of localising contacts from F/T readings, and its status codes.

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
"""

from typing import NamedTuple

import numpy as np

__all__ = ["Contact", "STATUS", "OK", "NO_CONTACT", "NEAR_MISS", "MISS", "OFF_PROBE", "DEGENERATE"]

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
