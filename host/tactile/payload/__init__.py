"""The finger's weight and the gauges' drift: a tool identified from a few poses, and removed.

- ``tool``: ``Tool`` (mass, centre of mass, biases, each with its standard error; the sensor
  and calibration id it belongs to) and tool.json (``read_tool``, ``write_tool``,
  ``check_device``); ``weight``, ``compensate``, ``tare_bias``: the tool's weight at an
  orientation, a wrench without it, the bias of a reading taken at any pose;
- ``fit``: ``identify(R_list, F_mean, T_mean, g)``, one linear least squares, and what
  poses it needs; readings averaged per hold of a pose log; ``identify_run(RUN, LOG)``, what
  ``tactile payload identify`` does (import it from there: it reads recordings, and the
  recording loader uses this package);
- ``drift``: the bias taken on the host and tracked between contacts (``BiasTracker``);
- ``compensator``: a stream of readings compensated and its contacts gated again on the host
  (``Compensator``), for record, derive, live, Foxglove and ``load_recording``;
- ``apply``: the compensator where the readings are: a live stream (``Following``), what
  ``record --payload`` asks of the board (``OnBoard``), a recording (``load_recording``);
  and the sensor's orientation at any reading's time, from a robot's log (``Orientations``);
- here: ``following``, the ``Following`` that ``tactile live``'s ``--payload`` and
  ``--pose-log`` ask for.

``tactile live`` imports this package to parse its options; NumPy and SciPy (the tool, the
orientations, the compensator) load only when a tool is given, so a plain ``tactile live``
stays as light as it was (tests/test_function_imports.py).

docs/rig.md says what the weight and the drift do, and how to identify a tool.
"""

from tactile.errors import InputError

__all__ = [
    "GRAVITY",
    "BiasTracker",
    "Compensator",
    "Gate",
    "Orientations",
    "Tool",
    "check_device",
    "compensate",
    "following",
    "identify",
    "read_tool",
    "tare_bias",
    "weight",
    "write_tool",
]


def __getattr__(name):
    """The public names, imported on first use: ``import tactile.payload`` stays light, as
    ``tactile live`` imports it for its options before any tool is given."""
    if name not in __all__:  # (a submodule not yet imported: the import system's question)
        raise AttributeError(f"module 'tactile.payload' has no attribute {name!r}")
    from tactile.payload import apply, compensator, drift, fit, tool

    for module in (apply, compensator, drift, fit, tool):
        if name in module.__all__:
            return getattr(module, name)
    raise AttributeError(f"module 'tactile.payload' has no attribute {name!r}")


def following(payload, pose_log, samples=None):
    """(``tactile.payload.apply.Following``, the robot log) of the tool files ``payload``
    through ``pose_log``, or (None, None) without tools; InputError (one line) for a tool
    without a log, a bad tool file or a log without orientations."""
    if not payload:
        return None, None
    if not pose_log:
        raise InputError("--payload: needs --pose-log (the sensor's orientation at each reading)")
    from tactile.payload.apply import Following, read_log
    from tactile.payload.tool import read_tool

    tools = [(path, read_tool(path)) for path in payload]
    log, orient = read_log(pose_log)
    return Following(tools, orient, log.clock, samples), log
