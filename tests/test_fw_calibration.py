"""F/T = C (g - bias) (ATI's convention, thesis ch. 5) against a NumPy reference."""

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
