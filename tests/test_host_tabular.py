"""The shared CSV reader and JSON writer: exact error locations, no NaN ever written."""

import json
import math

import numpy as np
import pytest

from tactile.errors import InputError
from tactile.jsonout import clean, dumps
from tactile.tabular import read_csv

REQ = ("x", "y", "z")


def _write(tmp_path, text):
    path = tmp_path / "data.csv"
    path.write_text(text)
    return path


def test_reads_columns_skips_comments_and_ignores_extras(tmp_path):
    path = _write(tmp_path, "# a comment\nx,y,z,note,finger\n1,2,3,hi,A\n\n# mid\n4,5,6,,B\n")
    table = read_csv(path, REQ, optional_text=("finger", "patch"))
    assert len(table) == 2 and table.lines == [3, 6]
    assert table.columns["finger"] == ["A", "B"] and "patch" not in table.columns
    np.testing.assert_array_equal(table.array("x", "z"), [[1, 3], [4, 6]])


@pytest.mark.parametrize(
    "text, expect",
    [
        ("x,y\n1,2\n", r"data\.csv:1: missing required column\(s\) z"),
        ("x,y,z\n1,2,abc\n", r"data\.csv:2: column 'z': not a number: 'abc'"),
        ("x,y,z\n1,2,3\n1,nan,3\n", r"data\.csv:3: column 'y': not a finite number"),
        ("x,y,z\n1,inf,3\n", r"data\.csv:2: column 'y': not a finite number"),
        ("x,y,z\n1,2\n", r"data\.csv:2: column 'z': missing value"),
        ("", r"empty file"),
        ("# only\nx,y,z\n", r"no data rows"),
    ],
)
def test_errors_name_file_line_and_column(tmp_path, text, expect):
    with pytest.raises(InputError, match=expect) as exc:
        read_csv(_write(tmp_path, text), REQ)
    assert "\n" not in str(exc.value) and exc.value.exit_code == 2


def test_unreadable_file_and_bad_encoding(tmp_path):
    with pytest.raises(InputError, match="cannot read"):
        read_csv(tmp_path / "missing.csv", REQ)
    path = tmp_path / "bin.csv"
    path.write_bytes(b"x,y,z\n\xff\xfe,1,2\n")
    with pytest.raises(InputError, match="not valid CSV"):
        read_csv(path, REQ)


def test_json_never_contains_nan():
    obj = {"a": math.nan, "b": [np.float64("inf"), np.int64(3)], "c": np.array([1.5, np.nan])}
    line = dumps(obj)
    assert json.loads(line) == {"a": None, "b": [None, 3], "c": [1.5, None]}
    assert "NaN" not in line and "Infinity" not in line
    assert clean((1, b"ab\x00")) == [1, "ab\x00"]
    with pytest.raises(TypeError):
        dumps({"x": object()})
