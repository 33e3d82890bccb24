"""EP2 simulation: height-field objects, contact layouts and three-finger sweeps (the ch. 4-5
studies and test cases: ``tactile_studies.ep2``)."""

from tactile_sim.ep2.objects import KINDS, make
from tactile_sim.ep2.sweep import sweep, write_csv, write_rows

__all__ = ["KINDS", "make", "sweep", "write_csv", "write_rows"]
