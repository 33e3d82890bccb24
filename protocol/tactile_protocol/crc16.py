"""CRC-16/CCITT-FALSE: poly 0x1021, init 0xFFFF, no reflection, no final xor.

Check value: crc16(b"123456789") == 0x29B1.  Table driven so that it is fast
enough on a microcontroller; CPython hosts may use ``binascii.crc_hqx``,
which computes the same function (tested against this one).
"""


def _make_table():
    table = []
    for byte in range(256):
        crc = byte << 8
        for _ in range(8):
            crc = ((crc << 1) ^ 0x1021) if crc & 0x8000 else (crc << 1)
        table.append(crc & 0xFFFF)
    return tuple(table)


_TABLE = _make_table()


def crc16(data, start=0, end=None, crc=0xFFFF):
    """CRC of ``data[start:end]`` (no slice is made), continuing from ``crc``."""
    if end is None:
        end = len(data)
    table = _TABLE
    for i in range(start, end):
        crc = ((crc << 8) & 0xFF00) ^ table[(crc >> 8) ^ data[i]]
    return crc
