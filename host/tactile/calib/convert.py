"""A file's matrix in the board's convention, checked: what SET_CAL sends (PROTOCOL.md §4).

The firmware computes F/T = C (g - bias) with ``g`` the six ADC codes of a sensor
(``tactile_fw.calibration``), so ``C`` is in N per count (rows fx fy fz) and N*m per count
(rows tx ty tz), columns gauges g0..g5 = converters 0..5 of the sensor.  A file's matrix
``M`` in FORCE and TORQUE units per gauge unit becomes

    C[r][j] = M[r][j] * unit[r] * v            unit[r] = N per FORCE (r < 3), N*m per TORQUE
                                              v = 1 for a matrix per count, else the
                                                  gauge volts one count stands for

(ATI calibrates in volts, so an ATI matrix needs ``volts_per_count``, docs/calibration.md).

Refused: a matrix whose rows, each scaled to unit length, have a condition number above
``MAX_CONDITION`` (or are singular), and a coefficient that float32 (SET_CAL's type) cannot
hold.  Scaling the rows first makes the number independent of the units (N or lbf, N*m or
N*mm) and of ``v``; real ATI matrices come out near 1 to 3 (docs/calibration.md).  Above
1e4, float32's relative rounding (2^-24) can already grow to 6e-4 of a reading.
"""

from collections import namedtuple

import numpy as np

from tactile.calib import units as U
from tactile.calib.files import GAUGES, ROWS, check_id
from tactile.errors import InputError
from tactile_protocol.messages import cal_checksum

__all__ = ["BoardMatrix", "MAX_CONDITION", "to_board", "condition"]

MAX_CONDITION = 1e4
FLOAT32_TINY = float(np.finfo(np.float32).tiny)  # the smallest normal float32
FLOAT32_MAX = float(np.finfo(np.float32).max)

BoardMatrix = namedtuple("BoardMatrix", "cal_id coeffs crc condition source")
BoardMatrix.__doc__ = """What SET_CAL sends: ``coeffs`` are 36 float32 values (as Python
floats, row-major, N or N*m per count), ``crc`` their ``cal_checksum`` (INFO's cal_crc),
``condition`` the row-scaled condition number, ``source`` the ``MatrixFile``."""


def condition(matrix):
    """(condition number of ``matrix`` with rows scaled to unit length, rank).

    Singular values by SVD; rank counts those above 6 eps times the largest.  A zero row is
    rank deficient (its condition number is returned as None, as for any singular matrix).
    """
    a = np.asarray(matrix, dtype=float)
    norms = np.linalg.norm(a, axis=1)
    if not np.all(norms > 0):
        return None, int(np.linalg.matrix_rank(a))
    s = np.linalg.svd(a / norms[:, None], compute_uv=False)
    rank = int(np.sum(s > s[0] * 6 * np.finfo(float).eps))
    if rank < 6:
        return None, rank
    return float(s[0] / s[-1]), rank


def si_per_count(mf, volts_per_count=None):
    """The file's matrix in N and N*m per count (float64), or InputError."""
    gauge_v = U.gauge_factor(mf.units.gauge)
    if gauge_v is None and volts_per_count is not None:
        raise InputError(
            f"--volts-per-count: {mf.path}'s matrix is per ADC count already"
            f" ({U.describe(mf.units)}); leave the option out"
        )
    if gauge_v is not None and volts_per_count is None:
        raise InputError(
            f"--volts-per-count: needed: {mf.path}'s matrix takes gauge volts"
            f" ({U.describe(mf.units)}); give the volts one ADC count stands for,"
            " V_excitation / (128 x 2^23) times any amplifier gain (docs/calibration.md)"
        )
    if volts_per_count is not None and not (0 < volts_per_count < float("inf")):
        raise InputError("--volts-per-count: must be a positive, finite number of volts")
    rows = [U.force_factor(mf.units.force)] * 3 + [U.torque_factor(mf.units.torque)] * 3
    per_gauge = 1.0 if gauge_v is None else gauge_v * volts_per_count
    return np.asarray(mf.matrix, dtype=float) * np.asarray(rows)[:, None] * per_gauge


def to_board(mf, volts_per_count=None, cal_id=None):
    """The ``BoardMatrix`` for ``MatrixFile`` ``mf``; ``cal_id`` overrides the file's id."""
    if cal_id is not None:
        cal_id = check_id(cal_id, "--id")
    elif mf.cal_id is None:
        raise InputError(f"--id: needed: {mf.path} carries no calibration id")
    else:
        cal_id = mf.cal_id
    kappa, rank = condition(mf.matrix)
    if kappa is None:
        raise InputError(f"{mf.path}: the matrix is singular (rank {rank} of 6): refused")
    if kappa > MAX_CONDITION:
        raise InputError(
            f"{mf.path}: the matrix is ill-conditioned: condition number {kappa:.3g} (rows"
            f" scaled to unit length) is above {MAX_CONDITION:g}: refused"
        )
    si = si_per_count(mf, volts_per_count)
    with np.errstate(over="ignore"):
        f32 = si.astype(np.float32)
    for r in range(6):
        for j in range(6):
            v, w = float(si[r, j]), float(f32[r, j])
            if abs(w) > FLOAT32_MAX or (v != 0 and abs(w) < FLOAT32_TINY):
                unit = "N" if r < 3 else "N*m"
                raise InputError(
                    f"{mf.places[r]}, column {j + 1} ({GAUGES[j]}): {v:.3g} {unit} per count"
                    " is outside float32's range (SET_CAL's type)"
                )
    coeffs = tuple(float(v) for v in f32.ravel())
    return BoardMatrix(cal_id, coeffs, cal_checksum(coeffs), kappa, mf)


def table(coeffs):
    """The matrix as text lines, every row with its unit (N or N*m per count)."""
    lines = ["        " + "".join(f"{g:>13}" for g in GAUGES)]
    for r in range(6):
        row = coeffs[6 * r : 6 * r + 6]
        unit = "N/count" if r < 3 else "N*m/count"
        lines.append(f"{ROWS[r]:<6}  " + "".join(f"{v:>13.6g}" for v in row) + f"  {unit}")
    return lines
