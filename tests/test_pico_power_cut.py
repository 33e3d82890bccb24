"""The emulated Pico loses power after each erase or program of its flash while it stores
new settings (`tactile config --persist`), then boots: it comes up with the old ones or the
new ones, never the defaults.  Stock MicroPython's littlefs, the firmware as flashed.
``cal<N>.bin`` goes through the same ``DirStorage.write``; a power cut at every call of
both is tested on CPython and MicroPython (test_fw_storage.py, test_fw_micropython.py),
at a boot per flash operation here.

The chip appends every flash operation to a journal (``pico_target.serve(flash_journal=)``);
the flash a power cut after operation k leaves is the flash before the session with the
journal's first k operations applied.
"""

import pytest
import serial
from pico_target import serve, wait_booted

from tactile.board.client import BoardClient
from tactile_protocol.constants import CFG_PERSIST, CFG_STREAM_CONTACTS

pytestmark = [pytest.mark.realtime, pytest.mark.slow]  # a boot per flash operation

OLD_HZ, NEW_HZ = 500, 250


def _store(client, rate_hz):
    """What `tactile config --rate RATE_HZ --persist` sends (thresholds in N)."""
    client.configure(rate_hz, 1.0, 0.5, 4, CFG_STREAM_CONTACTS | CFG_PERSIST, timeout=10.0)


def _client(server):
    wait_booted(server)
    client = BoardClient(serial.Serial(server.path, timeout=0.05), server.path)
    client.handshake(timeout=10.0)
    return client


def _operations(journal):
    """[(offset, bytes)] in the order the chip applied them."""
    data, at, ops = journal.read_bytes(), 0, []
    while at < len(data):
        offset = int.from_bytes(data[at : at + 4], "little")
        n = int.from_bytes(data[at + 4 : at + 8], "little")
        ops.append((offset, data[at + 8 : at + 8 + n]))
        at += 8 + n
    return ops


def _boot(flash):
    """The settings the board came up with: ``old``, ``new`` or the rate HELLO said."""
    with serve(flash=flash, fast=True) as server:
        client = _client(server)
        rate_hz = client.info.rate_hz
        client.close()
    return {OLD_HZ: "old", NEW_HZ: "new"}.get(rate_hz, f"{rate_hz} Hz")


def test_a_power_cut_after_any_flash_operation_boots_the_old_or_the_new_settings(
    pico_flashed, tmp_path
):
    before = bytearray(pico_flashed.read_bytes())
    journal = tmp_path / "flash.journal"
    with serve(flash=pico_flashed, fast=True, flash_journal=journal) as server:
        client = _client(server)
        try:
            _store(client, OLD_HZ)
            stored_old = len(_operations(journal))  # (the chip writes before it ACKs)
            _store(client, NEW_HZ)
        finally:
            client.close()
    ops = _operations(journal)
    assert len(ops) > stored_old
    for offset, data in ops[:stored_old]:
        before[offset : offset + len(data)] = data
    image = tmp_path / "cut.flash"
    seen = []
    for k in range(stored_old, len(ops) + 1):
        flash = bytearray(before)
        for offset, data in ops[stored_old:k]:
            flash[offset : offset + len(data)] = data
        image.write_bytes(flash)
        seen.append(_boot(image))
    assert seen[0] == "old" and seen[-1] == "new" and len(seen) >= 3
    bad = [(k, s) for k, s in enumerate(seen) if s not in ("old", "new")]
    assert not bad, f"(flash operations done, boot) of {len(ops) - stored_old}: {bad}"
