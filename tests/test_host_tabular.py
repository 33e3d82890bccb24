"""The shared CSV reader and JSON writer: exact error locations, no NaN ever written."""

import json
import math
import os
import pathlib

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from tactile.errors import InputError
from tactile.files import csv_dialect, tabular
from tactile.files.tabular import read_csv
from tactile.output.text import clean, dumps

REQ = ("x", "y", "z")


def _write(tmp_path, text):
    path = tmp_path / "data.csv"
    path.write_text(text)
    return path


def test_reads_columns_skips_comments_and_ignores_extras(tmp_path):
    path = _write(tmp_path, "# a comment\nx,y,z,note,finger\n1,2,3,hi,A\n\n# mid\n4,5,6,,B\n")
    table = read_csv(path, REQ, optional_text=("finger", "patch"))
    assert len(table) == 2 and list(table.lines) == [3, 6]
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
        ("", r"data\.csv:1: no header row \(the file is empty"),
        ("# only\n\n", r"data\.csv:1: no header row"),
        ("# only\nx,y,z\n", r"data\.csv:2: no data rows"),
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
    path.write_bytes(b"x,y,z\n1,2,3\n\xff\xfe,1,2\n")
    with pytest.raises(InputError, match=r"bin\.csv:3: not UTF-8 text \(byte 0xff at byte 1"):
        read_csv(path, REQ)  # at its own line (it was line 0)


def test_json_never_contains_nan():
    obj = {"a": math.nan, "b": [np.float64("inf"), np.int64(3)], "c": np.array([1.5, np.nan])}
    line = dumps(obj)
    assert json.loads(line) == {"a": None, "b": [None, 3], "c": [1.5, None]}
    assert "NaN" not in line and "Infinity" not in line
    assert clean((1, b"ab\x00")) == [1, "ab\x00"]
    with pytest.raises(TypeError):
        dumps({"x": object()})


# -- issue 12: Excel files, bounded reading, user text in messages --------------------------


def test_excel_csv_utf8_with_its_byte_order_mark_is_read(tmp_path):
    path = tmp_path / "excel.csv"
    path.write_bytes(b"\xef\xbb\xbfx,y,z\r\n1,2,3\r\n4,5,6\r\n")  # Excel's "CSV UTF-8"
    table = read_csv(path, REQ)
    assert list(table.lines) == [2, 3]
    np.testing.assert_array_equal(table.array(*REQ), [[1, 2, 3], [4, 5, 6]])


@pytest.mark.parametrize("eol", [b"\n", b"\r\n", b"\r"])
@pytest.mark.parametrize("chunk", [3, 7, 1 << 16])
def test_line_endings_and_numbers_survive_any_chunking(tmp_path, monkeypatch, eol, chunk):
    monkeypatch.setattr(tabular, "BLOCK_BYTES", chunk)  # lines and CR LF pairs cut across reads
    rows = [b"# c", b"x,y,z", b"1,2,3", b"", b"4,5,6"]
    path = tmp_path / "e.csv"
    path.write_bytes(eol.join(rows) + eol)
    table = read_csv(path, REQ)
    assert list(table.lines) == [3, 5]
    np.testing.assert_array_equal(table.array(*REQ), [[1, 2, 3], [4, 5, 6]])


def test_utf16_is_named_as_such(tmp_path):
    path = tmp_path / "u16.csv"
    path.write_bytes("x,y,z\n1,2,3\n".encode("utf-16"))
    with pytest.raises(InputError, match=r"u16\.csv:1: UTF-16 text; save it as 'CSV UTF-8'"):
        read_csv(path, REQ)


def test_a_huge_line_is_refused_at_its_line_without_reading_it_all(tmp_path):
    path = tmp_path / "long.csv"
    path.write_bytes(b"x,y,z\n1,2,3\n" + b"7" * (tabular.MAX_LINE_BYTES + 1) + b",1,2\n")
    with pytest.raises(InputError, match=r"long\.csv:3: line longer than 65536 bytes"):
        read_csv(path, REQ)
    path.write_bytes(b"x,y,z\n" + b"1" * (tabular.MAX_LINE_BYTES - 4) + b",2,3\n")  # at the limit
    with pytest.raises(InputError, match=r"long\.csv:2: column 'x': not a finite number"):
        read_csv(path, REQ)


@pytest.mark.parametrize("what", ["device", "directory", "fifo"])
def test_only_regular_files_are_read(tmp_path, what):
    path = {"device": pathlib.Path("/dev/zero"), "directory": tmp_path}.get(what)
    if path is None:
        path = tmp_path / "pipe.csv"
        os.mkfifo(path)  # opened without blocking: refused, not waited on
    with pytest.raises(InputError, match="a CSV must be a regular file") as exc:
        read_csv(path, REQ)
    assert str(exc.value).startswith(f"{path}: ")


def test_size_and_row_limits(tmp_path, monkeypatch):
    path = _write(tmp_path, "x,y,z\n" + "1,2,3\n" * 5)
    monkeypatch.setattr(tabular, "MAX_ROWS", 4)
    with pytest.raises(InputError, match=r"data\.csv:6: more than 4 data rows"):
        read_csv(path, REQ)
    monkeypatch.setattr(tabular, "MAX_FILE_BYTES", 20)
    with pytest.raises(InputError, match=r"data\.csv: larger than 20 bytes \(the limit"):
        read_csv(path, REQ)


def test_user_text_in_messages_is_escaped_and_cut(tmp_path):
    path = _write(tmp_path, "x,y,z\n1,2,\x1b[2J" + "9" * 500 + "a\n")
    with pytest.raises(InputError) as exc:
        read_csv(path, REQ)
    msg = str(exc.value)
    assert "\x1b" not in msg and "\\x1b[2J" in msg and len(msg) < len(str(path)) + 120
    path = _write(tmp_path, "a\x07,b\n1,2\n")
    with pytest.raises(InputError, match=r"header has: 'a\\x07', b\)") as exc:
        read_csv(path, REQ)


@pytest.mark.parametrize("value", ["0.5", "-1", "1e19", "1e308", "8"])
def test_whole_number_columns_are_range_checked(tmp_path, value):
    table = read_csv(_write(tmp_path, f"x,y,z\n1,2,3\n{value},5,6\n"), REQ)
    assert table.whole("y", 0, 7).tolist() == [2, 5]
    with pytest.raises(InputError) as exc:
        table.whole("x", 0, 7)
    expect = f"data.csv:3: column 'x': must be a whole number in 0..7, got {float(value)!r}"
    assert str(exc.value).endswith(expect)


def test_blank_float_columns_are_nan_where_empty_and_checked_elsewhere(tmp_path):
    path = _write(tmp_path, "x,y,z,t\n1,2,3,\n4,5,6, 7.5 \n")
    table = read_csv(path, REQ, blank_float=("t", "absent"))
    np.testing.assert_array_equal(table.columns["t"], [np.nan, 7.5])
    assert "absent" not in table.columns
    bad = _write(tmp_path, "x,y,z,t\n1,2,3,nan\n")  # 'nan' written out is not a blank
    with pytest.raises(InputError, match=r"data\.csv:2: column 't': not a finite number"):
        read_csv(bad, REQ, blank_float=("t",))
    short = _write(tmp_path, "x,y,z,t\n1,2,3\n")
    with pytest.raises(InputError, match=r"data\.csv:2: column 't': missing value"):
        read_csv(short, REQ, blank_float=("t",))


BLANK_CELLS = ["", "7.5", "-2", "+1", ".5", "1.", "1e400", "nan", "inf", "1_0", "0x10", "1e"]


@pytest.mark.parametrize("cell", BLANK_CELLS)
def test_blank_columns_read_the_same_by_both_parsers(tmp_path, monkeypatch, cell):
    """A plain file with blank cells (a recording's frames): the fast parser gives the
    line-by-line parser's table or its refusal, whatever sits in a blank column, and
    takes the rows itself when every cell is good."""
    rows = [f"{i},{i % 3},SAMPLE,,{i * 0.25}" for i in range(40)]
    rows[23] = f"23,2,SAMPLE,{cell},1"
    path = _write(tmp_path, "x,y,type,t,z\n" + "\n".join(rows) + "\n")
    fast = []
    parse = tabular.CsvBlocks._fast

    def read():
        try:
            t = read_csv(path, REQ, ("type",), blank_float=("t",))
        except InputError as exc:
            return str(exc)
        return t.array("x", "y", "z", "t").tobytes(), t.columns["type"], list(t.lines)

    def counted(self, first, run):
        block = parse(self, first, run)
        fast.append(0 if block is None else len(block.lines))
        return block

    monkeypatch.setattr(tabular, "BLOCK_BYTES", 200)
    monkeypatch.setattr(tabular.CsvBlocks, "_fast", counted)
    got = read()
    monkeypatch.setattr(tabular.CsvBlocks, "_fast", lambda self, first, run: None)
    assert got == read()
    good = cell in ("", "7.5", "-2", "+1", ".5", "1.")
    assert isinstance(got, str) != good and sum(fast) >= (30 if good else 0)


def test_a_caller_may_raise_the_byte_and_row_limits(tmp_path):
    path = _write(tmp_path, "x,y,z\n" + "1,2,3\n" * 5)
    with pytest.raises(InputError, match=r"data\.csv:6: more than 4 data rows"):
        read_csv(path, REQ, max_rows=4)
    assert len(read_csv(path, REQ, max_rows=5)) == 5
    with pytest.raises(InputError, match=r"data\.csv: larger than 10 bytes"):
        read_csv(path, REQ, max_bytes=10)


def test_the_units_line_is_found_before_the_header(tmp_path):
    path = _write(tmp_path, "# rig: x\n#  Units :  cm \nx,y,z\n1,2,3\n# units: m\n")
    assert csv_dialect.units_line(path) == (2, "cm")
    assert csv_dialect.units_line(_write(tmp_path, "x,y,z\n1,2,3\n")) is None


# -- issue 13: dumps writes the object itself where ``clean``'s copy would read the same ----

_KEYS = st.one_of(st.text(max_size=3), st.integers(-3, 3), st.booleans(), st.none(), st.floats())
_LEAVES = st.one_of(
    st.none(),
    st.booleans(),
    st.integers(-(2**70), 2**70),
    st.floats(),  # NaN, inf, -0.0 included
    st.text(max_size=4),
    st.binary(max_size=3),
    st.floats().map(np.float64),
    st.floats(width=32).map(np.float32),
    st.integers(-(2**62), 2**62).map(np.int64),
    st.booleans().map(np.bool_),
    st.lists(st.floats(), max_size=3).map(np.array),
)
_TREES = st.recursive(
    _LEAVES,
    lambda inner: st.one_of(
        st.lists(inner, max_size=4),
        st.lists(inner, max_size=4).map(tuple),
        st.dictionaries(st.text(max_size=3), inner, max_size=4),
        st.dictionaries(_KEYS, inner, max_size=4),
    ),
    max_leaves=12,
)


@given(_TREES)
def test_dumps_is_json_of_the_clean_copy(obj):
    """The same text (or the same error) as ``json.dumps(clean(obj))``, the way it was
    written before it skipped the copy: str keys and others (True -> "True", 1 and "1"
    merged), NaN and inf anywhere, NumPy scalars and arrays, bytes."""
    try:
        want = json.dumps(clean(obj), allow_nan=False, separators=(",", ":"))
    except Exception as exc:  # noqa: BLE001 - the same exception either way
        with pytest.raises(type(exc)):
            dumps(obj)
        return
    assert dumps(obj) == want


def test_dumps_of_an_ep2_record_is_unchanged():
    """A record as ``tactile ep2 analyze --json`` writes it: NumPy direction, tuples, a null."""
    from tactile.ep2 import analyze_patch
    from tactile_sim.ep2 import make, sweep

    d = sweep(make("saddle", 8.0), noise_pos=0.01, noise_normal=0.01, seed=1)
    rec = analyze_patch(d["points"], d["normals"], finger=d["finger"]).to_dict(7)
    rec["S_mean"] = float("nan")
    assert isinstance(rec["direction1"], np.ndarray) and isinstance(rec["k1_interval"], tuple)
    want = json.dumps(clean(rec), allow_nan=False, separators=(",", ":"))
    assert dumps(rec) == want and '"S_mean":null' in want
    del rec["S_mean"]
    assert dumps(rec) == json.dumps(clean(rec), allow_nan=False, separators=(",", ":"))
