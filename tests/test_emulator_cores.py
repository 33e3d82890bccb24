"""The emulator runs either firmware core (issue 16, part 4): the MicroPython one or the C core.

The two cores on the same scene, boot id and host bytes write the same bytes: the C core's
HAL reaches the same simulated ADCs and buses, link, clock and flash.  Choosing the core:
``tactile emulate --core``, a scene's ``[board] core``, ``sim://SCENE?core=``; and what a
user sees when the C core cannot run.
"""

import subprocess
import sys

import pytest
from toolchain import missing

from tactile_protocol import constants as C
from tactile_protocol.framing import FrameEncoder
from tactile_sim.emulator import SceneError, cores, load_scene
from tactile_sim.emulator.device import EmulatedBoard

FAULTS = """
[[sensor_fault]]
at_s = 0.2
kind = "i2c_timeout"
count = 3
[[sensor_fault]]
at_s = 0.4
kind = "stuck_drdy"
for_s = 0.03
[[sensor_fault]]
at_s = 0.6
kind = "i2c_nack"
sensor = 1
for_s = 0.02
[[sensor_fault]]
at_s = 0.8
kind = "saturate"
for_s = 0.01
"""


@pytest.fixture(scope="module")
def c_core():
    try:
        return cores.c_library()
    except cores.CoreUnavailable as exc:
        missing(str(exc))


def _scene(tmp_path, base, extra="", board=""):
    """Shipped scene ``base`` with ``board`` lines first in its [board] and ``extra`` after."""
    text = load_scene(base).path.read_text()
    if board:
        text = text.replace("[board]\n", "[board]\n" + board + "\n", 1)
        text = text.replace("\nrate_hz = 1000\n", "\n", 1) if "rate_hz" in board else text
    path = tmp_path / f"{base}.toml"
    path.write_text(text + "\n" + extra)
    return load_scene(path)


def _session(scene, core, host=()):
    """All bytes the board wrote in ``scene``; ``host``: (time in us, bytes the host sends)."""
    emu = EmulatedBoard(scene, boot_id=0xC0FFEE, core=core, board_id=b"emulated")
    out, t = bytearray(), 0
    plan = sorted(host)
    while t < 1_000_000:
        t += 10_000
        while plan and plan[0][0] <= t:
            emu.write_host(plan.pop(0)[1])
        emu.run_until(t)
        out += emu.read_host()
    return bytes(out), emu


def _commands():
    enc = FrameEncoder()
    frame = lambda t, *a: (t, bytes(enc.encode(*a)))  # noqa: E731
    return [
        frame(50_000, C.CMD_GET_INFO, 0, ()),
        frame(120_000, C.CMD_CONFIG, 0, (500, 900_000, 700_000, 2, 0x07)),
        frame(300_000, C.CMD_TARE, 0, (C.SENSOR_ALL, 20)),
        frame(450_000, C.CMD_STOP, 0, ()),
        frame(520_000, C.CMD_START, 0, ()),
        frame(530_000, C.CMD_CONFIG, 0, (5000, 1, 2, 3, 0)),  # refused: above max_rate_hz
    ]


@pytest.mark.parametrize(
    "base, board, extra",
    [
        ("press", "sensors = 2\nrate_hz = 800", FAULTS),  # every kind of sensor fault
        ("ep2_sweep_sphere", "", ""),  # three fingers on two buses
        ("ch5_convex", "", ""),  # the rig, contacts only
    ],
)
def test_both_cores_write_the_same_bytes(c_core, tmp_path, base, board, extra):
    scene = _scene(tmp_path, base, extra, board)
    host = _commands()
    py, py_emu = _session(scene, "python", host)
    c, c_emu = _session(scene, "c", host)
    assert type(c_emu.board).__name__ == "CBoard" and c_emu.core == "c"
    assert len(py) > 10_000 and py == c
    for name in ("samples", "i2c_errors", "drdy_timeouts", "saturations", "rx_errors"):
        assert getattr(py_emu.board, name) == getattr(c_emu.board, name), name
    if extra:
        assert py_emu.board.i2c_errors > 0 and py_emu.board.drdy_timeouts > 0


def test_a_scene_names_its_core_and_the_caller_may_override_it(c_core, tmp_path):
    scene = _scene(tmp_path, "press", board='core = "c"')
    assert scene.board["core"] == "c" and EmulatedBoard(scene).core == "c"
    assert EmulatedBoard(scene, core="python").core == "python"
    assert load_scene("press").board["core"] == "python"  # the default


def test_an_unknown_core_in_a_scene_is_one_line_naming_the_key(tmp_path):
    with pytest.raises(SceneError, match=r"\[board\] core: must be one of python, c, got 'rust'"):
        _scene(tmp_path, "press", board='core = "rust"')


def test_an_unknown_core_in_a_sim_url_is_one_line(cli):
    code, out, err = cli("info", "--port", "sim://press?core=rust")
    assert code == 4 and out == "" and err.count("\n") == 1
    assert "core must be one of python, c" in err


def test_without_a_compiler_the_c_core_is_refused_in_one_line(cli, mocker, tmp_path):
    from tactile_fw_tools import ccore

    mocker.patch.object(ccore.shutil, "which", return_value=None)
    mocker.patch.dict("os.environ", {"CC": ""})
    cores.c_library.cache_clear()
    try:
        code, out, err = cli("info", "--port", "sim://press?core=c")
    finally:
        cores.c_library.cache_clear()
    assert code == 4 and out == "" and err.count("\n") == 1 and "Traceback" not in err
    assert "core 'c': no C compiler (cc, gcc or clang) on PATH: install build-essential" in err


def test_emulate_core_c_serves_a_pty_that_record_reads(c_core, cli, tmp_path):
    """The user's flow with the C core: 'tactile emulate --core c', then 'tactile record'."""
    import json

    emulate = subprocess.Popen(
        [sys.executable, "-m", "tactile.cli.main", "emulate", "press", "--core", "c",
         "--duration", "30"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    try:
        path = emulate.stdout.readline().strip()
        assert path.startswith("/dev/"), emulate.stderr.read()
        code, _, err = cli("record", "--port", path, "--contacts", "1", "-o", tmp_path, "--quiet")
    finally:
        emulate.terminate()
        _, said = emulate.communicate(timeout=5)
    assert code == 0, err
    assert "on the c core" in said
    meta = json.loads((tmp_path / "meta.json").read_text())
    assert meta["contacts_ended"] == 1 and meta["decoder"]["lost_frames"] == 0
    assert meta["tared"] and meta["device"]["sensor_model"] == "FT6/ADS122C04x6"
