"""A simulated I2C bus with ``machine.I2C``'s method names, and fault injection.

Devices attach at 7-bit addresses and see each transaction as ``write(data)``
(the bytes after the address byte) or ``read_into(buf)``.  A combined
write-then-repeated-start-read (``readfrom_mem_into``) is one of each.
Errors are raised as MicroPython raises them: ``OSError(ENODEV)`` when the
address is not acknowledged, ``OSError(ETIMEDOUT)`` on a bus timeout.

Fault injection: ``nack`` (addresses that do not answer), ``fail_next(n,
errno)`` (the next n transactions fail).  ``bits`` counts bus bit-times
(9 per byte plus start/stop) so tests can check the firmware's I2C budget.
"""

import errno

ENODEV = errno.ENODEV
ETIMEDOUT = errno.ETIMEDOUT


class SimI2C:
    def __init__(self, freq=1_000_000):
        self.freq = freq
        self.devices = {}
        self.nack = set()
        self.transactions = 0
        self.bits = 0
        self._fail_n = 0
        self._fail_errno = ETIMEDOUT

    def attach(self, addr, device):
        if addr in self.devices:
            raise ValueError(f"I2C address 0x{addr:02x} already in use")
        self.devices[addr] = device
        return device

    def fail_next(self, n, err=ETIMEDOUT):
        """Make the next ``n`` transactions raise OSError(err)."""
        self._fail_n = n
        self._fail_errno = err

    def scan(self):
        return sorted(a for a in self.devices if a not in self.nack)

    def _device(self, addr, nbytes, restart=False):
        self.transactions += 1
        self.bits += 9 * (nbytes + 1 + (1 if restart else 0)) + 2 + (1 if restart else 0)
        if self._fail_n:
            self._fail_n -= 1
            raise OSError(self._fail_errno)
        dev = self.devices.get(addr)
        if dev is None or addr in self.nack:
            raise OSError(ENODEV)
        return dev

    # --- machine.I2C methods the firmware uses --------------------------------------
    def readfrom_mem_into(self, addr, memaddr, buf, addrsize=8):
        dev = self._device(addr, 1 + len(buf), restart=True)
        dev.write(bytes((memaddr,)))
        dev.read_into(buf)

    def writeto_mem(self, addr, memaddr, buf, addrsize=8):
        dev = self._device(addr, 1 + len(buf))
        dev.write(bytes((memaddr,)) + bytes(buf))

    def readfrom_into(self, addr, buf, stop=True):
        self._device(addr, len(buf)).read_into(buf)

    def writeto(self, addr, buf, stop=True):
        self._device(addr, len(buf)).write(bytes(buf))
        return len(buf) + 1  # acknowledged bytes, as machine.I2C returns
