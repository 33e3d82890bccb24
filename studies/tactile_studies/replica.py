"""The chapter 5 experiment replicated (thesis §5.1-5.2, tables 5-7).

The recorded contact frames and the robot's pose log become world contacts in
``tactile.commands.derive`` (wheel probe, eqs. 60-62); here the contacts become a patch
analysis with tangent- and position-weighted biquadratic fits on an 8x8 grid,
and the thesis's tables 5-7 to print beside it.
"""

import contextlib
import pathlib

from tactile import units
from tactile.commands.derive import derive
from tactile.ep2 import analyze_patch
from tactile.ep2.contacts_csv import read_contacts
from tactile.recording.files import remove_recording
from tactile.recording.session import Session
from tactile_sim.emulator import load_scene
from tactile_sim.emulator.device import EmulatedBoard, build_motion
from tactile_sim.emulator.pty_server import PtyServer
from tactile_sim.urlhandler import register

# Thesis tables 5-7: (S, sd S, R, sd R, radius cm) for the tangent and position fits.
THESIS = {
    "plane": {"tangent": (0.4703, 0.21204, 0.004114, 0.0006562, None),
              "position": (0.3643, 0.24721, 0.003026, 0.0009828, None)},
    "convex": {"tangent": (0.4980, 0.009639, 0.080290, 0.024210, 8.8078),
               "position": (0.5014, 0.015773, 0.073446, 0.016892, 9.6304)},
    "concave": {"tangent": (-0.4878, 0.036813, 0.057014, 0.02732, 12.4155),
                "position": (-0.4483, 0.123840, 0.053336, 0.01799, 13.4831)},
}  # fmt: skip
TRUE_RADIUS_CM = {"plane": None, "convex": 6.6, "concave": 11.25}


def analyse(points_cm, normals, finger):
    """Tangent- and position-weighted biquadratic fits on an 8x8 grid (§5.2)."""
    out = {}
    for weighting in ("tangent", "position"):
        out[weighting] = analyze_patch(
            points_cm,
            normals,
            method="spline",
            order=2,
            weighting=weighting,
            grid=8,
            finger=finger,
        )
    return out


def replicate(kind, outdir, via="pty"):
    """Record the ch. 5 scene for ``kind`` from the board emulator and analyse it.

    ``via="pty"``: the emulator serves a pseudo-terminal and the host records it exactly
    as it records a board; ``"sim"``: the in-process ``sim://`` port.  The robot's pose
    log is written from the scene, the contacts derived as ``tactile record --pose-log``
    does.  Returns (meta, derive lines, analysis per weighting).
    """
    outdir = pathlib.Path(outdir)
    remove_recording(outdir)  # the replica's own scratch output: each run starts afresh
    outdir.mkdir(parents=True, exist_ok=True)
    scene = load_scene(f"ch5_{kind}")
    serve = _on_pty if via == "pty" else _on_sim
    with serve(scene) as (port, motion, stop_when, on_ready):
        pose_log = outdir / "poses.csv"
        motion.write_pose_log(pose_log)
        session = Session(port, outdir, stop_when=stop_when, on_progress=on_ready)
        meta = session.run()
    lines = derive(outdir, pose_log)
    path = outdir / "contacts.csv"
    patch = read_contacts(path)[0]
    to_cm = units.LENGTH_M[units.stated_length(path)] / units.LENGTH_M["cm"]  # as tables 5-7
    return meta, lines, analyse(patch.points * to_cm, patch.normals, patch.finger)


@contextlib.contextmanager
def _on_sim(scene):
    """sim://: simulated time advances as the host reads; stop when the motion is over."""
    register()  # 'tactile demo --via sim' names no sim:// port on its command line
    motion = build_motion(scene)
    end_us = motion.duration_s * 1e6

    def stop_when(session):
        return "scene end" if session.client.port.emulator.t_us >= end_us else None

    yield f"sim://{scene.path}", motion, stop_when, None


@contextlib.contextmanager
def _on_pty(scene):
    """A PtyServer: real time until the host is ready (its TARE done, inside the scene's
    lead-in), then as fast as possible; stop when served and drained."""
    board = EmulatedBoard(scene)

    def on_ready(session):
        server.realtime = False

    def stop_when(session):
        done = not server.serving and session.client.port.in_waiting == 0
        return "scene end" if done else None

    with PtyServer(board, realtime=True, duration_s=board.motion.duration_s + 0.2) as server:
        yield server.path, board.motion, stop_when, on_ready
