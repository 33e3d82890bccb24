"""A recording: the session that reads a board into files, the files, their time base,
the loader and the exports.

- ``session``: ``tactile record``'s loop (reconnects, PINGs, stop conditions);
- ``files``: capture.bin, frames.csv, device.jsonl and meta.json as they are written;
- ``meta``, ``recover``, ``load``: meta.json, runs cut short, ``load_recording``;
- ``timebase``, ``timefit``, ``log_clock``, ``robot_log``: board time to host time, and
  the robot's pose log joined to it;
- ``derive``, ``export_mcap``, ``export_parquet``, ``export_target``: contacts and probes
  from a run, MCAP and Parquet exports, and where an export may write.
"""
