"""``tactile.explore`` (the planner, EP1's next roll) and ``tactile explore`` (the loop on the
emulated board and arm).  The planner's runs use the bench's geometry (``bench/explore.py``:
a touch meets the height field, its contact noised as the sweep's), on fixed seeds."""

import json
import math

import numpy as np
import pytest
from conftest import load_bench

from tactile.ep1.estimator import next_roll
from tactile.explore import Explorer, Fit, Region, fit_of, unknown
from tactile_sim.ep2.objects import make

bench = load_bench("explore")
NOISE = {"noise_pos": 0.05, "noise_normal": 0.03}


def explore(obj, seed, max_touches=18, region=None, **stop):
    """The explorer after a run on ``obj`` (cm, noise as tables 5-7); ``stop``: ``flat``,
    ``s_width``."""
    rng = np.random.default_rng(seed)
    region = region or Region((0.0, 0.0, 0.0), (0.0, 0.0, 1.0), 3.0, 1.5)
    ex = Explorer(region, max_touches=max_touches, options=dict(NOISE), **stop)
    while ex.done() is None:
        plan = ex.plan()
        p, n = bench.touch(obj, plan, rng, NOISE["noise_pos"], NOISE["noise_normal"])
        ex.add(p, n, plan)
    return ex


class Crease:
    """Two planes meeting along a line (a ridge for slope > 0), turned ``rot`` rad."""

    def __init__(self, slope, off=0.0, rot=0.3):
        self.a, self.off, self.rot = slope, off, rot

    def _u(self, x, y):
        return math.cos(self.rot) * np.asarray(x) + math.sin(self.rot) * np.asarray(y) - self.off

    def height(self, x, y):
        return -self.a * np.abs(self._u(x, y))

    def normals(self, x, y):
        g = -self.a * np.sign(self._u(x, y))
        n = np.stack([-g * math.cos(self.rot), -g * math.sin(self.rot), np.ones_like(g)], -1)
        return n / np.linalg.norm(n, axis=-1, keepdims=True)


def test_cylinder_confident_in_fewer_touches_than_the_fixed_plan():
    obj = make("cylinder", radius=6.6, rotation_deg=30, centre=(0.0, 0.0))
    ex = explore(obj, seed=3)
    assert ex.done() == "label" and ex.fit.label == "cylinder"
    assert ex.touches <= 9 < 18  # the fixed 3 x 6 plan takes 18
    lo, hi = ex.fit.result.S_interval
    assert lo <= 0.5 <= hi
    # after the seeds, each touch was chosen on the fit's principal-direction grid
    assert any("predicted S interval width" in f for f in _whys(obj, 3))


def _whys(obj, seed):
    rng = np.random.default_rng(seed)
    ex = Explorer(Region((0.0, 0.0, 0.0), (0.0, 0.0, 1.0), 3.0, 1.5), options=dict(NOISE))
    whys = []
    while ex.done() is None:
        plan = ex.plan()
        whys.append(plan.why)
        ex.add(*bench.touch(obj, plan, rng, 0.05, 0.03), plan)
    return whys


@pytest.mark.parametrize(
    "name, obj, truth, seeds",
    [
        ("plane", make("plane", slope=(0.3, 0.1), centre=(0.0, 0.0)), "plane", (0, 1, 2)),
        (
            "saddle near the cylinder band",
            make("quadric", k=(0.1, -0.045), centre=(0, 0), rotation_deg=20),
            "saddle",
            (0, 1, 2),
        ),  # fmt: skip
        ("ridge", Crease(0.5, 0.5), None, (0, 1, 2)),
        # (without the doubt on normals the fit misses, each of these was a concave
        # cylinder or a cylinder with confidence over 0.99)
        ("valley", Crease(-0.4, -1.0), None, (5, 6, 7)),
        ("valley across", Crease(-0.3, 0.8, rot=1.2), None, (0, 1, 2)),
        ("shallow ridge", Crease(0.25, -0.5, rot=2.0), None, (1, 3, 5)),
    ],
)
def test_no_confident_wrong_label_on_adversarial_surfaces(name, obj, truth, seeds):
    for seed in seeds:
        ex = explore(obj, seed, max_touches=12)
        if ex.done() == "label":
            assert ex.fit.label == truth, (name, seed, ex.fit.label, ex.fit.confidence)


# S = 0.75 (the cylinder/sphere band edge) at k2 / k1 = 0.414: seeds on which the band vote
# (0.95 or more) alone, or the 95 % S interval inside the band, gave a confident wrong label
@pytest.mark.parametrize("k2, seeds", [(0.0414, (18, 26, 28, 32))])
def test_a_label_whose_s_interval_crosses_its_band_edge_is_not_confident(k2, seeds):
    obj = make("quadric", k=(0.1, k2), centre=(0, 0), rotation_deg=40)
    for seed in seeds:
        ex = explore(obj, seed)
        for fit in ex.fits:
            if fit.result is not None and fit.label in bench.S_NAMES:
                lo, hi = fit.result.S_interval
                band = bench.S_NAMES.index(fit.label)
                assert bench.s_class(lo + 1e-9) == band == bench.s_class(hi - 1e-9), seed
        if ex.done() == "label":
            assert ex.fit.label == bench.truth_label(obj, ex.fit.result), (seed, ex.fit.label)
        else:
            assert "labels still feasible" in unknown(ex.fit, ex.touches)


def test_a_plane_is_confident_once_its_curvature_is_within_flat():
    obj = make("plane", slope=(0.3, 0.1), centre=(0.0, 0.0))
    for seed in (0, 1, 2):
        ex = explore(obj, seed, max_touches=9, flat=0.03)
        assert ex.done() == "label" and ex.fit.label == "plane", seed
        k = np.abs([*ex.fit.result.k1_interval, *ex.fit.result.k2_interval])
        assert ex.fit.confidence >= 0.95 and k.max() < 2 * 0.03
    # the flattest curved object of the bench (R 15 cm, 1/15 per cm) is never a plane
    pit = make("pit", radius=15.0, centre=(0.0, 0.0))
    for seed in (0, 1):
        ex = explore(pit, seed, flat=0.03)
        assert all(f.label != "plane" for f in ex.fits) and ex.fit.label == "concave_sphere"


def test_an_s_width_stop_waits_for_a_narrow_interval():
    obj = make("pit", radius=15.0, centre=(0.0, 0.0))
    quick, narrow = explore(obj, 4), explore(obj, 4, s_width=0.1)
    assert quick.done() == narrow.done() == "label"
    width = np.diff(narrow.fit.result.S_interval)[0]
    assert width <= 0.1 < np.diff(quick.fit.result.S_interval)[0]
    assert narrow.touches > quick.touches


def test_the_lattice_touches_the_squares_3_x_3_lattice_then_labels_no_sooner():
    obj = bench.build(bench.SPLITS["tune"]["cylinder"])
    rng, region = np.random.default_rng(0), Region((0.0, 0.0, 0.0), (0.0, 0.0, 1.0), 3.0, 1.5)
    ex, starts = Explorer(region, options=dict(NOISE), flat=0.03, lattice=True), []
    while ex.done() is None:
        plan = ex.plan()
        starts.append(plan.start)
        ex.add(*bench.touch(obj, plan, rng, NOISE["noise_pos"], NOISE["noise_normal"]), plan)
        assert ex.touches >= 9 or ex.done() is None  # (a confident label waits for the 9)
    first = {tuple(np.round(s[:2], 9)) for s in starts[:9]}  # the centre, corners, edges
    assert first == {(a, b) for a in (-3.0, 0.0, 3.0) for b in (-3.0, 0.0, 3.0)}
    assert all(s[2] == 1.5 for s in starts[:9])
    assert ex.done() == "label" and ex.fit.label == "cylinder" and ex.touches >= 9


def test_a_touch_across_a_ridge_is_named_and_the_first_face_kept():
    ex = explore(Crease(0.5, 0.5), seed=0, max_touches=12)
    said = [n for n in ex.notes if "lands across an edge" in n]
    assert said and "a ridge" in said[0] and "dihedral" in said[0]
    assert ex.keep is not None and ex.keep[0] and not ex.keep.all()


def test_stop_rules_budget_and_minimum():
    obj = make("sphere", radius=10.0, centre=(0.0, 0.0))
    ex = explore(obj, seed=1, max_touches=5)  # under the minimum: never confident
    assert ex.done() == "budget" and ex.touches == 5
    ex = explore(obj, seed=1)
    assert ex.done() == "label" and ex.touches >= 8 and ex.fit.label == "sphere"
    assert ex.fit.confidence >= 0.95


def test_a_missed_touch_counts_and_moves_the_next_one():
    region = Region((0.0, 0.0, 0.0), (0.0, 0.0, 1.0), 3.0, 1.5)
    ex = Explorer(region, max_touches=3)
    first = ex.plan()
    ex.add(None, None, first)
    assert ex.touches == 1 and "no contact" in ex.notes[0]
    assert ex.plan().start != first.start


def test_what_is_unknown_says_the_interval_and_the_feasible_labels():
    obj = make("quadric", k=(0.1, -0.045), centre=(0, 0), rotation_deg=20)
    rng = np.random.default_rng(0)
    x, y = rng.uniform(-3, 3, (2, 6))
    pts = np.column_stack([x, y, obj.height(x, y)]) + 0.05 * rng.standard_normal((6, 3))
    fit = fit_of(pts, obj.normals(x, y), confidence=0.999999, **NOISE)
    line = unknown(fit, 6)
    assert fit.result is not None and "after 6 touches S is" in line
    assert "labels still feasible: " in line and "95 %" in line
    assert unknown(Fit(refused="the contacts lie on one line"), 2).endswith("one line")
    flat = fit_of(pts * [1, 1, 0], np.tile([0.0, 0.0, 1.0], (6, 1)), **NOISE)
    assert flat.label == "plane" and "a plane cannot be told from a curvature under" in unknown(
        flat, 6
    )


def test_explore_csv_has_units_header_and_null_not_nan():
    from tactile.cli.cmd_explore import explore_csv

    rows = [Fit().row(1), {"touch": 2, "S": 0.5, "S_lo": 0.4, "S_hi": float("nan"),
                           "shape": "cylinder", "confidence": 0.97}]  # fmt: skip
    lines = explore_csv(rows).splitlines()
    assert lines[0].startswith("# units: 1")
    assert lines[1] == "touch,S,S_lo,S_hi,shape,confidence"
    assert lines[2] == "1,null,null,null,none,null"
    assert lines[3] == "2,0.5,0.4,null,cylinder,0.97"


# --- EP1: the next roll direction (eq. 64) on a known surface.


def test_next_roll_seeds_then_follows_the_least_known_principal_direction():
    from tactile_sim.ep1.probes import measure, simulate_probes
    from tactile_sim.ep1.rolling import true_curvature
    from tactile_sim.ep1.surfaces import fingertip
    from tactile_sim.ep1.surfaces import make as surface

    assert next_roll(np.zeros((0, 2)), np.zeros((0, 2)), 1.0)[1] == (1.0, 0.0)
    finger, obj = fingertip(1.0), surface("ellipsoid", a=1.6, b=0.9, c=1.2)
    rows = np.zeros((0, 4))
    phis = []
    for _ in range(3):
        phi, motion, why = next_roll(rows[:, :2], rows[:, 2:], 1.0)
        phis.append(phi)
        assert math.isclose(math.hypot(*motion), 1.0)
        assert math.isclose(motion[0], -math.sin(phi), abs_tol=1e-12)
        new = measure(simulate_probes(finger, obj, (0, 0), (0.2, 0.3), 0.05, [phi]), 1.0)
        rows = np.vstack([rows, new])
    # the first two span the plane (x, then across); the third is chosen, along a
    # principal direction of the estimate: S's eigenvector
    assert abs(math.cos(phis[1] - phis[0])) < 1e-4  # (across the measured rotation)
    k = np.linalg.lstsq(*_eq33(rows[:4]), rcond=None)[0]  # (each roll: out and back)
    vec = np.linalg.eigh(np.array([[k[0], k[1]], [k[1], k[2]]]))[1]
    motion = np.array([-math.sin(phis[2]), math.cos(phis[2])])
    assert max(abs(motion @ vec[:, 0]), abs(motion @ vec[:, 1])) > 1 - 1e-9
    # ... which is the surface's own principal direction there (noise-free probes)
    true = np.linalg.eigh(true_curvature(obj, (0.2, 0.3))["K"])[1]
    assert max(abs(motion @ true[:, 0]), abs(motion @ true[:, 1])) > math.cos(math.radians(2))
    assert "along the principal direction" in why


def _eq33(rows):
    a = np.column_stack([-rows[:, 1], rows[:, 0]])
    z = np.zeros(len(a))
    A = np.concatenate([np.column_stack([a, z]), np.column_stack([z, a])])
    return A, np.concatenate([rows[:, 2], rows[:, 3]])


# --- the command, end to end on the emulated board and arm.


@pytest.fixture
def emulated(tmp_path):
    """(board port, robot address) of explore_sphere served in-process, fast."""
    from tactile_sim.emulator.device import EmulatedBoard
    from tactile_sim.emulator.robot_server import EmulatedArm, RobotServer, board_waiter
    from tactile_sim.emulator.scene import load_scene
    from tactile_sim.emulator.servers import server_for

    board = EmulatedBoard(load_scene("explore_sphere"))

    def clock():
        return board.t_us

    arm = EmulatedArm(board.motion, clock, board_waiter(clock))
    server = server_for(board, realtime=False, when_opened=False, replay=False)
    server.prepare()
    with RobotServer(arm, "127.0.0.1", 0) as robot, server:
        yield server.path, robot.address


def test_cli_explores_the_emulated_sphere(cli, emulated, tmp_path):
    port, robot = emulated
    out = tmp_path / "run"
    code, stdout, stderr = cli("explore", "--port", port, "--robot", robot, "-o", out, "--json")
    assert code == 0, stderr
    result = json.loads(stdout)
    assert result["label"] == "sphere" and result["ended"] == "label"
    assert result["touches"] < 18 and result["confidence"] >= 0.95  # (the bench: <= 9)
    rows = (out / "explore.csv").read_text().splitlines()
    assert rows[1] == "touch,S,S_lo,S_hi,shape,confidence" and len(rows) == 2 + result["touches"]
    assert "nan" not in (out / "explore.csv").read_text().lower()
    contacts = (out / "contacts.csv").read_text().splitlines()
    assert contacts[0] == "# units: m" and len(contacts) == 2 + result["contacts"]
    meta = json.loads((out / "meta.json").read_text())
    assert meta["robot"] == robot and meta["label"] == "sphere" and meta["unknown"] is None
    assert meta["options"]["flat_per_m"] == 3.0 and meta["options"]["s_width"] is None
    code, stdout, stderr = cli("ep2", "analyze", out / "contacts.csv")  # the same contract
    assert code == 0 and "sphere" in stdout


def test_cli_budget_spent_exits_3_saying_what_is_unknown(cli, emulated, tmp_path):
    port, robot = emulated
    out = tmp_path / "run"
    fox = ["--foxglove", "--foxglove-port", "0"]
    code, stdout, stderr = cli("explore", "--port", port, "--robot", robot, "-o", out,
                               "--max-touches", "4", *fox)  # fmt: skip
    assert code == 3
    assert "foxglove: serving ws://127.0.0.1:" in stderr  # (contacts, patch, next touch live)
    assert "not confident: the budget is spent" in stdout and len(stdout.splitlines()) == 1
    assert "explore: after 4 touches" in stderr.splitlines()[-1]
    assert json.loads((out / "meta.json").read_text())["ended"] == "budget"


def test_cli_lattice_touches_the_lattice_first(cli, emulated, tmp_path):
    port, robot = emulated
    out = tmp_path / "run"
    code, stdout, stderr = cli("explore", "--port", port, "--robot", robot, "-o", out,
                               "--max-touches", "3", "--lattice")  # fmt: skip
    assert code == 3 and "explore: touch 2 (lattice 2)" in stderr and "(lattice 3)" in stderr
    assert json.loads((out / "meta.json").read_text())["options"]["lattice"] is True


@pytest.mark.parametrize(
    "args, says",
    [
        (["--confidence", "1.5"], "--confidence: 1.5"),
        (["--max-touches", "0"], "--max-touches: 0"),
        (["--robot", "nowhere"], "--robot"),
        (["--half-size", "-1"], "--half-size: -1"),
        (["--noise-normal", "nan"], "--noise-normal: nan"),
        (["--flat", "0"], "--flat: 0"),
        (["--s-width", "-0.1"], "--s-width: -0.1"),
    ],
)
def test_cli_bad_options_exit_2(cli, tmp_path, args, says):
    base = {"--robot": "127.0.0.1:9", "--port": "/dev/null"}
    base.update(dict(zip(args[::2], args[1::2], strict=True)))
    argv = [x for kv in base.items() for x in kv]
    code, _, stderr = cli("explore", *argv, "-o", tmp_path / "r")
    assert code == 2 and says in stderr and len(stderr.strip().splitlines()) == 1


def test_the_hold_is_the_frames_of_its_window_above_the_gate_across_a_wrap():
    from tactile.board.client import hold_wrench
    from tactile.board.stream_decoder import Contact, Sample

    def sample(t_us, fz_N):
        return Sample(0, t_us % 2**32, 0, 0, 0, 0, round(fz_N * 1e6), 1000, 0, 0)

    t0 = 2**32 - 3000  # the board's µs stamps wrap inside the hold
    before = [sample(t0 - 1000, 9.0)]  # a frame before the hold: not in it
    hold = [sample(t0 + k * 2000, 3.0 + 0.1 * k) for k in range(4)]  # 3.0 .. 3.3 N
    light = [sample(t0 + 500, 0.5)]  # under the gate
    other = [Contact(0, t0 + 700, 0, 1, 1, 0, 0, 0, 9_000_000, 0, 0, 0)]  # not a SAMPLE
    after = [sample(t0 + 9000, 9.0)]  # past the hold: reading stops
    late = [sample(t0 + 100, 50.0)]  # a batch after the one past the hold: never read
    batches = iter([before + hold[:2], light + other + hold[2:] + after, late])
    w, n = hold_wrench(batches, (t0, (t0 + 6000) % 2**32), 1.39)
    assert n == 4 and w[2] == pytest.approx(3.15) and w[3] == pytest.approx(1e-3)
    assert next(batches) is late
    w, n = hold_wrench(iter([light + hold]), None, 1.39)  # no window: every frame of the read
    assert n == 4 and w[2] == pytest.approx(3.15)
    assert hold_wrench(iter([light]), None, 1.39) == (None, 0)


def test_cli_a_start_the_arm_cannot_reach_is_a_touch_spent(cli, emulated, tmp_path):
    port, robot = emulated
    out = tmp_path / "run"  # seeds 0.035 m off the centre: outside the arm's +-0.03 m
    code, stdout, stderr = cli("explore", "--port", port, "--robot", robot, "-o", out,
                               "--max-touches", "3", "--half-size", "0.05")  # fmt: skip
    assert code == 3 and "after 3 touches" in stdout
    meta = json.loads((out / "meta.json").read_text())
    assert meta["touches"] == 3 and meta["contacts"] == 1, (meta["notes"], stderr)
    assert sum("unreachable start" in n for n in meta["notes"]) == 2
    assert len((out / "explore.csv").read_text().splitlines()) == 2 + 3


def test_cli_foxglove_gets_the_contacts_the_patch_and_the_next_touch(
    cli, emulated, tmp_path, monkeypatch
):
    from tactile.cli import cmd_explore

    published, fed = [], []

    class Live:  # what explore gives the live server: frames, and scene messages per topic
        class topics:
            @staticmethod
            def scene(topic, message, ns):
                published.append((topic, type(message).__name__))

        @staticmethod
        def feed(msgs, arrivals=None):
            fed.extend(msgs)

    declared = []  # made before the server listens (docs/foxglove.md: limits)
    monkeypatch.setattr(
        cmd_explore, "start_foxglove",
        lambda args, device=None, topics=(), port=None: declared.extend(topics) or Live,
    )  # fmt: skip
    monkeypatch.setattr(cmd_explore, "stop_foxglove", lambda server, quiet=False: None)
    port, robot = emulated
    code, _, _ = cli("explore", "--port", port, "--robot", robot, "-o", tmp_path / "r",
                     "--max-touches", "4", "--foxglove")  # fmt: skip
    assert code == 3 and fed
    assert {kind for _, kind in published} == {"SceneUpdate"}
    topics = [t for t, _ in published]  # before each touch its plan, after it the scene
    assert topics == ["/tactile/next_touch", "/tactile/contacts", "/tactile/patch"] * 4
    assert sorted(declared) == sorted(set(topics))


def test_a_contact_ep2_leaves_out_does_not_withhold_the_label():
    obj = make("sphere", radius=10.0, centre=(0.0, 0.0))
    rng = np.random.default_rng(1)
    ex = Explorer(Region((0.0, 0.0, 0.0), (0.0, 0.0, 1.0), 3.0, 1.5), options=dict(NOISE))
    while ex.done() is None:
        plan = ex.plan()
        p, n = bench.touch(obj, plan, rng, 0.05, 0.03)
        if ex.touches == 2:  # one normal 20 deg off: EP2 names it and leaves it out
            n = n + [math.tan(math.radians(20.0)), 0.0, 0.0]
        ex.add(p, n, plan)
    assert ex.done() == "label" and ex.fit.label == "sphere"
    assert any("left out" in w for w in ex.fit.result.warnings)
