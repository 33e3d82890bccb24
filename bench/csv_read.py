"""The CSV reader's speed: EP2 contacts through ``ContactsFile`` (the checking pass and
the second pass that gives the patches out) and through ``read_csv``, and a recording's
frames.csv (blank cells, a text column) through ``read_frames``.  CPU seconds of this
process, best of ``--repeats`` (the machine is shared).

Run: OPENBLAS_NUM_THREADS=1 .venv/bin/python bench/csv_read.py [--patches 10000,100000]
[--frames 300000] [--repeats 2]   (the files go to $TMPDIR: 27 MiB for 10k patches)
"""

import argparse
import os
import tempfile
import time

from ep2_cli_scale import ROWS, write_csv
from timing import best_of

from tactile.ep2.contacts_csv import REQUIRED, ContactsFile
from tactile.files.tabular import read_csv
from tactile.recording.layout import FRAME_COLUMNS, read_frames


def write_frames(path, n):
    """``n`` rows as the recorder writes them: samples of three sensors (phase and contact
    id blank), a contact row every 50th."""
    with open(path, "w") as fh:
        fh.write("# units: N, N*m, us, s\n" + FRAME_COLUMNS + "\n")
        for i in range(n):
            kind, phase = ("CONTACT", f"1,{i // 50}") if i % 50 == 0 else ("SAMPLE", ",")
            t = 1000 * i
            fh.write(
                f"{i},{t},{t * 1e-6 + 5:.6f},{1.7e9 + t * 1e-6:.6f},{kind},{i % 3},{phase},0,"
                f"{0.001 * i:.6f},-0.250000,9.810000,0.001000,0.000000,-0.012000\n"
            )


def contacts_file(path):
    f = ContactsFile(path)
    return sum(len(g.lines) for g in f)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--patches", default="10000,100000")
    ap.add_argument("--frames", type=int, default=300_000)
    ap.add_argument("--repeats", type=int, default=2)
    args = ap.parse_args()
    clock = time.process_time
    print("| file | rows | MiB | reader | CPU (s) | rows/s of CPU |")
    print("|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as tmp:
        for n in (int(v) for v in args.patches.split(",")):
            path = os.path.join(tmp, f"p{n}.csv")
            write_csv(path, n)
            mib, rows = os.path.getsize(path) / 2**20, n * ROWS
            runs = [("ContactsFile, both passes", lambda p=path: contacts_file(p))]
            if rows <= 1_000_000:
                runs.append(
                    ("read_csv", lambda p=path: len(read_csv(p, REQUIRED, ("finger", "patch"))))
                )
            for name, fn in runs:
                s, got = best_of(fn, args.repeats, clock)
                assert got == rows, (got, rows)
                print(
                    f"| {n:,} patches | {rows:,} | {mib:.0f} | {name} | {s:.2f} | {rows / s:,.0f} |"
                )
            os.unlink(path)
        path = os.path.join(tmp, "frames.csv")
        write_frames(path, args.frames)
        mib = os.path.getsize(path) / 2**20
        s, got = best_of(lambda: len(read_frames(path)), args.repeats, clock)
        assert got == args.frames
        print(f"| frames.csv | {got:,} | {mib:.0f} | read_frames | {s:.2f} | {got / s:,.0f} |")


if __name__ == "__main__":
    main()
