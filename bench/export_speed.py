"""Speed of reading a recording back (``tactile.load_recording``) and of ``tactile export
--format mcap``, on a synthetic recording: three sensors at 1 kHz, a SAMPLE row per sensor
and millisecond, host-time columns as a newer recorder writes them.

    .venv/bin/python bench/export_speed.py [--rows N]

Prints one table row per stage: wall time (best of 3), rows/s, and the file sizes.  Both
stages are single-threaded Python; run them side by side on one machine to compare.
"""

import argparse
import json
import pathlib
import sys
import tempfile

import numpy as np
from timing import best_of

ROOT = pathlib.Path(__file__).resolve().parents[1]
for sub in ("protocol", "firmware", "host", "sim", "studies"):
    sys.path.insert(0, str(ROOT / sub))

HEADER = (
    "seq,timestamp_us,host_monotonic_s,host_utc_s,type,sensor,phase,contact_id,flags,"
    "fx_N,fy_N,fz_N,tx_Nm,ty_Nm,tz_Nm"
)


def make_recording(out, rows, seed=1):
    """frames.csv and meta.json of ``rows`` SAMPLE rows, sensors 0..2 in turn."""
    rng = np.random.default_rng(seed)
    out.mkdir(parents=True)
    us = 1000 * (np.arange(rows) // 3)
    mono = 100.0 + us * 1e-6 * (1 + 30e-6)
    w = rng.normal(scale=2.0, size=(rows, 6)).round(6)
    with open(out / "frames.csv", "w", encoding="utf-8") as fh:
        fh.write(HEADER + "\n")
        for i in range(rows):
            cells = ",".join(f"{v:.6f}" for v in w[i])
            fh.write(
                f"{i % 65536},{us[i]},{mono[i]:.6f},{mono[i] + 1.7e9:.6f},SAMPLE,{i % 3},,,0,"
                f"{cells}\n"
            )
    meta = {"sessions": [{"rows_offset": 0, "samples": rows}], "device": None}
    (out / "meta.json").write_text(json.dumps(meta), encoding="utf-8")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rows", type=int, default=60_000, help="rows (default 60000)")
    args = parser.parse_args()

    from tactile import load_recording
    from tactile.foxglove.export_mcap import write_mcap

    with tempfile.TemporaryDirectory() as tmp:
        run = pathlib.Path(tmp) / "run"
        make_recording(run, args.rows)
        csv_mb = (run / "frames.csv").stat().st_size / 2**20
        load_s, rec = best_of(lambda: load_recording(run))
        assert rec.host_time_source == "frames.csv" and rec.host_time_why is None
        out = pathlib.Path(tmp) / "run.mcap"
        export_s, _ = best_of(lambda: write_mcap(rec, out))
        mcap_mb = out.stat().st_size / 2**20
    print(f"rows: {args.rows:,} (3 sensors, frames.csv {csv_mb:.1f} MiB, MCAP {mcap_mb:.1f} MiB)")
    print("| stage | wall s | rows/s |")
    print("|---|---:|---:|")
    print(f"| load_recording (frames.csv, meta.json) | {load_s:.2f} | {args.rows / load_s:,.0f} |")
    print(f"| write_mcap (WrenchStamped, zstd) | {export_s:.2f} | {args.rows / export_s:,.0f} |")
    print(f"export / load time: {export_s / load_s:.2f}")


if __name__ == "__main__":
    main()
