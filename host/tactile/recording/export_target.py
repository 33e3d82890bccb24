"""Where ``tactile export`` may write, checked before any work is done.

- Each output is a new file in an existing folder or a regular file
  (``tactile.files.atomic.check_target``): never a directory, a device (``/dev/null``
  included), a FIFO or a socket (exit 2).
- Never a file of the run being exported.  Paths are compared once symlinks are resolved,
  so a link to capture.bin is capture.bin.  Inside the run folder an export may name a new
  file, or an earlier export of its own format (a name ending ``.mcap`` or ``.parquet``),
  but never the recording's own files (``RUN_FILES``, even before they exist) nor any other
  file already there (exit 2).
- An export into the run folder holds the run's lock (``tactile.files.folder_lock``) while
  it reads and writes, so it is refused (exit 5) while a ``record`` writes there, and a
  ``record`` is refused while it writes.
"""

import os

from tactile.errors import InputError
from tactile.files.atomic import check_target
from tactile.recording.frames import CAPTURE, DEVICE, FRAMES, META

__all__ = ["RUN_FILES", "check_outputs"]

RUN_FILES = (CAPTURE, FRAMES, DEVICE, META, "contacts.csv", "probes.csv")


def _inside(folder, real):
    return os.path.commonpath([folder, real]) == folder


def check_outputs(run_dir, outs, suffix):
    """Check the outputs ``outs`` of an export of ``run_dir`` whose files end in
    ``suffix`` (``.mcap``); True when one lies inside the run (the export then locks it);
    ``InputError`` (exit 2) naming the first output refused."""
    run = os.path.realpath(run_dir)
    own = {os.path.join(run, n) for n in RUN_FILES}
    own |= {os.path.realpath(p) for p in own}
    inside = False
    for out in outs:
        real = check_target(out)
        if not _inside(run, real):
            continue
        inside = True
        if real in own or (os.path.lexists(real) and not real.endswith(suffix)):
            raise InputError(
                f"{out}: a file of the run being exported ({run_dir}); export never writes"
                " over a recording's files (choose another -o)"
            )
    return inside
