"""``patch_input.find_breaks`` (a stack of patches at once) gives exactly what the
reference below gives patch by patch: the same rows, finger labels (value and type) and
angles, in the same order, whatever the labels."""

import numpy as np
import pytest

from tactile.ep2.patch_input import find_breaks as find_breaks_many


def find_breaks(normals, finger, max_angle_deg=30.0):
    """The reference, one patch: (row, finger, angle deg) where consecutive normals of one
    finger (rows where ``finger == f``, in order) turn more than the angle."""
    if finger is None:
        return []
    finger = np.asarray(finger)
    out = []
    for f in dict.fromkeys(finger.tolist()):
        rows = np.flatnonzero(finger == f)
        if rows.size < 2:
            continue
        dots = np.einsum("ij,ij->i", normals[rows[:-1]], normals[rows[1:]])
        cross = np.linalg.norm(np.cross(normals[rows[:-1]], normals[rows[1:]]), axis=1)
        angle = np.degrees(np.arctan2(cross, dots))
        for j in np.flatnonzero(angle > max_angle_deg):
            out.append((int(rows[j + 1]), f, float(angle[j])))
    return out


def _normals(rng, n):
    """Unit normals that wander, with a few sudden turns: breaks present and absent."""
    steps = rng.normal(scale=0.15, size=(n, 3))
    steps[rng.random(n) < 0.15] *= 6.0  # turns of tens of degrees
    nrm = np.array([0.0, 0.0, 1.0]) + np.cumsum(steps, axis=0)
    return nrm / np.linalg.norm(nrm, axis=1)[:, None]


def _labels(rng, n, kind):
    """Finger labels of one kind, interleaved and unsorted, some fingers a single row."""
    k = rng.integers(1, 6)
    codes = rng.integers(0, k, size=n)
    codes[rng.integers(n)] = 7  # a one-row finger
    pool = {
        "text": np.array(["b", "a", "10", "2", "thumb", "a "]),
        "int": np.array([5, -3, 0, 12, 2**60, 1]),
        "float": np.array([2.5, -0.0, 0.0, np.nan, 1e300, 3.0]),
        "bool": np.array([True, False, True, False, True, False]),
    }[kind]
    picked = pool[np.r_[rng.permutation(len(pool)), 0, 1][codes % (len(pool) + 2)]]
    as_list = rng.random() < 0.5
    return picked.tolist() if as_list else picked


@pytest.mark.parametrize("seed", range(6))
def test_stacked_equals_one_at_a_time(seed):
    rng = np.random.default_rng(seed)
    n = int(rng.integers(1, 40))
    kinds = ("text", "int", "float", "bool", None, "mixed")
    normals, fingers = [], []
    for _ in range(60):
        normals.append(_normals(rng, n))
        kind = kinds[rng.integers(len(kinds))]
        if kind is None:
            fingers.append(None)
        elif kind == "mixed":  # numbers and text in one list: np.asarray makes all text
            fingers.append([int(v) if v.isdigit() else v for v in _labels(rng, n, "text")])
        else:
            fingers.append(_labels(rng, n, kind))
    stack = np.stack(normals)
    for angle in (5.0, 30.0, 60.0):
        want = [find_breaks(stack[b], fingers[b], angle) for b in range(len(fingers))]
        got = find_breaks_many(stack, fingers, angle)
        assert got == want
        assert [[tuple(map(type, t)) for t in p] for p in got] == [
            [tuple(map(type, t)) for t in p] for p in want
        ]
        if angle == 5.0 and n > 3:
            assert any(want) and not all(want)  # breaks present and absent


def test_odd_labels_go_one_at_a_time():
    rng = np.random.default_rng(9)
    stack = np.stack([_normals(rng, 12) for _ in range(3)])
    objects = [None, 1, "a"] * 4  # an object array: compared as find_breaks compares
    short = ["a", "b"] * 6
    got = find_breaks_many(stack, [objects, short, None], 5.0)
    assert got == [find_breaks(stack[0], objects, 5.0), find_breaks(stack[1], short, 5.0), []]
    assert got[0] and got[1]


def test_many_equals_the_loop_at_scale():
    """The case ``tactile ep2 analyze`` meets: text labels from the CSV, thousands of
    patches of one size, a few with breaks."""
    rng = np.random.default_rng(3)
    stack = np.stack([_normals(rng, 36) for _ in range(2000)])
    fingers = [[str(v) for v in rng.integers(0, 3, size=36)] for _ in range(2000)]
    want = [find_breaks(stack[b], fingers[b]) for b in range(2000)]
    assert find_breaks_many(stack, fingers) == want
    assert 0 < sum(map(bool, want)) < 2000


@pytest.mark.parametrize("kind", ["int", "float", "float_nan"])
def test_number_arrays_of_one_dtype_give_the_reference(kind):
    """Every patch's labels a NumPy array of one numeric dtype (the labels are then their
    own sort keys): the reference's rows, labels (value and type) and order; -0.0 is 0.0,
    2**60 stays itself, and a NaN label (equal to nothing) is numbered one by one."""
    rng = np.random.default_rng(17)
    n = 24
    pool = {
        "int": np.array([5, -3, 0, 2**60, 2**60 + 1]),
        "float": np.array([2.5, -0.0, 0.0, 1e300, -7.0]),
        "float_nan": np.array([2.5, np.nan, 0.0, 1e300, -7.0]),
    }[kind]
    stack = np.stack([_normals(rng, n) for _ in range(200)])
    fingers = [pool[rng.integers(0, len(pool), n)] for _ in range(200)]
    for angle in (5.0, 30.0):
        want = [find_breaks(stack[b], fingers[b], angle) for b in range(200)]
        got = find_breaks_many(stack, fingers, angle)
        assert got == want
        assert [[tuple(map(type, t)) for t in p] for p in got] == [
            [tuple(map(type, t)) for t in p] for p in want
        ]
        assert any(want)
