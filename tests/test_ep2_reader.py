"""The chunked EP2 contacts reader (issue 13): the same patches and the same one-line
errors as the whole-table reader it replaced, whatever the block size; both of its
parsers; scattered patches given out as soon as they are complete; its limits."""

from unittest import mock

import numpy as np
import pytest
from conftest import FUZZ_SCALE
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st
from test_csv_fuzz import ODD, files

from tactile.ep2 import contacts_csv
from tactile.ep2.contacts_csv import REQUIRED, Contacts, ContactsFile, group_rows, read_contacts
from tactile.errors import InputError, where
from tactile.files import csv_dialect, tabular

pytestmark = pytest.mark.filterwarnings("error")


def whole_table(path):
    """The reader before issue 13, kept as the reference: the whole table at once
    (``tabular.read_csv``, its line-by-line parser only), grouped by ``group_rows``, then
    the zero-normal and extent checks."""
    from tactile.ep2 import patch_input

    with mock.patch.object(tabular.CsvBlocks, "_fast", lambda self, first, run: None):
        table = tabular.read_csv(path, REQUIRED, optional_text=("finger", "patch"))
    pts, nrm = table.array("x", "y", "z"), table.array("nx", "ny", "nz")
    bad = np.flatnonzero(~(np.max(np.abs(nrm), axis=1) > 0))
    if bad.size:
        raise InputError(f"{where(path, table.lines[bad[0]], 'nx')}: zero-length normal (nx,ny,nz)")
    finger, patch = table.columns.get("finger"), table.columns.get("patch")
    lines = np.asarray(table.lines, dtype=np.int64)
    if patch is None:
        names, rows = [None], [np.arange(len(lines))]
    else:
        names, rows = group_rows(patch)
    out = [
        Contacts(n, pts[r], nrm[r], None if finger is None else [finger[i] for i in r],
                 lines[r].tolist())
        for n, r in zip(names, rows)
    ]  # fmt: skip
    for g in out:
        problem = patch_input.spread_problem(g.points)
        if problem is not None:
            row, axis, why = problem
            name = "" if g.patch is None else f"patch {csv_dialect.show(g.patch)}: "
            raise InputError(f"{where(path, g.lines[row], patch_input.AXES[axis])}: {name}{why}")
    return out


def outcome(read, path):
    try:
        return [(g.patch, g.points, g.normals, g.finger, g.lines) for g in read(path)]
    except InputError as exc:
        return str(exc)


def assert_same(got, want):
    if isinstance(want, str) or isinstance(got, str):
        assert got == want
        return
    assert len(got) == len(want)
    for a, b in zip(got, want):
        assert a[0] == b[0] and a[3] == b[3] and a[4] == b[4]
        assert a[1].dtype == b[1].dtype and a[1].shape == b[1].shape
        assert np.array_equal(a[1], b[1]) and np.array_equal(a[2], b[2])


FUZZ = settings(
    max_examples=150 * FUZZ_SCALE,
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
)


@FUZZ
@given(data=st.data(), block=st.sampled_from([7, 40, 200, 1 << 20]))
def test_hostile_files_give_the_whole_table_readers_answer(tmp_path, monkeypatch, data, block):
    monkeypatch.setattr(tabular, "BLOCK_BYTES", block)
    path = tmp_path / "c.csv"
    path.write_bytes(data.draw(files("contacts")))
    want = outcome(whole_table, path)
    event("refused" if isinstance(want, str) else "read")
    assert_same(outcome(read_contacts, path), want)


CELLS = st.one_of(
    st.floats(-1e3, 1e3).map(repr),
    st.sampled_from(["1e308", "-1e-320", "5e-324", " 2.5", "1_0", "nan", "x", "", '"3"', "0"]),
)


@st.composite
def scattered_files(draw):
    """Many short rows of scattered patch ids, mostly plain (the fast parser's case), with
    now and then a quoted, spaced, commented, blank or bad line, CR LF or LF."""
    pool = draw(st.sampled_from([["1", "2", "10"], ["a", "b b", "007", "1.5"], ["p"]]))
    header = draw(st.sampled_from(["x,y,z,nx,ny,nz,finger,patch", "patch,nz,ny,nx,z,y,x"]))
    names = header.split(",")
    lines = ["# made by a test", header]
    for i in range(draw(st.integers(1, 60))):
        cell = {"finger": str(i % 3), "patch": draw(st.sampled_from(pool))}
        for c in "xyz":
            cell[c] = repr(draw(st.floats(-10, 10)))
        for c in ("nx", "ny", "nz"):
            cell[c] = repr(draw(st.floats(0.1, 1)))
        if draw(st.integers(0, 30)) == 0:
            cell[draw(st.sampled_from(names))] = draw(CELLS)
        line = ",".join(cell[c] for c in names)
        lines.append(line)
        odd = draw(st.integers(0, 40))
        if odd == 0:
            lines.append(draw(st.sampled_from(["", "# note", "  ", ",,,", '"a\nb",1'])))
    eol = draw(st.sampled_from(["\n", "\r\n"]))
    return (eol.join(lines) + eol).encode()


@pytest.mark.slow
@FUZZ
@given(data=st.data(), block=st.sampled_from([16, 64, 300, 1 << 20]))
def test_scattered_files_give_the_whole_table_readers_answer(tmp_path, monkeypatch, data, block):
    monkeypatch.setattr(tabular, "BLOCK_BYTES", block)
    path = tmp_path / "c.csv"
    path.write_bytes(data.draw(scattered_files()))
    want = outcome(whole_table, path)
    event("refused" if isinstance(want, str) else "read")
    assert_same(outcome(read_contacts, path), want)


@pytest.mark.parametrize("column", ["x", "nz", "finger", "patch"])
@pytest.mark.parametrize("block", [64, 1 << 20])
def test_every_odd_cell_in_a_plain_file_gets_the_whole_table_readers_answer(
    tmp_path, monkeypatch, column, block
):
    monkeypatch.setattr(tabular, "BLOCK_BYTES", block)
    header = "x,y,z,nx,ny,nz,finger,patch".split(",")
    extra = ["inf", "-inf", "1e400", " 1", "1 ", "\t1", "\u00a0", "1e-400", "a#b", "#", "1;2"]
    for k, cell in enumerate(ODD + extra):
        rows = [
            [str(i), str(i % 4), "0.5", "0", "0", "1", str(i % 3), str(i % 5)] for i in range(30)
        ]
        rows[17][header.index(column)] = cell
        path = tmp_path / f"odd{k}.csv"
        path.write_bytes(
            ("\n".join(",".join(r) for r in [header, *rows]) + "\n").encode(
                "utf-8", "surrogatepass"
            )
        )
        assert_same(outcome(read_contacts, path), outcome(whole_table, path))


@pytest.mark.parametrize("extra", [-1, 0, 1, 2])
def test_a_plain_line_at_the_length_limit(tmp_path, extra):
    """A patch id that makes its line the limit long (and a byte either side), in a plain
    file the fast parser takes: the same answer as the whole-table reader."""
    row = "1,2,3,0,0,1,0,"
    long_id = "p" * (tabular.MAX_LINE_BYTES - len(row) + extra)
    rows = [f"{i},{i % 3},0.5,0,0,1,{i % 3},a" for i in range(3000)]
    rows[2000] = row + long_id
    path = tmp_path / "long.csv"
    path.write_text("x,y,z,nx,ny,nz,finger,patch\n" + "\n".join(rows) + "\n")
    got = outcome(read_contacts, path)
    assert_same(got, outcome(whole_table, path))
    assert isinstance(got, str) == (extra > 0)


def _plain_file(path, n_patches, rows=12, seed=0, window=7):
    """Plain rows (the fast parser's case) of ``n_patches`` patches, each patch's rows spread
    over a window of ``window`` patches; numbers with every digit a float can carry."""
    rng = np.random.default_rng(seed)
    ids = np.repeat(np.arange(n_patches), rows)
    for s in range(0, ids.size, window * rows):
        ids[s : s + window * rows] = rng.permutation(ids[s : s + window * rows])
    vals = rng.normal(size=(ids.size, 6)) * 10.0 ** rng.integers(-5, 5, size=(ids.size, 1))
    with open(path, "w") as fh:
        fh.write("x,y,z,nx,ny,nz,finger,patch\n")
        for pid, v in zip(ids, vals):
            fh.write(",".join(repr(float(x)) for x in v) + f",{pid % 3},p{pid}\n")


def test_fast_and_slow_parsers_agree_and_the_fast_one_does_the_work(tmp_path, monkeypatch):
    path = tmp_path / "plain.csv"
    _plain_file(path, 300)
    monkeypatch.setattr(tabular, "BLOCK_BYTES", 2048)
    fast = []
    parse = tabular.CsvBlocks._fast

    def counted(self, first, run):
        block = parse(self, first, run)
        fast.append(0 if block is None else len(block.lines))
        return block

    monkeypatch.setattr(tabular.CsvBlocks, "_fast", counted)
    got = outcome(read_contacts, path)
    assert sum(fast) > 0.9 * 300 * 12  # plain runs are parsed in C
    monkeypatch.setattr(tabular.CsvBlocks, "_fast", lambda self, first, run: None)
    assert_same(got, outcome(read_contacts, path))
    assert_same(got, outcome(whole_table, path))


def test_a_quoted_field_over_a_line_break_spans_blocks(tmp_path, monkeypatch):
    path = tmp_path / "q.csv"
    rows = [f"{i},0,{i % 2},0,0,1,{i % 3},a" for i in range(40)]
    rows[20] = rows[20][:-1] + '"a\nstill a"'  # patch id with a line break, over a run's end
    path.write_text("x,y,z,nx,ny,nz,finger,patch\n" + "\n".join(rows) + "\n")
    for block in (8, 50, 1 << 20):
        monkeypatch.setattr(tabular, "BLOCK_BYTES", block)
        got = outcome(read_contacts, path)
        assert [g[0] for g in got] == ["a", "a\nstill a"] and got[1][4] == [23]
        assert_same(got, outcome(whole_table, path))


def test_a_patch_is_given_out_once_complete_not_at_the_end_of_the_file(tmp_path, monkeypatch):
    path = tmp_path / "many.csv"
    _plain_file(path, 400)
    monkeypatch.setattr(tabular, "BLOCK_BYTES", 4096)
    read = []
    iterate = tabular.CsvBlocks.__iter__

    def counted(self):
        for block in iterate(self):
            read.append(len(block.lines))
            yield block

    monkeypatch.setattr(tabular.CsvBlocks, "__iter__", counted)
    patches = ContactsFile(path)
    assert len(patches) == 400 and sum(read) == 400 * 12  # the first pass read it all
    order = [g.patch for g in whole_table(path)]
    read.clear()
    it = iter(patches)
    first = next(it)
    assert first.patch == order[0] and len(first.points) == 12
    assert sum(read) < 0.05 * 400 * 12  # ... the second had read a few blocks
    assert [g.patch for g in it] == order[1:]


def _contiguous(path, sizes, column=True):
    with open(path, "w") as fh:
        fh.write("x,y,z,nx,ny,nz,finger" + (",patch\n" if column else "\n"))
        for k, n in enumerate(sizes):
            for i in range(n):
                fh.write(f"{i},{i % 3},{k},0,0,1,{i % 3}" + (f",{k}\n" if column else "\n"))


def test_patches_under_way_hold_at_most_the_open_row_limit(tmp_path, monkeypatch):
    monkeypatch.setattr(contacts_csv, "MAX_OPEN_ROWS", 50)
    ok = tmp_path / "ok.csv"
    _contiguous(ok, [30] * 10)  # 300 rows, 30 at a time
    assert len(list(ContactsFile(ok))) == 10
    late = tmp_path / "late.csv"  # patch 0's last row at the end: everything waits for it
    text = ok.read_text().splitlines()
    late.write_text("\n".join([text[0], *text[2:], text[1]]) + "\n")
    with pytest.raises(InputError) as err:
        ContactsFile(late)
    msg = str(err.value)
    assert msg.startswith(f"{late}:2: column 'patch': patch '0' ends only at line 301")
    assert "more than 50 rows" in msg and "sort the file by patch" in msg
    bare = tmp_path / "bare.csv"
    _contiguous(bare, [60], column=False)
    with pytest.raises(InputError, match=r"bare.csv:2: more than 50 rows in one patch"):
        ContactsFile(bare)
    assert len(read_contacts(bare)) == 1  # within the limit of a file read whole


@FUZZ
@given(ids=st.lists(st.integers(0, 6), min_size=1, max_size=40), limit=st.integers(1, 40))
def test_the_open_row_limit_is_the_rows_held_from_first_row_to_give_out(tmp_path, ids, limit):
    """The limit against the obvious count: just after each row, the rows of every patch
    seen so far whose patch, or one before it in file order, still has rows to come."""
    order = list(dict.fromkeys(ids))
    last = {p: max(i for i, q in enumerate(ids) if q == p) for p in order}
    done = [max(last[q] for q in order[: k + 1]) for k in range(len(order))]
    most = max(
        sum(ids.count(p) for k, p in enumerate(order) if ids.index(p) <= i and done[k] >= i)
        for i in range(len(ids))
    )
    path = tmp_path / "ids.csv"
    body = "".join(f"{i},{i % 2},0,0,0,1,0,{p}\n" for i, p in enumerate(ids))
    path.write_text("x,y,z,nx,ny,nz,finger,patch\n" + body)
    event("refused" if most > limit else "read")
    if most > limit:
        with pytest.raises(InputError, match=f"more than {limit} rows would wait"):
            ContactsFile(path, max_open=limit)
    else:
        assert [g.patch for g in ContactsFile(path, max_open=limit)] == [str(p) for p in order]


def test_patch_and_id_limits_name_the_first_row_past_them(tmp_path, monkeypatch):
    path = tmp_path / "ids.csv"
    _contiguous(path, [3] * 6)
    monkeypatch.setattr(contacts_csv, "MAX_PATCHES", 4)
    with pytest.raises(InputError, match=r"ids.csv:14: column 'patch': more than 4 patches"):
        ContactsFile(path)
    monkeypatch.setattr(contacts_csv, "MAX_PATCHES", 10)
    monkeypatch.setattr(contacts_csv, "MAX_ID_CHARS", 3)
    with pytest.raises(InputError, match=r"ids.csv:11: column 'patch': the patch ids hold"):
        ContactsFile(path)


def test_a_streamed_file_may_exceed_the_whole_file_limits(tmp_path, monkeypatch):
    path = tmp_path / "big.csv"
    _contiguous(path, [20] * 30)
    monkeypatch.setattr(tabular, "MAX_FILE_BYTES", 4096)
    monkeypatch.setattr(tabular, "MAX_ROWS", 100)
    with pytest.raises(InputError, match="larger than 4 KiB"):
        read_contacts(path)
    assert len(ContactsFile(path)) == 30
    monkeypatch.setattr(contacts_csv, "MAX_ROWS", 100)
    with pytest.raises(InputError, match=r"big.csv:102: more than 100 data rows"):
        ContactsFile(path, max_rows=contacts_csv.MAX_ROWS)


def test_a_file_changed_between_the_passes_is_refused(tmp_path):
    path = tmp_path / "c.csv"
    _contiguous(path, [5, 5])
    patches = ContactsFile(path)
    with open(path, "a") as fh:
        fh.write("9,9,9,0,0,1,0,1\n")
    with pytest.raises(InputError, match="changed while it was read"):
        list(patches)


def test_one_pass_checks_the_whole_file_before_any_patch(tmp_path):
    """An error at the end of the file is found before the first patch is given out."""
    path = tmp_path / "c.csv"
    _contiguous(path, [5] * 40)
    with open(path, "a") as fh:
        fh.write("1e-301,0,0,0,0,1,0,late\n0,0,0,0,0,1,0,late\n")
    with pytest.raises(InputError, match=r"c.csv:202: column 'x': patch 'late': the contacts"):
        ContactsFile(path)


@settings(max_examples=300 * FUZZ_SCALE)
@given(
    scale=st.one_of(st.integers(-323, -280), st.integers(280, 308), st.integers(-300, 300)),
    steps=st.lists(st.integers(-(2**60), 2**60), min_size=2, max_size=6),
    axis=st.integers(0, 2),
)
def test_a_spread_extent_refuses_needs_an_odd_coordinate(scale, steps, axis):
    """The first pass keeps no box per patch: only a patch with a coordinate beyond
    ``ODD_COORDINATE`` can have a spread ``spread_problem`` refuses, so only those are looked at."""
    from tactile.ep2 import patch_input

    lo, hi = contacts_csv.ODD_COORDINATE
    pts = np.zeros((len(steps), 3))
    with np.errstate(over="ignore"):
        pts[:, axis] = np.array(steps, float) * 2.0**-60 * 10.0**scale
    pts = pts[np.isfinite(pts).all(axis=1)]
    a = np.abs(pts)
    odd = ((a > hi) | ((a < lo) & (a > 0))).any()
    if patch_input.spread_problem(pts) is not None:
        event("refused")
        assert odd
