"""Loading a ``BoardMatrix`` onto a board and verifying it through INFO (PROTOCOL.md §4).

SET_CAL carries the sensor, the id and the 36 float32 coefficients; the board stores them
and ACKs (or NAKs, naming the field).  An ACK says the frame arrived; INFO then says what
the sensor applies: its ``cal_id_N`` and ``cal_crc_N``, a CRC-16 of the coefficients as the
board holds them.  Both must equal what was sent, or the load is reported as failed
(``BoardError``, exit 4): a board that kept an older matrix under the same id fails too.
"""

from tactile.errors import BoardError, InputError

__all__ = ["CalibrationNotApplied", "install", "check_sensor"]


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
