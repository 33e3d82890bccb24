"""The pseudo-terminal a server offers: a real tty the host opens with pyserial exactly as it
opens ``/dev/ttyACM0``; the master side's reads, writes, presence and what the host has not
read yet.

The master is in packet mode (``TIOCPKT``): besides the host's bytes it hears each flush of
the host's input, which pyserial makes as every ``open()`` ends.  So a host that closes the
port and opens it again before the server has looked (a script's next command, a loaded
machine) is still seen to have come back (``opens``), where presence alone (POLLHUP only
while nobody has the port open) would miss it.  A host's own flush mid-session reads the
same: a new host, as a USB board sees a new DTR."""

import errno
import fcntl
import os
import select
import struct
import sys
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
        self.packets = _packet_mode(self.master)
        self.opens = 0  # the host's input flushes heard: one at each pyserial open
        self._held = bytearray()  # the host's bytes read since the latest flush
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

    def pump(self):
        """Take what the host sent (its bytes, and in packet mode its flushes) off the pty;
        the bytes wait for ``read``, those before a flush dropped (their host has gone)."""
        while True:
            try:
                packet = os.read(self.master, 4097)
            except OSError as exc:  # EIO: no host has the slave open
                if exc.errno in (errno.EIO, errno.EAGAIN):
                    return
                raise
            if not packet:
                return
            if not self.packets:
                self._held += packet
            elif packet[0] == termios.TIOCPKT_DATA:
                self._held += packet[1:]
            elif packet[0] & termios.TIOCPKT_FLUSHREAD:
                self.opens += 1
                self._held.clear()

    @property
    def waiting(self):
        """Whether ``pump`` took host bytes that no ``read`` has yet."""
        return bool(self._held)

    def read(self):
        """The host's bytes that ``pump`` took since the last call."""
        data = bytes(self._held)
        self._held.clear()
        return data

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


def _packet_mode(fd):
    """Put the pty master ``fd`` in packet mode; whether it took (not on every platform)."""
    try:
        fcntl.ioctl(fd, termios.TIOCPKT, (1).to_bytes(4, sys.byteorder))  # (an int, by address)
    except (OSError, AttributeError):
        return False
    return True
