"""Gauge codes to force/torque: F/T = C (g - bias), ATI's convention (thesis ch. 5).

``C`` is 6x6, row-major, rows fx fy fz tx ty tz, in newtons (rows 0-2) and
newton-metres (rows 3-5) per ADC count, as float32 on the wire (SET_CAL).
Outputs are int32 in the protocol's units: 1 uN and 1 uN*m, rounded half to
even (Python's ``round``) and clamped to int32.  ``bias`` holds gauge codes
captured by TARE (kept in RAM, as ATI's bias is).  The matrix and its id live
in ``cal<N>.bin`` on the board; a sensor without a file gets the identity
(1 uN per count) with id 0 and the host is told FAULT_NO_CALIBRATION.

``raw`` keeps the 36 coefficients as float32 bytes, exactly as SET_CAL carried them, and
``crc`` their checksum (``cal_checksum``), which HELLO/INFO report so the host can verify
the matrix, not only its id.  The file is written from ``raw``: on a port whose floats
are single precision, ``scaled / SCALE`` need not give the received float32 back.
"""

import struct

from tactile_protocol.crc16 import crc16
from tactile_protocol.messages import CAL_COEFFS_FMT

N = 6
SCALE = 1e6  # N -> uN, N*m -> uN*m
INT32_MAX = 0x7FFFFFFF
INT32_MIN = -0x80000000
_MAGIC = b"TCAL"
_FMT = "<4sBI36f"  # magic, format version, cal_id, C row-major
_HEAD = "<4sBI"
_SIZE = struct.calcsize(_FMT)
_FLOAT32_MAX = 3.4028234663852886e38


def file_name(sensor):
    return "cal%d.bin" % sensor


def identity():
    return [1e-6 if r == c else 0.0 for r in range(N) for c in range(N)]


def bad_coefficient(coeffs):
    """Index of the first non-finite or non-float32 coefficient, else -1."""
    for k in range(len(coeffs)):
        v = coeffs[k]
        if v != v or v > _FLOAT32_MAX or v < -_FLOAT32_MAX:
            return k
    return -1


class Calibration:
    def __init__(self, coeffs=None, cal_id=0):
        self.scaled = [0.0] * (N * N)
        self.bias = [0.0] * N
        self.cal_id = 0
        self.raw = b""
        self.crc = 0
        self.present = False
        self.set(identity() if coeffs is None else coeffs, cal_id)
        self.present = coeffs is not None

    def set(self, coeffs, cal_id):
        if len(coeffs) != N * N or bad_coefficient(coeffs) >= 0:
            raise ValueError("calibration: need 36 finite float32 coefficients")
        for k in range(N * N):
            self.scaled[k] = coeffs[k] * SCALE
        self.raw = struct.pack(CAL_COEFFS_FMT, *coeffs)
        self.crc = crc16(self.raw)
        self.cal_id = cal_id
        self.present = True

    def coefficients(self):
        """The 36 coefficients as float32 values, as received (row-major)."""
        return list(struct.unpack(CAL_COEFFS_FMT, self.raw))

    def apply(self, counts, out):
        """out[r] = round(1e6 * sum_c C[r][c] (counts[c] - bias[c])), clamped to int32."""
        b = self.bias
        m = self.scaled
        d0 = counts[0] - b[0]
        d1 = counts[1] - b[1]
        d2 = counts[2] - b[2]
        d3 = counts[3] - b[3]
        d4 = counts[4] - b[4]
        d5 = counts[5] - b[5]
        k = 0
        for r in range(N):
            v = m[k] * d0 + m[k + 1] * d1 + m[k + 2] * d2 + m[k + 3] * d3 + m[k + 4] * d4
            v += m[k + 5] * d5
            if v >= INT32_MAX:
                out[r] = INT32_MAX
            elif v <= INT32_MIN:
                out[r] = INT32_MIN
            else:
                out[r] = round(v)
            k += N

    # --- persistence --------------------------------------------------------------
    def to_bytes(self, sensor):
        body = struct.pack(_HEAD, _MAGIC, 1, self.cal_id) + self.raw
        crc = crc16(body)
        return body + bytes((crc & 0xFF, crc >> 8))

    def save(self, storage, sensor):
        storage.write(file_name(sensor), self.to_bytes(sensor))


def load(storage, sensor):
    """The stored calibration of ``sensor``, or the identity if absent/corrupt."""
    data = storage.read(file_name(sensor))
    cal = Calibration()
    if data is None or len(data) != _SIZE + 2:
        return cal
    if crc16(data, 0, _SIZE) != data[_SIZE] | (data[_SIZE + 1] << 8):
        return cal
    fields = struct.unpack(_FMT, data[:_SIZE])
    if fields[0] != _MAGIC or fields[1] != 1:
        return cal
    try:
        cal.set(fields[3:], fields[2])
    except ValueError:
        return Calibration()
    return cal
