"""The finger's weight and the gauges' drift: a tool identified from a few poses, and removed.

- ``tool``: ``Tool`` (mass, centre of mass, biases, each with its standard error; the sensor
  and calibration id it belongs to) and tool.json (``read_tool``, ``write_tool``,
  ``check_device``);
- ``fit``: ``identify(R_list, F_mean, T_mean, g)``, one linear least squares, and what poses
  it needs;
- ``tool_weight``: ``weight``, ``compensate``, ``tare_bias``: the tool's weight at an orientation,
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


def __getattr__(name):
    """The public names, imported on first use: ``import tactile.payload`` stays light, as
    ``tactile live`` imports its option module (``live_args``) before any tool is given."""
    if name not in __all__:  # (a submodule not yet imported: the import system's question)
        raise AttributeError(f"module 'tactile.payload' has no attribute {name!r}")
    from tactile.payload import compensator, drift, fit, orientation, tool, tool_weight

    for module in (compensator, drift, fit, orientation, tool, tool_weight):
        if name in module.__all__:
            return getattr(module, name)
    raise AttributeError(f"module 'tactile.payload' has no attribute {name!r}")
