"""A simulated I2C bus with ``machine.I2C``'s method names, and fault injection.

Devices attach at 7-bit addresses (``attach``) and see each transaction
as ``write(data)`` (the bytes after the address byte) or ``read_into(buf)``.
A combined write-then-repeated-start-read (``readfrom_mem_into``) is one of
each.
Errors are raised as MicroPython raises them: ``OSError(ENODEV)`` when the
address is not acknowledged, ``OSError(ETIMEDOUT)`` on a bus timeout.

A device may also offer ``read_mem_into(cmd, buf)``, the combined
transaction in one call without building the command's bytes (the sampling
loop's path; ``ADS122C04Model`` has it).  Runs on MicroPython too
(tests/test_fw_micropython.py).

Fault injection: ``nack`` (addresses that do not answer), ``fail_next(n,
errno)`` (the next n transactions fail).  ``bits`` counts bus bit-times
(9 per byte, address byte included, plus start/stop and the repeated start's
extra bit) so tests can check the firmware's I2C budget.
"""

import errno

ENODEV = errno.ENODEV
ETIMEDOUT = errno.ETIMEDOUT


class SimI2C:
    def __init__(self, freq=1_000_000):
        self.freq = freq
        self.devices = {}  # add with attach() only: it also fills _mem_readers
        self._mem_readers = {}  # addr -> the device's combined command-then-read
        self.nack = set()
        self.transactions = 0
        self.bits = 0
        self._fail_n = 0
        self._fail_errno = ETIMEDOUT

    def attach(self, addr, device):
        if addr in self.devices:
            raise ValueError(f"I2C address 0x{addr:02x} already in use")
        self.devices[addr] = device
        self._mem_readers[addr] = getattr(device, "read_mem_into", None) or (
            lambda cmd, buf: (device.write(bytes((cmd,))), device.read_into(buf))
        )
        return device

    def fail_next(self, n, err=ETIMEDOUT):
        """Make the next ``n`` transactions raise OSError(err)."""
        self._fail_n = n
        self._fail_errno = err

    def begin(self, addr):
        """The address phase of a transaction a controller drives byte by byte (the emulated
        Pico's): the device, to ``write`` and ``read_into`` next, or OSError as the whole
        transaction would raise it (a NACK, an injected failure)."""
        return self._device(addr, 0)

    def fails_pending(self):
        """Whether the next transactions are set to fail (``fail_next``)."""
        return self._fail_n > 0

    def scan(self):
        return sorted(a for a in self.devices if a not in self.nack)

    def _device(self, addr, bits):
        self.transactions += 1
        self.bits += bits
        if self._fail_n:
            self._fail_n -= 1
            raise OSError(self._fail_errno)
        dev = self.devices.get(addr)
        if dev is None or addr in self.nack:
            raise OSError(ENODEV)
        return dev

    # --- machine.I2C methods the firmware uses --------------------------------------
    # Bit-times: n data bytes + the address byte, 9 bits each, + start and stop; the
    # combined transfer adds a second address byte and the repeated start.
    def readfrom_mem_into(self, addr, memaddr, buf, addrsize=8):
        # the sampling loop's transaction (RREG, RDATA): _device inlined
        self.transactions += 1
        self.bits += 9 * len(buf) + 30  # 9 * (1 + len + 2) + 3
        if self._fail_n:
            self._fail_n -= 1
            raise OSError(self._fail_errno)
        read = self._mem_readers.get(addr)
        if read is None or addr in self.nack:
            raise OSError(ENODEV)
        read(memaddr, buf)

    def writeto_mem(self, addr, memaddr, buf, addrsize=8):
        dev = self._device(addr, 9 * len(buf) + 20)  # 9 * (1 + len + 1) + 2
        dev.write(bytes((memaddr,)) + bytes(buf))

    def readfrom_into(self, addr, buf, stop=True):
        self._device(addr, 9 * len(buf) + 11).read_into(buf)  # 9 * (len + 1) + 2

    def writeto(self, addr, buf, stop=True):
        self._device(addr, 9 * len(buf) + 11).write(bytes(buf))
        return len(buf) + 1  # acknowledged bytes, as machine.I2C returns
