"""Consistent Overhead Byte Stuffing (Cheshire & Baker, 1999).

``encode_into`` writes into a caller-owned buffer and allocates nothing, for
the board's hot path.  ``encode``/``decode`` are conveniences; the host uses
the C ``cobs`` package where present and falls back to these.  Encoded data
never contains 0x00, and one frame is the encoding followed by 0x00.
"""


def max_encoded_len(n):
    """Worst-case encoded length of ``n`` source bytes."""
    return n + n // 254 + 1


def encode_into(src, n, dst, pos=0):
    """Encode ``src[:n]`` into ``dst`` at ``pos``; return the end offset."""
    code_pos = pos
    out = pos + 1
    code = 1
    for i in range(n):
        b = src[i]
        if b == 0:
            dst[code_pos] = code
            code_pos = out
            out += 1
            code = 1
            continue
        dst[out] = b
        out += 1
        code += 1
        if code == 0xFF and i + 1 < n:  # full block, more data follows
            dst[code_pos] = code
            code_pos = out
            out += 1
            code = 1
    dst[code_pos] = code
    return out


def encode(data):
    """Return the COBS encoding of ``data`` (no delimiter)."""
    buf = bytearray(max_encoded_len(len(data)))
    end = encode_into(data, len(data), buf)
    return bytes(buf[:end])


def decode(enc):
    """Decode one COBS block (no delimiter); ValueError if it is malformed."""
    out = bytearray()
    i = 0
    n = len(enc)
    while i < n:
        code = enc[i]
        if code == 0:
            raise ValueError("COBS: zero byte inside a frame")
        end = i + code
        if end > n:
            raise ValueError("COBS: block runs past the end")
        for j in range(i + 1, end):
            b = enc[j]
            if b == 0:
                raise ValueError("COBS: zero byte inside a frame")
            out.append(b)
        i = end
        if code != 0xFF and i < n:
            out.append(0)
    return bytes(out)
