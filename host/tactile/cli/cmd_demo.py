"""``tactile demo``: the chapter 5 experiment replicated on the board emulator.

For each of the thesis's three surfaces: the emulated board (the real
firmware, simulated transducer) streams CONTACT frames over a serial port;
``tactile_studies.replica.replicate`` records them as ``tactile record`` does (TARE,
capture, frames, meta), localises each contact on the wheel probe with the
robot's pose log (eqs. 60-62), fits tangent- and position-weighted
biquadratic patches on an 8x8 grid, and this prints S, sd S, R, sd R and
radius beside the thesis's tables 5-7.
"""

KINDS = ("plane", "convex", "concave")


def add_arguments(parser):
    parser.add_argument("--object", choices=KINDS, action="append", help="default: all three")
    parser.add_argument("-o", "--out", default="demo-out", help="recordings go here (demo-out/)")
    parser.add_argument(
        "--via",
        choices=("pty", "sim"),
        default="pty",
        help="serial path: a pseudo-terminal (default) or the in-process sim:// port",
    )


def run(args):
    import pathlib

    from tactile_studies import replica

    print("Chapter 5 replica on the board emulator (ch5_* scenes): biquadratic fits, 8x8 grid")
    print(f"{'surface':<9}{'fit':<10}{'':>7}{'S':>9}{'sd S':>10}{'R':>10}{'sd R':>10}{'radius':>9}")
    for kind in args.object or KINDS:
        outdir = pathlib.Path(args.out) / kind
        meta, _, results = replica.replicate(kind, outdir, args.via)
        for weighting, res in results.items():
            _row(kind, weighting, "ours", _ours(res))
            _row("", "", "thesis", replica.THESIS[kind][weighting])
        true = replica.TRUE_RADIUS_CM[kind]
        print(
            f"{'':<9}{meta['contacts_ended']} contacts, {results['tangent'].n_points} localised "
            f"readings, {meta['decoder']['lost_frames']} frames lost; "
            f"label '{results['tangent'].shape}'" + (f"; true radius {true} cm" if true else "")
        )
        print(f"{'':<9}recording: {outdir}")
    return 0


def _ours(res):
    return (res.S_mean, res.S_std, res.R_mean, res.R_std, res.radius)


def _row(kind, weighting, who, values):
    cells = "".join(f"{'-' if v is None else f'{v:.4f}':>10}" for v in values)
    print(f"{kind:<9}{weighting:<10}{who:>7}{cells}")
