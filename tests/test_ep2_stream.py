"""``tactile ep2 analyze`` at scale (issue 13): grouping of scattered rows, streamed output,
``--jobs``."""

import json

import numpy as np
import pytest
import tolerance

from tactile.cli.main import main
from tactile.ep2 import JetOptions, SplineOptions
from tactile.ep2.contacts_csv import group_rows, read_contacts
from tactile.ep2.patch_input import Request

pytestmark = pytest.mark.filterwarnings("error::RuntimeWarning")


def _reference_groups(ids):
    """The obvious (quadratic) grouping: ids by first appearance, rows in file order."""
    return {name: [i for i, p in enumerate(ids) if p == name] for name in dict.fromkeys(ids)}


@pytest.mark.parametrize("kind", ["numeric", "text", "mixed"])
def test_grouping_matches_the_reference_on_interleaved_unsorted_ids(kind):
    rng = np.random.default_rng(13)
    pool = {
        "numeric": [str(v) for v in rng.permutation(400)[:60]],
        "text": [f"p{v}" for v in rng.permutation(400)[:60]],
        "mixed": ["b", "10", "2", "a", "007", "7", "1.5", "x y"],
    }[kind]
    ids = [pool[i] for i in rng.integers(0, len(pool), 3000)]
    names, rows = group_rows(ids)
    ref = _reference_groups(ids)
    assert names == list(ref)
    assert [r.tolist() for r in rows] == list(ref.values())
    assert all(r.dtype == np.int64 for r in rows)


def test_grouping_of_one_id_and_of_every_row_its_own_id():
    names, rows = group_rows(["7"] * 5)
    assert names == ["7"] and rows[0].tolist() == [0, 1, 2, 3, 4]
    ids = [str(v) for v in range(50, 0, -1)]
    names, rows = group_rows(ids)
    assert names == ids and [r.tolist() for r in rows] == [[i] for i in range(50)]


def _patches():
    """Good patches of several shapes and ids, and patches the data do not determine."""
    from tactile_sim.ep2 import make, sweep

    good = [
        ("12", sweep(make("sphere", 8.0), noise_pos=0.005, noise_normal=0.005, seed=1)),
        ("a", sweep(make("cylinder", 6.0, 30.0), noise_pos=0.005, noise_normal=0.005, seed=2)),
        ("3", sweep(make("saddle", 9.0), noise_pos=0.005, noise_normal=0.005, seed=3)),
        ("2.5", sweep(make("plane"), noise_pos=0.005, noise_normal=0.005, seed=4)),
        ("007", sweep(make("pit", 7.0), noise_pos=0.005, noise_normal=0.005, seed=5)),
    ]
    rows = {}
    for pid, data in good:
        table = np.column_stack([data["points"], data["normals"]])
        rows[pid] = [
            ",".join(f"{v:.10g}" for v in r) + f",{int(f)},{pid}"
            for r, f in zip(table, data["finger"])
        ]
    for pid in ("line", "9"):  # one finger along a line: refused, exit 3
        rows[pid] = [f"0,{y},0,0,0,1,0,{pid}" for y in range(6)]
    return rows


def _scattered(rows, seed):
    """All patches' rows merged in a random order, each patch's rows still in its order."""
    rng = np.random.default_rng(seed)
    queues = {pid: list(r) for pid, r in rows.items()}
    out = []
    while queues:
        pid = list(queues)[rng.integers(len(queues))]
        out.append(queues[pid].pop(0))
        if not queues[pid]:
            del queues[pid]
    return out


@pytest.fixture
def mixed_csv(tmp_path):
    path = tmp_path / "mixed.csv"
    path.write_text("x,y,z,nx,ny,nz,finger,patch\n" + "\n".join(_scattered(_patches(), 1)) + "\n")
    return path


def test_scattered_rows_give_the_patches_of_the_contiguous_file(mixed_csv, tmp_path):
    rows = _patches()
    plain = tmp_path / "plain.csv"
    plain.write_text("x,y,z,nx,ny,nz,finger,patch\n" + "\n".join(sum(rows.values(), [])) + "\n")
    a, b = read_contacts(str(mixed_csv)), read_contacts(str(plain))
    first = list(dict.fromkeys(line.rsplit(",", 1)[1] for line in _scattered(rows, 1)))
    assert [g.patch for g in a] == first  # order of first appearance in the file
    by_id = {g.patch: g for g in b}
    for g in a:
        ref = by_id[g.patch]
        assert np.array_equal(g.points, ref.points) and np.array_equal(g.normals, ref.normals)
        assert g.finger == ref.finger
        assert g.lines == sorted(g.lines) and len(g.lines) == len(ref.lines)


def _run(capsys, *args):
    capsys.readouterr()
    code = main(["ep2", "analyze", *args])
    cap = capsys.readouterr()
    return code, cap.out, cap.err


@pytest.mark.parametrize("fmt", [[], ["--json"]])
def test_jobs_give_the_sequential_output_byte_for_byte(mixed_csv, capsys, fmt):
    one = _run(capsys, str(mixed_csv), *fmt)
    assert one[0] == 3 and "2 of 7 patch(es) not determined" in one[2]
    assert len(one[2].splitlines()) == 1 and "Traceback" not in one[2]
    for jobs in ("2", "3"):
        assert _run(capsys, str(mixed_csv), *fmt, "--jobs", jobs) == one


def _skeleton(got, want, path="record"):
    """Records alike but for their numbers: text, labels, keys and types exactly."""
    if isinstance(want, dict):
        assert isinstance(got, dict) and list(got) == list(want), path
        for k in want:
            _skeleton(got[k], want[k], f"{path}.{k}")
    elif isinstance(want, list | tuple):
        assert isinstance(got, list | tuple) and len(got) == len(want), path
        for i, (a, b) in enumerate(zip(got, want)):
            _skeleton(a, b, f"{path}[{i}]")
    elif not (isinstance(want, float) and not isinstance(got, bool)):
        assert got == want and type(got) is type(want), path


def _close(got, want, outcome, group, split=False):
    """The records ``got`` (JSON) of one patch equal ``want``, the ``analyze_one`` records
    ``outcome`` gave for its ``group``: text exactly, numbers to a tolerance derived from
    their sensitivity to the patch's data (a batched fit sums in another order than one
    patch alone: ``tests/tolerance.py``)."""
    from tactile.ep2.contacts_csv import Contacts
    from tactile.ep2.stream import analyze_one
    from tactile.output.text import dumps

    _skeleton(got, want)

    def records(pts, nrm):
        g = Contacts(group.patch, pts, nrm, group.finger, group.lines)
        return json.loads(dumps(analyze_one(g, outcome.name, OPTS, split).records))

    sens = tolerance.sensitivity(records, (group.points, group.normals))
    tolerance.assert_close(got, want, sens)


OPTS = Request(
    "jet",
    jet=JetOptions(max_normal_angle=80.0, break_angle=30.0, grid=8),
    spline=SplineOptions(order=None, segments=1, weighting="auto", align=False),
)


def _per_patch(groups, split=False):
    """The records of ``analyze_sweep`` patch by patch (the CLI before issue 13's batch)."""
    from tactile.cli.cmd_ep2 import patch_id
    from tactile.ep2.stream import analyze_one

    return [analyze_one(g, patch_id(g.patch), OPTS, split) for g in groups]


@pytest.mark.parametrize("jobs", ["1", "2"])
def test_batched_records_are_the_per_patch_records_in_file_order(mixed_csv, capsys, jobs):
    from tactile.output.text import dumps

    code, out, err = _run(capsys, str(mixed_csv), "--json", "--jobs", jobs)
    assert code == 3 and "2 of 7 patch(es) not determined" in err
    recs = [json.loads(line) for line in out.splitlines()]
    assert "NaN" not in out and "Infinity" not in out
    groups = read_contacts(str(mixed_csv))
    want = _per_patch(groups)
    assert len(recs) == len(want) == 7
    for rec, w, g in zip(recs, want, groups):
        if w.data_error is not None:  # refused: that patch alone, its reason on one line
            assert rec == {"patch": w.name, "n_points": 6, "shape": None, "error": w.data_error}
            assert "not determined" in rec["error"] and "\n" not in rec["error"]
            continue
        (one,) = w.records
        assert rec.pop("units")["radius"] == "u"  # the CLI's: mixed.csv states no unit
        _close([rec], json.loads(dumps([one])), w, g)
    assert sum(r["shape"] is not None for r in recs) == 5


def _many_patches(tmp_path, n, seed=0, split_some=False):
    """``n`` scattered patches with numeric ids (some sweeps broken by a crease)."""
    from tactile_sim.ep2 import make, sweep

    rng = np.random.default_rng(seed)
    kinds = ("sphere", "cylinder", "saddle", "pit")
    rows = {}
    for k in range(n):
        d = sweep(make(kinds[k % 4], 7.0 + k % 5), noise_pos=0.01, noise_normal=0.01, seed=k)
        pts, nrm = d["points"].copy(), d["normals"].copy()
        if split_some and k % 3 == 0:  # a fold: every finger's second half turned 90 deg
            turn = np.array([[1.0, 0, 0], [0, 0, -1], [0, 1, 0]])
            for f in np.unique(d["finger"]):
                half = np.flatnonzero(d["finger"] == f)[len(pts) // 6 :]
                pts[half] = (pts[half] - pts.mean(axis=0)) @ turn.T + pts.mean(axis=0)
                nrm[half] = nrm[half] @ turn.T
        table = np.column_stack([pts, nrm])
        pid = str(int(rng.integers(10**6)) * 10 + k % 10)
        rows[pid] = [
            ",".join(f"{v:.9g}" for v in r) + f",{int(f)},{pid}" for r, f in zip(table, d["finger"])
        ]
    path = tmp_path / f"many{n}.csv"
    lines = _scattered(rows, seed)
    path.write_text("x,y,z,nx,ny,nz,finger,patch\n" + "\n".join(lines) + "\n")
    return path


@pytest.mark.parametrize("split", [False, True])
def test_chunks_jobs_and_block_sizes_give_the_same_bytes(tmp_path, capsys, monkeypatch, split):
    """Several chunks of a scattered file: --jobs 1 and 2, blocks of 1 KiB and of the
    default, and the non-streaming run (the whole list first) print the same bytes; the
    batch gives the per-patch records, split parts included."""
    from tactile.ep2 import stream
    from tactile.files import tabular
    from tactile.output.text import dumps

    monkeypatch.setattr(stream, "CHUNK", 4)  # 14 patches: four chunks, the last short
    path = _many_patches(tmp_path, 14, split_some=split)
    flags = ["--json", *(["--split"] if split else [])]
    one = _run(capsys, str(path), *flags)
    assert "Traceback" not in one[2]
    assert _run(capsys, str(path), *flags, "--jobs", "2") == one
    monkeypatch.setattr(tabular, "BLOCK_BYTES", 1024)
    assert _run(capsys, str(path), *flags, "--jobs", "2") == one
    from tactile.ep2 import contacts_csv  # every patch in memory first: not streamed

    groups = read_contacts(str(path))
    monkeypatch.setattr(contacts_csv, "ContactsFile", lambda _: groups)
    assert _run(capsys, str(path), *flags) == one
    want = []
    outcomes = _per_patch(groups, split)
    for o in outcomes:
        refused = {"patch": o.name, "n_points": o.n_points, "shape": None, "error": o.data_error}
        want += o.records or [refused]
    recs = [json.loads(line) for line in one[1].splitlines()]
    assert len(recs) == len(want) and (len(recs) > 14) == split  # split parts are records
    assert sum(r["shape"] is not None for r in recs) >= 14
    assert one[0] == (3 if any(r["shape"] is None for r in recs) else 0)  # 3: one refused
    for got in recs:
        if got["shape"] is not None:
            assert got.pop("units")["k1"] == "1/u"  # the CLI names the (unstated) unit
    at = 0
    for o, g in zip(outcomes, groups, strict=True):
        if o.records:
            n = len(o.records)
            _close(recs[at : at + n], json.loads(dumps(o.records)), o, g, split)
        else:
            assert recs[at] == json.loads(dumps(want[at]))
        at += max(len(o.records), 1)


@pytest.mark.parametrize("jobs", ["0", "-1", "257"])
def test_bad_jobs_exit_2_one_line(mixed_csv, capsys, jobs):
    code, out, err = _run(capsys, str(mixed_csv), "--jobs", jobs)
    assert code == 2 and out == "" and "--jobs" in err and len(err.splitlines()) == 1


def test_progress_bar_only_on_a_terminal_for_long_files(monkeypatch):
    import sys

    from tactile.cli.cmd_ep2 import PROGRESS_FROM, _progress

    class Stream:
        def __init__(self, tty):
            self.tty = tty

        def isatty(self):
            return self.tty

        def write(self, text):
            return len(text)

        def flush(self):
            pass

    monkeypatch.setattr(sys, "stderr", Stream(False))  # piped or captured: never a bar
    assert _progress(10 * PROGRESS_FROM) is None
    monkeypatch.setattr(sys, "stderr", Stream(True))
    assert _progress(PROGRESS_FROM) is None
    bar = _progress(PROGRESS_FROM + 1)
    assert bar is not None and bar.total == PROGRESS_FROM + 1
    bar.close()


def test_a_large_file_shows_its_checking_pass_on_a_terminal(mixed_csv, monkeypatch):
    import sys

    from tactile.cli import cmd_ep2

    class Tty:
        text = ""

        def isatty(self):
            return True

        def write(self, text):
            Tty.text += text
            return len(text)

        def flush(self):
            pass

    monkeypatch.setattr(sys, "stderr", Tty())
    assert len(cmd_ep2._checked(str(mixed_csv))) == 7  # small: no bar
    assert Tty.text == ""
    monkeypatch.setattr(cmd_ep2, "CHECK_BAR_FROM", 100)
    assert len(cmd_ep2._checked(str(mixed_csv))) == 7
    size = mixed_csv.stat().st_size
    assert "ep2 check: 100%" in Tty.text and f"{size / 1000:.1f}k/{size / 1000:.1f}k" in Tty.text


def test_a_part_ep2_cannot_represent_stops_both_runs_at_the_same_patch(tmp_path, capsys):
    rows = _patches()
    good = [pid for pid in rows if pid not in ("line", "9")]
    # --split cuts this sweep where its normal turns 90 deg; the first part spans 1e-301
    tiny = ["0,0,0,0,0,1,0,tiny", "1e-301,0,0,0,0,1,0,tiny"]
    tiny += [f"{x},0,0,1,0,0,0,tiny" for x in (5, 6, 7)]
    lines = sum((rows[p] for p in good[:3]), []) + tiny + sum((rows[p] for p in good[3:]), [])
    path = tmp_path / "tiny.csv"
    path.write_text("x,y,z,nx,ny,nz,finger,patch\n" + "\n".join(lines) + "\n")
    one = _run(capsys, str(path), "--split", "--json")
    assert one[0] == 2 and "patch tiny:" in one[2] and "under the 1e-300" in one[2]
    assert len(one[2].splitlines()) == 1 and "Traceback" not in one[2]
    assert [json.loads(x)["patch"] for x in one[1].splitlines()] == [12, "a", 3]
    assert _run(capsys, str(path), "--split", "--json", "--jobs", "2") == one


def _sizes_csv(tmp_path, n):
    """``n`` patches of 9 to 36 contacts (3 to 6 fingers, as many stops), one after another."""
    from tactile_sim.ep2 import make, sweep

    lines = ["# units: mm", "x,y,z,nx,ny,nz,finger,patch"]
    for k in range(n):
        side = 3 + k % 4
        obj = make(("sphere", "cylinder", "saddle", "pit")[k % 4], 8.0)
        d = sweep(obj, fingers=side, spacing=4.0 / (side - 1), samples=side, repeats=1,
                  noise_pos=0.01, noise_normal=0.01, seed=k)  # fmt: skip
        table = np.column_stack([d["points"], d["normals"]])
        lines += [",".join(f"{v:.8g}" for v in r) + f",{f},{k}" for r, f in zip(table, d["finger"])]
    path = tmp_path / "sizes.csv"
    path.write_text("\n".join(lines) + "\n")
    return path


def test_small_chunks_and_blocks_print_the_bytes_of_the_whole_file_at_once(
    tmp_path, capsys, monkeypatch
):
    """A few hundred patches of 9 to 36 contacts: read in 2 KiB blocks and fitted 7 patches
    at a time (--jobs 1 and 2), the output is that of every patch in one chunk."""
    from tactile.ep2 import stream
    from tactile.files import tabular

    path = str(_sizes_csv(tmp_path, 300))
    monkeypatch.setattr(stream, "CHUNK", 10**6)  # the whole file in one chunk
    whole = _run(capsys, path, "--json")
    assert whole[0] in (0, 3) and len(whole[1].splitlines()) == 300
    monkeypatch.setattr(stream, "CHUNK", 7)
    monkeypatch.setattr(tabular, "BLOCK_BYTES", 2048)
    assert _run(capsys, path, "--json") == whole
    assert _run(capsys, path, "--json", "--jobs", "2") == whole


@pytest.mark.parametrize(
    ("sizes", "chunk", "rows", "want"),
    [
        ([10] * 7, 3, 1000, [3, 3, 1]),  # the count cuts
        ([10] * 7, 100, 25, [2, 2, 2, 1]),  # the contacts cut
        ([5, 40, 5, 5], 100, 30, [1, 1, 2]),  # a patch over the budget goes alone
        ([], 4, 100, []),
    ],
)
def test_chunks_hold_at_most_chunk_patches_and_chunk_rows_contacts(
    monkeypatch, sizes, chunk, rows, want
):
    """Work units are cut by count and by contacts, so memory in flight follows the rows
    however large the patches; every patch goes in one, in order."""
    from types import SimpleNamespace

    from tactile.ep2 import stream

    monkeypatch.setattr(stream, "CHUNK", chunk)
    monkeypatch.setattr(stream, "CHUNK_ROWS", rows)
    named = [(SimpleNamespace(points=np.zeros((n, 3))), str(i)) for i, n in enumerate(sizes)]
    got = list(stream.chunks(named))
    assert [len(w) for w in got] == want
    assert [name for w in got for _, name in w] == [str(i) for i in range(len(sizes))]
