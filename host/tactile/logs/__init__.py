"""The robot's logs beside a recording, as files: their formats, below every reader and writer.

``robot_log``: the pose, SCARA-joint and probe logs (columns, units line, comment tags, the
writer).  The simulator's robots write them; the host's localisation (``tactile.localize``),
EP1 (``tactile.ep1``) and the recording's clock join (``tactile.recording.log_clock``) read
them.  Nothing here imports the rest of the host but ``tactile.units``.
"""
