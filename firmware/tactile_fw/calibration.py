"""Gauge codes to force/torque: F/T = C (g - bias), ATI's convention (thesis ch. 5).

``C`` is 6x6, row-major, rows fx fy fz tx ty tz, in newtons (rows 0-2) and
newton-metres (rows 3-5) per ADC count, as float32 on the wire (SET_CAL).
Outputs are int32 in the protocol's units: 1 uN and 1 uN*m, clamped to int32.
``bias`` holds the gauge codes captured by TARE (kept in RAM, as ATI's bias
is).  The matrix and its id live in ``cal<N>.bin`` on the board; a sensor
without a file gets the identity (1 uN per count) with id 0 and the host is
told FAULT_NO_CALIBRATION.

Integer fixed point, identical here, on MicroPython and in the C core
(``firmware/c/tc_cal.c``), so the two boards agree bit for bit
(docs/firmware.md, "Calibration in fixed point"):

- row r of C in uN per count, K = 1e6 C, becomes integers A_j = round(K_j 2^S_r),
  with S_r the largest shift that keeps |A_j| <= 2^26 (at most ``S_MAX``); the
  float32 bits are decoded with integer arithmetic, so a float32 port gets the
  same A as a double one;
- the bias is kept in 1/256 counts: b_j = round(256 sum / n);
- out_r = floor((256 sum_j A_j g_j - sum_j A_j b_j + 2^(T-1)) / 2^T), T = S_r + 8,
  clamped to int32 (rounding half up).

Per sample every intermediate stays below 2^30, a small int on 32-bit
MicroPython ports, so calibrating allocates nothing: g = gh 2^12 + gl and
A = Ah 2^12 + Al (gl, Al in 0..4095), three sums of products, carries.

``raw`` keeps the 36 coefficients as float32 bytes, exactly as SET_CAL carried them, and
``crc`` their checksum (``cal_checksum``), which HELLO/INFO report so the host can verify
the matrix, not only its id.  The file is written from ``raw``.
"""

import struct

from tactile_protocol.crc16 import crc16
from tactile_protocol.messages import CAL_COEFFS_FMT

N = 6
INT32_MAX = 0x7FFFFFFF
INT32_MIN = -0x80000000
A_BITS = 26  # |A| <= 2^26: the per-sample sums stay below 2^30 (module docstring)
S_MAX = 40  # a row of tiny coefficients: finer steps than this are not kept
BIAS_FRAC = 8  # the bias in 1/256 counts
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


def micro_units(value):
    """A float32 value times 1e6 as ``(sign, P, e)``: 1e6 value = sign P 2^e, P an integer.

    From the float32 bits, so that ports computing in float32 and in double agree.
    """
    bits = struct.unpack("<I", struct.pack("<f", value))[0]
    sign = -1 if bits >> 31 else 1
    exp = (bits >> 23) & 0xFF
    frac = bits & 0x7FFFFF
    if exp == 0:
        return sign, frac * 1000000, -149
    return sign, (frac | 0x800000) * 1000000, exp - 150


def _round_shift(p, k):
    """round(p 2^k) for p >= 0, halves up."""
    if k >= 0:
        return p << k
    return (p + (1 << (-k - 1))) >> -k


def fixed_row(coeffs):
    """(A, S) for one row of six float32 coefficients (module docstring)."""
    parts = [micro_units(v) for v in coeffs]
    top = None
    for _, p, e in parts:
        if p:
            length = _bit_length(p) + e  # 1e6 |v| < 2^length
            top = length if top is None or length > top else top
    s = S_MAX if top is None else min(S_MAX, A_BITS - top)
    return [sign * _round_shift(p, e + s) for sign, p, e in parts], s


def _bit_length(p):
    n = 0
    while p:
        p >>= 1
        n += 1
    return n


class Calibration:
    def __init__(self, coeffs=None, cal_id=0):
        self.raw = b""
        self.crc = 0
        self.a_hi = [0] * (N * N)  # A >> 12
        self.a_lo = [0] * (N * N)  # A & 0xFFF
        self.a = [0] * (N * N)
        self.shift = [0] * N  # S per row
        self.bias_q8 = [0] * N  # TARE bias in 1/256 counts
        self._row = [None] * N  # per row: (c1, c2, c3, T) constants, see _offsets
        self.cal_id = 0
        self.present = False
        self.set(identity() if coeffs is None else coeffs, cal_id)
        self.present = coeffs is not None

    def set(self, coeffs, cal_id):
        if len(coeffs) != N * N or bad_coefficient(coeffs) >= 0:
            raise ValueError("calibration: need 36 finite float32 coefficients")
        for r in range(N):
            a, s = fixed_row(coeffs[N * r : N * r + N])
            self.shift[r] = s
            for j in range(N):
                k = N * r + j
                self.a[k] = a[j]
                self.a_hi[k] = a[j] >> 12
                self.a_lo[k] = a[j] & 0xFFF
        self.raw = struct.pack(CAL_COEFFS_FMT, *coeffs)
        self.crc = crc16(self.raw)
        self.cal_id = cal_id
        self.present = True
        self._offsets()

    def coefficients(self):
        """The 36 coefficients as float32 values, as received (row-major)."""
        return list(struct.unpack(CAL_COEFFS_FMT, self.raw))

    # --- bias (TARE) ----------------------------------------------------------------
    def set_bias_sums(self, sums, n):
        """bias = sums / n gauge counts, kept as round(256 sums / n) (halves up)."""
        for j in range(N):
            self.bias_q8[j] = (2 * (sums[j] << BIAS_FRAC) + n) // (2 * n)
        self._offsets()

    def set_bias(self, counts):
        self.set_bias_sums(counts, 1)

    def bias_counts(self):
        return [b / (1 << BIAS_FRAC) for b in self.bias_q8]

    def offset(self, r):
        """O_r = sum_j A_j b_j - 2^(T-1) (the rounding half folded in), exact."""
        t = self.shift[r] + BIAS_FRAC
        o = 0
        for j in range(N):
            o += self.a[N * r + j] * self.bias_q8[j]
        return o - (1 << (t - 1)) if t > 0 else o

    def _offsets(self):
        """Split -O_r over the limbs of 256 sum A g = HH 2^32 + MID 2^20 + LL 2^8."""
        for r in range(N):
            neg = -self.offset(r)
            r0 = neg & 0xFF
            rest = neg >> 8
            c1 = rest & 0xFFF
            rest >>= 12
            c2 = rest & 0xFFF
            c3 = rest >> 12
            self._row[r] = (r0, c1, c2, c3, self.shift[r] + BIAS_FRAC)

    # --- per sample -----------------------------------------------------------------
    def apply(self, counts, out):
        """out[r] = round((1e6 C (counts - bias))[r]) in fixed point, clamped to int32."""
        gh0 = counts[0] >> 12
        gh1 = counts[1] >> 12
        gh2 = counts[2] >> 12
        gh3 = counts[3] >> 12
        gh4 = counts[4] >> 12
        gh5 = counts[5] >> 12
        gl0 = counts[0] & 0xFFF
        gl1 = counts[1] & 0xFFF
        gl2 = counts[2] & 0xFFF
        gl3 = counts[3] & 0xFFF
        gl4 = counts[4] & 0xFFF
        gl5 = counts[5] & 0xFFF
        ah = self.a_hi
        al = self.a_lo
        k = 0
        for r in range(N):
            h0 = ah[k]
            h1 = ah[k + 1]
            h2 = ah[k + 2]
            h3 = ah[k + 3]
            h4 = ah[k + 4]
            h5 = ah[k + 5]
            l0 = al[k]
            l1 = al[k + 1]
            l2 = al[k + 2]
            l3 = al[k + 3]
            l4 = al[k + 4]
            l5 = al[k + 5]
            hh = h0 * gh0 + h1 * gh1 + h2 * gh2 + h3 * gh3 + h4 * gh4 + h5 * gh5
            mid = h0 * gl0 + h1 * gl1 + h2 * gl2 + h3 * gl3 + h4 * gl4 + h5 * gl5
            mid += l0 * gh0 + l1 * gh1 + l2 * gh2 + l3 * gh3 + l4 * gh4 + l5 * gh5
            ll = l0 * gl0 + l1 * gl1 + l2 * gl2 + l3 * gl3 + l4 * gl4 + l5 * gl5
            out[r] = _finish(hh, mid, ll, self._row[r])
            k += N

    # --- persistence --------------------------------------------------------------
    def to_bytes(self, sensor):
        body = struct.pack(_HEAD, _MAGIC, 1, self.cal_id) + self.raw
        crc = crc16(body)
        return body + bytes((crc & 0xFF, crc >> 8))

    def save(self, storage, sensor):
        storage.write(file_name(sensor), self.to_bytes(sensor))


def _finish(hh, mid, ll, row):
    """floor(total / 2^T) clamped to int32, total = 256 (HH 2^24 + MID 2^12 + LL) - O."""
    r0, c1, c2, c3, t = row
    a1 = ll + c1
    a2 = mid + c2 + (a1 >> 12)
    a3 = hh + c3 + (a2 >> 12)
    # total = a3 2^32 + r2 2^20 + r1 2^8 + r0, with r2 = a2 & 4095, r1 = a1 & 4095
    if t >= 32:
        return a3 >> (t - 32)
    if t > 0:
        if a3 >= 1 << (t - 1):
            return INT32_MAX
        if a3 < -(1 << (t - 1)):
            return INT32_MIN
        if t >= 20:
            return (a3 << (32 - t)) + ((a2 & 0xFFF) >> (t - 20))
        low = ((a2 & 0xFFF) << 12 | (a1 & 0xFFF)) << 8 | r0  # < 2^32: only for S < 12
        return (a3 << (32 - t)) + (low >> t)
    # T <= 0: coefficients of 0.5 N per count and more; exact, whatever it allocates
    v = ((((((a3 << 12) + (a2 & 0xFFF)) << 12) + (a1 & 0xFFF)) << 8) + r0) << -t
    return INT32_MAX if v > INT32_MAX else INT32_MIN if v < INT32_MIN else v


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
