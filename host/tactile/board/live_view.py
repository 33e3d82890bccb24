"""The state behind ``tactile live``: latest force/torque and contact state per sensor.

``LiveState.update(messages)`` folds frames in; ``render()`` gives two text lines per
sensor, each within 80 columns for any value the wire can carry (int32 uN, uN*m).  Pure
bookkeeping: the CLI reads the port and draws.
"""

import math

from tactile_protocol import constants as C
from tactile_protocol.settings import wrench_si


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
