"""``tactile.files.writing`` and ``tactile.files.writing``: a whole file is replaced or
left as it was, only over a regular file, and a folder has one writer."""

import errno
import fcntl
import os
import stat
import subprocess
import sys

import pytest
from full_disk import TEMP, full_disk

from tactile.errors import HostFileError, InputError
from tactile.files import writing
from tactile.files.writing import PathRefused, WriteError, atomic_write, write_bytes


def _device(path):
    """A character device at ``path``: a node of its own (/dev/full's numbers) as root, else
    a symlink to /dev/null; either way nothing on the machine is at stake."""
    if os.geteuid() == 0:
        os.mknod(path, 0o600 | stat.S_IFCHR, os.makedev(1, 7))
    else:
        os.symlink("/dev/null", path)


def _entries(folder):
    return sorted(os.listdir(folder))


def test_a_new_file_and_a_replaced_one_keep_nothing_else(tmp_path):
    target = tmp_path / "out.csv"
    write_bytes(target, "a,b\n")
    assert target.read_text() == "a,b\n"
    target.chmod(0o640)
    write_bytes(target, b"c,d\n")
    assert target.read_bytes() == b"c,d\n"
    assert stat.S_IMODE(target.stat().st_mode) == 0o640  # the old file's permissions
    assert _entries(tmp_path) == ["out.csv"]


def test_a_symlink_to_a_file_is_followed_and_kept(tmp_path):
    (tmp_path / "real.txt").write_text("old")
    (tmp_path / "link.txt").symlink_to("real.txt")
    write_bytes(tmp_path / "link.txt", "new")
    assert (tmp_path / "link.txt").is_symlink() and (tmp_path / "real.txt").read_text() == "new"


@pytest.mark.parametrize("kind", ["directory", "FIFO", "device", "socket", "link to a device"])
def test_what_is_not_a_regular_file_is_refused_before_anything_is_written(tmp_path, kind):
    target = tmp_path / "out"
    if kind == "directory":
        target.mkdir()
    elif kind == "FIFO":
        os.mkfifo(target)
    elif kind == "device":
        _device(target)
    elif kind == "link to a device":
        _device(tmp_path / "node")
        target.symlink_to(tmp_path / "node")
    else:
        import socket

        sock = socket.socket(socket.AF_UNIX)
        sock.bind(str(target))
    before = os.lstat(target)
    with pytest.raises(PathRefused) as exc:
        write_bytes(target, b"x")
    assert exc.value.exit_code == 2 and str(exc.value).startswith(f"{target}: ")
    assert "not a regular file" in str(exc.value)
    after = os.lstat(target)
    assert (after.st_ino, after.st_mode) == (before.st_ino, before.st_mode)  # the same node
    assert not [n for n in os.listdir(tmp_path) if n.endswith(".tmp")]


def test_a_users_file_beside_the_target_is_never_the_temporary(tmp_path):
    """The old temporaries were NAME.tmp: a user's file of that name was replaced or deleted."""
    (tmp_path / "out.mcap.tmp").write_text("mine")
    (tmp_path / "meta.tmp").write_text("mine too")
    write_bytes(tmp_path / "out.mcap", b"x")
    with pytest.raises(ValueError), atomic_write(tmp_path / "meta.json") as fh:
        fh.write(b"half")
        raise ValueError("the writer failed")
    assert (tmp_path / "out.mcap.tmp").read_text() == "mine"
    assert (tmp_path / "meta.tmp").read_text() == "mine too"
    assert _entries(tmp_path) == ["meta.tmp", "out.mcap", "out.mcap.tmp"]


def test_a_full_disk_is_exit_5_naming_the_file_and_the_old_file_stays(tmp_path):
    target = tmp_path / "out.parquet"
    target.write_bytes(b"old")
    with full_disk(tmp_path, 10, {TEMP % "out.parquet"}) as disk:
        with pytest.raises(WriteError) as exc:
            write_bytes(target, b"x" * 100)
    assert disk.hits
    assert exc.value.exit_code == 5 and isinstance(exc.value, HostFileError | OSError)
    assert exc.value.errno == errno.ENOSPC
    assert str(exc.value) == (
        f"{target}: cannot write: No space left on device (the file is unchanged)"
    )
    assert target.read_bytes() == b"old" and _entries(tmp_path) == ["out.parquet"]


def test_a_missing_folder_is_exit_2(tmp_path):
    with pytest.raises(PathRefused) as exc:
        write_bytes(tmp_path / "no" / "x.csv", "x")
    assert exc.value.exit_code == 2 and "no directory" in str(exc.value)
    assert isinstance(exc.value, InputError)


# --- one writer per folder ----------------------------------------------------------------


def _flock(path):
    """Lock ``path`` as another writer would (its own open file description)."""
    fd = os.open(path, os.O_RDONLY)
    fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    return fd


def test_a_folder_another_holds_is_refused_and_left_alone(tmp_path):
    run = tmp_path / "run"
    run.mkdir()
    fd = _flock(run)
    try:
        with pytest.raises(writing.Busy) as exc:
            writing.hold(run, create=True)
        assert exc.value.exit_code == 5 and str(exc.value).startswith(f"{run}: another tactile")
    finally:
        os.close(fd)
    with writing.hold(run):  # free again
        pass
    assert run.is_dir() and _entries(run) == []  # not made by the lock: kept


def test_a_process_holds_its_folder_again_and_the_last_release_frees_it(tmp_path):
    run = tmp_path / "run"
    outer = writing.hold(run, create=True)
    inner = writing.hold(run, create=True)
    inner.release()
    inner.release()  # a second release of one hold changes nothing
    with pytest.raises(BlockingIOError):
        os.close(_flock(run))  # still held by ``outer``
    (run / "capture.bin").write_bytes(b"x")
    outer.release()
    os.close(_flock(run))  # free
    assert _entries(run) == ["capture.bin"]  # a folder with files is kept


def test_the_folders_a_lock_made_go_when_they_are_left_empty(tmp_path):
    with writing.hold(tmp_path / "a" / "b" / "run", create=True):
        assert (tmp_path / "a" / "b" / "run").is_dir()
    assert _entries(tmp_path) == []


def test_another_process_is_refused_while_this_one_holds_the_folder(tmp_path):
    run = tmp_path / "run"
    code = (
        "import sys\n"
        "from tactile.files import writing\n"
        "try:\n"
        f"    writing.hold({str(run)!r}, create=True)\n"
        "except writing.Busy as exc:\n"
        "    sys.exit(exc.exit_code)\n"
    )
    with writing.hold(run, create=True):
        held = subprocess.run([sys.executable, "-c", code], timeout=60)
    free = subprocess.run([sys.executable, "-c", code], timeout=60)
    assert (held.returncode, free.returncode) == (5, 0)


def test_where_a_folder_takes_no_flock_a_lock_file_inside_it_does(tmp_path, monkeypatch):
    """Some network file systems answer flock on a folder with EBADF."""
    real = fcntl.flock

    def flock(fd, op):
        if stat.S_ISDIR(os.fstat(fd).st_mode):
            raise OSError(errno.EBADF, os.strerror(errno.EBADF))
        return real(fd, op)

    monkeypatch.setattr(writing.fcntl, "flock", flock)
    run = tmp_path / "run"
    with writing.hold(run, create=True):
        assert _entries(run) == [writing.LOCK_FILE]
        fd = os.open(run / writing.LOCK_FILE, os.O_RDONLY)
        with pytest.raises(BlockingIOError):  # another writer's lock on it is refused
            real(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        os.close(fd)
    assert _entries(tmp_path) == []  # the lock file and the folder it made are gone
