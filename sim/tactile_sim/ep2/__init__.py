"""EP2 simulation: height-field objects, three-finger sweeps, and the ch. 4-5 studies."""

from tactile_sim.ep2.objects import KINDS, make
from tactile_sim.ep2.sweep import sweep, write_csv

__all__ = ["KINDS", "make", "sweep", "write_csv"]
