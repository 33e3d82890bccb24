"""The tool's weight on a sensor: what the sensor carries, turned into its frame.

The tool (``[tool]``: mass m, centre of mass c in the sensor frame) hangs on each sensor, and
gravity g (``[world] gravity_m_s2``) points the same way in the world whatever the hand does.
At the sensor's orientation R (world from sensor) the load it adds, sensor frame, is

    F = m R^T g  (N),    T = c x F  (N*m, about the sensor origin)

(``docs/emulator.md``).  ``ToolWeight.loaded`` adds it to a motion's contact wrench, so it
reaches the gauges through the transducer like any load.  A scene without a tool builds no
``ToolWeight`` (``from_scene`` is None), so its wrench is computed as it always was.
"""

import numpy as np

__all__ = ["ToolWeight"]


class ToolWeight:
    def __init__(self, mass_kg, com_m, gravity_m_s2):
        self.mass = float(mass_kg)
        self.com = np.asarray(com_m, float)
        self.gravity = np.asarray(gravity_m_s2, float)

    @classmethod
    def from_scene(cls, scene):
        """The scene's tool, or None for a weightless one (no term added)."""
        tool = scene.tool
        if tool["mass_kg"] == 0.0:
            return None
        return cls(tool["mass_kg"], tool["com_m"], scene.world["gravity_m_s2"])

    def wrench(self, R):
        """(6,) F, T in the sensor frame at orientation R (3, 3), world from sensor."""
        fx, fy, fz = (self.mass * (self.gravity @ R)).tolist()  # m R^T g
        cx, cy, cz = self.com.tolist()
        return np.array([fx, fy, fz, cy * fz - cz * fy, cz * fx - cx * fz, cx * fy - cy * fx])

    def loaded(self, motion, sensor):
        """The wrench on ``sensor`` at t_s: the motion's contact load plus the tool's weight
        at the orientation the motion holds the sensor in."""

        def wrench_at(t_s):
            return motion.wrench_at(t_s, sensor) + self.wrench(motion.orientation_at(t_s, sensor))

        return wrench_at
