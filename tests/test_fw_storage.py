"""The board's flash files survive a power cut at any point: a boot finds the old settings
and calibration or the new ones, never the defaults (tests/power_cut.py cuts the power at
every filesystem call of ``DirStorage``; test_fw_micropython.py does the same on MicroPython).
"""

import pytest
from ccore_twin import c_rig
from fw_rig import Rig, decode_frames
from power_cut import NEW, OLD, Flash, boot, cut_once, cut_twice, install, sweep, uninstall

from tactile_fw import settings
from tactile_fw.storage import DirStorage, intact
from tactile_protocol.constants import MSG_HELLO
from tactile_protocol.messages import BY_TYPE

RENAMES = {"rename replaces (littlefs, POSIX)": False, "rename refuses an existing file": True}


@pytest.fixture(params=list(RENAMES), ids=["replaces", "refuses"])
def refuse_replace(request):
    return RENAMES[request.param]


def test_a_power_cut_at_any_flash_call_boots_the_old_or_the_new_copy(tmp_path, refuse_replace):
    rows = sweep(str(tmp_path), refuse_replace)
    cut = {call for _, call, _, _ in rows}
    assert {"open", "write", "close", "rename"} <= cut  # every kind of call was cut
    assert rows[-1][1:] == (None, "new", "new")  # and the writes complete without a cut
    for k, call, seen_settings, seen_cal in rows:
        assert seen_settings in ("old", "new"), f"cut at call {k} ({call}): {seen_settings}"
        assert seen_cal in ("old", "new"), f"cut at call {k} ({call}): calibration {seen_cal}"
    for column in (2, 3):  # once the new copy is what a boot finds, it stays so
        seen = [row[column] for row in rows]
        assert seen == sorted(seen, key=("old", "new").index)


def test_a_second_write_cut_after_a_first_keeps_what_the_board_booted_with(
    tmp_path, refuse_replace
):
    """A first write cut between removing the file and renaming the new copy (refusing
    renames) leaves only ``.tmp``: the next write must not truncate it before it is safe."""
    n = len(sweep(str(tmp_path), refuse_replace))
    for k1 in range(n):
        for k2 in range(n + 2):
            first, second = cut_twice(str(tmp_path), k1, k2, refuse_replace)
            assert "defaults" not in first
            for was, now in zip(first, second):
                assert now in (was, "newer"), f"cuts at calls {k1}, {k2}: {first} then {second}"


def test_a_torn_temporary_is_never_loaded(tmp_path):
    store = DirStorage(str(tmp_path))
    NEW[0].save(store)
    whole = (tmp_path / "settings.bin").read_bytes()
    (tmp_path / "settings.bin.tmp").write_bytes(whole[:-3])
    assert store.read("settings.bin") == whole  # the file itself first
    (tmp_path / "settings.bin").unlink()
    assert store.read("settings.bin") is None  # a torn copy alone: nothing was stored
    assert settings.load(store, 1000).fields() == settings.Settings().fields()
    (tmp_path / "settings.bin.tmp").write_bytes(whole)
    assert store.read("settings.bin") == whole  # a whole one alone: the new copy


def test_intact_is_the_crc_both_board_files_end_with():
    for data in (OLD[0].to_bytes(), OLD[1].to_bytes(0)):
        assert intact(data)
        assert not intact(data[:-1]) and not intact(data[:-2] + bytes((data[-2] ^ 1, data[-1])))
    assert not intact(b"") and not intact(b"\x01") and not intact(None)


class _FlakyFlash(Flash):
    """Stores every byte written with its lowest bit flipped, and never loses power."""

    def open(self, path, mode="r"):
        f = super().open(path, mode)
        if "w" in mode:
            write = f.write
            f.write = lambda data: write(bytes(b ^ 1 for b in data))
        return f


def test_a_copy_that_reads_back_wrong_is_refused_and_the_old_one_kept(tmp_path):
    root = str(tmp_path)
    cut_once(root, -1, False, then=OLD)  # OLD stored, uncut
    saved = install(_FlakyFlash())
    try:
        with pytest.raises(OSError, match="read back"):
            NEW[0].save(DirStorage(root))  # CONFIG then NAKs NAK_STORAGE
    finally:
        uninstall(saved)
    assert boot(root) == ("old", "old")


def _hello(rig):
    rig.board.boot()
    mtype, _, _, values = decode_frames(rig.link.take())[0]
    assert mtype == MSG_HELLO
    return dict(zip(BY_TYPE[MSG_HELLO][4], values))


@pytest.mark.parametrize("core", ["python", "c"])
def test_both_cores_boot_the_old_or_the_new_copy_after_any_cut(tmp_path, ccore_lib, core):
    """The C core reads its files through the same storage (``read``), .tmp fallback and all."""
    root = str(tmp_path)
    rates = {OLD[0].rate_hz: "old", NEW[0].rate_hz: "new"}
    cal_ids = {OLD[1].cal_id: "old", NEW[1].cal_id: "new"}
    for k, _, want_settings, want_cal in sweep(root, True):
        cut_once(root, k, True)  # the state of that kill point again
        if core == "python":
            rig = Rig(storage=DirStorage(root))
        else:
            rig = c_rig(ccore_lib, storage=DirStorage(root))
        hello = _hello(rig)
        got = (rates.get(hello["rate_hz"]), cal_ids.get(hello["cal_id_0"]))
        assert got == (want_settings, want_cal), f"{core} core, cut at call {k}: {hello}"
