"""From a recording and the robot's pose log to the inputs of EP2 and EP1.

The F/T wire carries no robot pose: the robot controller logs it.  The pose
log's header says what it is:

- ``t_start_us,t_end_us,finger,q1,q2,q3,z`` (+ ``# rig: scara L1=.. L2=.. L3=.. L4=..``):
  the ch. 5 SCARA with its wheel probe (eqs. 60-62) -> ``contacts.csv`` (cm, as tables 5-7);
- ``t_start_us,t_end_us,finger,px,py,pz,qw,qx,qy,qz``: a spherical fingertip's sensor pose
  per window -> ``contacts.csv`` (m); both read by ``tactile.localize.pose_log``;
- ``probe,t_start_us,t_end_us,dtheta_x,dtheta_y``: EP1 rolling probes
  (``tactile.ep1.from_ft``) -> ``probes.csv``.

The CONTACT frames come from ``capture.bin`` (the recording's source of truth).
"""

import pathlib

import numpy as np

from tactile.errors import DataError, InputError
from tactile_protocol import constants as C

SCARA_PER_CONTACT = 2  # §5.1: two samples per probed point


def contact_frames(messages, per_contact=None, above_N=None, gate="xy"):
    """CONTACT readings (BEGIN and IN; END is already outside the gate).

    ``per_contact``: keep only the first N readings of each contact (per sensor);
    ``above_N``: only readings whose gated force (x-y or 3-D magnitude) exceeds it, as
    §5.1 takes a sample "when the x-y force exceeds 5 units" (inside a contact, the
    firmware's hysteresis lets the force dip to the exit threshold).
    Returns (timestamps_us, sensor, wrench (n, 6) in N and N*m, contact ids).
    """
    taken, rows = {}, []
    floor = None if above_N is None else above_N / C.FORCE_LSB_N
    for m in messages:
        if m.type_code != C.MSG_CONTACT or m.phase == C.PHASE_END:
            continue
        if floor is not None:
            fz2 = m.fz * m.fz if gate == "3d" else 0
            if m.fx * m.fx + m.fy * m.fy + fz2 <= floor * floor:
                continue
        key = (m.sensor, m.contact_id)
        if m.phase == C.PHASE_BEGIN or (floor is not None and key not in taken):
            taken[key] = 0
        k = taken.get(key)
        if k is None or (per_contact is not None and k >= per_contact):
            continue
        taken[key] = k + 1
        rows.append((m.timestamp_us, m.sensor, m.contact_id, m.fx, m.fy, m.fz, m.tx, m.ty, m.tz))
    a = np.array(rows, dtype=float).reshape(-1, 9)
    wrench = a[:, 3:] * np.repeat([C.FORCE_LSB_N, C.TORQUE_LSB_NM], 3)
    return a[:, 0], a[:, 1].astype(int), wrench, a[:, 2].astype(int)


def check_log(pose_log):
    """Read the robot log once, so a bad one is refused before anything is recorded."""
    from tactile.localize.pose_log import log_columns, read_pose_log

    if "dtheta_x" in log_columns(pose_log):
        from tactile.ep1.from_ft import read_probe_log

        return read_probe_log(pose_log)
    return read_pose_log(pose_log)


def _gate(meta):
    """(enter threshold N, gate 'xy' or '3d') of the recorded board."""
    dev = (meta or {}).get("device") or {}
    return float(dev.get("enter_threshold_N", 0.0)), dev.get("gate", "xy")


def derive(outdir, pose_log, per_contact=None):
    """Write contacts.csv or probes.csv into ``outdir``; return lines to print."""
    import json

    from tactile.localize.pose_log import log_columns
    from tactile.stream_decoder import decode_bytes

    outdir = pathlib.Path(outdir)
    columns = log_columns(pose_log)
    try:
        data = (outdir / "capture.bin").read_bytes()
        meta = json.loads((outdir / "meta.json").read_text(encoding="utf-8"))
    except (OSError, ValueError) as exc:
        raise InputError(f"{outdir}: not a complete recording: {exc}") from None
    messages, _ = decode_bytes(data)
    threshold, gate = _gate(meta)
    if "dtheta_x" in columns:
        return _derive_probes(outdir, pose_log, messages, threshold)
    return _derive_posed(outdir, pose_log, messages, threshold, gate, per_contact)


def _write(path, text):
    tmp = path.with_suffix(".tmp")
    tmp.write_text(text, encoding="utf-8")
    tmp.replace(path)


def _derive_posed(outdir, pose_log, messages, threshold, gate, per_contact):
    """SCARA joints (ch. 5, written in cm as tables 5-7) or sensor poses (m)."""
    from tactile.localize import format_contacts
    from tactile.localize.pose_log import posed_world_contacts, read_pose_log

    log = read_pose_log(pose_log)
    scara = log.kind == "scara"
    if scara:
        n = SCARA_PER_CONTACT if per_contact is None else per_contact
        t, sensor, wrench, _ = contact_frames(messages, n, above_N=threshold, gate=gate)
    else:
        t, sensor, wrench, _ = contact_frames(messages, per_contact)
    points, normals, finger, report = posed_world_contacts(log, t, sensor, wrench, threshold)
    if len(points) == 0:
        raise DataError(f"{outdir}: no contact could be localised ({report})")
    path = outdir / "contacts.csv"
    scale, unit = (100.0, "cm") if scara else (1.0, "m")
    _write(path, format_contacts(points, normals, finger=finger, scale=scale))
    return [f"{len(points)} of {len(t)} contact readings localised ({unit}) -> {path}; {report}"]


def _derive_probes(outdir, pose_log, messages, threshold):
    from tactile.ep1.from_ft import probe_report, probes_from_frames, read_probe_log
    from tactile.ep1.probes_csv import format_probes

    log = read_probe_log(pose_log)
    t, _, wrench, _ = contact_frames(messages)
    rows, usable = probes_from_frames(log, t, wrench, threshold)
    if not np.any(usable):
        first = probe_report(log, t, wrench, threshold)[0]
        raise DataError(f"{outdir}: no probe is usable ({first})")
    path = outdir / "probes.csv"
    _write(path, format_probes(rows[usable]))
    out = [f"{int(np.sum(usable))} of {len(usable)} probes usable -> {path}"]
    out += [ln for ln in probe_report(log, t, wrench, threshold) if ": ok" not in ln]
    out.append(f"next: tactile ep1 estimate {path} --finger-radius {log.radius_m!r}")
    return out
