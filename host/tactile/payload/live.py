"""A tool's weight removed from a live stream, batch by batch (``tactile live`` and ``record
--foxglove`` with ``--payload``): what the terminal and Foxglove show is the compensated
wrench, and the contact state is the host's gate's.

Each frame's time in the pose log's clock: the board's stamp, or for a log in a host clock
the host time the recorder gave it, else its arrival (``tactile live``: within the link's
delay, a few ms).  The host tares at the first steady stretch of the stream (the finger
free, as a TARE wants); until then the tool's identified bias is used.
"""

import time

from tactile.payload.compensator import Compensator
from tactile.payload.tool import check_device

__all__ = ["Following"]


class Following:
    """``tools`` (``Tool`` list) compensated through ``orient`` (``Orientations``) for a log
    in ``clock`` ("board", "utc" or "monotonic"); the board's INFO comes with the first batch."""

    def __init__(self, tools, orient, clock="board", samples=None):
        self.named = (
            [(str(p), t) for p, t in tools] if tools and isinstance(tools[0], tuple) else None
        )
        self.tools = [t for _, t in tools] if self.named else list(tools)
        self.orient, self.clock, self.samples = orient, clock, samples
        self.comp = None
        self.utc_minus_mono = time.time() - time.monotonic()

    def check(self, device):
        """InputError unless each tool is for a sensor of ``device`` (a board's INFO as a
        dict) with the calibration it was measured with."""
        for name, tool in self.named or [("payload", t) for t in self.tools]:
            check_device(tool, device, name)

    def _times(self, msgs, host_times, arrivals):
        if self.clock == "board":
            return None
        k = 1 if self.clock == "utc" else 0
        if host_times is not None:
            return [-1 if t is None else round(t[k] * 1e6) for t in host_times]
        shift = self.utc_minus_mono if k else 0.0
        return [
            -1 if a is None else round((a + shift) * 1e6) for a in arrivals or [None] * len(msgs)
        ]

    def feed(self, msgs, device, host_times=None, arrivals=None):
        """(frames, host_times, arrivals) of one batch, each list re-cut to the frames out."""
        if self.comp is None:
            dev = dict(device or {})
            if self.samples is not None:
                dev["streams"] = ["samples", "contacts"] if self.samples else ["contacts"]
            self.comp = Compensator(self.tools, self.orient, dev)
        out, index = self.comp.messages(msgs, self._times(msgs, host_times, arrivals))
        pick = index.tolist()
        host = None if host_times is None else [host_times[i] for i in pick]
        arrived = None if arrivals is None else [arrivals[i] for i in pick]
        return out, host, arrived

    def report(self):
        return [] if self.comp is None else self.comp.report()
