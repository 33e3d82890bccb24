"""The byte link to the host and the board's non-blocking transmit ring.

A link (USB CDC on a board, a tty on Linux, a pipe in the emulator) offers:

- ``readinto(buf)`` -> number of bytes read, 0 or None when nothing waits
  (never blocks);
- ``write(mv)`` -> number of bytes accepted, 0 or None when the host is not
  reading (never blocks; may accept part);
- optionally ``opened()`` -> True once each time the host opens the port
  (DTR / a pty's open), and ``streaming(on)`` (the MicroPython port turns
  Ctrl-C off while streaming).

``TxRing`` queues whole frames in a fixed buffer and drains it as the link
accepts bytes; a frame that does not fit is dropped whole and counted, so
the sampling loop never waits for the host and the host never sees half a
frame.
"""


class TxRing:
    def __init__(self, link, size=4096):
        self.link = link
        self.size = size
        self.buf = bytearray(size)
        self.mv = memoryview(self.buf)
        self.head = 0  # next byte to fill
        self.tail = 0  # next byte to send
        self.used = 0
        self.dropped = 0  # frames dropped because the host was not reading
        self.sent = 0  # frames queued

    def send(self, frame):
        n = len(frame)
        if self.size - self.used < n:
            self.dropped += 1
            self.flush()
            return False
        head = self.head
        first = self.size - head
        if n <= first:
            self.mv[head : head + n] = frame
        else:
            self.mv[head:] = frame[:first]
            self.mv[: n - first] = frame[first:]
        self.head = (head + n) % self.size
        self.used += n
        self.sent += 1
        self.flush()
        return True

    def flush(self):
        link = self.link
        while self.used:
            tail = self.tail
            chunk = self.size - tail
            if chunk > self.used:
                chunk = self.used
            w = link.write(self.mv[tail : tail + chunk])
            if not w:
                return
            self.tail = (tail + w) % self.size
            self.used -= w
            if w < chunk:
                return

    def clear(self):
        """Forget what is queued (a new host session); its frames count as dropped.

        Each queued frame ends with its one 0x00 (COBS leaves no other), so the
        zeros in the ring are the frames the host will never get, including one
        it got only the start of.
        """
        buf = self.buf
        size = self.size
        t = self.tail
        for k in range(self.used):
            if buf[(t + k) % size] == 0:
                self.dropped += 1
        self.head = self.tail = self.used = 0


class PipeLink:
    """In-memory link: the host side reads ``take()`` and writes ``put()``.

    ``capacity`` bounds the bytes the host has not yet read (a full USB/pty
    buffer); ``paused`` makes writes accept nothing (host not reading).
    """

    def __init__(self, capacity=1 << 16):
        self.rx = bytearray()
        self.tx = bytearray()
        self.capacity = capacity
        self.paused = False
        self._opened = False
        self.streaming_on = False

    # device side
    def readinto(self, buf):
        n = min(len(buf), len(self.rx))
        if n == 0:
            return None
        buf[:n] = self.rx[:n]
        self.rx = self.rx[n:]  # (MicroPython bytearrays have no slice deletion)
        return n

    def write(self, mv):
        if self.paused:
            return None
        n = min(len(mv), self.capacity - len(self.tx))
        if n <= 0:
            return None
        self.tx += mv[:n]
        return n

    def opened(self):
        o = self._opened
        self._opened = False
        return o

    def streaming(self, on):
        self.streaming_on = on

    # host side
    def put(self, data):
        self.rx += data

    def take(self):
        out = bytes(self.tx)
        self.tx = bytearray()
        return out

    def host_open(self):
        self._opened = True
