"""``tactile live --port P``: a terminal view of force/torque and contact state.

By default the SAMPLE stream is switched on for the session (not persisted), and streaming
started if the board was stopped; on exit both are undone (the board's CONFIG as it was, a
stopped board stopped again); ``--as-is`` leaves the board as it is.  Every line
fits 80 columns.  A ``sim://`` port runs as fast as the host reads unless its URL asks
for ``?realtime=1``: live says so once, on stderr.  ``--foxglove`` serves the same frames to
Foxglove (``tactile.cli.options``).  ``--payload TOOL --pose-log LOG`` shows (and
serves) the wrench with the tool's weight and the bias removed and the host's contact state
(``tactile.payload.apply``); the robot's log says the sensor's orientation as it runs.

**The state behind the view**: latest force/torque and contact state per sensor.

``LiveState.update(messages)`` folds frames in; ``render()`` gives two text lines per
sensor, each within 80 columns for any value the wire can carry (int32 uN, uN*m).  Pure
bookkeeping: ``run`` reads the port and draws.
"""

import math
import sys
import time

from tactile.board.client import info_dict
from tactile.cli.options import (
    add_foxglove_arguments,
    add_port_argument,
    check_foxglove,
    connect,
    start_foxglove,
    stop_foxglove,
)
from tactile.errors import PortLost
from tactile.output.text import printable
from tactile.payload import following as payload_following
from tactile_protocol import constants as C
from tactile_protocol.settings import STREAMS, to_newtons, wrench_si

REFRESH_S = 0.1


def add_arguments(parser):
    add_port_argument(parser)
    parser.add_argument("--duration", type=float, help="stop after S seconds (default: Ctrl-C)")
    parser.add_argument("--as-is", action="store_true", help="do not switch on SAMPLE frames")
    parser.add_argument(
        "--pose-log", help="the robot's log (sensor poses): with --payload, the orientation"
    )
    parser.add_argument(
        "--payload",
        action="append",
        metavar="TOOL",
        help="a sensor's tool file: its weight and the bias removed; needs --pose-log",
    )
    add_foxglove_arguments(parser)


def run(args):
    check_foxglove(args)
    samples = None if args.as_is else True  # (live switches the SAMPLE stream on)
    following, log = payload_following(args.payload, args.pose_log, samples)  # before the board
    client = connect(args)
    if following is not None:
        try:
            following.check(_device(client))
        except BaseException:
            client.close()
            raise
    if getattr(client.port, "simulated_time", False):  # sim:// unpaced (tactile_sim.urlhandler)
        print(
            printable(
                f"tactile live: note: {args.port} runs faster than real time;"
                " add ?realtime=1 to the URL to pace it by the clock"
            ),
            file=sys.stderr,
        )
    restore = live = None
    try:
        restore = None if args.as_is else _samples_on(client)
        posed = log if getattr(log, "kind", None) in ("pose", "scara") else None
        live = start_foxglove(args, _device(client), pose_log=posed, port=client.port)
        _view(client, args.duration, live, following)
    except PortLost:
        restore = None  # a dead port cannot be told anything: the error alone, once
        raise
    finally:
        try:
            if restore is not None:
                _restore(client, *restore)
        finally:
            client.close()
            stop_foxglove(live)
    return 0


def _device(client):
    return info_dict(client.info) if client.info is not None else None


def _view(client, duration, live=None, following=None):
    """Draw the board's state until ``duration`` s have passed (or Ctrl-C); ``live``: a
    ``tactile.foxglove.live.LiveServer`` fed every batch; ``following``: a tool's weight
    removed first."""
    state, tty = LiveState(), sys.stdout.isatty()
    start = last = time.monotonic()
    drawn = 0
    try:
        while duration is None or time.monotonic() - start < duration:
            msgs, arrivals = client.read_timed()
            if following is not None:
                msgs, _, arrivals = following.feed(msgs, _device(client), arrivals=arrivals)
            state.update(msgs)
            if live is not None:
                live.feed(msgs, arrivals=arrivals)
            now = time.monotonic()
            if now - last >= (REFRESH_S if tty else 1.0):
                last = now
                drawn = _draw(state, client, now - start, tty, drawn)
        _draw(state, client, time.monotonic() - start, tty, drawn)
    except KeyboardInterrupt:
        pass


def _samples_on(client):
    """Turn the SAMPLE stream on and start streaming; return what ``_restore`` needs: the
    CONFIG values as they were (None: not changed), and whether the board was streaming."""
    i = client.get_info()
    values = (
        i.rate_hz,
        to_newtons(i.enter_threshold),
        to_newtons(i.exit_threshold),
        i.debounce,
        i.flags & C.CFG_WRITABLE & ~C.CFG_PERSIST,
    )
    changed = not values[4] & STREAMS["samples"]
    if changed:
        client.configure(*values[:4], values[4] | STREAMS["samples"])
    streaming = bool(i.flags & C.CFG_STREAMING)
    if not streaming:
        client.start()
    return (values if changed else None), streaming


def _restore(client, values, streaming):
    """The board as ``_samples_on`` found it: its CONFIG, and stopped if it was."""
    if values is not None:
        client.configure(*values)
    if not streaming:
        client.stop()


def _draw(state, client, elapsed, tty, drawn):
    c = client.decoder.counters
    lines = state.render()
    lines.append(f"{elapsed:6.1f} s  frames {c.frames}  lost {c.lost_frames}  damaged {c.damaged}")
    lines = [printable(line)[:WIDTH] for line in lines]  # a counter past 10^20 is cut
    if tty and drawn:
        sys.stdout.write(f"\x1b[{drawn}F")  # escaped: ours, back to the first line drawn
    end = "\x1b[K\n" if tty else "\n"  # (clear the rest of the line)
    sys.stdout.write("".join(line + end for line in lines))  # escaped: each line above
    sys.stdout.flush()
    return len(lines)


class SensorView:
    __slots__ = ("wrench", "in_contact", "contacts", "saturated", "readings")

    def __init__(self):
        self.wrench = (0.0,) * 6
        self.in_contact = False
        self.contacts = 0
        self.saturated = 0
        self.readings = 0


class LiveState:
    def __init__(self):
        self.sensors = {}
        self.status = None

    def update(self, messages):
        for m in messages:
            if m.type_code in (C.MSG_SAMPLE, C.MSG_CONTACT):
                v = self.sensors.setdefault(m.sensor, SensorView())
                v.readings += 1
                v.wrench = wrench_si(m.fx, m.fy, m.fz, m.tx, m.ty, m.tz)
                v.saturated = m.flags & C.FLAG_SAT_MASK
                if m.type_code == C.MSG_SAMPLE:
                    v.in_contact = bool(m.flags & C.FLAG_IN_CONTACT)
                else:
                    v.in_contact = m.phase != C.PHASE_END
                    v.contacts += m.phase == C.PHASE_BEGIN
            elif m.type_code == C.MSG_STATUS:
                self.status = m

    def render(self):
        """Two lines per sensor: |F| (N), contact state, count and saturation; then F (N)
        and M (N*m).  Every line fits 80 columns (``WIDTH``)."""
        lines = []
        for i in sorted(self.sensors):
            v = self.sensors[i]
            fx, fy, fz, tx, ty, tz = v.wrench
            state = "CONTACT" if v.in_contact else "free   "
            sat = f"  SATURATED 0x{v.saturated:02x}" if v.saturated else ""
            norm = math.sqrt(fx * fx + fy * fy + fz * fz)
            lines.append(f"sensor {i}  |F| {norm:9.3f} N  {state}  contacts {v.contacts}{sat}")
            lines.append(
                f"  F [{fx:+9.3f} {fy:+9.3f} {fz:+9.3f}] N  M [{tx:+10.4f} {ty:+10.4f}"
                f" {tz:+10.4f}] N*m"
            )
        if not lines:
            lines.append("waiting for SAMPLE or CONTACT frames...")
        return lines


WIDTH = 80
