"""The tool's weight in the sensor frame, and a wrench with it removed.

``weight(R, tool)`` is the wrench the tool's weight puts on the sensor at orientation R (the
sensor frame's axes in the world's, (..., 3, 3)): F_w = m R^T g, T_w = c x F_w
(``tactile.payload.tool``).  ``compensate(wrench, R, tool, bias)`` is the wrench less that
weight and less the bias: what the contact alone applies.  ``tare_bias(reading, R, tool)``
is the bias a reading taken out of contact at orientation R gives: the reading less the
tool's weight there (not the whole reading, which is what a TARE on the board takes, and
which holds at that one orientation only).
"""

import numpy as np

__all__ = ["compensate", "gravity_in_sensor", "tare_bias", "weight"]


def gravity_in_sensor(R, g):
    """R^T g (..., 3): the world's gravity ``g`` (3,) in the sensor frame, m/s^2."""
    R = np.asarray(R, dtype=float)
    return np.einsum("...ji,j->...i", R, np.asarray(g, dtype=float))


def weight(R, tool):
    """(..., 6): the force (N) and torque (N*m, about the sensor's origin) the tool's weight
    applies at orientations ``R`` (..., 3, 3)."""
    F = tool.mass_kg * gravity_in_sensor(R, tool.gravity_m_s2)
    T = np.cross(np.broadcast_to(tool.com_m, F.shape), F)
    return np.concatenate([F, T], axis=-1)


def compensate(wrench, R, tool, bias=None):
    """``wrench`` (..., 6) in N and N*m less the tool's weight at ``R`` (..., 3, 3) and less
    ``bias`` (6,) or (..., 6) (default: the tool's identified biases)."""
    b = tool.bias if bias is None else np.asarray(bias, dtype=float)
    return np.asarray(wrench, dtype=float) - weight(R, tool) - b


def tare_bias(reading, R, tool):
    """The bias (6,) of ``reading`` (6,) (N, N*m; a mean taken out of contact, or (n, 6)
    readings, averaged) at orientation ``R`` (3, 3): the reading less the tool's weight."""
    r = np.asarray(reading, dtype=float).reshape(-1, 6).mean(axis=0)
    return r - weight(np.asarray(R, dtype=float).reshape(3, 3), tool)
