"""Nothing lost when the disk fills or the run is killed: ``record`` ends with one line and
exit 5, every reader opens what was kept, and a run cut short opens from capture.bin."""

import json
import os
import shutil
import subprocess
import sys

import pytest
from full_disk import TEMP, full_disk

import tactile
from tactile.board.stream_decoder import decode_bytes
from tactile.recording.session import Session

RECORD = ("record", "--port", "sim://press", "--quiet")


def _readings(out):
    """The SAMPLE/CONTACT messages of ``out``'s capture.bin, decoded independently."""
    messages, _ = decode_bytes((out / "capture.bin").read_bytes())
    return [m for m in messages if m.type_name in ("SAMPLE", "CONTACT")]


def _one_line(err, *words):
    assert "Traceback" not in err and err.count("\n") == 1, err
    for w in words:
        assert w in err, err


def _all_kept(out, cli):
    """Every reader opens the run, with every reading capture.bin holds; no temporary."""
    assert not list(out.glob("*.tmp"))
    want = _readings(out)
    rec = tactile.load_recording(out)
    assert [(m.seq, m.timestamp_us) for m in want] == list(zip(rec.seq, rec.board_us))
    code, _, err = cli("export", out, "--format", "parquet", "-o", out.parent / "x.parquet")
    assert code == 0 and err.count("\n") <= 1 and "Traceback" not in err, err
    code, stdout, _ = cli("decode", out / "capture.bin")
    assert code == 0 and stdout.startswith("HELLO")
    return rec


def _record_full(cli, out, free, names, *stop):
    with full_disk(out, free, names) as disk:
        code, _, err = cli(*RECORD, *(stop or ("--duration", "20")), "-o", out)
    assert disk.hits, "the disk never filled"
    return code, err


@pytest.mark.parametrize("name", ["frames.csv", "capture.bin"])
def test_a_full_disk_ends_the_run_with_exit_5_and_keeps_everything_received(cli, tmp_path, name):
    out = tmp_path / "run"
    out.mkdir()
    code, err = _record_full(cli, out, 60_000, {name})
    assert code == 5
    _one_line(err, f"{out / name}: disk full", "kept", "meta.json says ended 'disk full'")
    meta = json.loads((out / "meta.json").read_text())
    assert meta["ended"] == "disk full" and meta["bytes"] == (out / "capture.bin").stat().st_size
    assert (out / "frames.csv").read_bytes().endswith(b"\n")  # the torn row cut
    assert meta["samples"] == len((out / "frames.csv").read_text().splitlines()) - 2
    rec = _all_kept(out, cli)
    assert len(rec) > 100 and all("rebuilt" in n for n in rec.notes)


def test_a_full_disk_everywhere_keeps_the_old_meta_and_the_loader_copes(cli, tmp_path):
    out = tmp_path / "run"
    out.mkdir()
    with full_disk(out, None, in_place=False) as disk:
        session = Session("sim://press", out, duration_s=20, stop_when=lambda s: _fill(s, disk))
        with pytest.raises(tactile.errors.HostFileError) as exc:
            session.run()
    _one_line(str(exc.value) + "\n", "disk full", "meta.json not updated")
    assert exc.value.exit_code == 5
    assert json.loads((out / "meta.json").read_text())["ended"] == "running"
    rec = _all_kept(out, cli)
    assert any("says 'running'" in n for n in rec.notes)


def _fill(session, disk):
    if session.stats.samples > 300:  # by data, not by the wall clock
        disk.free = 0


@pytest.fixture(scope="module")
def good_run(tmp_path_factory):
    from tactile.cli.main import main

    out = tmp_path_factory.mktemp("good") / "run"
    assert main([*RECORD, "--contacts", "2", "-o", str(out)]) == 0
    return out


def test_meta_json_that_cannot_be_replaced_is_overwritten_in_place(tmp_path):
    """Its first write made room; later ones find no space for a temporary."""
    out = tmp_path / "run"
    out.mkdir()

    def stop(session):
        _fill(session, disk)
        return "done" if session.stats.samples > 600 else None

    with full_disk(out, None, {TEMP % "meta.json"}) as disk:
        meta = Session("sim://press", out, duration_s=20, stop_when=stop).run()
    assert disk.hits and not list(out.glob("*.tmp"))
    written = json.loads((out / "meta.json").read_text())  # compact, padded: valid JSON
    assert written["ended"] == meta["ended"] == "done"
    assert written["bytes"] == (out / "capture.bin").stat().st_size


def test_a_failed_rewrite_of_the_host_times_keeps_the_rows_and_leaves_no_temporary(cli, tmp_path):
    out = tmp_path / "run"
    out.mkdir()
    code, err = _record_full(cli, out, 1000, {TEMP % "frames.csv"}, "--contacts", "1")
    assert code == 0, err
    meta = json.loads((out / "meta.json").read_text())
    assert meta["time_base"]["frames_csv"] == "the fit as each row was written"
    _all_kept(out, cli)


def test_nothing_written_at_all_is_one_line_naming_the_file(cli, tmp_path):
    out = tmp_path / "run"
    out.mkdir()
    code, err = _record_full(cli, out, 0, None)
    assert code == 5
    _one_line(err, f"{out / 'frames.csv'}: disk full", "nothing recorded")
    assert not list(out.glob("*.tmp"))


@pytest.mark.skipif(not os.path.exists("/dev/full"), reason="no /dev/full")
@pytest.mark.parametrize("name", ["capture.bin", "frames.csv"])
def test_a_real_enospc_from_dev_full(cli, tmp_path, name):
    """The appended files; meta.json's temporary has a name nobody can know beforehand."""
    out = tmp_path / "run"
    out.mkdir()
    (out / name).symlink_to("/dev/full")  # the kernel answers every write with ENOSPC
    code, _, err = cli(*RECORD, "--duration", "5", "-o", out)
    assert code == 5
    _one_line(err, f"{out / name}: disk full (No space left on device)")
    if name != "frames.csv":
        assert json.loads((out / "meta.json").read_text())["ended"] == "disk full"
    assert not list(out.glob("*.tmp"))


def test_a_real_file_size_limit_tears_nothing(cli, tmp_path):
    """RLIMIT_FSIZE: the kernel's own short write and EFBIG, in a subprocess."""
    resource = pytest.importorskip("resource")
    out = tmp_path / "run"

    def limit():
        resource.setrlimit(resource.RLIMIT_FSIZE, (150_000, resource.RLIM_INFINITY))

    r = subprocess.run([sys.executable, "-m", "tactile.cli.main", *RECORD, "--duration", "60",
                        "-o", str(out)], capture_output=True, text=True, preexec_fn=limit,
                       timeout=120)  # fmt: skip
    assert r.returncode == 5
    _one_line(r.stderr, "file too large", "kept")
    assert json.loads((out / "meta.json").read_text())["ended"] == "file too large"
    assert (out / "frames.csv").read_bytes().endswith(b"\n")  # on a whole row
    _all_kept(out, cli)


# --- a run cut short: killed, or written by a recorder that left a torn row -----------------


def _damaged(good_run, tmp_path, damage):
    out = tmp_path / "run"
    shutil.copytree(good_run, out)
    frames = out / "frames.csv"
    if damage == "torn row":
        frames.write_bytes(frames.read_bytes()[:-25])
    elif damage == "short frames.csv":  # killed between the capture's write and the rows'
        frames.write_text("".join(frames.read_text().splitlines(keepends=True)[:-5]))
        meta = json.loads((out / "meta.json").read_text())
        (out / "meta.json").write_text(json.dumps({**meta, "ended": "running"}))
    elif damage == "no frames.csv":
        frames.unlink()
    elif damage == "no meta.json":  # killed during the handshake
        (out / "meta.json").unlink()
    elif damage == "torn meta.json":
        (out / "meta.json").write_text((out / "meta.json").read_text()[:100])
    return out


@pytest.mark.parametrize(
    "damage, note",
    [
        ("torn row", "a torn last row"),
        ("short frames.csv", "5 readings after its last whole row rebuilt"),
        ("no frames.csv", "frames.csv: missing"),
        ("no meta.json", "meta.json: missing"),
        ("torn meta.json", "meta.json: unreadable"),
    ],
)
def test_a_run_cut_short_opens_from_capture_bin_with_a_note(cli, good_run, tmp_path, damage, note):
    out = _damaged(good_run, tmp_path, damage)
    rec = _all_kept(out, cli)
    assert any(note in n for n in rec.notes), rec.notes
    want = _readings(out)
    assert [m.fx / 1e6 for m in want] == list(rec.force_N[:, 0])
    code, _, err = cli("export", out, "--format", "parquet", "-o", tmp_path / "y.parquet")
    assert code == 0 and err.startswith("tactile export: note: ") and err.count("\n") == 1


def test_append_after_a_torn_row_starts_on_a_fresh_row(cli, good_run, tmp_path):
    out = _damaged(good_run, tmp_path, "torn row")
    code, _, err = cli(*RECORD, "--duration", "0.3", "-o", out, "--append")
    assert code == 0, err
    lines = (out / "frames.csv").read_text().splitlines()
    assert all(len(line.split(",")) == 15 for line in lines[1:])  # none glued
    rec = tactile.load_recording(out)
    want = _readings(out)
    assert len(rec) == len(want) and not rec.notes
    meta = rec.meta
    assert (
        meta["samples"] == len(lines) - 2 and meta["bytes"] == (out / "capture.bin").stat().st_size
    )


@pytest.mark.parametrize("name", ["capture.bin", "device.jsonl", "frames.csv"])
def test_a_fifo_among_a_runs_files_is_refused_at_once(tmp_path, name):
    """A FIFO where the writer appends would block until a reader came: exit 2 at once."""
    import os
    import subprocess
    import sys

    run_dir = tmp_path / "run"
    run_dir.mkdir()
    os.mkfifo(run_dir / name)
    proc = subprocess.run(
        [sys.executable, "-m", "tactile.cli.main", "record", "--port", "sim://press",
         "--duration", "0.2", "-o", str(run_dir), "--quiet", "--append"],
        capture_output=True, text=True, timeout=60,
    )  # fmt: skip
    assert proc.returncode == 2 and proc.stderr.count("\n") == 1, proc.stderr
    assert f"{name}: not a regular file" in proc.stderr
