"""From a recording and the robot's pose log to the inputs of EP2 and EP1: what ``tactile
record --pose-log`` does after recording, and the chapter 5 replica with it.

The F/T wire carries no robot pose: the robot controller logs it (``tactile.logs``).  The
log's header says what it is:

- ``t_start_us,t_end_us,finger,q1,q2,q3,z`` (+ ``# rig: scara L1=.. L2=.. L3=.. L4=..``):
  the ch. 5 SCARA with its wheel probe (eqs. 60-62) -> ``contacts.csv`` (m; tables 5-7 are in
  cm);
- ``t_start_us,t_end_us,finger,px,py,pz,qw,qx,qy,qz``: a spherical fingertip's sensor pose
  per window -> ``contacts.csv`` (m); both read by ``tactile.logs.read``;
- ``probe,t_start_us,t_end_us,dtheta_x,dtheta_y``: EP1 rolling probes (read by
  ``tactile.logs.read``, turned into probes by ``tactile.ep1.probes``) -> ``probes.csv``.

The CONTACT frames come from ``capture.bin`` (the recording's source of truth); which of them
are readings is ``tactile.localize.contact``'s rule.  A log stamped in a host clock (UTC or
monotonic, ``tactile.logs.tags``) is joined through the time base in ``meta.json``: each
frame's board stamp becomes that clock's time (``tactile.recording.timebase.recorded_times``).

When fewer than half the readings are localised, a ``warning:`` line says so and counts
where the rest went (outside every window, below the gate, off the probe, too noisy), with
the likely cause of each.
"""

import pathlib

import numpy as np

from tactile.board.stream_decoder import decode_bytes
from tactile.ep1.probes import format_probes, probe_report, probes_from_frames
from tactile.errors import DataError, InputError
from tactile.files import bounded
from tactile.files.writing import write_bytes
from tactile.localize import format_contacts
from tactile.localize.contact import Readings, contact_frames
from tactile.localize.posed import posed_world_contacts
from tactile.logs.read import log_columns, read_pose_log, read_probe_log
from tactile.logs.tags import clock_of
from tactile.payload.apply import read_log
from tactile.payload.compensator import Compensator, words
from tactile.payload.tool import check_device, tool_doc
from tactile.recording.layout import amend, read_meta
from tactile.recording.timebase import recorded_times

__all__ = ["check_log", "derive"]

MAX_CAPTURE_BYTES = 2 * 2**30  # read whole: a long recording's capture.bin


def check_log(pose_log):
    """Read the robot log once, so a bad one is refused before anything is recorded: a
    ``ProbeLog`` (EP1) or a ``PoseLog``."""
    if "dtheta_x" in log_columns(pose_log):
        return read_probe_log(pose_log)
    return read_pose_log(pose_log)


def _gate(meta):
    """(enter threshold N, gate 'xy' or '3d') of the recorded board."""
    dev = (meta or {}).get("device") or {}
    return float(dev.get("enter_threshold_N", 0.0)), dev.get("gate", "xy")


def derive(outdir, pose_log, per_contact=None, payload=None):
    """Write contacts.csv or probes.csv into ``outdir``; return lines to print.

    ``payload``: [(tool.json's path, ``Tool``)]: each tool's weight and the bias are removed
    from its sensor's readings and the contacts gated again on the host
    (``tactile.payload.compensator``) before anything is localised; meta.json's "payload"
    gets what was done (``compensation``)."""
    outdir = pathlib.Path(outdir)
    columns = log_columns(pose_log)
    try:
        data = bounded.read_bytes(outdir / "capture.bin", MAX_CAPTURE_BYTES, "a capture")
        meta = read_meta(outdir / "meta.json")
    except InputError as exc:
        raise InputError(f"{exc} (not a complete recording)") from None
    clock = clock_of(pose_log, None, columns) or "board"
    if clock == "board":
        messages, _ = decode_bytes(data)
        times = None
    else:
        messages, times = recorded_times(data, meta, clock, outdir)
    threshold, gate = _gate(meta)
    said = []
    if payload:
        messages, times, said = compensated(outdir, pose_log, messages, times, meta, payload)
    if "dtheta_x" in columns:
        return said + _derive_probes(outdir, pose_log, messages, threshold, times)
    return said + _derive_posed(
        outdir, pose_log, messages, threshold, gate, per_contact, times, bool(payload)
    )


def _derive_posed(outdir, pose_log, messages, threshold, gate, per_contact, times=None, host=False):
    """SCARA joints (ch. 5) or sensor poses: contacts.csv in metres either way (the thesis's
    tables 5-7 are in cm; ``tactile ep2 analyze --units cm`` shows them so).  ``host``: the
    contacts are the host's gate's (a payload), and none at all is an empty contacts.csv."""
    log = read_pose_log(pose_log)
    rule = Readings.for_log(log.kind, per_contact, threshold, gate)
    t, sensor, wrench, _ = contact_frames(messages, times=times, rule=rule)
    if log.kind == "pose" and log.probe is None and len(t) == 0:  # holds, nothing touched
        return [
            f"no contact readings, and no '# probe:' line in {pose_log}: no contacts.csv (a log"
            f" of holds? tactile payload identify {outdir} --pose-log {pose_log})"
        ]
    points, normals, finger, report = posed_world_contacts(log, t, sensor, wrench, threshold)
    path = outdir / "contacts.csv"
    if len(t) == 0 and host:  # the host's gate found none: the board's were the weight's
        write_bytes(path, format_contacts(points, normals, finger=finger))
        return [f"0 contact readings (the host's gate found no contact) -> {path}"]
    if len(t) == 0:
        raise DataError(
            f"{outdir}: no CONTACT readings in the recording (did a finger touch? a TARE taken"
            " under load hides every contact)"
        )
    if len(points) == 0:
        raise DataError(f"{outdir}: no contact could be localised: {_why(report, threshold)}")
    write_bytes(path, format_contacts(points, normals, finger=finger))  # metres, whatever the log
    lines = [f"{len(points)} of {len(t)} contact readings localised (m) -> {path}; {report}"]
    if 2 * len(points) < len(t):
        lines.append(
            f"warning: only {len(points):,} of {len(t):,} readings"
            f" ({100 * len(points) / len(t):.0f}%) were localised: {_why(report, threshold)}"
        )
    return lines


def _why(report, threshold):
    """Where the readings that were not localised went, each with its likely cause."""
    causes = (
        (report.outside, "outside every pose window of their finger (a log of another run,"
         " or in another clock? frames taken while the robot moves are outside by design)"),
        (report.no_contact, f"at or below the {threshold:g} N gate (a TARE taken under load"
         " shifts every reading; the board now refuses one)"),
        (report.unusable, "with a line of action that misses the fingertip (a wrong"
         " '# probe:' line, or a sensor biased under load)"),
        (report.imprecise, "too noisy (normal error above 10 deg: a force too low for the"
         " sensor's noise)"),
    )  # fmt: skip
    parts = [f"{n:,} {what}" for n, what in causes if n]
    return "; ".join(parts) if parts else "no reading reached a pose window"


def _derive_probes(outdir, pose_log, messages, threshold, times=None):
    log = read_probe_log(pose_log)
    t, _, wrench, _ = contact_frames(messages, times=times)
    rows, usable = probes_from_frames(log, t, wrench, threshold)
    if not np.any(usable):
        first = probe_report(log, t, wrench, threshold)[0]
        raise DataError(f"{outdir}: no probe is usable ({first})")
    path = outdir / "probes.csv"
    write_bytes(path, format_probes(rows[usable]))
    out = [f"{int(np.sum(usable))} of {len(usable)} probes usable -> {path}"]
    out += [ln for ln in probe_report(log, t, wrench, threshold) if ": ok" not in ln]
    if 2 * np.sum(usable) < len(usable):
        out.append(
            f"warning: only {int(np.sum(usable))} of {len(usable)} probes are usable (the"
            " lines above say why)"
        )
    out.append(f"next: tactile ep1 estimate {path} --finger-radius {float(log.radius_m):.10g}")
    return out


def compensated(outdir, pose_log, messages, times, meta, payload):
    """(messages, times, lines): the frames with the tools' weight and bias removed and
    their contacts gated on the host; meta.json's "payload" records it."""
    device = meta.get("device")
    for path, tool in payload:
        check_device(tool, device, path)
    _, orient = read_log(pose_log)
    comp = Compensator([tool for _, tool in payload], orient, device)
    out, index = comp.whole(messages, times)
    report = comp.report()
    tools = [{"file": str(path), "tool": tool_doc(tool)} for path, tool in payload]
    before = meta.get("payload") or {}
    amend(outdir / "meta.json", "payload", {**before, "tools": tools, "compensation": report})
    lines = [words(r) for r in report]
    return out, None if times is None else np.asarray(times)[index], lines
