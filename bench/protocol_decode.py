"""Host decode throughput for a stream of SAMPLE frames (issue: >= 500,000 frames/s).

Run: ``.venv/bin/python bench/protocol_decode.py``.  Prints a Markdown table:
frames/s and MB/s on one core (median of repeats), for the C ``cobs``
package and the pure-Python fallback, for large reads and for the 4 KiB
reads a serial port typically returns, set against the link limits.
"""

import statistics
import time

from tactile.board.stream_decoder import StreamDecoder
from tactile_protocol import cobs_codec
from tactile_protocol.constants import MSG_SAMPLE
from tactile_protocol.framing import FrameEncoder

N_FRAMES = 200_000
REPEATS = 7
USB_FS_CDC = 1.0e6  # bytes/s, practical USB full-speed CDC ceiling
UART_921600 = 921600 / 10  # bytes/s with 8N1 framing


def make_stream(n):
    enc = FrameEncoder()
    return b"".join(
        bytes(enc.encode(MSG_SAMPLE, 1000 * i, (0, 0x40, 1000 * i, -7 * i, 5000000, 12, -3, 0)))
        for i in range(n)
    )


def throughput(stream, chunk, codec, n):
    times = []
    for _ in range(REPEATS if codec is None else 2):
        decoder = StreamDecoder(cobs_decode=codec)
        t0 = time.perf_counter()
        delivered = 0
        for start in range(0, len(stream), chunk):
            delivered += len(decoder.feed(stream[start : start + chunk]))
        times.append(time.perf_counter() - t0)
        assert delivered == n and decoder.counters.lost_frames == 0
    t = statistics.median(times)
    return n / t, len(stream) / t / 1e6


def main():
    stream = make_stream(N_FRAMES)
    frame_len = len(stream) / N_FRAMES
    print(f"SAMPLE frame on the wire: {frame_len:.0f} bytes; {N_FRAMES} frames per run\n")
    print("| decoder | read size | frames/s | MB/s | x USB FS CDC | x UART 921600 |")
    print("|---|---|---:|---:|---:|---:|")
    usb_fps = USB_FS_CDC / frame_len
    uart_fps = UART_921600 / frame_len
    for label, codec in (("cobs (C)", None), ("pure Python", cobs_codec.decode)):
        for chunk in (65536, 4096):
            fps, mbs = throughput(stream, chunk, codec, N_FRAMES)
            print(
                f"| {label} | {chunk} B | {fps:,.0f} | {mbs:.1f} | {fps / usb_fps:.0f} |"
                f" {fps / uart_fps:.0f} |"
            )
    print(
        f"\nLink limits for this frame: USB FS CDC ~{usb_fps:,.0f} frames/s,"
        f" UART 921600 baud {uart_fps:,.0f} frames/s."
    )


if __name__ == "__main__":
    main()
