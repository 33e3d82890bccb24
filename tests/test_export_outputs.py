"""Where ``tactile export -o`` may write: a new or a regular file, never a file of the run
being exported, a device, a FIFO or a directory; a full disk is exit 5; an export into a
run another writer holds is refused."""

import fcntl
import os
import shutil
import stat
import subprocess
import sys

import pytest
from full_disk import TEMP, full_disk

pytest.importorskip("pyarrow.parquet", reason="the 'parquet' extra (pyarrow) is missing")

PARQUET = ("--format", "parquet")


@pytest.fixture
def run(recorded_run, tmp_path):
    """A copy of the shared recording, which these tests may try to damage."""
    out = tmp_path / "run"
    shutil.copytree(recorded_run, out)
    return out


def _snapshot(folder):
    """Every entry of ``folder`` (recursively): its kind and bytes."""
    out = {}
    for root, dirs, files in os.walk(folder):
        for name in dirs + files:
            path = os.path.join(root, name)
            st = os.lstat(path)
            data = open(path, "rb").read() if stat.S_ISREG(st.st_mode) else None
            out[os.path.relpath(path, folder)] = (stat.S_IFMT(st.st_mode), st.st_ino, data)
    return out


def _one_line(code, err, want):
    assert code == want and err.count("\n") == 1 and "Traceback" not in err, (code, err)


@pytest.mark.parametrize(
    "name", ["capture.bin", "frames.csv", "meta.json", "device.jsonl", "contacts.csv"]
)
@pytest.mark.parametrize("fmt", ["mcap", "parquet"])
def test_a_file_of_the_run_is_never_written_over(cli, run, name, fmt):
    if fmt == "mcap":
        pytest.importorskip("mcap_ros2", reason="the 'export' extra is missing")
    before = _snapshot(run)
    code, out, err = cli("export", run, "--format", fmt, "-o", run / name)
    _one_line(code, err, 2)
    assert f"{run / name}: a file of the run being exported" in err and out == ""
    assert _snapshot(run) == before  # every reading still there, nothing added


def test_a_link_to_a_file_of_the_run_is_that_file(cli, run, tmp_path):
    (tmp_path / "out.parquet").symlink_to(run / "capture.bin")
    before = _snapshot(run)
    code, _, err = cli("export", run, *PARQUET, "-o", tmp_path / "out.parquet")
    _one_line(code, err, 2)
    assert "a file of the run" in err and _snapshot(run) == before
    assert (tmp_path / "out.parquet").is_symlink()


def test_an_earlier_export_in_the_run_is_replaced_and_nothing_else_is_left(cli, run):
    for _ in range(2):
        code, _, err = cli("export", run, *PARQUET)
        assert code == 0, err
    names = sorted(p.name for p in run.iterdir())
    assert names == sorted(
        ["capture.bin", "contacts.csv", "device.jsonl", "frames.csv", "meta.json"]
        + ["run.parquet", "run.contacts.parquet"]
    )


@pytest.mark.parametrize("kind", ["FIFO", "device", "link to /dev/null"])
def test_a_fifo_or_a_device_is_refused_and_stays_what_it_was(cli, run, tmp_path, kind):
    target = tmp_path / "out"
    if kind == "FIFO":
        os.mkfifo(target)
    elif kind == "device" and os.geteuid() == 0:
        os.mknod(target, 0o600 | stat.S_IFCHR, os.makedev(1, 7))  # /dev/full's numbers
    elif kind == "device":
        pytest.skip("only root makes a device node")
    else:
        target.symlink_to("/dev/null")
    before = os.lstat(target)
    code, _, err = cli("export", run, *PARQUET, "-o", target)
    _one_line(code, err, 2)
    assert "not a regular file" in err
    after = os.lstat(target)
    assert (after.st_mode, after.st_ino, after.st_rdev) == (
        before.st_mode,
        before.st_ino,
        before.st_rdev,
    )
    assert sorted(os.listdir(tmp_path)) == ["out", "run"]


def test_a_directory_is_refused_and_a_users_name_tmp_is_untouched(cli, run, tmp_path):
    (tmp_path / "adir").mkdir()
    (tmp_path / "adir.tmp").write_text("the user's own file")
    code, _, err = cli("export", run, *PARQUET, "-o", tmp_path / "adir")
    _one_line(code, err, 2)
    assert f"{tmp_path / 'adir'}: a directory" in err and "adir.tmp" not in err
    assert (tmp_path / "adir.tmp").read_text() == "the user's own file"
    assert sorted(os.listdir(tmp_path)) == ["adir", "adir.tmp", "run"]


@pytest.mark.parametrize("fmt", ["mcap", "parquet"])
def test_a_full_disk_is_exit_5_and_the_old_export_stays(cli, run, tmp_path, fmt):
    if fmt == "mcap":
        pytest.importorskip("mcap_ros2", reason="the 'export' extra is missing")
    out = tmp_path / f"x.{fmt}"
    out.write_bytes(b"an earlier export")
    with full_disk(tmp_path, 1000, {TEMP % out.name}) as disk:
        code, stdout, err = cli("export", run, "--format", fmt, "-o", out)
    assert disk.hits
    _one_line(code, err, 5)
    assert f"{out}: cannot write: No space left on device (the file is unchanged)" in err
    assert stdout == "" and out.read_bytes() == b"an earlier export"
    assert sorted(os.listdir(tmp_path)) == ["run", out.name]


def test_the_kernels_file_size_limit_is_exit_5(run, tmp_path):
    """RLIMIT_FSIZE: the kernel's own EFBIG, in a subprocess (Python ignores SIGXFSZ)."""
    resource = pytest.importorskip("resource")

    def limit():
        resource.setrlimit(resource.RLIMIT_FSIZE, (4096, resource.RLIM_INFINITY))

    out = tmp_path / "big.parquet"
    r = subprocess.run([sys.executable, "-m", "tactile.cli.main", "export", str(run), *PARQUET,
                        "-o", str(out)], capture_output=True, text=True, preexec_fn=limit,
                       timeout=120)  # fmt: skip
    _one_line(r.returncode, r.stderr, 5)
    assert f"{out}: cannot write: File too large (nothing written)" in r.stderr
    assert sorted(os.listdir(tmp_path)) == ["run"]


def test_an_export_into_a_run_another_writer_holds_is_refused(cli, run, tmp_path):
    """The test holds the run's lock as a ``record`` would: the export into it is refused at
    once; one elsewhere (it only reads the run) goes ahead."""
    fd = os.open(run, os.O_RDONLY)
    fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    try:
        before = _snapshot(run)
        code, _, err = cli("export", run, *PARQUET)
        _one_line(code, err, 5)
        assert "another tactile process is writing there" in err and _snapshot(run) == before
        code, _, err = cli("export", run, *PARQUET, "-o", tmp_path / "elsewhere.parquet")
        assert code == 0, err
    finally:
        os.close(fd)
    code, _, err = cli("export", run, *PARQUET)
    assert code == 0 and (run / "run.parquet").is_file(), err
