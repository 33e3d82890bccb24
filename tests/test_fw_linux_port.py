"""Linux-controller port: smbus2 behind machine.I2C's names, a raw non-blocking tty."""

import os
import pty

from tactile_fw.ads122c04 import ADS122C04
from tactile_fw.link import TxRing
from tactile_fw_tools import port_linux


class FakeSMBus:
    """Records i2c_rdwr messages; answers reads from a register dict."""

    def __init__(self):
        self.log = []
        self.answer = {}

    def i2c_rdwr(self, *msgs):
        last_write = None
        for m in msgs:
            if m.flags & 1:  # I2C_M_RD
                data = self.answer.get((m.addr, last_write), bytes(m.len))
                for k in range(m.len):
                    m.buf[k] = data[k]
                self.log.append(("r", m.addr, m.len))
            else:
                last_write = bytes(m)
                self.log.append(("w", m.addr, last_write))


def test_smbus_adapter_maps_the_driver_calls():
    fake = FakeSMBus()
    i2c = port_linux.SMBusI2C(1, smbus=fake)
    adc = ADS122C04(i2c, 0x41)
    fake.answer[(0x41, b"\x20")] = bytes((adc.config0,))
    fake.answer[(0x41, b"\x24")] = bytes((adc.config1,))
    adc.init()
    assert fake.log[0] == ("w", 0x41, b"\x06")  # RESET
    assert fake.log[1] == ("w", 0x41, bytes((0x40, adc.config0)))  # WREG 0
    assert fake.log[-1] == ("w", 0x41, b"\x08")  # START/SYNC
    fake.answer[(0x41, b"\x10")] = b"\xff\xff\xfe"
    assert adc.read() == -2
    assert fake.log[-2:] == [("w", 0x41, b"\x10"), ("r", 0x41, 3)]  # one combined transfer


def test_tty_link_is_raw_and_never_blocks():
    master, slave = pty.openpty()
    try:
        link = port_linux.TtyLink(os.ttyname(slave))
        buf = bytearray(64)
        assert not link.readinto(buf)
        os.write(master, b"\x03\x00\x11")
        assert link.readinto(buf) == 3 and bytes(buf[:3]) == b"\x03\x00\x11"  # raw: no Ctrl-C
        ring = TxRing(link, size=512)
        frame = bytes(range(1, 200)) + b"\0"
        sent = sum(ring.send(frame) for _ in range(2000))  # nobody reads the master side
        assert 0 < sent < 2000 and ring.dropped == 2000 - sent
        os.close(link.fd)
    finally:
        os.close(master)
        os.close(slave)


def test_monotonic_clock_wraps_like_micropython():
    c = port_linux.MonotonicClock()
    assert c.ticks_diff(c.ticks_add(0x3FFFFFF0, 0x20), 0x3FFFFFF0) == 0x20
    assert c.ticks_add(0x3FFFFFF0, 0x20) == 0x10
    a = c.ticks_us()
    c.sleep_us(2000)
    assert c.ticks_diff(c.ticks_us(), a) >= 2000


def test_a_missing_i2c_bus_is_one_line_and_exit_4(tmp_path):
    import subprocess
    import sys

    r = subprocess.run(
        [sys.executable, "-m", "tactile_fw_tools.port_linux", "--tty", "/dev/null"]
        + ["--i2c", "250", "--storage", str(tmp_path)],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert r.returncode == 4 and r.stdout == "", (r.returncode, r.stderr)
    assert r.stderr.count("\n") == 1 and "/dev/i2c-250" in r.stderr, r.stderr
    assert "Traceback" not in r.stderr
