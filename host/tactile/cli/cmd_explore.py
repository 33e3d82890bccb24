"""``tactile explore --port P --robot HOST:PORT -o RUN``: touch where the patch is least known.

The loop (``tactile.explore`` plans, docs/explore.md): the robot touches (``tactile.robot``:
a start, a direction, a force, a travel limit) and holds; the board's SAMPLE frames of the
hold above the board's contact gate are averaged; the spherical fingertip localises the
contact (``--localise force``: the force's line through the fingertip's centre, frictionless as
§5.1.1's probe; ``moment``: the line of action, valid with friction; then the sensor's pose at
the hold); EP2 refits with intervals; the planner chooses the next touch.  It stops when the
label is confident (``--confidence``, ``--flat``, ``--s-width``; with ``--lattice`` the first
9 touches are the square's 3 x 3 lattice and a label waits for them) or ``--max-touches`` are
spent, and then prints the label on one line: exit 0, or 3 with what is still unknown.

RUN/contacts.csv (EP2's contract, m), RUN/explore.csv (a row per touch: touch, S, S_lo,
S_hi, shape, confidence; ``null`` where there is no value) and RUN/meta.json are replaced
whole after every touch, under the run folder's lock: nothing felt is lost when a run ends
early.  Lengths in m, forces in N.  The sensor is tared once at the start, before any
touch; the touches keep the hand's orientation, so the tool's weight stays tared out.
"""

import datetime
import json
import math
import sys
import time
from concurrent.futures import ThreadPoolExecutor

import numpy as np

from tactile import __version__
from tactile.board.client import hold_wrench, info_dict
from tactile.cli.options import (
    add_foxglove_arguments,
    add_port_argument,
    check_foxglove,
    connect,
    start_foxglove,
    stop_foxglove,
)
from tactile.commands import add_quiet
from tactile.errors import BoardError, DataError, InputError
from tactile.explore import Explorer, Region, unknown
from tactile.files.writing import atomic_write, hold
from tactile.foxglove.scene import contacts_update, patch_mesh, patch_update
from tactile.foxglove.topics import CONTACTS_TOPIC, NEXT_TOUCH_TOPIC, PATCH_TOPIC
from tactile.localize import (
    format_contacts,
    pose_from_quaternion,
    sphere_contact,
    sphere_contact_frictionless,
    to_world,
)
from tactile.output.text import clean, dumps, printable
from tactile.robot import RobotClient, RobotError, parse_address
from tactile_protocol import constants as C
from tactile_protocol import settings as board_settings

COLUMNS = ("touch", "S", "S_lo", "S_hi", "shape", "confidence")
UNITS_LINE = "# units: 1 (touch: a count; S, S_lo, S_hi: shape index; confidence: 0-1)"
HOLD_S = 0.2  # a robot that does not know the board's clock: the hold read after its answer
READ_S = 5.0  # longest wait for the hold's frames
DRAIN_READS = 64  # reads (64 KiB each at most) of what came between touches
FLAT = 3.0  # 1/m: the bench's 0.03 per cm, under half the flattest curvature it labels (R 15 cm)
UNREACHABLE = ": unreachable"  # (the robot's line for a pose outside its reach, docs/robot.md)
POSITIVE = ("half_size", "standoff", "force", "finger_radius", "noise_pos", "noise_normal",
            "flat", "s_width")  # fmt: skip


# (option, type, default, help): the stop rule and the geometry, lengths in m
OPTIONS = (
    ("--confidence", float, 0.95, "stop once the label's confidence reaches this (0-1)"),
    ("--max-touches", int, 18, "touch budget (18: the thesis's 3 x 6 plan)"),
    ("--flat", float, FLAT, f"a plane: both curvatures within +-this (1/m; {FLAT:g}: R 33 cm)"),
    ("--s-width", float, None, "a curved label also waits for an S interval this narrow (1)"),
    ("--half-size", float, 0.015, "half the side of the square explored (m)"),
    ("--standoff", float, 0.015, "a touch starts this far above the expected surface (m)"),
    ("--force", float, 3.0, "press force (N)"),
    ("--finger-radius", float, 0.012, "the spherical fingertip's radius (m)"),
    ("--finger-offset", float, 0.03, "its centre along the sensor's +x axis (m)"),
    ("--noise-pos", float, None, "the contacts' position noise (m; default: estimated by EP2)"),
    ("--noise-normal", float, None, "their normals' noise (rad; default: estimated by EP2)"),
)


def add_arguments(parser):
    add_port_argument(parser)
    parser.add_argument("--robot", required=True, metavar="HOST:PORT", help="the robot's address")
    parser.add_argument("-o", "--out", required=True, help="run folder")
    for flag, kind, default, text in OPTIONS:
        parser.add_argument(flag, type=kind, default=default, help=text)
    parser.add_argument(
        "--localise",
        choices=("force", "moment"),
        default="force",
        help="contact from the force alone (frictionless, §5.1.1) or"
        " from the line of action (with friction)",
    )
    parser.add_argument(
        "--lattice",
        action="store_true",
        help="the first 9 touches on the square's 3 x 3 lattice, no label sooner",
    )
    parser.add_argument("--json", action="store_true", help="the result as one JSON object")
    add_quiet(parser)
    add_foxglove_arguments(parser)


def check(args):
    """Bad options, each one line (exit 2), before anything moves."""
    if not 0.0 < args.confidence < 1.0:
        raise InputError(f"--confidence: {args.confidence} is not a probability in (0, 1)")
    if not 1 <= args.max_touches <= 1000:
        raise InputError(f"--max-touches: {args.max_touches} is not a count in 1-1000")
    for name in POSITIVE:
        v = getattr(args, name)  # (the noises may be left out: None)
        if v is not None and not (math.isfinite(v) and v > 0):
            raise InputError(f"--{name.replace('_', '-')}: {v} is not a positive number")
    if not math.isfinite(args.finger_offset):
        raise InputError(f"--finger-offset: {args.finger_offset} is not a number")
    check_foxglove(args)
    return parse_address(args.robot)


def run(args):
    address = check(args)
    explore = Run(args, address)
    explore.connect()  # (a board or robot that is not there leaves no run folder behind)
    with hold(args.out, create=True):
        return explore.run()


class Run:
    """One exploration: the board, the robot, the planner and the run folder."""

    def __init__(self, args, address, clock=time.monotonic):
        self.args, self.address, self.clock = args, address, clock
        self.started = datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds")
        self.client = self.robot = self.live = None
        self.explorer, self.R, self.gate, self.home = None, np.eye(3), 0.0, None
        self.said, self.ended, self.device = 0, "error", None

    def connect(self):
        try:
            self.client = connect(self.args)
            self.device = info_dict(self.client.info)
            self.robot = RobotClient(self.address)
            self.home = self.robot.pose()
        except BaseException:
            self._close()
            raise

    def run(self):
        try:
            scene = (CONTACTS_TOPIC, PATCH_TOPIC, NEXT_TOUCH_TOPIC)
            self.live = start_foxglove(self.args, self.device, topics=scene, port=self.client.port)
            self._start()
            self._loop()
        except KeyboardInterrupt:
            self.ended = "interrupted"  # (meta.json says so; every contact is kept)
            raise
        finally:
            self._close()
        return self._finish()

    def _start(self):
        """Tare unloaded, stream, and place the region under the fingertip."""
        self.client.tare()
        if not self.client.info.flags & C.CFG_STREAMING:
            self.client.start()
        pose = self.home
        R, t = pose_from_quaternion(pose.position_m, pose.quaternion, scalar_first=True)
        self.R = R
        pole = R[:, 0]  # the fingertip's pole: the touches come along it at first
        a = self.args
        centre = t + a.finger_offset * pole + (a.finger_radius + a.standoff) * pole
        region = Region(tuple(centre), tuple(-pole), a.half_size, a.standoff)
        noise = {k: getattr(a, k) for k in ("noise_pos", "noise_normal") if getattr(a, k)}
        self.explorer = Explorer(region, a.confidence, a.max_touches, flat=a.flat,
                                 s_width=a.s_width, lattice=a.lattice, options=noise)  # fmt: skip
        self.gate = board_settings.to_newtons(self.client.info.enter_threshold)

    def _loop(self):
        ex = self.explorer
        while ex.done() is None:
            plan = ex.plan()
            self._publish_next(plan)
            point, normal, why = self._touch(plan)
            fit = ex.add(point, normal, plan, why)
            self._say(ex.touches, plan, point, why, fit)
            self._write()
            self._publish(fit)
        self.ended = ex.done()

    def _touch(self, plan):
        """(world point, normal, None) of the contact ``plan`` finds, or (None, None, why)."""
        a = self.args
        d = np.asarray(plan.direction, float)
        centre = np.asarray(plan.start, float) - a.finger_radius * d  # the leading point
        origin = centre - a.finger_offset * self.R[:, 0]
        self._drain()
        try:
            touch, msgs = self._reading(self.robot.touch, tuple(origin), tuple(d), a.force,
                                        plan.max_travel)  # fmt: skip
        except RobotError as exc:  # a start the arm cannot reach: a touch spent, go on
            if UNREACHABLE not in str(exc):
                raise
            return None, None, str(exc)
        if not touch.touched:
            return None, None, f"no contact within {plan.max_travel:.4g} m"
        wrench, n = hold_wrench(self._batches(msgs, touch.t_us), touch.t_us, self.gate)
        if wrench is None:
            return None, None, f"no frame above the gate ({self.gate:g} N) during the hold"
        wrench = np.asarray(wrench)
        R, t = pose_from_quaternion(touch.pose.position_m, touch.pose.quaternion,
                                    scalar_first=True)  # fmt: skip
        tip = (a.finger_offset, 0.0, 0.0)  # the fingertip's centre in the sensor frame
        if a.localise == "force":
            c = sphere_contact_frictionless(wrench[None, :3], tip, a.finger_radius, self.gate)
        else:
            c = sphere_contact(wrench[None, :3], wrench[None, 3:], tip, a.finger_radius,
                               self.gate)  # fmt: skip
        if not c.usable[0]:
            return None, None, f"the hold's wrench ({n} frames) does not locate a contact"
        p, nrm = to_world(R, t, c.point[0], c.normal[0])
        return p, nrm, None

    def _reading(self, call, *args):
        """``call(*args)`` (a robot command) while the board's stream is read: the emulated
        arm answers once the board's clock has passed the motion, and the board's clock
        waits for a host that reads.  Returns (its answer, the messages read meanwhile)."""
        msgs = []
        with ThreadPoolExecutor(1) as pool:
            job = pool.submit(call, *args)
            while not job.done():
                msgs += self._feed(self.client.read_timed())
            return job.result(), msgs

    def _drain(self):
        """What the board sent since the last touch (bounded: a board in fast mode never
        stops sending)."""
        for _ in range(DRAIN_READS):
            if not self.client.waiting():
                return
            self._feed(self.client.read_timed())

    def _feed(self, got):
        msgs, times = got
        if self.live is not None:
            self.live.feed(msgs, arrivals=times)
        return msgs

    def _batches(self, first, window):
        """``first`` (what was read while the robot moved), then what the board sends, for
        ``READ_S`` (``HOLD_S`` for a robot that does not know the board's clock)."""
        yield first
        deadline = self.clock() + (READ_S if window else HOLD_S)
        while self.clock() < deadline:
            yield self._feed(self.client.read_timed())

    def _say(self, k, plan, point, why, fit):
        if self.args.quiet:
            return
        where = "missed" if point is None else "contact at (" + ", ".join(
            f"{v:.4f}" for v in point) + ") m"  # fmt: skip
        conf = f" {fit.confidence:.3f}" if fit.result is not None else ""
        line = f"explore: touch {k} ({plan.why}): {where}; fit: {fit.label}{conf}"
        print(printable(line), file=sys.stderr, flush=True)
        for note in self.explorer.notes[self.said :]:
            print(printable(f"explore: {note}"), file=sys.stderr, flush=True)
        self.said = len(self.explorer.notes)

    def _write(self):
        """contacts.csv, explore.csv and meta.json, each replaced whole."""
        ex, out = self.explorer, self.args.out
        pts = np.array(ex.points).reshape(-1, 3)
        nrm = np.array(ex.normals).reshape(-1, 3)
        with atomic_write(f"{out}/contacts.csv", text=True) as fh:
            fh.write(format_contacts(pts, nrm))
        with atomic_write(f"{out}/explore.csv", text=True) as fh:
            fh.write(explore_csv([f.row(i + 1) for i, f in enumerate(ex.fits)]))
        with atomic_write(f"{out}/meta.json", text=True) as fh:
            fh.write(json.dumps(clean(self._meta()), indent=2, allow_nan=False) + "\n")

    def _meta(self):
        ex, a = self.explorer, self.args
        fit = ex.fit
        options = {"confidence": a.confidence, "max_touches": a.max_touches, "flat_per_m": a.flat,
                   "s_width": a.s_width, "lattice": a.lattice, "half_size_m": a.half_size,
                   "standoff_m": a.standoff, "force_N": a.force, "finger_radius_m": a.finger_radius,
                   "finger_offset_m": a.finger_offset, "localise": a.localise,
                   "noise_pos_m": a.noise_pos, "noise_normal_rad": a.noise_normal}  # fmt: skip
        return {
            "tactile_version": __version__,
            "protocol_version": C.PROTOCOL_VERSION,
            "command": sys.argv,
            "port": a.port,
            "robot": a.robot,
            "started_at": self.started,
            "ended": self.ended,
            "device": self.device,
            "options": options,
            "touches": ex.touches,
            "contacts": len(ex.points),
            "label": fit.label,
            "confidence": _finite(fit.confidence),
            "unknown": None if self.ended == "label" else unknown(fit, ex.touches),
            "notes": list(ex.notes),
            "units": {"lengths": "m", "forces": "N", "S": "1", "confidence": "1"},
        }

    def _publish_next(self, plan):
        if self.live is not None:
            ns = time.time_ns()
            msg = contacts_update("next_touch", [plan.start], [plan.direction], ns)
            self.live.topics.scene(NEXT_TOUCH_TOPIC, msg, ns)

    def _publish(self, fit):
        if self.live is None:
            return
        ex, ns = self.explorer, time.time_ns()
        pts = np.array(ex.points).reshape(-1, 3)
        self.live.topics.scene(CONTACTS_TOPIC, contacts_update("contacts", pts,
                               np.array(ex.normals).reshape(-1, 3), ns), ns)  # fmt: skip
        r = fit.result
        record = r.to_dict(1) if r is not None else {"shape": None, "error": fit.refused}
        mesh = patch_mesh(r) if r is not None and r.shape != "uncertain" else None
        anchor = pts.mean(axis=0) if len(pts) else np.zeros(3)
        self.live.topics.scene(PATCH_TOPIC, patch_update(record, mesh, anchor, len(pts), ns), ns)

    def _close(self):
        try:
            if self.robot is not None and self.explorer is not None:
                self._reading(self.robot.move, self.home)  # (ends the press it holds)
        except BoardError:
            pass
        for part in (self.robot, self.client):
            if part is not None:
                part.close()
        stop_foxglove(self.live, quiet=self.args.quiet)
        if self.explorer is not None and self.explorer.touches:
            self._write()

    def _finish(self):
        ex, fit = self.explorer, self.explorer.fit
        line = final_line(fit, ex.touches, self.ended)
        if self.args.json:
            row = fit.row(ex.touches)
            s_iv = None if row["S_lo"] is None else [row["S_lo"], row["S_hi"]]
            print(dumps(self._meta() | {"S": row["S"], "S_interval": s_iv}))
        else:
            print(printable(line))
        if self.ended != "label":
            raise DataError(f"explore: {unknown(fit, ex.touches)}")
        return 0


def final_line(fit, touches, ended):
    """The result on one line."""
    r = fit.result
    s = ""
    if r is not None and r.S is not None and r.S_interval:
        s = f", S {r.S:.3f} in [{r.S_interval[0]:.3f}, {r.S_interval[1]:.3f}] (95 %)"
    how = "confident" if ended == "label" else "not confident: the budget is spent"
    conf = f" {fit.confidence:.3f}" if r is not None else ""
    return f"{fit.label} (confidence{conf or ' none'}, {how}) after {touches} touches{s}"


def explore_csv(rows):
    """explore.csv's text: the units line, the header, a row per touch (``null``: none)."""
    lines = [UNITS_LINE, ",".join(COLUMNS)]
    for row in rows:
        lines.append(",".join(_cell(row[c]) for c in COLUMNS))
    return "\n".join(lines) + "\n"


def _cell(v):
    if v is None or isinstance(v, float) and not math.isfinite(v):
        return "null"
    return repr(float(v)) if isinstance(v, float) else str(v)


def _finite(v):
    return v if isinstance(v, (int, float)) and math.isfinite(v) else None
