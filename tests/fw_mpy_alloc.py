"""Heap bytes allocated per call on MicroPython (gc.mem_alloc with the collector off)."""

import gc

from tactile_fw import frontend
from tactile_fw.ads122c04 import CMD_RDATA, DRDY, rreg
from tactile_fw.board import Board
from tactile_fw.storage import MemoryStorage
from tactile_fw.timing import ManualClock


class NullBus:
    def __init__(self):
        self.regs = [0, 0, 0, 0]

    def readfrom_mem_into(self, addr, mem, buf, addrsize=8):
        if mem == CMD_RDATA:
            buf[0] = 0x12
            buf[1] = 0x34
            buf[2] = 0x56
        elif mem == rreg(2):
            buf[0] = DRDY
        else:
            buf[0] = self.regs[(mem >> 2) & 3]

    def writeto_mem(self, addr, mem, buf, addrsize=8):
        self.regs[(mem >> 2) & 3] = buf[0]

    def writeto(self, addr, buf, stop=True):
        return 2


class Discard:
    def readinto(self, buf):
        return None

    def write(self, mv):
        return len(mv)

    def opened(self):
        return False


clock = ManualClock(0)
board = Board([frontend.make_sensor(NullBus(), 0)], Discard(), clock, MemoryStorage())
board.boot()
board.settings.flags = 0x01  # SAMPLE stream
board.start_streaming()
sensor = board.sensors[0]
cal = board.cals[0]
gate = board.gates[0]
ft = [0] * 6
vals = board._sample_vals


def step():
    clock.t_us += 1000
    board.poll()


def per_call(name, fn, n=500):
    fn()
    gc.collect()
    gc.disable()
    a0 = gc.mem_alloc()
    for _ in range(n):
        fn()
    used = gc.mem_alloc() - a0
    gc.enable()
    print(name, used // n)


per_call("read", sensor.poll)
per_call("calibrate", lambda: cal.apply(sensor.counts, ft))
per_call("gate", lambda: gate.update(1500000, -20000, 300))
per_call("encode", lambda: board.enc.encode(3, 123456, vals, False))
per_call("poll", step)
