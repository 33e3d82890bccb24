"""Calibration matrices are judged in float32, as SET_CAL sends them: a coefficient that
overflows or underflows float32 is named so, in one line and without a NumPy warning, and
rank and condition are those of the float32 matrix, whatever its scale."""

import json
import warnings

import numpy as np
import pytest

from tactile.calib import board_matrix, files
from tactile.errors import InputError

GOOD = [[1e-6 * (1 + (r == c)) + 1e-8 * r * c for c in range(6)] for r in range(6)]


def _write(tmp_path, name, text):
    path = tmp_path / name
    path.write_text(text)
    return path


def _csv_text(matrix):
    return "".join(",".join(repr(v) for v in row) + "\n" for row in matrix)


def _refused(path, match, **kw):
    with pytest.raises(InputError, match=match) as info:
        board_matrix.to_board(files.read(path), **kw)
    assert "\n" not in str(info.value)
    return str(info.value)


IDENTITY = np.eye(6)


@pytest.mark.parametrize(
    "scale, says",
    [
        (1e-200, r"1e-200 N per count underflows float32 .*so does every non-zero coefficient"),
        (1e200, r"1e\+200 N per count overflows float32 .*so does every non-zero coefficient"),
    ],
)
def test_a_matrix_beyond_float32_is_named_so_without_a_numpy_warning(tmp_path, cli, scale, says):
    path = _write(tmp_path, "m.json", json.dumps({"id": 1, "matrix": (IDENTITY * scale).tolist()}))
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a numpy RuntimeWarning would fail here
        msg = _refused(path, says)
        code, _, err = cli("calibrate", "--dry-run", path)
    assert "singular" not in msg and "rank" not in msg
    assert code == 2 and err.count("\n") == 1 and "Warning" not in err


@pytest.mark.parametrize("scale", [1e-30, 1e30, 1.0])
def test_any_scale_float32_holds_is_judged_by_its_shape_alone(tmp_path, scale):
    path = _write(tmp_path, "m.json", json.dumps({"id": 1, "matrix": (IDENTITY * scale).tolist()}))
    bm = board_matrix.to_board(files.read(path))
    assert bm.condition == pytest.approx(1.0)


def test_rows_that_differ_only_below_float32_are_the_same_row_as_sent(tmp_path):
    m = np.array(GOOD)
    m[4] = m[1] * (1 + 1e-9)  # in float64 condition ~1e9 (was: ill-conditioned); float32: equal
    assert (np.float32(m[4]) == np.float32(m[1])).all()
    _refused(
        _write(tmp_path, "m.csv", _csv_text(m.tolist())), r"singular \(rank 5 of 6\)", cal_id=1
    )
