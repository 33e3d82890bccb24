"""The held-out case generator for the weight and drift benches (docs/scenes.md): a split by
a rule on the case number alone, the held-out part sealed, cases wider than the shipped
scenes, and every case a scene the emulator builds."""

import collections
import hashlib
import json
import subprocess
import sys

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from tactile_sim.emulator import load_scene
from tactile_sim.emulator.device import build_motion
from tactile_sim.weight_cases import (
    DRIFTS,
    FAMILIES,
    N_CASES,
    OBJECTS,
    Sealed,
    cases,
    draw,
    split_of,
    write_cases,
)

BENCH = cases("bench")


def test_the_split_is_a_rule_on_the_case_number_alone():
    held = cases("held_out", final=True)
    assert {c.id for c in held} | {c.id for c in BENCH} == set(range(N_CASES))
    assert not {c.id for c in held} & {c.id for c in BENCH}
    for c in held + BENCH:
        first = hashlib.sha256(f"tactile weight case {c.id}".encode()).digest()[0]
        assert c.split == split_of(c.id) == ("held_out" if first < 64 else "bench")
    assert 0.15 < len(held) / N_CASES < 0.35
    # drawing more never moves nor changes a case
    assert cases("bench", n=N_CASES // 2) == [c for c in BENCH if c.id < N_CASES // 2]
    assert draw(7) == draw(7) and draw(7) != draw(11)


def test_the_held_out_cases_are_sealed_outside_the_final_bench(tmp_path):
    with pytest.raises(Sealed, match="final bench only"):
        cases("held_out")
    cmd = [sys.executable, "-m", "tactile_sim.weight_cases", "held_out", str(tmp_path / "ho")]
    out = subprocess.run(cmd, capture_output=True, text=True, timeout=60)
    assert out.returncode == 2 and out.stdout == "" and out.stderr.count("\n") == 1
    assert "final bench only" in out.stderr and not (tmp_path / "ho").exists()


def test_the_bench_cases_are_wider_than_the_shipped_scenes():
    by = collections.defaultdict(set)
    for c in BENCH:
        by["family"].add(c.family)
        by["drift"].add(c.truth["drift"])
        by["orientations"].add(c.truth.get("orientations"))
        if c.family in ("ep1", "ep2"):
            by[c.family].add(c.truth["object"])
    assert by["family"] == set(FAMILIES) and by["drift"] == set(DRIFTS)
    assert by["ep1"] == by["ep2"] == set(OBJECTS)
    assert {"spread9", "random", "one_axis"} <= by["orientations"]
    masses = [c.truth["mass_kg"] for c in BENCH]
    assert min(masses) == 0.0 and max(masses) > 0.09 and max(masses) <= 0.1
    assert len({c.seed for c in BENCH}) == len(BENCH)
    assert all(c.truth["mass_kg"] >= 0.05 for c in BENCH if c.family == "turn")


def test_every_case_is_a_scene_the_emulator_builds_with_its_truth(tmp_path):
    paths = write_cases(tmp_path, "bench")
    manifest = json.loads((tmp_path / "cases.json").read_text())
    assert manifest["split"] == "bench" and len(manifest["cases"]) == len(paths) == len(BENCH)
    for path, entry in zip(paths, manifest["cases"]):
        scene = load_scene(path)
        assert scene.tool["mass_kg"] == entry["truth"]["mass_kg"]
        assert scene.tool["com_m"] == entry["truth"]["com_m"]
        assert scene.motion["kind"] == {"identify": "poses", "ep1": "roll", "ep2": "sweep",
                                        "turn": "poses"}[entry["family"]]  # fmt: skip
        motion = build_motion(scene)
        assert motion.duration_s > 0


def _down(rpy):
    """The finger's axis (sensor +x) in the world for each [roll, pitch, yaw]."""
    return Rotation.from_euler("xyz", rpy, degrees=True).as_matrix()[:, :, 0]


def _rank(rpy):
    """Rank of the tool's least squares in (m, b_F, m c, b_T) over these orientations."""
    rows = []
    for R in Rotation.from_euler("xyz", rpy, degrees=True).as_matrix():
        s = R.T @ [0.0, 0.0, -9.81]
        cross = np.array([[0, -s[2], s[1]], [s[2], 0, -s[0]], [-s[1], s[0], 0]])
        rows.append(np.hstack([s[:, None], np.eye(3), np.zeros((3, 6))]))
        rows.append(np.hstack([np.zeros((3, 4)), -cross, np.eye(3)]))
    return np.linalg.matrix_rank(np.vstack(rows), tol=1e-9)


def test_the_orientation_sets_are_what_they_say():
    for c in BENCH:
        rpy = c.truth.get("orientations_deg")
        if c.family == "identify" and c.truth["orientations"] == "one_axis":
            np.testing.assert_allclose(_down(rpy), [[0, 0, -1]] * len(rpy), atol=1e-9)
            assert _rank(rpy) < 10  # spun about its own axis: nothing identified
        elif c.family == "identify":
            assert 6 <= len(rpy) <= 9 and _rank(rpy) == 10
        elif c.family == "turn":  # down to up, 30 deg at a time about a horizontal axis
            axis = _down(rpy)
            np.testing.assert_allclose(axis[0], [0, 0, -1], atol=1e-9)
            np.testing.assert_allclose(axis[-1], [0, 0, 1], atol=1e-9)
            steps = np.degrees(np.arccos(np.clip(np.sum(axis[1:] * axis[:-1], 1), -1, 1)))
            np.testing.assert_allclose(steps, 30.0, atol=1e-6)
