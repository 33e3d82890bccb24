"""``tactile export RUN --format parquet`` (issue 14, part 5): frames and contacts as Parquet
tables with units, read back with pyarrow and checked against the capture decoded on its own."""

import json
import subprocess
import sys

import numpy as np
import pytest
from recorded import HOST_HEADER, frame_line, variant

pq = pytest.importorskip("pyarrow.parquet", reason="the 'parquet' extra (pyarrow) is missing")


def test_frames_and_contacts_read_back_in_si_with_units_in_the_schema(
    recorded_run, recorded_msgs, tmp_path, cli
):
    out = tmp_path / "r.parquet"
    code, stdout, err = cli("export", recorded_run, "--format", "parquet", "-o", out)
    assert code == 0 and err == "", err
    table = pq.read_table(out)
    assert stdout.startswith(f"wrote {out}: {len(recorded_msgs):,} frames (N, N*m, s")
    cols = table.to_pydict()
    assert cols["seq"] == [m.seq for m in recorded_msgs] and cols["board_us"] == [
        m.timestamp_us for m in recorded_msgs
    ]
    assert cols["sensor"] == [m.sensor for m in recorded_msgs]
    assert cols["is_contact"] == [m.type_name == "CONTACT" for m in recorded_msgs]
    for name, attr in zip(
        ("fx_N", "fy_N", "fz_N", "tx_Nm", "ty_Nm", "tz_Nm"), "fx fy fz tx ty tz".split()
    ):
        assert cols[name] == [
            getattr(m, attr) / 1e6 for m in recorded_msgs
        ]  # uN -> N, exactly as frames.csv
    units = {f.name: f.metadata[b"unit"].decode() for f in table.schema}
    assert units["fx_N"] == "N" and units["tz_Nm"] == "N*m" and units["board_time_s"] == "s"
    assert units["board_us"] == "us" and units["host_utc_s"] == "s"
    meta = table.schema.metadata
    assert json.loads(meta[b"meta.json"]) == json.loads((recorded_run / "meta.json").read_text())
    assert json.loads(meta[b"tactile"])["table"] == "frames"
    contacts = pq.read_table(tmp_path / "r.contacts.parquet")
    lines = (recorded_run / "contacts.csv").read_text().splitlines()
    assert lines[0] == "# units: m" and contacts.num_rows == len(lines) - 2 > 0
    first = [float(v) for v in lines[2].split(",")[:6]]
    got = [contacts.column(c)[0].as_py() for c in ("x_m", "y_m", "z_m", "nx", "ny", "nz")]
    np.testing.assert_allclose(got, first, rtol=1e-12, atol=1e-15)  # normals: made unit length
    assert {f.name: f.metadata[b"unit"] for f in contacts.schema}["x_m"] == b"m"


def test_a_host_time_not_determined_is_null_not_nan(recorded_run, recorded_msgs, tmp_path, cli):
    """Rows without a host time (empty cells in frames.csv) come out null: no NaN in output."""
    host = lambda m: (None, None) if m.seq % 2 else (10.0 + m.seq, 1.7e9 + m.seq)  # noqa: E731
    text = "\n".join([HOST_HEADER, *(frame_line(m, host(m)) for m in recorded_msgs)]) + "\n"
    rec = variant(recorded_run, tmp_path / "half", "# units: N, N*m, us, s\n" + text)
    code, _, err = cli("export", rec, "--format", "parquet")
    assert code == 0, err
    table = pq.read_table(rec / "half.parquet")
    utc = table.column("host_utc_s").to_pylist()
    assert utc == [None if m.seq % 2 else 1.7e9 + m.seq for m in recorded_msgs]
    assert table.column("host_utc_s").null_count == sum(m.seq % 2 for m in recorded_msgs) > 0
    assert not any(np.isnan(v) for v in utc if v is not None)


def test_without_the_extra_the_command_says_how_to_install_it(
    recorded_run, tmp_path, cli, monkeypatch
):
    monkeypatch.setitem(sys.modules, "pyarrow", None)  # import -> ImportError
    monkeypatch.setitem(sys.modules, "pyarrow.parquet", None)
    code, out, err = cli(
        "export", recorded_run, "--format", "parquet", "-o", tmp_path / "x.parquet"
    )
    assert code == 2 and out == ""
    assert err == "tactile export: error: Parquet export needs the 'parquet' extra:" \
        " pip install 'tactile-shape[parquet]'\n"  # fmt: skip
    assert not (tmp_path / "x.parquet").exists()


def test_mcap_export_and_the_loader_do_not_import_pyarrow(recorded_run, tmp_path):
    code = (
        "import sys, tactile\n"
        "from tactile.cli.main import main\n"
        f"main(['export', {str(recorded_run)!r}, '-o', {str(tmp_path / 'r.mcap')!r}])\n"
        f"tactile.load_recording({str(recorded_run)!r})\n"
        "print('pyarrow' in sys.modules)\n"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert done.stdout.splitlines()[-1] == "False"


def test_an_output_that_cannot_be_written_is_one_line_exit_2(recorded_run, tmp_path, cli):
    code, out, err = cli("export", recorded_run, "--format", "parquet",
                         "-o", tmp_path / "no" / "such" / "x.parquet")  # fmt: skip
    assert code == 2 and out == "" and err.count("\n") == 1 and "Traceback" not in err
    assert "x.parquet: cannot write" in err
    assert not list((tmp_path).rglob("*.parquet*"))  # nothing half-written left behind
