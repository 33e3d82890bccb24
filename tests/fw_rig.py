"""Test rig for the firmware: the real Board on simulated ADCs, clock and link."""

from tactile_fw import frontend
from tactile_fw.board import Board
from tactile_fw.link import PipeLink
from tactile_fw.storage import MemoryStorage
from tactile_fw.timing import ManualClock
from tactile_protocol.cobs_codec import decode
from tactile_protocol.constants import CMD_CONFIG
from tactile_protocol.crc16 import crc16
from tactile_protocol.framing import FrameEncoder
from tactile_protocol.messages import BY_TYPE, unpack
from tactile_sim.adc_model import ADS122C04Model
from tactile_sim.i2c_bus import SimI2C


def decode_frames(data):
    """Split a byte stream into (type, seq, ts, values); every frame must be valid."""
    out = []
    for part in data.split(b"\0")[:-1]:
        body = decode(part)
        assert crc16(body, 0, len(body) - 2) == body[-2] | (body[-1] << 8)
        out.append(unpack(body[:-2]))
    return out


def name(frame):
    return BY_TYPE[frame[0]][1]


class Rig:
    """``n`` sensors; sensor i on bus i % 2; gauge codes from ``codes[i](t_us)``."""

    def __init__(self, n=1, storage=None, **board_kw):
        self.clock = ManualClock(0)
        self.buses = [SimI2C(), SimI2C()]
        self.models = []
        self.codes = [lambda t: (0, 0, 0, 0, 0, 0)] * n
        sensors = []
        for i in range(n):
            bus = self.buses[i % 2]
            row = []
            for j, addr in enumerate(frontend.ADDRESS_PLAN[i // 2]):
                m = ADS122C04Model(self._now)
                m.source = self._source(m, i, j)
                bus.attach(addr, m)
                row.append(m)
            self.models.append(row)
            sensors.append(frontend.make_sensor(bus, i // 2, bus_key=i % 2))
        self.sensors = sensors
        self.link = PipeLink()
        self.storage = storage if storage is not None else MemoryStorage()
        self.board = Board(sensors, self.link, self.clock, self.storage, **board_kw)
        self.seq = 0
        self.log = []  # every frame received so far

    def _now(self):
        return self.clock.t_us

    def _source(self, model, i, j):
        return lambda t: model.volts_for_code(self.codes[i](t)[j])

    def set_codes(self, i, fn_or_codes):
        if callable(fn_or_codes):
            self.codes[i] = fn_or_codes
        else:
            c = tuple(fn_or_codes)
            self.codes[i] = lambda t: c

    def send(self, mtype, values=(), check=True):
        self.link.put(bytes(FrameEncoder(self.seq).encode(mtype, 0, values, check)))
        self.seq = (self.seq + 1) & 0xFFFF
        return (self.seq - 1) & 0xFFFF

    def run(self, us, step=50):
        end = self.clock.t_us + us
        while self.clock.t_us < end:
            self.board.poll()
            self.clock.advance(step)

    def frames(self):
        got = decode_frames(self.link.take())
        self.log.extend(got)
        return got

    def command(self, mtype, values=(), us=2000, check=True):
        seq = self.send(mtype, values, check)
        self.run(us)
        return seq, self.frames()

    def config(self, rate=1000, enter=1_000_000, exit_=500_000, debounce=2, flags=0x03):
        return self.command(CMD_CONFIG, (rate, enter, exit_, debounce, flags))


def replies(frames, seq):
    """ACK/NAK frames answering the host command numbered ``seq``."""
    return [f for f in frames if name(f) in ("ACK", "NAK") and f[3][1] == seq]
