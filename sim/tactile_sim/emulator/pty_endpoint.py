"""The pseudo-terminal a server offers: a real tty the host opens with pyserial exactly as it
opens ``/dev/ttyACM0``; the master side's reads, writes, presence and what the host has not
read yet."""

import errno
import fcntl
import os
import select
import struct
import termios
import time
import tty


class PtyEndpoint:
    """One pseudo-terminal; ``path`` is the slave device the host opens."""

    def __init__(self):
        self.master, slave = os.openpty()
        tty.setraw(slave)  # no echo or line editing even before the host configures it
        self.path = os.ttyname(slave)
        os.close(slave)
        os.set_blocking(self.master, False)
        self._poll = select.poll()
        self._poll.register(self.master, select.POLLIN | select.POLLHUP)
        self.host_present = False

    def wait(self, timeout_s):
        """Wait up to ``timeout_s`` for host input; return (readable, present).

        While no host has the slave open the master reports POLLHUP, at once and for as long
        as nobody opens it, so poll() cannot block then: the rest of the timeout is slept
        instead and presence looked at again, never spun on (an idle emulator waiting for a
        host took most of a core).  A host that opens the port is seen within ``timeout_s``.
        """
        deadline = time.monotonic() + max(0.0, timeout_s)
        readable, present = self._look(timeout_s)
        if not present and (left := deadline - time.monotonic()) > 0:
            time.sleep(left)
            readable, present = self._look(0.0)
        return readable, present

    def _look(self, timeout_s):
        events = self._poll.poll(max(0.0, timeout_s) * 1000)
        flags = 0
        for _, ev in events:
            flags |= ev
        present = not (flags & select.POLLHUP)
        return bool(flags & select.POLLIN) and present, present

    def read(self):
        try:
            return os.read(self.master, 4096)
        except OSError as exc:  # EIO: no host has the slave open
            if exc.errno in (errno.EIO, errno.EAGAIN):
                return b""
            raise

    def write(self, data):
        """Write what the pty takes now; return bytes accepted."""
        try:
            return os.write(self.master, data)
        except OSError as exc:
            if exc.errno in (errno.EAGAIN, errno.EIO):
                return 0
            raise

    def unread(self):
        """Bytes waiting in the slave's input queue (the part the kernel counts); 0 if unknown.

        Opens the slave briefly: only while a host has it open, so presence is unchanged.
        Up to ~16 kB more can wait in the pty's internal buffer until the host reads.
        """
        try:
            fd = os.open(self.path, os.O_RDONLY | os.O_NOCTTY | os.O_NONBLOCK)
        except OSError:
            return 0
        try:
            return struct.unpack("i", fcntl.ioctl(fd, termios.FIONREAD, b"\0\0\0\0"))[0]
        except OSError:
            return 0
        finally:
            os.close(fd)

    def close(self):
        """Close the master (the host's port dies); once, however often it is called."""
        if self.master is not None:
            os.close(self.master)
            self.master = None
