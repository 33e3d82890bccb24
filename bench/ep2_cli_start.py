"""One patch through the CLI against starting Python with numpy: issue 28's 2.5x target.

Run: .venv/bin/python bench/ep2_cli_start.py [--repeats 15]

Writes one 36-contact patch (a noisy sphere, ``ep2_cli_scale.write_csv``) and times, in
turn in one run, ``python -c "import numpy"`` and ``tactile ep2 analyze FILE`` (the
installed console script, table output), wall seconds of each child process, best and
median of ``--repeats``; their ratio; and the heaviest modules the CLI run imported
(``-X importtime``), to show that nothing but numpy and the package is loaded.
"""

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_args import positive_int  # noqa: E402
from ep2_cli_scale import write_csv  # noqa: E402

HERE = Path(__file__).resolve().parent
BIN = Path(sys.executable).parent


def wall(cmd):
    t0 = time.perf_counter()
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    return time.perf_counter() - t0


def heaviest(path, top=8):
    """[(cumulative ms, module)] of the CLI run's imports, largest first."""
    out = subprocess.run(
        [sys.executable, "-X", "importtime", "-m", "tactile", "ep2", "analyze", path],
        capture_output=True, text=True, check=True,
    )  # fmt: skip
    rows = []
    for line in out.stderr.splitlines():
        parts = line.split("|")
        if len(parts) == 3 and parts[1].strip().isdigit():
            rows.append((int(parts[1]) / 1000, parts[2].strip()))
    top_level = [r for r in rows if not r[1].startswith(" ") and "." not in r[1]]
    return sorted(top_level, reverse=True)[:top]


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=positive_int, default=15)
    args = ap.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        path = os.path.join(tmp, "one.csv")
        write_csv(path, 1)
        numpy_cmd = [sys.executable, "-c", "import numpy"]
        cli_cmd = [str(BIN / "tactile"), "ep2", "analyze", path]
        wall(cli_cmd)  # (warm the page cache)
        a, b = [], []
        for _ in range(args.repeats):
            a.append(wall(numpy_cmd))
            b.append(wall(cli_cmd))
        print("| command | best wall (s) | median wall (s) |")
        print("|---|---|---|")
        print(f'| `python -c "import numpy"` | {min(a):.3f} | {statistics.median(a):.3f} |')
        print(f"| `tactile ep2 analyze one.csv` | {min(b):.3f} | {statistics.median(b):.3f} |")
        print(
            f"| ratio | {min(b) / min(a):.2f} | {statistics.median(b) / statistics.median(a):.2f} |"
        )
        print()
        print("Top-level imports of the CLI run, cumulative ms:",
              ", ".join(f"{m} {ms:.0f}" for ms, m in heaviest(path)))  # fmt: skip
    return 0


if __name__ == "__main__":
    sys.exit(main())
