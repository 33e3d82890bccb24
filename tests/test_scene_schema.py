"""Scenes are validated whole against one schema (issue 12): every malformed kind a one-line
error naming file, section and key, with exit 2, by every route that loads a scene."""

import os
import subprocess
import sys

import pytest
from conftest import ROOT

from tactile_protocol import constants as C
from tactile_protocol import settings
from tactile_sim.emulator import load_scene, scene_schema
from tactile_sim.emulator.device import EmulatedBoard
from tactile_sim.emulator.scene import MOTIONS, SCENE_DIR

sys.path.insert(0, str(ROOT / "bench"))
import scene_variants  # noqa: E402

SHIPPED = sorted(p.stem for p in SCENE_DIR.glob("*.toml"))


@pytest.mark.filterwarnings("error")  # a warning would be a second line on the terminal
@pytest.mark.parametrize("route", sorted(scene_variants.ROUTES))
@pytest.mark.parametrize("variant", scene_variants.VARIANTS, ids=lambda v: v.name)
def test_a_malformed_scene_is_one_line_and_exit_2(tmp_path, variant, route):
    code, out, err, path, command = scene_variants.run(variant, tmp_path, route)
    assert scene_variants.verdict(variant, code, err, path, command) == "held", err
    assert "Traceback" not in out + err


def test_the_table_covers_what_the_issue_found():
    names = [v.name for v in scene_variants.VARIANTS]
    assert len(names) >= 58 and len(set(names)) == len(names)
    found = " ".join(names)
    issue = ('seed = "abc"', "sensors = 0", "sensors = 5", "sensors = 1000000", "cal_id = -1")
    issue += ("max_rate_hz = 70000", "a table", "NaN noise", "inf noise", "negative noise")
    issue += ("duration_s = -4", 'gate = "4d"', "force_range_N = -50", "unknown key")
    for kind in issue + ("unknown section",):
        assert kind in found, kind


@pytest.mark.parametrize("name", SHIPPED)
def test_every_shipped_scene_validates_and_builds(name):
    scene = load_scene(name)
    board = EmulatedBoard(scene)
    board.host_opened()
    board.run_until(60_000)
    assert board.read_host()  # HELLO and frames: the board runs


def test_a_bad_scene_through_the_real_cli_process(tmp_path):
    variant = next(v for v in scene_variants.VARIANTS if v.name == "NaN noise")
    path = scene_variants.write(variant, tmp_path)
    cmd = [sys.executable, "-m", "tactile.cli.main", "emulate", str(path)]
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(sys.path))  # this checkout's sources
    out = subprocess.run(cmd, capture_output=True, text=True, timeout=60, env=env)
    assert out.returncode == 2 and out.stdout == ""
    why = "must be finite, >= 0 and <= 2147.48, got nan"
    assert out.stderr == f"tactile emulate: error: {path}: [sensor] noise_force_N[1]: {why}\n"


def test_a_missing_scene_names_the_shipped_ones(cli, tmp_path):
    code, _, err = cli("info", "--port", f"sim://{tmp_path}/nope.toml")
    assert code == 2 and err.count("\n") == 1 and "no such scene file" in err
    assert "ch5_convex" in err


def test_one_schema_for_every_motion_module():
    assert set(scene_schema.MOTION) == set(MOTIONS)


def test_limits_come_from_the_protocol_and_firmware():
    b = {k: key.type for k, key in scene_schema.SECTIONS["board"].items()}
    s = {k: key.type for k, key in scene_schema.SECTIONS["sensor"].items()}
    assert (b["sensors"].lo, b["sensors"].hi) == (1, C.MAX_SENSORS)
    assert (b["debounce"].lo, b["debounce"].hi) == (1, settings.MAX_DEBOUNCE)
    assert b["rate_hz"].lo == settings.MIN_RATE_HZ
    assert b["rate_hz"].hi == b["max_rate_hz"].hi == 0xFFFF  # the wire's u16
    assert s["cal_id"].hi == 0xFFFF_FFFF  # INFO's u32
    assert b["enter_threshold_N"].hi == pytest.approx(0x7FFF_FFFF * C.FORCE_LSB_N)


def test_the_docs_show_the_schema():
    doc = (ROOT / "docs" / "scenes.md").read_text(encoding="utf-8")
    assert scene_schema.markdown() in doc, (
        "docs/scenes.md is out of date: paste the output of\n  python -c 'from "
        'tactile_sim.emulator.scene_schema import markdown; print(markdown(), end="")\''
    )
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    assert "docs/scenes.md" in readme


def test_the_docs_example_is_a_valid_scene(tmp_path):
    doc = (ROOT / "docs" / "scenes.md").read_text(encoding="utf-8")
    example = doc.split("```toml\n", 1)[1].split("```", 1)[0]
    (tmp_path / "example.toml").write_text(example)
    scene = load_scene(tmp_path / "example.toml")
    assert scene.motion["kind"] == "press" and scene.sensor_faults[0]["kind"] == "i2c_timeout"
    EmulatedBoard(scene).run_until(10_000)


def test_defaults_are_filled_and_not_shared(tmp_path):
    path = tmp_path / "s.toml"
    path.write_text('[motion]\nkind = "press"\nkeyframes = [[0, 0, 0, 0, 0, 0, 0]]\n')
    a, b = load_scene(path), load_scene(path)
    assert a.board["streams"] == ["contacts"] and a.sensor["noise_force_N"] == [0.0, 0.0, 0.0]
    assert a.name == "s" and a.link is None and a.sensor_faults == []
    a.board["streams"].append("samples")
    assert b.board["streams"] == ["contacts"]
    assert scene_schema.BOARD["streams"].default == ["contacts"]


@pytest.mark.parametrize("where", ["dir", "/dev/zero", "fifo"])
def test_a_scene_that_is_no_file_is_refused_before_reading(cli, tmp_path, where):
    path = {"dir": tmp_path, "fifo": tmp_path / "fifo"}.get(where, where)
    if where == "fifo":
        os.mkfifo(path)  # reading it would block for ever
    code, _, err = cli("emulate", path)
    kind = "a directory" if where == "dir" else "not a regular file"
    assert (
        code == 2
        and err == f"tactile emulate: error: {path}: {kind} (a scene must be a regular file)\n"
    )
