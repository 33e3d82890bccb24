"""F/T = C (g - bias) (ATI's convention, thesis ch. 5) against a NumPy reference."""

import binascii
import struct

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


@pytest.mark.parametrize("seed", range(4))
def test_apply_matches_numpy(seed):
    rng = np.random.default_rng(seed)
    c = realistic_matrix(rng)
    bias = rng.integers(-200_000, 200_000, 6)
    cal = Calibration([float(v) for v in c.ravel()], cal_id=seed)
    cal.bias[:] = [float(b) for b in bias]
    out = [0] * 6
    g_all = rng.integers(-0x800000, 0x7FFFFF, (2000, 6))
    got = np.empty((2000, 6), dtype=np.int64)
    for k, g in enumerate(g_all):
        cal.apply([int(v) for v in g], out)
        got[k] = out
    ref = np.rint(1e6 * (c.astype(np.float64) @ (g_all - bias).T).T).astype(np.int64)
    assert np.abs(got - ref).max() <= 1  # summation order differs only in the last bit
    assert np.mean(got == ref) > 0.999


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
    cal.scaled[:] = [v * (1 + 1e-7) for v in cal.scaled]  # what float32 arithmetic may leave
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
