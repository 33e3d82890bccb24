"""One board scenario on a deterministic stand-in, for any board (runs on MicroPython too).

The stand-in: a ``ManualClock`` started just before the 2^30 tick wrap and moved 250 us per
poll, two ``SimI2C`` buses with six ``ADS122C04Model`` each (sensor i on bus i, slot 0) whose
inputs follow a scripted load, a ``PipeLink`` and a ``MemoryStorage``.  The host's commands:
CONFIG, SET_CAL, START, a press on sensor 0 (contact BEGIN/IN/END), an I2C NACK on sensor 1
and its recovery, TARE, STOP, GET_INFO and a refused CONFIG.  ``scenario(factory)`` returns
what the board sent after each step (hex), its counters and its storage; the same clock,
sensor answers and commands give the same bytes from every board built to be identical.

Run as a script (``mpremote run``) on a Pico flashed with the firmware and ``tactile_sim``'s
bus and converter model, it prints that record for the Python ``Board`` and for the C core
in ``tactile_native``, one line each (tests/test_natmod.py).
"""

from tactile_fw import frontend
from tactile_fw.identity import boot_id_from
from tactile_fw.link import PipeLink
from tactile_fw.storage import MemoryStorage
from tactile_fw.timing import ManualClock
from tactile_protocol.framing import encode_frame
from tactile_sim.adc_model import ADS122C04Model
from tactile_sim.i2c_bus import SimI2C

N_SENSORS = 2
STEP_US = 250
BOOT_ID = boot_id_from(b"\x10\x20\x30\x40\xfd\xfe\xff\x00")


def _hex(data):
    return "".join("%02x" % b for b in data)


def scenario(factory):
    """The record of one run: ``factory(buses, layout, link, clock, storage, boot_id)``
    builds the board (``layout``: (bus, slot) per sensor)."""
    clock = ManualClock((1 << 30) - 7000)  # the tick counter wraps during the run
    force = [0, 0]
    buses = [SimI2C(), SimI2C()]

    def source(i, j):
        def volts(t):
            code = force[i] if j == 0 else (j * 1000 - force[i] // 7 + i * 333)
            return code * 3.3 / 128 / 8388608

        return volts

    for i in range(N_SENSORS):
        for j, a in enumerate(frontend.ADDRESS_PLAN[0]):
            buses[i].attach(a, ADS122C04Model(lambda: clock.t_us, source=source(i, j)))
    link = PipeLink()
    storage = MemoryStorage()
    layout = [(i, 0) for i in range(N_SENSORS)]
    board = factory(buses, layout, link, clock, storage, BOOT_ID)
    record = []
    seq = [0]

    def cmd(mtype, values):
        link.put(encode_frame(mtype, seq[0], 0, values))
        seq[0] += 1

    def run(us):
        end = clock.t_us + us
        while clock.t_us < end:
            board.poll()
            clock.advance(STEP_US)

    def dump():
        record.append(_hex(link.take()))

    board.boot()
    dump()
    cmd(0x42, (1000, 1000000, 500000, 2, 0x03))  # CONFIG: 1 kHz, samples + contacts
    cal = tuple(1.5e-6 if r == c else 1e-8 * (r - c) for r in range(6) for c in range(6))
    cmd(0x46, (0, 77) + cal)  # SET_CAL sensor 0 (written to cal0.bin)
    cmd(0x44, ())  # START
    run(2000)
    dump()
    for k in range(8):  # a press on sensor 0: contact BEGIN, IN, END
        force[0] = 1500000 if 2 <= k < 5 else 50000 * k
        force[1] = 20000 * k
        run(1000)
    dump()
    force[0] = force[1] = 0
    buses[1].nack.add(frontend.ADDRESS_PLAN[0][2])  # sensor 1's third converter stops answering
    run(1000)
    buses[1].nack.clear()
    run(3000)  # backoff, re-init, FAULT_RECOVERED
    dump()
    cmd(0x43, (0, 3))  # TARE sensor 0 over 3 samples
    run(4000)
    dump()
    cmd(0x45, ())  # STOP
    cmd(0x41, ())  # GET_INFO
    cmd(0x42, (5000, 1, 0, 1, 0))  # refused: above the ceiling
    run(1000)
    dump()
    stats = counters(board)
    record.append(" ".join("%s=%d" % kv for kv in stats))
    for name in sorted(storage.files):
        record.append("%s=%s" % (name, _hex(storage.files[name])))
    return record


def counters(board):
    """The STATUS counters of either board (the Python one keeps two in its parts)."""
    sched, tx = getattr(board, "sched", None), getattr(board, "tx", None)
    return (
        ("samples", board.samples),
        ("i2c_errors", board.i2c_errors),
        ("drdy_timeouts", board.drdy_timeouts),
        ("overruns", sched.overruns if sched is not None else board.overruns),
        ("tx_dropped", tx.dropped if tx is not None else board.tx_dropped),
        ("rx_errors", board.rx_errors),
        ("last_error", board.last_error),
    )


def python_board(buses, layout, link, clock, storage, boot_id):
    from tactile_fw.board import Board

    sensors = [frontend.make_sensor(buses[b], s, bus_key=b) for b, s in layout]
    return Board(sensors, link, clock, storage, boot_id=boot_id)


def native_board(buses, layout, link, clock, storage, boot_id):
    import tactile_native

    return tactile_native.Board(buses, layout, link, clock, storage, boot_id)


if __name__ == "__main__":
    import time

    for name, factory in (("python", python_board), ("native", native_board)):
        t0 = time.ticks_ms()
        lines = scenario(factory)
        print("%s %d %s" % (name, time.ticks_diff(time.ticks_ms(), t0), "|".join(lines)))
