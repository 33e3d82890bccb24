"""A recording: the session that reads a board into files, the files, their time base,
the loader and the tabular export.

- ``session``: ``tactile record``'s loop (reconnects, PINGs, stop conditions), with
  ``run_state``: the same board after a reconnection, the run's own time and the host's
  stalls, its counts, and a pose log's end;
- ``layout``: frames.csv's row, the run's file names, whole lines, the reader; meta.json;
- ``files``: capture.bin, frames.csv, device.jsonl and meta.json as they are written;
- ``recover``, ``load``: runs cut short, ``load_recording``;
- ``timebase``, ``timefit``: board time to host time (a robot log in a host clock is joined
  to the frames through it);
- ``export``: the Parquet export, and where an export may write.

Beside it, not in it: the robot's logs (``tactile.logs``), contacts and probes derived from
a run (``tactile.commands.derive``), and Foxglove, live and as MCAP (``tactile.foxglove``).
"""
