"""The robot's logs beside a recording, as files: their formats, below every reader and writer.

- ``robot_log``: the pose, SCARA-joint and probe logs (columns, units line, comment tags, the
  writer); the simulator's robots write through it;
- ``tags``: the ``# tag:`` lines before a log's header, and which clock its times
  are in and when it ends;
- ``read``: the readers, a ``PoseLog`` (``tactile.localize`` places contacts in
  the world through it) and a ``ProbeLog`` (``tactile.ep1.probes`` makes probes of it).

Nothing here imports the rest of the host but its vocabulary (``tactile.units``,
``tactile.errors``) and its file readers (``tactile.files``).
"""
