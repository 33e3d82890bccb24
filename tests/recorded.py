"""Shared by the loader and export tests: a real recording (the EP2 sphere sweep through
``sim://``, three sensors, contacts.csv in m) and variants of its files as the recorder
writes them with and without host time."""

import json
import shutil
import sys

from tactile.board.stream_decoder import decode_bytes

LEGACY_HEADER = (
    "seq,timestamp_us,type,sensor,phase,contact_id,flags,fx_N,fy_N,fz_N,tx_Nm,ty_Nm,tz_Nm"
)
HOST_HEADER = (
    "seq,timestamp_us,host_monotonic_s,host_utc_s,type,sensor,phase,contact_id,flags,"
    "fx_N,fy_N,fz_N,tx_Nm,ty_Nm,tz_Nm"
)


def record_sweep(out, tmp):
    """``tactile record`` the shipped sphere sweep into ``out`` (three contacts, its pose
    log in ``tmp``)."""
    from tactile.cli.main import main
    from tactile_sim.emulator.device import build_motion
    from tactile_sim.emulator.scene import load_scene

    poses = tmp / "poses.csv"
    build_motion(load_scene("ep2_sweep_sphere")).write_pose_log(poses)
    argv = ["record", "--port", "sim://ep2_sweep_sphere", "--no-tare", "--contacts", "3",
            "--pose-log", str(poses), "-o", str(out), "--quiet"]  # fmt: skip
    saved, sys.argv = sys.argv, ["tactile", *argv]  # meta.json's command, as from a shell
    try:
        assert main(argv) == 0
    finally:
        sys.argv = saved
    return out


def frames_of(run):
    """The SAMPLE/CONTACT messages of ``run``'s capture.bin, decoded independently."""
    messages, _ = decode_bytes((run / "capture.bin").read_bytes())
    return [m for m in messages if m.type_name in ("SAMPLE", "CONTACT")]


def frame_line(m, host=None):
    """A frames.csv row of message ``m``: the legacy layout, or with ``host`` = (monotonic
    s, UTC s) or (None, None) the layout with host-time columns."""
    phase, cid = ("", "") if m.type_name == "SAMPLE" else (m.phase, m.contact_id)
    w = ",".join(f"{v / 1e6:.6f}" for v in (m.fx, m.fy, m.fz, m.tx, m.ty, m.tz))
    times = ""
    if host is not None:
        times = ",".join("" if v is None else f"{v:.6f}" for v in host) + ","
    return f"{m.seq},{m.timestamp_us},{times}{m.type_name},{m.sensor},{phase},{cid},{m.flags},{w}"


def variant(run, dest, frames_text=None, meta_change=None):
    """A copy of ``run`` in ``dest`` with frames.csv replaced by ``frames_text`` and meta.json
    passed through ``meta_change(doc)`` (which edits it in place)."""
    shutil.copytree(run, dest)
    if frames_text is not None:
        (dest / "frames.csv").write_text(frames_text, encoding="utf-8")
    if meta_change is not None:
        doc = json.loads((dest / "meta.json").read_text(encoding="utf-8"))
        doc.pop("time_base", None)
        for s in doc.get("sessions", []):
            s.pop("time_base", None)
        meta_change(doc)
        (dest / "meta.json").write_text(json.dumps(doc), encoding="utf-8")
    return dest
