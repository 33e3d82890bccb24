"""Digests of what the shipped scenes produce, to hold them bit for bit across model changes.

Per scene (MicroPython core, a fixed boot id and board id): the bytes the board sends in the
first ``SECONDS`` of simulated time with a host reading (HELLO, then frames), the six gauge
counts of every sensor at ``GAUGE_TIMES`` instants across the motion, and the robot log the
scene writes, if any.  ``python tests/scene_golden.py`` prints them as JSON;
``tests/data/scene_golden.json`` holds them as computed on main (a tree of ``git archive
main`` with its source folders on PYTHONPATH), the code without the tool's weight and the
gauges' drift.  A change on main to what the firmware sends (a new HELLO field) means
recomputing them there.
"""

import hashlib
import json
import pathlib
import sys
import tempfile

import numpy as np

from tactile_sim.emulator import load_scene
from tactile_sim.emulator.device import EmulatedBoard
from tactile_sim.emulator.scene import SCENE_DIR

SECONDS = 4.0
GAUGE_TIMES = 400
BOOT_ID, BOARD_ID = 0x1234ABCD, b"GOLDEN38"
GOLDEN = pathlib.Path(__file__).with_name("data") / "scene_golden.json"
# the scenes on the code before the weight and the drift (the newer ones have no past)
SCENES = ("ch5_concave", "ch5_convex", "ch5_plane", "ep1_roll", "ep2_sweep_saddle",
          "ep2_sweep_sphere", "press")  # fmt: skip


def _sha(data):
    return hashlib.sha256(data).hexdigest()


def frames_digest(scene):
    board = EmulatedBoard(scene, boot_id=BOOT_ID, core="python", board_id=BOARD_ID)
    board.host_opened()
    out = bytearray()
    end = round(SECONDS * 1e6)
    while board.t_us < end:
        board.run_until(min(end, board.t_us + 2000))
        out += board.read_host()
    return _sha(bytes(out)), len(out)


def gauges_digest(scene):
    board = EmulatedBoard(scene, boot_id=BOOT_ID, core="python", board_id=BOARD_ID)
    span = getattr(board.motion, "duration_s", 0.0) or 5.0
    times = np.linspace(0, round(span * 1e6), GAUGE_TIMES).astype(np.int64)
    rows = [m.gauges(int(t)).copy() for t in times for m in board.models]
    return _sha(np.array(rows, "<f8").tobytes())


def strip_columns(text, names):
    """A CSV's text without the columns ``names`` (after its ``#`` lines)."""
    lines = text.splitlines(keepends=True)
    head = next(i for i, line in enumerate(lines) if not line.startswith("#"))
    keep = [i for i, c in enumerate(lines[head].rstrip("\n").split(",")) if c not in names]
    rows = [",".join(line.rstrip("\n").split(",")[i] for i in keep) + "\n" for line in lines[head:]]
    return "".join(lines[:head] + rows)


def log_digest(scene, strip=()):
    """The robot log's digest, the columns ``strip`` names taken out (a format's new ones)."""
    motion = EmulatedBoard(scene, boot_id=BOOT_ID, core="python", board_id=BOARD_ID).motion
    write = getattr(motion, "write_pose_log", None) or getattr(motion, "write_probe_log", None)
    if write is None:
        return None
    with tempfile.TemporaryDirectory() as tmp:
        path = pathlib.Path(tmp) / "log.csv"
        write(path)
        return _sha(strip_columns(path.read_text(), strip).encode())


def digests(name, strip=()):
    scene = load_scene(SCENE_DIR / f"{name}.toml")
    frames, n = frames_digest(scene)
    return {"frames": frames, "frame_bytes": n, "gauges": gauges_digest(scene),
            "log": log_digest(scene, strip)}  # fmt: skip


if __name__ == "__main__":
    names = sys.argv[1:] or SCENES
    json.dump({name: digests(name) for name in names}, sys.stdout, indent=1, sort_keys=True)
    print()
