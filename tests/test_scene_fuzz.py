"""Fuzzing the scene loader (issue 12): a shipped scene with random values, types, keys and
sections either loads, builds and runs, or is refused in one line naming the file and the
key; never another exception, never a hang.

CI runs a fixed-seed budget (the ``ci`` profile of conftest); ``TACTILE_FUZZ=long`` runs
``FUZZ_SCALE`` times as many examples, randomised.
"""

import datetime
import re
import signal
import sys

import pytest
from conftest import FUZZ_SCALE, ROOT
from hypothesis import given, settings
from hypothesis import strategies as st

from tactile_sim.emulator import SceneError, load_scene, scene_schema
from tactile_sim.emulator.device import EmulatedBoard

sys.path.insert(0, str(ROOT / "bench"))
import scene_variants  # noqa: E402

EXAMPLES = 150
# One example (load, build, 50 ms of board time) takes at most ~0.4 s of CPU.  A hang is
# CPU spent (every loop here computes) or, failing that, wall time; the wall backstop is
# wide because this machine is shared and its wall clock says little about our work.
CPU_BUDGET_S = 10
WALL_BUDGET_S = 300
BASES = ("press", "ch5_plane", "ep2_sweep_sphere", "ep1_roll")

_SCALARS = st.one_of(
    st.integers(-(2**70), 2**70),
    st.integers(-3, 70),
    st.floats(allow_nan=True, allow_infinity=True),
    st.floats(-10.0, 10.0),
    st.sampled_from([0, -1, 1, 0.0, -0.0, 1e-320, 1e300, -4.0, 1e6, 2**32]),
    st.booleans(),
    st.text(st.characters(blacklist_categories=("Cs",)), max_size=12),
    st.sampled_from(["xy", "3d", "contacts", "samples", "plane", "sphere", "saddle", "ellipsoid"]),
    st.dates(min_value=datetime.date(1, 1, 1)),
)
_NAMES = st.from_regex(r"[a-z_]{1,12}", fullmatch=True)
VALUES = st.recursive(
    _SCALARS,
    lambda inner: st.lists(inner, max_size=8) | st.dictionaries(_NAMES, inner, max_size=4),
    max_leaves=20,
)
SECTIONS = list(scene_schema.TOP) + ["extra"]
KEYS = sorted({key.name for key in scene_schema.KEYS})  # every key the schema knows


def in_range(t):
    """Values the schema accepts for type ``t`` (its extremes included): valid, but odd,
    combinations are where building and running can still go wrong."""
    if t.kind == "int":
        return st.integers(t.lo, t.hi) | st.sampled_from([t.lo, t.hi])
    if t.kind == "number":
        return st.floats(t.lo, t.hi, exclude_min=t.open)
    if t.kind == "bool":
        return st.booleans()
    if t.kind == "text":
        return st.text(st.characters(min_codepoint=32, max_codepoint=126), min_size=1,
                       max_size=t.hi)  # fmt: skip
    if t.kind == "choice":
        return st.sampled_from(scene_schema.choices(t))
    if t.kind == "list":
        return st.lists(in_range(t.of), min_size=t.lo, max_size=min(t.hi, t.lo + 6))
    if t.kind == "row":
        return st.tuples(*map(in_range, t.of)).map(list)
    if t.kind == "table":
        return st.dictionaries(st.sampled_from("abcrRCd"), in_range(t.of), max_size=4)
    return st.one_of(*map(in_range, t.of))  # either


def _keys(data, section):
    if section == "motion":
        kind = data.get("motion", {}).get("kind") if isinstance(data.get("motion"), dict) else None
        return scene_schema.MOTION.get(kind, {}) if isinstance(kind, str) else {}
    return scene_schema.SECTIONS.get(section, {})


@st.composite
def mutated_scenes(draw):
    """(base, data): a shipped scene with one to four keys or sections changed or dropped:
    mostly to values the schema accepts, else to anything TOML can hold."""
    base = draw(st.sampled_from(BASES))
    data = scene_variants.base_data(base)
    for _ in range(draw(st.integers(1, 4))):
        section = draw(st.sampled_from(SECTIONS))
        what = draw(st.sampled_from(["valid"] * 6 + ["any", "any", "drop", "section"]))
        if what == "section":
            data[section] = draw(VALUES | st.lists(st.dictionaries(_NAMES, _SCALARS), max_size=3))
            continue
        if section == "sensor_fault":
            faults = data.setdefault("sensor_fault", [])
            if isinstance(faults, list) and what == "valid":
                keys = scene_schema.SECTIONS["sensor_fault"]
                faults.append({k: draw(in_range(v.type)) for k, v in keys.items()
                               if k == "kind" or draw(st.booleans())})  # fmt: skip
                continue
            section = "extra"
        table = data.setdefault(section, {})
        if not isinstance(table, dict):
            continue
        keys = _keys(data, section)
        if what == "drop" and table:
            del table[draw(st.sampled_from(sorted(table)))]
        elif what == "valid" and keys:
            key = draw(st.sampled_from(sorted(keys)))
            table[key] = draw(in_range(keys[key].type))
        else:
            table[draw(st.sampled_from(KEYS) | _NAMES)] = draw(VALUES)
    return base, data


# (timer, its signal, budget s, what it measures)
TIMERS = (
    (signal.ITIMER_PROF, signal.SIGPROF, CPU_BUDGET_S, "CPU"),
    (signal.ITIMER_REAL, signal.SIGALRM, WALL_BUDGET_S, "wall"),
)


def _timeout(signum, frame):
    _, _, budget, what = next(t for t in TIMERS if t[1] == signum)
    raise TimeoutError(f"a scene took over {budget} s of {what} time to load, build and run")


@pytest.mark.slow
@pytest.mark.filterwarnings("error")  # a numpy warning on the terminal counts as a failure
@settings(max_examples=EXAMPLES * FUZZ_SCALE)
@given(mutated_scenes())
def test_a_mutated_scene_loads_or_is_one_line_naming_file_and_key(tmp_path_factory, case):
    _, data = case
    path = tmp_path_factory.mktemp("fuzz") / "scene.toml"
    path.write_text(scene_variants.to_toml(data), encoding="utf-8")
    old = [signal.signal(sig, _timeout) for _, sig, _, _ in TIMERS]
    for timer, _, budget, _ in TIMERS:
        signal.setitimer(timer, budget)
    try:
        scene = load_scene(path)
        board = EmulatedBoard(scene)
        board.host_opened()
        board.run_until(50_000)  # HELLO and the first samples: values reach the firmware
    except SceneError as exc:
        msg = str(exc)
        assert "\n" not in msg and "\r" not in msg, msg
        where = r"(\[\[sensor_fault\]\]( #\d+)?|\[[^\]]+\])( \S+)?|[^\s:]+"
        assert re.match(re.escape(str(path)) + rf": ({where}): \S", msg), msg
    finally:
        for (timer, sig, _, _), handler in zip(TIMERS, old):
            signal.setitimer(timer, 0)
            signal.signal(sig, handler)
