"""``tactile flash``: dry-run listing, staging, and one-line errors."""

import types

import pytest

from tactile import flashing
from tactile.errors import BoardError, PortError


def test_dry_run_lists_every_board_file(cli):
    code, out, err = cli("flash", "--port", "/dev/ttyACM0", "--dry-run", "--sensors", "2")
    assert code == 0 and err == ""
    lines = out.splitlines()
    assert len(lines) == len(flashing.board_files()) + 2
    assert any(":lib/tactile_fw/board.py" in line for line in lines)
    assert "main(n_sensors=2, wdt_ms=0)" in lines[-2]


def test_dry_run_with_mpy_names_mpy_targets(cli):
    code, out, _ = cli("flash", "--port", "a0", "--dry-run", "--mpy")
    assert code == 0
    assert "lib/tactile_fw/board.mpy" in out and "lib/tactile_fw/__init__.py" in out


def test_bad_sensor_count_is_one_line(cli):
    code, out, err = cli("flash", "--port", "a0", "--dry-run", "--sensors", "5")
    assert code == 2 and "--sensors 5" in err and len(err.strip().splitlines()) == 1


def test_missing_mpremote_is_one_line(cli, mocker):
    mocker.patch.object(flashing.shutil, "which", return_value=None)
    mocker.patch.object(flashing.pathlib.Path, "exists", return_value=False)
    code, _, err = cli("flash", "--port", "/dev/ttyACM0")
    assert code == 4 and "mpremote not found" in err and len(err.strip().splitlines()) == 1


def test_missing_port_is_one_line(cli):
    code, _, err = cli("flash", "--port", "/dev/ttyNOPE")
    assert code == 4 and "/dev/ttyNOPE not found" in err


def test_flash_stages_files_and_calls_mpremote(tmp_path, mocker):
    calls = []

    def fake_run(cmd, **kw):
        calls.append(cmd)
        lib = cmd[cmd.index("-r") + 1]
        import pathlib

        staged = sorted(
            str(p.relative_to(pathlib.Path(lib).parent)) for p in pathlib.Path(lib).rglob("*.mpy")
        )
        calls.append(staged)
        return types.SimpleNamespace(returncode=0, stderr="")

    mocker.patch.object(flashing, "find_mpremote", return_value=["mpremote"])
    written = flashing.flash("a0", mpy=True, n_sensors=3, run=fake_run)
    cmd, staged = calls
    assert cmd[:3] == ["mpremote", "connect", "a0"] and cmd[-1] == "reset"
    assert "lib/tactile_fw/board.mpy" in staged and "lib/tactile_protocol/framing.mpy" in staged
    assert "main.py" in written


def test_the_native_module_is_staged_as_shipped_with_or_without_mpy(tmp_path):
    """The C core's .mpy goes to /lib unchanged: mpy-cross compiles Python, not it."""
    shipped = [src for src, dest in flashing.board_files() if dest == "lib/tactile_native.mpy"]
    assert len(shipped) == 1
    for mpy in (False, True):
        written = flashing.stage(tmp_path / str(mpy), mpy=mpy)
        assert "lib/tactile_native.mpy" in written
        staged = tmp_path / str(mpy) / "lib" / "tactile_native.mpy"
        assert staged.read_bytes() == shipped[0].read_bytes()


def test_mpremote_failure_is_reported(mocker):
    mocker.patch.object(flashing, "find_mpremote", return_value=["mpremote"])
    fail = types.SimpleNamespace(returncode=1, stderr="Traceback\nmpremote: failed to access a0")
    with pytest.raises(BoardError, match="failed to access a0"):
        flashing.flash("a0", run=lambda cmd, **kw: fail)


def test_port_error_is_a_board_error():
    with pytest.raises(PortError):
        flashing._check_port("/dev/ttyDOES_NOT_EXIST")
