"""EP2's memory grows with a patch's rows, not their square: a patch of 100,000 rows is
analysed under a 1.5 GiB address-space cap (its normal screen once built an n x n matrix:
80 GB for these rows), a file of unlike patches is fitted in stacks whose padding stays
within a row budget, and a patch over ``patch_input.MAX_ROWS`` is refused in one line,
exit 2, before its rows are read."""

import resource
import subprocess
import sys

import numpy as np
import pytest

from tactile.ep2 import analyze_patch, batch, patch_input
from tactile.errors import InputError

CAP = 1536 * 2**20  # bytes of address space for the CLI run (Python, NumPy, OpenBLAS ~150 MB)


def _sphere_rows(n, seed, patch=None, radius=8.0):
    """CSV rows of ``n`` noisy contacts on a sphere cap (4 x 4), optionally a patch id."""
    rng = np.random.default_rng(seed)
    xy = rng.uniform(-2.0, 2.0, (n, 2))
    z = np.sqrt(radius**2 - np.sum(xy * xy, axis=1))
    pts = np.column_stack([xy, z]) + 1e-3 * rng.standard_normal((n, 3))
    table = np.column_stack([pts, np.column_stack([xy, z]) / radius])
    tail = "" if patch is None else f",{patch}"
    return [",".join(f"{v:.9g}" for v in row) + tail for row in table]


def _capped(args, cap=CAP):
    """``tactile ep2 analyze ARGS`` in a process whose address space is capped at ``cap``."""

    def limit():
        resource.setrlimit(resource.RLIMIT_AS, (cap, cap))

    return subprocess.run(
        [sys.executable, "-m", "tactile.cli.main", "ep2", "analyze", *args],
        capture_output=True, text=True, preexec_fn=limit, timeout=600,
        env={"OPENBLAS_NUM_THREADS": "1", "PATH": "/usr/bin:/bin"},
    )  # fmt: skip


@pytest.mark.slow
def test_a_patch_of_100k_rows_and_small_ones_beside_it_fit_in_bounded_memory(tmp_path):
    """One patch of 100,000 contacts between 40 of 30: answered under the cap, the small
    patches stacked together and not padded to the large one's rows."""
    rows = [r for k in range(20) for r in _sphere_rows(30, k, patch=f"s{k}")]
    rows += _sphere_rows(100_000, 99, patch="big")
    rows += [r for k in range(20, 40) for r in _sphere_rows(30, k, patch=f"s{k}")]
    path = tmp_path / "big.csv"
    path.write_text("x,y,z,nx,ny,nz,patch\n" + "\n".join(rows) + "\n")
    proc = _capped([str(path), "--json"])
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert "Traceback" not in proc.stderr
    lines = proc.stdout.splitlines()
    assert len(lines) == 41 and '"patch":"big","n_points":100000' in lines[20]
    assert '"shape":"sphere"' in lines[20]


def test_a_patch_of_a_million_rows_is_refused_in_one_line_before_it_is_read(tmp_path):
    """The CLI's documented limit (1,000,000 rows of one patch waiting) lets such a file in;
    the row count from the checking pass refuses it, naming its first line, under a cap far
    below what its fit would take."""
    block = _sphere_rows(1000, 0)
    path = tmp_path / "million.csv"
    with path.open("w") as fh:
        fh.write("x,y,z,nx,ny,nz\n")
        for _ in range(1000):
            fh.write("\n".join(block) + "\n")
    proc = _capped([str(path)], cap=768 * 2**20)
    assert proc.returncode == 2, proc.stderr[-2000:]
    assert proc.stdout == "" and len(proc.stderr.splitlines()) == 1, proc.stderr
    assert f" {path}:2: 1,000,000 contacts in one patch" in proc.stderr
    assert f"{patch_input.MAX_ROWS:,}" in proc.stderr and "split" in proc.stderr


def test_the_api_refuses_a_patch_over_the_limit_before_fitting():
    n = patch_input.MAX_ROWS + 1
    pts = np.zeros((n, 3))
    pts[:, 0] = np.arange(n)
    with pytest.raises(InputError, match=f"{n:,} contacts in one patch"):
        analyze_patch(pts, np.tile([0.0, 0.0, 1.0], (n, 1)))


@pytest.mark.parametrize(
    ("sizes", "chunk", "rows", "want"),
    [
        ([100] * 600, 256, 250_000, [256, 256, 88]),  # like sizes: the chunks as ever
        ([30] * 5 + [100_000], 256, 250_000, [5, 1]),  # the large one alone
        ([10, 20, 30, 40], 256, 100, [3, 1]),  # 3 x 30 <= 100, 4 x 40 > 100
        ([500, 600], 8, 100, [1, 1]),  # each over the budget: one a stack
        ([], 4, 100, []),
    ],
)
def test_stacks_keep_padding_within_the_row_budget(sizes, chunk, rows, want):
    order = sorted(range(len(sizes)), key=sizes.__getitem__)
    got = batch.stacks(order, sizes, chunk, rows)
    assert [len(s) for s in got] == want
    assert [j for s in got for j in s] == order  # every patch once, in size order
    for s in got:
        assert len(s) == 1 or len(s) * max(sizes[j] for j in s) <= rows
