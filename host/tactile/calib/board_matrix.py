"""A file's matrix in the board's convention, checked: what SET_CAL sends (PROTOCOL.md §4).

The firmware computes F/T = C (g - bias) with ``g`` the six ADC codes of a sensor
(``tactile_fw.calibration``), so ``C`` is in N per count (rows fx fy fz) and N*m per count
(rows tx ty tz), columns gauges g0..g5 = converters 0..5 of the sensor.  A file's matrix
``M`` in FORCE and TORQUE units per gauge unit becomes

    C[r][j] = M[r][j] * unit[r] * v            unit[r] = N per FORCE (r < 3), N*m per TORQUE
                                              v = 1 for a matrix per count, else the
                                                  gauge volts one count stands for

(ATI calibrates in volts, so an ATI matrix needs ``volts_per_count``, docs/calibration.md).

The matrix is judged as sent, in float32 (SET_CAL's type).  Refused: a coefficient that
overflows float32 or, non-zero, underflows it (a matrix times 1e-200 would arrive as
zeros); then a matrix whose rows, each scaled to unit length, have a condition number above
``MAX_CONDITION`` or a rank below 6 (singular values above 6 float32 eps of the largest,
so the tolerance follows the matrix's own scale).  Scaling the rows first makes the number
independent of the units (N or lbf, N*m or N*mm) and of ``v``; real ATI matrices come out
near 1 to 3 (docs/calibration.md).  Above 1e4, float32's relative rounding (2^-24) can
already grow to 6e-4 of a reading.

Loading a ``BoardMatrix`` onto a board and verifying it through INFO (PROTOCOL.md §4):
SET_CAL carries the sensor, the id and the 36 float32 coefficients; the board stores them
and ACKs (or NAKs, naming the field).  An ACK says the frame arrived; INFO then says what
the sensor applies: its ``cal_id_N`` and ``cal_crc_N``, a CRC-16 of the coefficients as the
board holds them.  Both must equal what was sent, or the load is reported as failed
(``BoardError``, exit 4): a board that kept an older matrix under the same id fails too.
"""

from collections import namedtuple

import numpy as np

from tactile.calib import describe, force_factor, gauge_factor, torque_factor
from tactile.calib.files import GAUGES, ROWS, check_id
from tactile.errors import BoardError, InputError
from tactile_protocol.messages import cal_checksum

__all__ = [
    "BoardMatrix",
    "MAX_CONDITION",
    "to_board",
    "condition",
    "CalibrationNotApplied",
    "install",
    "check_sensor",
]

MAX_CONDITION = 1e4
FLOAT32_TINY = float(np.finfo(np.float32).tiny)  # the smallest normal float32
FLOAT32_MAX = float(np.finfo(np.float32).max)
FLOAT32_EPS = float(np.finfo(np.float32).eps)

BoardMatrix = namedtuple("BoardMatrix", "cal_id coeffs crc condition source")
BoardMatrix.__doc__ = """What SET_CAL sends: ``coeffs`` are 36 float32 values (as Python
floats, row-major, N or N*m per count), ``crc`` their ``cal_checksum`` (INFO's cal_crc),
``condition`` the row-scaled condition number, ``source`` the ``MatrixFile``."""


def condition(matrix):
    """(condition number of ``matrix`` with rows scaled to unit length, rank).

    Singular values by SVD of the row-scaled matrix (a zero row stays zero); rank counts
    those above 6 float32 eps (2^-23) times the largest, float32 being what the board
    holds.  A rank below 6 gives None for the condition number."""
    a = np.asarray(matrix, dtype=float)
    norms = np.linalg.norm(a, axis=1)
    s = np.linalg.svd(a / np.where(norms > 0, norms, 1.0)[:, None], compute_uv=False)
    rank = int(np.sum(s > s[0] * 6 * FLOAT32_EPS)) if s[0] > 0 else 0
    if rank < 6:
        return None, rank
    return float(s[0] / s[-1]), rank


def si_per_count(mf, volts_per_count=None):
    """The file's matrix in N and N*m per count (float64), or InputError."""
    gauge_v = gauge_factor(mf.units.gauge)
    if gauge_v is None and volts_per_count is not None:
        raise InputError(
            f"--volts-per-count: {mf.path}'s matrix is per ADC count already"
            f" ({describe(mf.units)}); leave the option out"
        )
    if gauge_v is not None and volts_per_count is None:
        raise InputError(
            f"--volts-per-count: needed: {mf.path}'s matrix takes gauge volts"
            f" ({describe(mf.units)}); give the volts one ADC count stands for,"
            " V_excitation / (128 x 2^23) times any amplifier gain (docs/calibration.md)"
        )
    if volts_per_count is not None and not (0 < volts_per_count < float("inf")):
        raise InputError("--volts-per-count: must be a positive, finite number of volts")
    rows = [force_factor(mf.units.force)] * 3 + [torque_factor(mf.units.torque)] * 3
    per_gauge = 1.0 if gauge_v is None else gauge_v * volts_per_count
    with np.errstate(over="ignore", under="ignore"):  # as_float32 names what float32 refuses
        return np.asarray(mf.matrix, dtype=float) * np.asarray(rows)[:, None] * per_gauge


def to_board(mf, volts_per_count=None, cal_id=None):
    """The ``BoardMatrix`` for ``MatrixFile`` ``mf``; ``cal_id`` overrides the file's id."""
    if cal_id is not None:
        cal_id = check_id(cal_id, "--id")
    elif mf.cal_id is None:
        raise InputError(f"--id: needed: {mf.path} carries no calibration id")
    else:
        cal_id = mf.cal_id
    f32 = as_float32(mf, si_per_count(mf, volts_per_count))
    kappa, rank = condition(f32)  # judged as sent
    if kappa is None:
        raise InputError(f"{mf.path}: the matrix is singular (rank {rank} of 6): refused")
    if kappa > MAX_CONDITION:
        raise InputError(
            f"{mf.path}: the matrix is ill-conditioned: condition number {kappa:.3g} (rows"
            f" scaled to unit length) is above {MAX_CONDITION:g}: refused"
        )
    coeffs = tuple(float(v) for v in f32.ravel())
    return BoardMatrix(cal_id, coeffs, cal_checksum(coeffs), kappa, mf)


def as_float32(mf, si):
    """``si`` (N and N*m per count) rounded to float32, SET_CAL's type; ``InputError``
    naming the first coefficient that overflows it (above 3.4e38) or underflows it
    (non-zero, below 1.2e-38), and saying when every non-zero one does."""
    with np.errstate(over="ignore", under="ignore", invalid="ignore"):
        f32 = si.astype(np.float32)
    nonzero = si != 0
    over = ~np.isfinite(f32)
    under = nonzero & (np.abs(f32) < FLOAT32_TINY)
    for bad, word, limit in (
        (over, "overflows", f"above {FLOAT32_MAX:.3g}"),
        (under, "underflows", f"non-zero below {FLOAT32_TINY:.3g}"),
    ):
        if bad.any():
            r, j = (int(k) for k in np.argwhere(bad)[0])
            v = float(si[r, j])
            value = f"{v:.3g}" if np.isfinite(v) else "beyond 1.8e308"
            unit = "N" if r < 3 else "N*m"
            every = "; so does every non-zero coefficient" if bad.sum() == nonzero.sum() else ""
            raise InputError(
                f"{mf.places[r]}, column {j + 1} ({GAUGES[j]}): {value} {unit} per count"
                f" {word} float32 ({limit}, SET_CAL's type){every}: refused"
            )
    return f32.astype(float)


def table(coeffs):
    """The matrix as text lines, every row with its unit (N or N*m per count)."""
    lines = ["        " + "".join(f"{g:>13}" for g in GAUGES)]
    for r in range(6):
        row = coeffs[6 * r : 6 * r + 6]
        unit = "N/count" if r < 3 else "N*m/count"
        lines.append(f"{ROWS[r]:<6}  " + "".join(f"{v:>13.6g}" for v in row) + f"  {unit}")
    return lines


class CalibrationNotApplied(BoardError):
    """The board ACKed SET_CAL but INFO does not report the matrix that was sent."""


def check_sensor(sensor, n_sensors):
    """``sensor`` (an int, or None when not given) checked against the board's sensor count.

    With several sensors the user must say which one: each transducer has its own matrix.
    """
    plural = f"{n_sensors} sensor{'s' * (n_sensors != 1)}"
    if sensor is None:
        if n_sensors == 1:
            return 0
        raise InputError(
            f"--sensor: needed: the board has {plural} (0..{n_sensors - 1}); say which"
            " transducer this matrix belongs to"
        )
    if not 0 <= sensor < n_sensors:
        raise InputError(f"--sensor: {sensor}, but the board has {plural} (0..{n_sensors - 1})")
    return sensor


def install(client, board_matrix, sensor=None, timeout=2.0):
    """SET_CAL ``board_matrix`` onto ``sensor`` of ``client``'s board; return the INFO after.

    ``sensor`` None means the only one (InputError if the board has several).
    """
    before = client.get_info()
    sensor = check_sensor(sensor, before.n_sensors)
    client.set_calibration(sensor, board_matrix.cal_id, board_matrix.coeffs, timeout=timeout)
    after = client.get_info()
    got = (getattr(after, f"cal_id_{sensor}"), getattr(after, f"cal_crc_{sensor}"))
    want = (board_matrix.cal_id, board_matrix.crc)
    if got != want:
        raise CalibrationNotApplied(
            f"{client.name}: sensor {sensor} reports calibration id {got[0]} (checksum"
            f" 0x{got[1]:04x}) after SET_CAL was acknowledged; sent id {want[0]} (checksum"
            f" 0x{want[1]:04x}): the board does not apply the matrix sent"
        )
    return sensor, after
