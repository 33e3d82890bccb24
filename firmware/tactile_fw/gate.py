"""Contact gate: hysteresis on the force magnitude plus a debounce count (thesis §5.1).

The thesis takes a sample "when the force sensor measures a force in the x-y
plane with magnitude greater than 5 units" (§5.1).  A single threshold
chatters when |F| hovers near it, so the gate has two levels: a contact
begins after ``debounce`` consecutive samples with |F| > enter and ends after
``debounce`` consecutive samples with |F| < exit (exit <= enter).  |F| is
taken in the x-y plane (thesis) or in 3-D (CFG_GATE_3D).  Integer bounds
decide most samples; the rest compare exact squared magnitudes (no square root).
"""

from tactile_protocol.constants import const

NONE = const(-1)  # no CONTACT message for this sample
BEGIN = const(0)  # = PHASE_BEGIN
IN = const(1)  # = PHASE_IN
END = const(2)  # = PHASE_END


class ContactGate:
    def __init__(self, enter, exit_, debounce, three_d=False):
        self.in_contact = False
        self.count = 0
        self.contact_id = 0
        self.configure(enter, exit_, debounce, three_d)

    def configure(self, enter, exit_, debounce, three_d):
        if not 0 <= exit_ <= enter or debounce < 1:
            raise ValueError("gate: need 0 <= exit <= enter and debounce >= 1")
        self.enter = enter
        self.exit = exit_
        self.enter2 = enter * enter
        self.exit2 = exit_ * exit_
        self.debounce = debounce
        self.three_d = three_d
        self.reset()

    def reset(self):
        self.in_contact = False
        self.count = 0

    def _cmp(self, fx, fy, fz, level, level2):
        """+1, 0, -1 as |F| is above, at or below ``level``.

        max|f_i| <= |F| <= sum|f_i| decides most samples in small integers; only
        samples inside that band square the components, exactly (as the C core
        does in 64 bits; on MicroPython those squares are long ints, heap objects).
        """
        ax = fx if fx >= 0 else -fx
        ay = fy if fy >= 0 else -fy
        lo = ax if ax > ay else ay
        hi = ax + ay
        if self.three_d:
            az = fz if fz >= 0 else -fz
            if az > lo:
                lo = az
            hi += az
        if lo > level:
            return 1
        if hi < level:
            return -1
        m2 = fx * fx + fy * fy
        if self.three_d:
            m2 += fz * fz
        return 1 if m2 > level2 else (-1 if m2 < level2 else 0)

    def loaded(self, fx, fy, fz):
        """True when |F| (as the gate measures it) is above the enter level: a sample the gate
        would count toward a contact (TARE refuses such samples)."""
        return self._cmp(fx, fy, fz, self.enter, self.enter2) > 0

    def update(self, fx, fy, fz):
        """Feed one sample; return BEGIN, IN, END or NONE (out of contact)."""
        if not self.in_contact:
            if self._cmp(fx, fy, fz, self.enter, self.enter2) > 0:
                self.count += 1
                if self.count >= self.debounce:
                    self.in_contact = True
                    self.count = 0
                    self.contact_id = (self.contact_id + 1) & 0xFFFF
                    return BEGIN
            else:
                self.count = 0
            return NONE
        if self._cmp(fx, fy, fz, self.exit, self.exit2) < 0:
            self.count += 1
            if self.count >= self.debounce:
                self.in_contact = False
                self.count = 0
                return END
        else:
            self.count = 0
        return IN
