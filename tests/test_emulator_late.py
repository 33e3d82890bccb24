"""An emulator that falls behind real time says so: it skips the polls it had no time for,
the firmware counts the missed periods and flags the next samples late, and ``record``
reports the late readings in its summary and in meta.json (pty_server.BEHIND_S)."""

import json
import time

from tactile.cli.cmd_record import summary
from tactile_protocol import constants as C
from tactile_sim.emulator import load_scene
from tactile_sim.emulator.device import EmulatedBoard
from tactile_sim.emulator.pty_server import BEHIND_S, PtyServer


def test_a_board_that_falls_behind_skips_ahead_and_flags_late_samples(cli, tmp_path):
    """The wall clock jumps 0.3 s ahead of the board once (an injected clock: a stall of
    the emulator's process, without waiting for one)."""
    board = EmulatedBoard(load_scene("press"))
    t0 = time.monotonic()
    stall = {"at": None}

    def wall():
        if stall["at"] is None and board.t_us > 300_000:
            stall["at"] = board.t_us
        return time.monotonic() - t0 + (0.3 if stall["at"] is not None else 0.0)

    server = PtyServer(board, duration_s=1.2, when_opened=True, clock=lambda: t0 + wall())
    with server:
        code, out, err = cli("record", "--port", server.path, "--duration", "0.8",
                             "-o", tmp_path / "r")  # fmt: skip
    assert code == 0, err
    assert server.skipped >= 1 and 0.3 > BEHIND_S
    meta = json.loads((tmp_path / "r" / "meta.json").read_text())
    assert meta["late_samples"] >= 1 and meta["sessions"][0]["late_samples"] >= 1
    assert "late (the board missed its rate)" in out
    flagged = [
        row for row in (tmp_path / "r" / "frames.csv").read_text().splitlines()[2:]
        if row.split(",")[4] == "SAMPLE" and int(row.split(",")[8]) & C.FLAG_LATE
    ]  # fmt: skip
    assert len(flagged) == meta["late_samples"]


def test_the_summary_names_late_readings_only_when_there_are_some():
    meta = {
        "decoder": {"lost_frames": 0, "crc_errors": 0},
        "ended": "duration",
        "gaps": [],
        "samples": 100,
        "contacts_ended": 0,
        "elapsed_s": 1.0,
        "late_samples": 0,
    }
    assert "late" not in summary(meta, "r")
    assert "3 readings late (the board missed its rate)" in summary(
        {**meta, "late_samples": 3}, "r"
    )
