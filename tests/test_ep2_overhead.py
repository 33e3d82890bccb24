"""The per-patch steps around the EP2 fit, rewritten on Python numbers for speed (issue 13),
give what their array forms give: the S vote."""

import gc
import math

import numpy as np
import pytest

from tactile.ep2 import analyze_patches, centre_result
from tactile.ep2.geometry import S_EDGES, S_NAMES


def _vote_with_arrays(s_est, s_sd, p_flat):
    """``centre_result.vote`` as numpy writes it (np.diff, np.argmax), the reference."""
    lo, hi = s_sd
    edges = [-np.inf, *S_EDGES.tolist(), np.inf]
    shares = np.diff([centre_result.split_normal_cdf(e, s_est, lo, hi) for e in edges])
    shares = shares * (1.0 - p_flat)
    best = int(np.argmax(shares))
    votes = {S_NAMES[i]: float(c) for i, c in enumerate(shares) if c > 1e-4}
    label = S_NAMES[best] if shares[best] >= centre_result.MIN_VOTE else "uncertain"
    return label, float(shares[best]), votes


@pytest.mark.parametrize("seed", range(3))
def test_vote_is_its_array_form(seed):
    rng = np.random.default_rng(seed)
    seen = set()
    for _ in range(3000):
        s = float(rng.choice([rng.uniform(-1.2, 1.2), *S_EDGES, 1.0, -1.0, math.nan]))
        sd = tuple(float(rng.choice([rng.uniform(0, 0.4), 0.0, 1e-12, math.nan])) for _ in "ab")
        if not any(sd):
            continue
        p = float(rng.choice([0.0, rng.uniform(), 1.0]))
        got, want = centre_result.vote(s, sd, p), _vote_with_arrays(s, sd, p)
        assert repr(got) == repr(want)  # NaN confidences included
        seen.add(got[0] == "uncertain")
    assert seen == {True, False}


def test_a_stacks_votes_are_each_patchs_vote():
    """``votes`` over a stack of 4,000 gives each patch's ``vote`` (its band rule where no sd,
    else ``votes`` of that one alone, which ``test_vote_is_its_array_form`` checks against
    the split normal's CDF) bit for bit: no row leaks into another; S on and off the band
    edges, sds of 0 (one side or both), tiny, NaN."""
    rng = np.random.default_rng(7)
    s = rng.choice([*rng.uniform(-1.2, 1.2, 8), *S_EDGES, 1.0, -1.0, math.nan], 4000)
    lo, hi = (rng.choice([*rng.uniform(0, 0.4, 8), 0.0, -0.0, 1e-12, math.nan], 4000) for _ in "ab")
    p = rng.choice([0.0, 0.3, 0.999, 1.0], 4000)
    got = centre_result.votes(s, lo, hi, p)
    want = [
        centre_result.vote(*a) for a in zip(s.tolist(), zip(lo.tolist(), hi.tolist()), p.tolist())
    ]
    assert repr(got) == repr(want)  # NaN confidences included
    assert {g[0] for g in got} >= {"uncertain", "sphere", "saddle"}


def test_duplicate_rows_found_as_by_whole_rows():
    """``patch_input.has_duplicates`` (whole rows compared only where two x are equal) says
    what comparing every row says: exact repeats, equal x alone, -0.0 and 0.0, NaN."""
    from tactile.ep2.patch_input import has_duplicates

    def repeats(P, N):  # every row of every patch compared whole
        return np.array([len(np.unique(np.c_[p, n][np.isfinite(np.c_[p, n]).all(1)], axis=0))
                         < len(p) for p, n in zip(P, N, strict=True)])  # fmt: skip

    rng = np.random.default_rng(5)
    P, N = rng.normal(size=(300, 9, 3)), rng.normal(size=(300, 9, 3))
    P[::3, 4], N[::3, 4] = P[::3, 1], N[::3, 1]  # a repeated row
    P[1::3, 5, 0] = P[1::3, 2, 0]  # the same x, another row
    P[2::9, 6, 0], P[2::9, 7, 0] = 0.0, -0.0
    P[5::9, 3, 1] = np.nan
    got = has_duplicates(P, N)
    assert np.array_equal(got, repeats(P, N))
    assert got[::3].all() and not got[1::3].any() and got[5::9].all()


def _spheres(n, seed=0, rows=12):
    """n noisy sphere caps (r 20, 4 wide) as ``analyze_patches`` takes them."""
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(n):
        xy = rng.uniform(-2, 2, (rows, 2))
        z = np.sqrt(400.0 - np.sum(xy * xy, 1)) - 20.0  # a dome
        pts = np.c_[xy, z] + rng.normal(0, 1e-3, (rows, 3))
        out.append({"points": pts, "normals": np.c_[xy, z + 20.0] / 20.0,
                    "noise_pos": 1e-3, "noise_normal": 1e-3})  # fmt: skip
    return out


@pytest.mark.parametrize("enabled", [True, False])
def test_a_stack_runs_without_the_cyclic_collector_and_leaves_it_as_it_was(enabled):
    """One stack of 256 patches: at most the pass after it (not one per 700 allocations),
    and the collector's state as the caller had it (the patches built and the young
    generation emptied first: what ran before, not the stack, set its count)."""
    patches = _spheres(256)
    gc.collect()
    passes = []
    gc.callbacks.append(lambda phase, info: phase == "start" and passes.append(info))
    was = gc.isenabled()
    (gc.enable if enabled else gc.disable)()
    try:
        got = analyze_patches(patches)
        assert gc.isenabled() is enabled
    finally:
        gc.callbacks.pop()
        (gc.enable if was else gc.disable)()
    assert all(r.shape == "sphere" for r in got)
    assert len(passes) <= (1 if enabled else 0)


def test_a_second_stack_reuses_the_heap_instead_of_faulting_its_pages_in():
    """Once an application opts in (``batch.keep_heap``, as ``tactile ep2 analyze`` does),
    glibc keeps ``batch.HEAP_PAD`` of freed heap: a stack's temporaries (MBs) reuse the
    last stack's pages.  Without it each stack of 36-contact patches faults in about 10
    pages a patch (a tenth of the CPU)."""
    import resource

    from tactile.ep2 import batch

    if not batch.keep_heap():
        pytest.skip("no glibc mallopt here")
    patches = _spheres(256, rows=36)
    analyze_patches(patches)
    before = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
    analyze_patches(patches)
    faults = resource.getrusage(resource.RUSAGE_SELF).ru_minflt - before
    assert faults < 2 * len(patches)  # (Python's own arenas fault a few hundred)


def test_the_library_leaves_the_allocator_alone_and_the_cli_opts_in(cli, tmp_path, mocker):
    """Setting the process's allocator is the application's choice: ``analyze_patches``
    never calls ``keep_heap``; ``tactile ep2 analyze`` does, once, before fitting."""
    from tactile.cli import cmd_ep2
    from tactile.ep2 import batch

    spy = mocker.patch.object(cmd_ep2, "keep_heap", wraps=batch.keep_heap)
    lib = mocker.patch.object(batch, "keep_heap")
    analyze_patches(_spheres(4, rows=12))
    assert lib.call_count == 0
    f = tmp_path / "c.csv"
    rows = [
        f"{x},{y},{-(x * x + y * y) / 20},{x / 10},{y / 10},1"
        for x in range(-2, 3)
        for y in range(-2, 3)
    ]
    f.write_text("# units: cm\nx,y,z,nx,ny,nz\n" + "\n".join(rows) + "\n")
    code, _, err = cli("ep2", "analyze", f, "--quiet")
    assert code == 0, err
    assert spy.call_count == 1
