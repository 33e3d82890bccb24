"""A scene builds and imports only what it names (issue 6): no rolling in a sweep, and so on."""

import json
import subprocess
import sys

import pytest

FAMILIES = ("tactile_sim.ep1", "tactile_sim.ep2", "tactile_sim.rig", "tactile.ep1", "tactile.ep2",
            "tactile.localize", "matplotlib")  # fmt: skip


def _loaded(scene):
    code = (
        "import json, sys; from tactile_sim.emulator import load_scene; "
        "from tactile_sim.emulator.device import EmulatedBoard; "
        f"EmulatedBoard(load_scene({scene!r})).run_until(200000); "
        f"print(json.dumps(sorted({{m.rsplit('.', 1)[0] if m.count('.') > 1 else m "
        f"for m in sys.modules if m.startswith({FAMILIES!r})}})))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    return set(json.loads(out.stdout))


@pytest.mark.parametrize(
    "scene, needs, never",
    [
        (
            "ep2_sweep_sphere",
            {"tactile_sim.ep2"},
            {"tactile_sim.ep1", "tactile.ep1", "tactile.ep2"},
        ),
        ("ep1_roll", {"tactile_sim.ep1"}, {"tactile_sim.ep2", "tactile.ep2", "tactile.ep1"}),
        ("ch5_convex", {"tactile_sim.rig"}, {"tactile_sim.ep1", "tactile_sim.ep2", "tactile.ep2"}),
    ],
)
def test_a_scene_loads_only_its_own_kinematics(scene, needs, never):
    loaded = _loaded(scene)
    assert needs <= loaded, loaded
    assert not (never & loaded), loaded
    assert "matplotlib" not in loaded
