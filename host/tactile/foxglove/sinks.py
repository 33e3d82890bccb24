"""Where the topics go, and the thread that keeps the live view off the caller's loop.

A sink takes every message ``Topics`` logs in its foxglove-sdk context; it is the SDK's own,
so a topic is declared once and logged once, whichever sinks listen:

- ``WebSocketSink``: the SDK's WebSocket server (``tactile live`` and ``record
  --foxglove``); it keeps ``backlog`` messages per client and drops a slow client's oldest;
- ``McapSink``: the SDK's MCAP writer into a binary file the caller opened (``tactile
  export``'s temporary, ``tactile.files.atomic``), with MCAP's ``ros2`` profile.  A write the
  file refuses (a full disk) stops the export, and ``close`` raises it as the ``OSError``
  it was (the SDK's own error names no errno).

Both are context managers (``close`` on the way out).  ``sdk`` imports foxglove-sdk for an
extra and hands its log lines to ``tactile.output.text.adopt`` (escaped, rate-limited, shown
with ``tactile -v``).  ``Worker`` is the one bounded queue, stop marker and thread of the
live view: ``put`` never waits, a full queue drops the item and counts it.
"""

import contextlib
import queue
import threading

from tactile.errors import InputError
from tactile.extras import need
from tactile.output.text import adopt

__all__ = ["McapSink", "Sink", "WebSocketSink", "Worker", "sdk"]

SDK_LOGGER, LOGGER = "foxglove", "tactile.foxglove"  # the SDK's loggers, and where they go
_STOP = object()


def sdk(extra, purpose, *modules):
    """The ``foxglove`` module (and ``modules``), or ``MissingExtra`` naming ``extra``; the
    SDK's loggers adopted before its first line.  Returns (modules..., the ``Adopted``
    handler)."""
    found = need(extra, purpose, "foxglove", *modules)
    return (*found, adopt(SDK_LOGGER, LOGGER))


class Sink:
    """A sink of a foxglove-sdk context: it gets what the context's channels log until
    ``close``."""

    def close(self):
        raise NotImplementedError

    def __enter__(self):
        return self

    def __exit__(self, kind, exc, tb):
        if kind is None:
            self.close()
            return
        with contextlib.suppress(Exception):  # the error on its way out is the one to see
            self.close()


class WebSocketSink(Sink):
    """The SDK's WebSocket server on ``host``:``port`` (0: any free port; ``port`` says
    which); ``listener``: the SDK's server callbacks, or None."""

    def __init__(self, fox, context, host, port, backlog, listener=None):
        try:
            self.server = fox.start_server(
                name="tactile",
                host=host,
                port=port,
                context=context,
                message_backlog_size=backlog,
                server_listener=listener,
            )
        except Exception as exc:  # the SDK's bind error (a RuntimeError, or its own class)
            raise InputError(f"--foxglove: cannot serve on {host}:{port} ({exc})") from None
        self.host, self.port = host, self.server.port

    @property
    def url(self):
        return f"ws://{self.host}:{self.port}"

    def close(self):
        self.server.stop()


class _Watched:
    """A binary file whose first failed call (a write, or the flush or seek that writes
    what is buffered) is kept, for ``McapSink``."""

    def __init__(self, fh):
        self.fh, self.error = fh, None

    def _call(self, name, *args):
        try:
            return getattr(self.fh, name)(*args)
        except OSError as exc:
            self.error = self.error or exc
            raise

    def write(self, data):
        return self._call("write", data)

    def seek(self, offset, whence=0):
        return self._call("seek", offset, whence)

    def tell(self):
        return self._call("tell")

    def flush(self):
        return self._call("flush")


class McapSink(Sink):
    """The SDK's MCAP writer into ``fh`` (open for binary writing, seekable)."""

    def __init__(self, fox, context, fh):
        self.file = _Watched(fh)
        options = fox.mcap.MCAPWriteOptions(profile="ros2")
        self.writer = fox.open_mcap(self.file, context=context, writer_options=options)

    @property
    def failed(self):
        """Whether a write failed: nothing more reaches the file."""
        return self.file.error is not None

    def metadata(self, name, values):
        """A metadata record ``name`` of string ``values``."""
        self._sdk(self.writer.write_metadata, name, values)

    def close(self):
        """Finish the file (summary, footer); a failed write is raised as it was."""
        self._sdk(self.writer.close)
        if self.file.error is not None:
            raise self.file.error

    def _sdk(self, call, *args):
        try:
            call(*args)
        except RuntimeError:  # the SDK's FoxgloveError: the file's own error, if it had one
            if self.file.error is None:
                raise
            raise self.file.error from None


class Worker:
    """A daemon thread that hands each item ``put`` to ``handle``, in order, until
    ``close``.  ``done``, ``dropped`` (the queue of ``size`` was full), ``failed`` (``handle``
    raised; ``error`` is the first such)."""

    def __init__(self, name, handle, size):
        self.handle = handle
        self.queue = queue.Queue(size)
        self.done = self.dropped = self.failed = 0
        self.error = None
        self.thread = threading.Thread(target=self._run, name=name, daemon=True)
        self.thread.start()

    def put(self, item):
        """Queue ``item`` without waiting; False (and counted) when the queue is full."""
        try:
            self.queue.put_nowait(item)
        except queue.Full:
            self.dropped += 1
            return False
        return True

    def close(self, timeout_s):
        """Handle what is queued, then stop (up to ``timeout_s`` to queue the stop and as
        long again for the thread)."""
        try:
            self.queue.put(_STOP, timeout=timeout_s)
        except queue.Full:
            pass
        self.thread.join(timeout_s)

    def _run(self):
        while True:
            item = self.queue.get()
            if item is _STOP:
                return
            try:
                self.handle(item)
                self.done += 1
            except Exception as exc:  # one bad item must not end the live view
                self.failed += 1
                self.error = self.error or f"{type(exc).__name__}: {exc}"
