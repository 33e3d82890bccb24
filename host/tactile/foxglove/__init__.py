"""Foxglove, live and recorded: one set of topics, written through two sinks.

- ``topics``: each topic's name, schema and encoding, declared once, and ``Topics``, which
  makes a topic's channel in a foxglove-sdk context when it is first logged; the sinks: the
  SDK's WebSocket server and its MCAP writer as sinks of a context, and the
  live view's one queue and thread (``Worker``);
- ``live``, ``live_scene``: ``tactile live``/``record --foxglove``, the 3D
  scene localised as frames arrive;
- ``scene``: the scene's messages (contacts, transforms, the EP2 patch);
- ``export_mcap``: ``tactile export --format mcap``, the recording through the same topics.

foxglove-sdk (the ``foxglove`` and ``export`` extras) is imported only when a server starts
or an export runs.  This package stands above the recording, the robot logs, localisation
and EP2, and nothing in the library imports it.
"""
