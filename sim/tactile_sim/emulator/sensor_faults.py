"""Timed faults of the simulated hardware: I2C timeouts or NACKs, stuck DRDY, saturation.

Scene ``[[sensor_fault]]`` tables: ``at_s``, ``kind`` (``i2c_timeout``,
``i2c_nack``, ``stuck_drdy``, ``saturate``), ``sensor`` (default 0),
``count`` (transactions, for ``i2c_timeout``) or ``for_s`` (duration).
The firmware must report each as STATUS and recover (issue 5).
"""

import errno

KINDS = ("i2c_timeout", "i2c_nack", "stuck_drdy", "saturate")


class FaultSchedule:
    """The scene's faults on the models' clock (us), from the scene's start (``restart``)."""

    def __init__(self, events, emulator):
        self.scene = sorted(events, key=lambda e: e["at_us"])
        self.events = list(self.scene)
        self.emu = emulator
        self.active = []  # (end_us, undo)

    def restart(self, at_us):
        """The scene again from the models' time ``at_us``: what is active ends, and every
        fault is due again ``at_s`` after it."""
        for _, undo in self.active:
            undo()
        self.active = []
        self.events = [dict(e, at_us=e["at_us"] + int(at_us)) for e in self.scene]

    @classmethod
    def from_scene(cls, scene, emulator):
        """The scene's ``[[sensor_fault]]`` tables (checked by ``scene_schema``), or None."""
        events = [
            {
                "at_us": int(e["at_s"] * 1e6),
                "kind": e["kind"],
                "sensor": e["sensor"],
                "count": e["count"],
                "for_us": int(e["for_s"] * 1e6),
            }
            for e in scene.sensor_faults
        ]
        return cls(events, emulator) if events else None

    def update(self, t_us):
        while self.events and self.events[0]["at_us"] <= t_us:
            self._start(self.events.pop(0), t_us)
        for item in [a for a in self.active if a[0] <= t_us]:
            self.active.remove(item)
            item[1]()

    def _start(self, e, t_us):
        emu, s = self.emu, e["sensor"]
        adcs = emu.adcs[6 * s : 6 * s + 6]
        bus = emu.buses[s // 2]
        if e["kind"] == "i2c_timeout":
            bus.fail_next(e["count"], errno.ETIMEDOUT)
            return
        if e["kind"] == "i2c_nack":
            addrs = [a for a, d in bus.devices.items() if d in adcs]
            bus.nack.update(addrs)
            self.active.append((t_us + e["for_us"], lambda: bus.nack.difference_update(addrs)))
        elif e["kind"] == "stuck_drdy":
            for adc in adcs:
                adc.stuck_drdy = True
            self.active.append(
                (t_us + e["for_us"], lambda: [setattr(a, "stuck_drdy", False) for a in adcs])
            )
        else:  # saturate
            for adc in adcs[:1]:
                adc.saturate = 1
            self.active.append((t_us + e["for_us"], lambda: setattr(adcs[0], "saturate", 0)))

    def next_us(self):
        times = [e["at_us"] for e in self.events[:1]] + [a[0] for a in self.active]
        return min(times) if times else None
