"""F/T = C (g - bias) (ATI's convention, thesis ch. 5): the fixed-point definition, exact,
and its distance from the float product (NumPy)."""

import binascii
import struct
from fractions import Fraction

import numpy as np
import pytest

from tactile_fw import calibration
from tactile_fw.calibration import Calibration
from tactile_fw.storage import DirStorage, MemoryStorage


def realistic_matrix(rng):
    """A Nano17-like matrix: dominant diagonal couplings, N and N*m per 24-bit count."""
    c = rng.normal(0.0, 2e-8, (6, 6))
    c[:3] += np.diag(rng.uniform(5e-7, 2e-6, 3)) @ rng.normal(1.0, 0.3, (3, 6))
    c[3:] *= 0.02
    return c.astype(np.float32)


def exact(cal, g):
    """The fixed-point definition (calibration.py's docstring) in unbounded integers."""
    out = []
    for r in range(6):
        t = cal.shift[r] + calibration.BIAS_FRAC
        a = cal.a[6 * r : 6 * r + 6]
        total = sum(256 * a[j] * g[j] - a[j] * cal.bias_q8[j] for j in range(6))
        v = (total + (1 << (t - 1))) >> t if t > 0 else total << -t
        out.append(min(max(v, -(2**31)), 2**31 - 1))
    return out


def fixed_point_bound_un(cal, c, g, bias):
    """|fixed - float| in uN per row: A's step times |g - b|, the bias's 1/512 count, rounding.

    A_j = round(K_j 2^S) is within 2^-(S+1) of K_j = 1e6 C_j; the bias within 2^-9 counts.
    """
    step = np.array([2.0 ** -(s + 1) for s in cal.shift])
    k = np.abs(1e6 * c.astype(np.float64))
    return step * np.abs(g - bias).sum() + k.sum(axis=1) / 512 + 1.0


@pytest.mark.parametrize("seed", range(4))
def test_apply_is_the_fixed_point_definition_and_close_to_float(seed):
    rng = np.random.default_rng(seed)
    c = realistic_matrix(rng)
    n = 7
    sums = rng.integers(-1_400_000, 1_400_000, 6)
    cal = Calibration([float(v) for v in c.ravel()], cal_id=seed)
    cal.set_bias_sums([int(v) for v in sums], n)
    bias = sums / n
    out = [0] * 6
    g_all = rng.integers(-0x800000, 0x7FFFFF, (2000, 6))
    g_all[:6] = np.where(rng.random((6, 6)) < 0.5, -0x800000, 0x7FFFFF)  # full scale
    got = np.empty((2000, 6), dtype=np.int64)
    for k, g in enumerate(g_all):
        cal.apply([int(v) for v in g], out)
        assert out == exact(cal, [int(v) for v in g])
        got[k] = out
    ref = np.rint(1e6 * (c.astype(np.float64) @ (g_all - bias).T).T)
    diff = np.abs(got - ref)
    for k in range(len(g_all)):
        assert np.all(diff[k] <= fixed_point_bound_un(cal, c, g_all[k], bias))
    assert diff.max() <= 5  # uN, over the whole 24-bit range of every gauge


def test_a_float32_port_gets_the_same_integers():
    """A is decoded from the float32 bits, not computed in the port's float type."""
    a, s = calibration.fixed_row([1e-6, -2.5e-6, 3.0e-7, 0.0, -0.0, 1.4e-45])
    assert s == calibration.A_BITS - 2  # the largest, 2.5 uN/count, is below 2^2
    want = [round(Fraction(float(np.float32(v))) * 10**6 * 2**s) for v in (1e-6, 2.5e-6, 3e-7)]
    assert [abs(v) for v in a[:3]] == want and a[1] < 0 and a[3:] == [0, 0, 0]
    assert max(abs(v) for v in a) <= 2**calibration.A_BITS


@pytest.mark.parametrize("value", [0.0, 1e-30, 1e-3, 0.05, 1.0, 3e38, -3e38])
def test_extreme_matrices_follow_the_definition(value):
    """Rows of zeros, of tiny and of absurd coefficients: exact, clamped, no error."""
    rng = np.random.default_rng(3)
    cal = Calibration([value] * 36)
    cal.set_bias_sums([5, -3, 0, 1, 2, 3], 3)
    out = [0] * 6
    for g in rng.integers(-0x800000, 0x7FFFFF, (50, 6)).tolist() + [[0] * 6, [1] * 6]:
        cal.apply(g, out)
        assert out == exact(cal, g)


def test_per_sample_intermediates_stay_small_ints():
    """Below 2^30 (a small int on 32-bit MicroPython): the worst matrix and the worst codes."""
    cal = Calibration([-(2.0**-20) if k % 2 else 2.0**-20 for k in range(36)])
    cal.set_bias_sums([-0x800000] * 3 + [0x7FFFFF] * 3, 1)
    g = [0x7FFFFF, -0x800000] * 3
    gh = [v >> 12 for v in g]
    gl = [v & 0xFFF for v in g]
    for r in range(6):
        h, lo = cal.a_hi[6 * r : 6 * r + 6], cal.a_lo[6 * r : 6 * r + 6]
        sums = (
            sum(abs(h[j] * gh[j]) for j in range(6)),
            sum(abs(h[j] * gl[j]) + abs(lo[j] * gh[j]) for j in range(6)),
            sum(abs(lo[j] * gl[j]) for j in range(6)),
        )
        assert max(sums) < 2**30
        assert abs(cal._row[r][3]) < 2**29  # the offset's top limb


def test_apply_clamps_to_int32():
    cal = Calibration([1.0] * 36)  # 1 N per count: far beyond the int32 range in uN
    out = [0] * 6
    cal.apply([0x7FFFFF] * 6, out)
    assert out == [0x7FFFFFFF] * 6
    cal.apply([-0x800000] * 6, out)
    assert out == [-0x80000000] * 6


def test_identity_default_is_one_micronewton_per_count():
    cal = Calibration()
    assert not cal.present and cal.cal_id == 0
    out = [0] * 6
    cal.apply([1, -2, 3, -4, 5, -6], out)
    assert out == [1, -2, 3, -4, 5, -6]


def test_round_trip_through_a_file(tmp_path):
    rng = np.random.default_rng(7)
    c = realistic_matrix(rng)
    cal = Calibration([float(v) for v in c.ravel()], cal_id=123456789)
    store = DirStorage(str(tmp_path))
    cal.save(store, 2)
    back = calibration.load(store, 2)
    assert back.present and back.cal_id == 123456789
    assert np.array_equal(np.float32(back.coefficients()), c.ravel())
    assert not calibration.load(store, 1).present  # no file: identity


def test_the_file_holds_the_received_float32_bytes_not_a_rescaled_copy():
    """A port with single-precision floats computes scaled = c * 1e6; the file must not
    store scaled / 1e6 (an ulp away there), or the checksum INFO reports after a reboot
    would differ from the host's.  Simulated: the scaled copy is perturbed by one part in
    1e7, as a float32 round trip can; the file and the checksum still match what was sent."""
    c = [float(np.float32(1.2345678e-6 * (k + 1))) for k in range(36)]
    sent = struct.pack("<36f", *c)
    cal = Calibration(c, cal_id=9)
    cal.a[:] = [v + 1 for v in cal.a]  # the fixed-point copy is not what the file holds
    store = MemoryStorage()
    cal.save(store, 0)
    assert store.read("cal0.bin")[9 : 9 + 144] == sent  # magic 4, version 1, id 4, then C
    back = calibration.load(store, 0)
    assert back.crc == cal.crc == binascii.crc_hqx(sent, 0xFFFF)


def test_corrupt_file_is_ignored():
    store = MemoryStorage()
    Calibration([1e-6] * 36, 5).save(store, 0)
    data = bytearray(store.read("cal0.bin"))
    data[20] ^= 1
    store.files["cal0.bin"] = bytes(data)
    assert not calibration.load(store, 0).present


def test_non_finite_coefficients_are_refused():
    with pytest.raises(ValueError):
        Calibration([float("nan")] + [0.0] * 35)
    assert calibration.bad_coefficient([0.0] * 5 + [1e39]) == 5
