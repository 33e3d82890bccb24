"""``tactile demo``: the main job, run on the embedded default.

Until the board emulator lands (issue 6) this runs the most complete
pipeline there is: a simulated device stream with link damage, framed by
the protocol package and decoded by the host, with the counters printed.
"""

import random


def add_arguments(parser):
    parser.add_argument("--frames", type=int, default=2000, help="frames to stream")
    parser.add_argument("--seed", type=int, default=1)


def run(args):
    from tactile.stream_decoder import StreamDecoder
    from tactile_protocol import constants as C
    from tactile_protocol.framing import FrameEncoder

    rng = random.Random(args.seed)
    enc = FrameEncoder()
    stream = bytearray(bytes(enc.encode(C.MSG_HELLO, 0, _hello(C))))
    damaged = 0
    for i in range(args.frames):
        fx = int(6e6 * max(0.0, 1 - abs(i % 400 - 200) / 120))  # press and release
        frame = bytearray(enc.encode(C.MSG_SAMPLE, 1000 * i, (0, 0, fx, 0, -fx // 3, 0, 0, 0)))
        if rng.random() < 0.01:
            frame[rng.randrange(1, len(frame) - 1)] ^= 0x5A
            damaged += 1
        stream += frame
    decoder = StreamDecoder()
    messages = decoder.feed(bytes(stream))
    c = decoder.counters
    print(
        f"streamed {args.frames} SAMPLE frames ({len(stream)} bytes), damaged {damaged} on the link"
    )
    print(f"decoded  {len(messages) - 1} samples; lost {c.lost_frames} (seq gaps {c.seq_gaps}),")
    print(f"         crc errors {c.crc_errors}, undecodable {c.undecodable}, salvaged {c.salvaged}")
    return 0


def _hello(C):
    return (0, 1, 0, C.PROTOCOL_VERSION, b"demo", 1, 1000, 0, 0, 0, 0, 1000, 5000000, 4000000, 3, 3)
