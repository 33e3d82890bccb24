"""What ``record --payload`` asks of the board (``tactile.recording.session.Session``).

- Each tool must be for a sensor of this board, measured with the calibration that sensor
  reports (``check``): a run refused here leaves nothing behind.
- Removing a tool's weight and gating contacts again needs every reading, so the SAMPLE
  stream is switched on for the run (``samples_on``: not persisted) and the board's
  configuration put back at its end (``put_back``).
- meta.json's "payload" says which tools, and whether the stream was switched on (``meta``).
"""

import contextlib

from tactile.board.client import info_dict
from tactile.errors import BoardError, InputError
from tactile.payload.tool import check_device, tool_doc
from tactile_protocol import constants as C
from tactile_protocol.settings import to_newtons

__all__ = ["OnBoard"]


class OnBoard:
    """The tools ``[(tool.json's path, Tool)]`` of one recording."""

    def __init__(self, tools):
        self.tools = list(tools)
        self.refused = False  # the board is not the tools': the run leaves nothing
        self.restore = None  # CONFIG values to put back (the SAMPLE stream switched on)

    def __bool__(self):
        return bool(self.tools)

    def check(self, client):
        """InputError unless the board of ``client`` (its HELLO/INFO) is the tools'."""
        try:
            for path, tool in self.tools:
                check_device(tool, info_dict(client.info), path)
        except InputError:
            self.refused = True
            raise

    def samples_on(self, client):
        """Switch the SAMPLE stream on (not persisted); INFO read again, so meta.json's
        device says it streams."""
        i = client.info
        if i.flags & C.CFG_STREAM_SAMPLES:
            return
        levels = (to_newtons(i.enter_threshold), to_newtons(i.exit_threshold))
        values = (i.rate_hz, *levels, i.debounce)
        flags = i.flags & C.CFG_WRITABLE & ~C.CFG_PERSIST
        client.configure(*values, flags | C.CFG_STREAM_SAMPLES)
        self.restore = (*values, flags)
        client.get_info()

    def put_back(self, client):
        """The board's configuration as it was before ``samples_on`` (if it is still there)."""
        if self.restore is not None and client is not None:
            with contextlib.suppress(BoardError):
                client.configure(*self.restore)

    def meta(self):
        """meta.json's "payload": each tool file and its values."""
        tools = [{"file": str(path), "tool": tool_doc(tool)} for path, tool in self.tools]
        return {"tools": tools, "samples_switched_on": self.restore is not None}
