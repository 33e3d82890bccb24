"""The emulator runs the real firmware on simulated hardware (issue 6), in process.

The gate and the sensor faults, on both firmware cores: ``test_board_suite.py``.
"""

import pathlib
import re
import subprocess
import sys

import pytest
from board_target import run_emulated

from tactile_sim.emulator import SceneError, load_scene
from tactile_sim.emulator.device import EmulatedBoard
from tactile_sim.urlhandler import register

ROOT = pathlib.Path(__file__).resolve().parents[1]
register()


def _scene(tmp_path, text):
    path = tmp_path / "scene.toml"
    path.write_text(text)
    return path


def _press(tmp_path, extra="", noise=True):
    text = load_scene("press").path.read_text()
    if not noise:
        text = re.sub(r"noise_force_N = .*", "noise_force_N = [0.0, 0.0, 0.0]", text)
    return _scene(tmp_path, text + "\n" + extra)


def test_it_is_the_real_firmware():
    from tactile_fw.board import Board

    board = EmulatedBoard(load_scene("press"))
    assert type(board.board) is Board


def test_sim_holds_no_second_copy_of_the_protocol():
    text = "\n".join(p.read_text() for p in (ROOT / "sim").rglob("*.py"))
    assert "0x1021" not in text and "crc_hqx" not in text
    assert not re.search(r"^\s*(from cobs|import cobs)", text, re.M)
    assert not re.search(r"def (encode_into|crc16|pack_into)\b", text)
    assert "struct.pack" not in text


def test_link_faults_are_counted_exactly(tmp_path):
    corrupt = list(range(50, 3000, 97))
    drop = list(range(101, 3000, 211))
    extra = f"[link]\ncorrupt_frames = {corrupt}\ndrop_byte_frames = {drop}\n"
    port, msgs, counters = run_emulated(f"sim://{_press(tmp_path, extra)}", 3.5)
    injected = port.faults.injected
    assert injected["corrupted"] == len(corrupt) and injected["dropped_bytes"] == len(drop)
    total = injected["corrupted"] + injected["dropped_bytes"]
    assert counters.lost_frames == total
    assert counters.crc_errors + counters.undecodable == total
    seqs = [m.seq for m in msgs]
    assert len(seqs) + total == seqs[-1] + 1  # every undamaged frame arrived


def test_faults_can_be_turned_off_in_the_url(tmp_path):
    extra = "[link]\ncorrupt_frames = [10, 20]\n"
    _, _, counters = run_emulated(f"sim://{_press(tmp_path, extra)}?faults=0", 0.5)
    assert counters.lost_frames == 0


def test_noiseless_scene_draws_no_random_numbers(tmp_path):
    board = EmulatedBoard(load_scene(_press(tmp_path, noise=False)))
    assert all(model.rng is None for model in board.models)
    noisy = EmulatedBoard(load_scene("press"))
    assert all(model.rng is not None for model in noisy.models)


def test_a_press_scene_loads_no_rolling_or_fitting_code():
    code = (
        "import sys; from tactile_sim.emulator import load_scene; "
        "from tactile_sim.emulator.device import EmulatedBoard; "
        "EmulatedBoard(load_scene('press')).run_until(100000); "
        "print(sorted(m for m in sys.modules if m.startswith(('tactile_sim.ep1', "
        "'tactile_sim.ep2', 'tactile.ep1', 'tactile.ep2', 'scipy', 'matplotlib'))))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"


@pytest.mark.parametrize(
    "text, expect",
    [
        ('[motion]\nkind = "teleport"\n', "kind: must be one of"),
        (
            '[board]\nrate_hz = "fast"\n[motion]\nkind = "press"\nkeyframes = [[0,0,0,0,0,0,0]]\n',
            "rate_hz: must be an integer",
        ),
        (
            '[board]\nspeed = 1\n[motion]\nkind = "press"\nkeyframes = [[0,0,0,0,0,0,0]]\n',
            "unknown key",
        ),
        ('[motion]\nkind = "press"\nkeyframes = [[0, 1]]\n', "keyframes"),
        ("[motion\n", "scene.toml"),
        (
            '[board]\nrate_hz = 99999\n[motion]\nkind = "press"\nkeyframes = [[0,0,0,0,0,0,0]]\n',
            "rate_hz",
        ),
    ],
)
def test_bad_scenes_are_one_line_errors(tmp_path, text, expect):
    with pytest.raises(SceneError, match=expect) as exc:
        EmulatedBoard(load_scene(_scene(tmp_path, text)))
    assert "\n" not in str(exc.value)


def test_emulate_cli_reports_bad_scene(tmp_path, cli):
    code, out, err = cli("emulate", tmp_path / "missing.toml")
    assert code == 2 and "missing.toml" in err and "Traceback" not in err


def test_every_registered_motion_kind_has_its_module():
    import importlib

    from tactile_sim.emulator.scene import MOTIONS

    for module in MOTIONS.values():
        assert callable(importlib.import_module(module).build)


def test_press_motion_scalar_path_equals_numpy_interp():
    import numpy as np

    from tactile_sim.emulator.device import build_motion

    motion = build_motion(load_scene("press"))
    times = np.random.default_rng(3).uniform(-1.0, 9.0, 2000).tolist() + [0.0, 0.5, 1.0, 2.0]
    for t in times:
        t_wrapped = motion.t[0] + (t - motion.t[0]) % motion.span
        expect = [np.interp(t_wrapped, motion.t, motion.w[:, k]) for k in range(6)]
        assert motion.wrench_at(t).tolist() == expect  # bit for bit
