"""Which board a recording is of, and holding a reconnection's bytes until the board is known.

A port that comes back after it was lost may not lead to the same board: on a shared machine
another board can take the path (``/dev/ttyACM0``) while this one is unplugged.  HELLO and
INFO carry the board's unique id (``board_id``, PROTOCOL.md section 4: on a Pico its flash
chip's id) and its ``boot_id``.  ``BoardIdentity`` remembers the id from the run's first
HELLO and every boot id since; after a reconnection it accepts the same board, rebooted or
not, and refuses another (``OtherBoard``, exit 4: ``tactile.recording.session`` ends the run
there, everything of its own board kept).

``Held`` keeps a reconnection's bytes out of the capture until the board answering has said
who it is: the same board's bytes then go to the capture, in order, as if never held; another
board's are dropped and the decoder is put back as it was before them, so its frames, counts
and reboot are not this recording's.  An attempt that fails before any HELLO keeps its bytes
(``release``): nothing says they are another board's.
"""

import copy

from tactile.board.messages import board_id_text
from tactile.errors import BoardError


class OtherBoard(BoardError):
    """Another board answered on the port after it was lost (one line, exit 4)."""


class BoardIdentity:
    """The board of a run: its ``board_id`` (bytes) and the ``boot_ids`` seen, in order."""

    def __init__(self):
        self.board_id = None
        self.boot_ids = []

    def seen(self, info):
        """The board's HELLO/INFO: the first names the run's board; later ones may add a boot."""
        if not self.boot_ids:
            self.board_id = info.board_id
        if not self.boot_ids or self.boot_ids[-1] != info.boot_id:
            self.boot_ids.append(info.boot_id)

    def same(self, info):
        """Whether ``info`` (a HELLO/INFO after a reconnection) is this run's board."""
        return not self.boot_ids or info.board_id == self.board_id

    def rebooted(self, info):
        """Whether this run's board, back after a reconnection, booted since it was last seen."""
        return bool(self.boot_ids) and info.boot_id != self.boot_ids[-1]

    def refusal(self, port, info, where):
        """The one line that ends a run on which ``info``'s board answered, not its own."""
        return OtherBoard(
            f"{port}: another board answered after the port was lost (board id"
            f" {board_id_text(info.board_id)}, not this run's {board_id_text(self.board_id)});"
            f" recording stopped, everything from this run's board is in {where}"
        )

    def meta(self):
        if not self.boot_ids:
            return None
        return {"board_id": board_id_text(self.board_id), "boot_ids": list(self.boot_ids)}


class Held:
    """A reconnection attempt's bytes, held from ``client``'s capture until ``accept``ed
    (written with ``write``, in order) or ``refuse``d (dropped, the client put back)."""

    def __init__(self, client, write):
        self.client, self.write = client, write
        self.chunks = []
        self.saved = (copy.deepcopy(client.decoder), client.info, client.capture)
        client.capture = self.chunks.append

    @property
    def bytes(self):
        return sum(len(c) for c in self.chunks)

    def accept(self):
        """The board is this run's: the bytes go to the capture as they came."""
        self.client.capture = self.saved[2]
        for chunk in self.chunks:
            self.write(chunk)
        self.chunks = []

    release = accept  # an attempt that failed before the board said who it is

    def refuse(self):
        """Another board's: none of its bytes, frames or counts are this recording's.
        Returns how many bytes were dropped."""
        decoder, info, capture = self.saved
        self.client.decoder, self.client.info, self.client.capture = decoder, info, capture
        self.client.backlog, self.client.backlog_times = [], []
        dropped, self.chunks = self.bytes, []
        return dropped
