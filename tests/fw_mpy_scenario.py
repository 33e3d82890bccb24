"""A firmware scenario that runs unchanged on MicroPython and CPython.

Prints the bytes the board sent, in hex, one chunk per line: the test runs it
under both interpreters and compares.  Imports only what MicroPython has.
"""

from tactile_fw import frontend
from tactile_fw.board import Board
from tactile_fw.identity import boot_id_from
from tactile_fw.link import PipeLink
from tactile_fw.storage import MemoryStorage
from tactile_fw.timing import ManualClock
from tactile_protocol.framing import encode_frame
from tactile_sim.adc_model import ADS122C04Model
from tactile_sim.i2c_bus import SimI2C

clock = ManualClock((1 << 30) - 5000)  # ticks wrap during the run
bus = SimI2C()
force = [0]


def src(j):
    def volts(t):
        code = force[0] if j == 0 else (j * 1000 - force[0] // 7)
        return code * 3.3 / 128 / 8388608

    return volts


for j, a in enumerate(frontend.ADDRESS_PLAN[0]):
    bus.attach(a, ADS122C04Model(lambda: clock.t_us, source=src(j)))
link = PipeLink()
boot_id = boot_id_from(b"\x01\x02\x03\x04\xfd\xfe\xff\x00")  # 32-bit arithmetic on the board
board = Board([frontend.make_sensor(bus, 0)], link, clock, MemoryStorage(), boot_id=boot_id)
board.boot()
seq = 0


def cmd(mtype, values):
    global seq
    link.put(encode_frame(mtype, seq, 0, values))
    seq += 1


def run(us):
    end = clock.t_us + us
    while clock.t_us < end:
        board.poll()
        clock.advance(50)


def dump():
    data = link.take()
    print(data.hex() if hasattr(data, "hex") else "".join("%02x" % b for b in data))


cmd(0x42, (1000, 1000000, 500000, 2, 0x03))  # CONFIG: samples + contacts
cmd(0x46, (0, 77) + tuple(1.5e-6 if r == c else 1e-8 for r in range(6) for c in range(6)))
cmd(0x44, ())  # START
run(5000)
dump()
for k in range(40):
    force[0] = 1500000 if 10 <= k < 25 else 20000 * k
    run(1000)
dump()
bus.nack.add(0x43)
run(4000)
bus.nack.clear()
run(10000)
dump()
cmd(0x43, (0, 5))  # TARE
cmd(0x42, (5000, 1, 0, 1, 0))  # refused: above the ceiling
cmd(0x41, ())
run(20000)
dump()
print("samples", board.samples, "i2c_errors", board.i2c_errors, "overruns", board.sched.overruns)
