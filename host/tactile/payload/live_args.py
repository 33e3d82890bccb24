"""``--payload`` and ``--pose-log`` for ``tactile live``: the ``Following`` they ask for.

``tactile live`` imports this module to parse its options; NumPy and SciPy (the tool, the
orientations, the compensator) load only when a tool is given, so a plain ``tactile live``
stays as light as it was (tests/test_function_imports.py).
"""

from tactile.errors import InputError

__all__ = ["following"]


def following(payload, pose_log, samples=None):
    """(``tactile.payload.live.Following``, the robot log) of the tool files ``payload``
    through ``pose_log``, or (None, None) without tools; InputError (one line) for a tool
    without a log, a bad tool file or a log without orientations."""
    if not payload:
        return None, None
    if not pose_log:
        raise InputError("--payload: needs --pose-log (the sensor's orientation at each reading)")
    from tactile.payload.live import Following
    from tactile.payload.orientation import read_log
    from tactile.payload.tool import read_tool

    tools = [(path, read_tool(path)) for path in payload]
    log, orient = read_log(pose_log)
    return Following(tools, orient, log.clock, samples), log
