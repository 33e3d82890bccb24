"""The chapter 5 experiment replicated (thesis §5.1-5.2, tables 5-7).

The recorded contact frames and the robot's pose log become world contacts in
``tactile.derive`` (wheel probe, eqs. 60-62); here the contacts become a patch
analysis with tangent- and position-weighted biquadratic fits on an 8x8 grid,
and the thesis's tables 5-7 to print beside it.
"""

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
    from tactile.ep2 import analyze_patch

    out = {}
    for weighting in ("tangent", "position"):
        out[weighting] = analyze_patch(
            points_cm, normals, degree=2, weighting=weighting, grid=8, finger=finger
        )
    return out


def replicate(kind, outdir, port=None, scene_time_us=None, on_progress=None):
    """Record the ch. 5 scene for ``kind`` over a serial port and derive its contacts.

    ``port``: a device serving ``ch5_KIND`` (a pty from ``tactile emulate``) with
    ``scene_time_us`` reading its simulated clock, or None for the in-process
    ``sim://ch5_KIND``.  The robot's pose log is written from the scene; recording stops
    when the motion is over.  Returns (meta, derive lines, analysis per weighting).
    """
    import pathlib

    from tactile.derive import derive
    from tactile.ep2.contacts_csv import read_contacts
    from tactile.record_session import Session
    from tactile.recording import remove_recording
    from tactile.serial_port import open_port
    from tactile_sim.emulator import load_scene
    from tactile_sim.emulator.device import build_motion

    outdir = pathlib.Path(outdir)
    remove_recording(outdir)  # the replica's own scratch output: each run starts afresh
    outdir.mkdir(parents=True, exist_ok=True)
    motion = build_motion(load_scene(f"ch5_{kind}"))
    pose_log = outdir / "poses.csv"
    motion.write_pose_log(pose_log)
    opened = []

    def opener(name):
        opened.append(open_port(name))
        return opened[-1]

    if scene_time_us is None:
        scene_time_us = lambda: opened[-1].emulator.t_us  # noqa: E731  (sim://)

    def scene_over(session):
        return "scene end" if scene_time_us() >= motion.duration_s * 1e6 else None

    session = Session(
        port or f"sim://ch5_{kind}",
        outdir,
        opener=opener,
        stop_when=scene_over,
        on_progress=on_progress,
    )
    meta = session.run()
    lines = derive(outdir, pose_log)
    patch = read_contacts(outdir / "contacts.csv")[0]
    return meta, lines, analyse(patch.points, patch.normals, patch.finger)
