"""``tactile calibrate --port P FILE``: load a 6x6 calibration matrix and its id onto a board
sensor, then verify them through INFO (id and checksum).  FILE is ATI's ``.cal`` XML, a CSV
or a JSON matrix (docs/calibration.md); ``--dry-run`` shows what would be sent."""

from tactile.calib import board_matrix, describe, files
from tactile.cli.board_args import add_port_argument, connect
from tactile.output.text import (
    printable,  # the label and notes quote the file
    printable_lines,  # the file's words
)


def add_arguments(parser):
    add_port_argument(parser)
    parser.add_argument("file", metavar="FILE", help="ATI .cal, CSV or JSON calibration matrix")
    parser.add_argument("--sensor", type=int, help="sensor index (needed on a multi-sensor board)")
    parser.add_argument("--id", type=int, help="calibration id 1..4294967295 (default: the file's)")
    parser.add_argument(
        "--volts-per-count",
        type=float,
        metavar="V",
        help="gauge volts per ADC count, for a matrix per volt such as ATI's",
    )
    parser.add_argument("--index", type=int, help="which calibration of a multi-range ATI .cal")
    parser.add_argument(
        "--dry-run", action="store_true", help="check FILE and print the matrix; no board"
    )


def run(args):
    mf = files.read(args.file, args.index)
    bm = board_matrix.to_board(mf, args.volts_per_count, args.id)
    scale = f"; {args.volts_per_count:.6g} V per count" if args.volts_per_count else ""
    print(printable(f"{args.file}: {mf.label}{scale}"))
    for note in mf.notes:
        print(printable(f"note: {note}"))
    print(
        printable(
            f"id {bm.cal_id} ({'--id' if args.id is not None else mf.id_from});"
            f" condition number {bm.condition:.3g} (rows scaled to unit length; refused above"
            f" {board_matrix.MAX_CONDITION:g}); checksum 0x{bm.crc:04x}"
        )
    )
    if args.dry_run:
        print(printable(f"would send (from {describe(mf.units)}):"))
        print(printable_lines(board_matrix.table(bm.coeffs)))
        return 0
    client = connect(args)
    try:
        sensor, _ = board_matrix.install(client, bm, args.sensor)
    finally:
        client.close()
    print(
        printable(
            f"sensor {sensor}: calibration {bm.cal_id} loaded and verified"
            f" (INFO reports id {bm.cal_id}, checksum 0x{bm.crc:04x})"
        )
    )
    return 0
