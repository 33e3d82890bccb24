"""Damage on the device-to-host byte path, placed by frame and recorded exactly.

Frames are counted at their 0x00 delimiters as they leave the board (no
decoding, no CRC: that is the firmware's and the host's business).  A
damaged frame gets either one byte XOR-ed (never into 0x00, never the
delimiter) or one byte removed (never the delimiter), so each damaged frame
costs the host exactly that frame and one damaged span.  ``injected``
counts what was done, for tests to compare with the host's counters.
"""


class LinkFaults:
    def __init__(self, corrupt_frames=(), drop_byte_frames=()):
        self.corrupt = set(int(k) for k in corrupt_frames)
        self.drop = set(int(k) for k in drop_byte_frames) - self.corrupt
        self.frame_index = 0  # index of the frame whose bytes come next
        self.offset = 0  # bytes of that frame seen so far
        self.injected = {"corrupted": 0, "dropped_bytes": 0}

    @classmethod
    def from_scene(cls, link):
        if link is None or not (link["corrupt_frames"] or link["drop_byte_frames"]):
            return None
        return cls(link["corrupt_frames"], link["drop_byte_frames"])

    def apply(self, data):
        out = bytearray()
        for b in data:
            k, i = self.frame_index, self.offset
            if b == 0:
                self.frame_index += 1
                self.offset = 0
                out.append(0)
                continue
            self.offset += 1
            if i == 1 and k in self.corrupt:  # the byte after the first COBS code byte
                mask = 0x5A if b != 0x5A else 0xA5
                out.append(b ^ mask)
                self.injected["corrupted"] += 1
            elif i == 1 and k in self.drop:
                self.injected["dropped_bytes"] += 1
            else:
                out.append(b)
        return bytes(out)
