"""The finger's weight and the gauges' drift: a tool identified from a few poses, and removed.

- ``tool``: ``Tool`` (mass, centre of mass, biases, each with its standard error; the sensor
  and calibration id it belongs to) and tool.json (``read_tool``, ``write_tool``,
  ``check_device``);
- ``fit``: ``identify(R_list, F_mean, T_mean, g)``, one linear least squares, and what poses
  it needs;
- ``weight``: ``weight``, ``compensate``, ``tare_bias``: the tool's weight at an orientation,
  a wrench without it, the bias of a reading taken at any pose;
- ``holds``, ``orientation``: readings averaged per hold of a pose log, and the sensor's
  orientation at any reading's time;
- ``drift``: the bias taken on the host and tracked between contacts (``BiasTracker``);
- ``compensator``: a stream of readings compensated and its contacts gated again on the host
  (``Compensator``), for record, derive, live, Foxglove and ``load_recording``;
- ``from_run``: ``identify_run(RUN, LOG)``, what ``tactile payload identify`` does (import it
  from there: it reads recordings, and the recording loader uses this package).

docs/rig.md says what the weight and the drift do, and how to identify a tool.
"""

from tactile.payload.compensator import Compensator, Gate
from tactile.payload.drift import BiasTracker
from tactile.payload.fit import identify
from tactile.payload.orientation import Orientations
from tactile.payload.tool import GRAVITY, Tool, check_device, read_tool, write_tool
from tactile.payload.weight import compensate, tare_bias, weight

__all__ = [
    "GRAVITY",
    "BiasTracker",
    "Compensator",
    "Gate",
    "Orientations",
    "Tool",
    "check_device",
    "compensate",
    "identify",
    "read_tool",
    "tare_bias",
    "weight",
    "write_tool",
]
