"""``tactile demo``: the chapter 5 experiment replicated on the board emulator.

For each of the thesis's three surfaces: the emulated board (the real
firmware, simulated transducer) streams CONTACT frames over the serial path
(``sim://``), the host TAREs it, decodes, localises each contact on the wheel
probe with the robot's pose log (eqs. 60-62), fits tangent- and
position-weighted biquadratic patches on an 8x8 grid and prints S, sd S, R,
sd R and radius beside the thesis's tables 5-7.
"""

KINDS = ("plane", "convex", "concave")


def add_arguments(parser):
    parser.add_argument("--object", choices=KINDS, action="append", help="default: all three")


def run(args):
    import serial

    from tactile import replica
    from tactile.stream_decoder import StreamDecoder
    from tactile_protocol import constants as C
    from tactile_protocol.framing import FrameEncoder
    from tactile_sim.rig.geometry import FREDDY
    from tactile_sim.urlhandler import register

    register()
    lengths = (FREDDY.L1, FREDDY.L2, FREDDY.L3, FREDDY.L4)
    print("Chapter 5 replica on the board emulator (sim://ch5_*): biquadratic fits, 8x8 grid")
    print(f"{'surface':<9}{'fit':<10}{'':>7}{'S':>9}{'sd S':>10}{'R':>10}{'sd R':>10}{'radius':>9}")
    for kind in args.object or KINDS:
        port = serial.serial_for_url(f"sim://ch5_{kind}", timeout=0.005)
        port.write(bytes(FrameEncoder().encode(C.CMD_TARE, 0, (C.SENSOR_ALL, 64))))
        decoder, messages = StreamDecoder(), []
        motion = port.emulator.motion
        while port.emulator.t_us < motion.duration_s * 1e6:
            messages += decoder.feed(port.read(65536))
        times, wrench, _ = replica.contact_samples(messages)
        enter = port.emulator.scene.board["enter_threshold_N"]
        points, normals, finger = replica.world_contacts(
            times, wrench, motion.poses(), lengths, enter
        )
        results = replica.analyse(points, normals, finger)
        for weighting, res in results.items():
            _row(kind, weighting, "ours", _ours(res))
            _row("", "", "thesis", replica.THESIS[kind][weighting])
        true = replica.TRUE_RADIUS_CM[kind]
        print(
            f"{'':<9}{len(times)} samples, {len(points)} localised, "
            f"{decoder.counters.lost_frames} frames lost; label '{results['tangent'].shape}'"
            + (f"; true radius {true} cm" if true else "")
        )
    return 0


def _ours(res):
    return (res.S_mean, res.S_std, res.R_mean, res.R_std, res.radius)


def _row(kind, weighting, who, values):
    cells = "".join(f"{'-' if v is None else f'{v:.4f}':>10}" for v in values)
    print(f"{kind:<9}{weighting:<10}{who:>7}{cells}")
