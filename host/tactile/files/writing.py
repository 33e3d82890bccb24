"""Files the host writes: whole files never half written, and one writer per folder.

**Whole files**: never half written, and never over what is not a file.

``atomic_write(path)`` is the one way the host writes a whole file (an export, meta.json,
frames.csv's final rewrite, contacts.csv and probes.csv, a figure, a table).  Files that
grow as data arrive (capture.bin, frames.csv while recording) are appended, not here.

- The target is a new file in an existing directory, or a regular file; a symlink is
  followed (the file it names is replaced and the link kept).  A directory, a device
  (``/dev/null`` and ``/dev/full`` too), a FIFO or a socket is refused before anything is
  written: ``PathRefused``, exit 2.  ``check_target`` makes the same check alone, so a
  command refuses a bad output before its work.
- The bytes go to a temporary beside the target, ``.NAME.XXXXXXXX.tmp`` (16 random hex
  digits), created exclusively (``O_EXCL``): it never names, replaces or deletes a user's
  file.  It is flushed and fsynced, given the old file's permissions, renamed over the
  target, and the directory is fsynced where the system allows it.
- Whatever goes wrong, the temporary is removed and the target is as it was.  An
  ``OSError`` becomes ``WriteError`` (exit 5: a full disk, a quota, an I/O error, a
  read-only file system), one line naming the path; a directory that refuses a new file
  (no permission, gone) is ``PathRefused`` (exit 2).  Both are ``OSError``\\ s too, so code
  that treats a failed write as an ``OSError`` keeps working; other exceptions pass as
  they are, after the clean-up.

**One writer per folder**: an advisory ``fcntl.flock`` on the folder itself.

``hold(path, create=False)`` locks the folder ``path`` (a recording) for this process, or
raises ``Busy`` (exit 5) at once when another process holds it, having written nothing:

- with ``create`` the folder and any missing parents are made first (``mkdir``, then the
  lock, then the caller looks inside), so two writers racing into one new folder find one
  lock: one writes, the other is refused;
- the lock is on the folder's own descriptor, so it leaves no file behind, and it goes
  with the process: a writer that is killed frees it;
- once locked, the folder at ``path`` must still be the one locked (a holder that gave up
  may have removed it); if not, the lock is taken again on the folder now there;
- a process that already holds the folder holds it again (a count), so a command may lock
  its run for its whole length and the ``Recording`` inside it lock it too;
- ``release`` of the last hold removes the folders it made when they are empty (a run
  that received nothing leaves nothing), then unlocks.

Where the file system offers ``flock`` on no folder (``EBADF`` on some network file
systems), the lock is a file ``.tactile.lock`` inside it instead.  An advisory lock binds
only those that take it: every tactile writer of a run does.
"""

import contextlib
import errno
import fcntl
import os
import secrets
import stat

from tactile.errors import HostFileError, InputError

__all__ = [
    "PathRefused",
    "WriteError",
    "atomic_write",
    "check_target",
    "write_bytes",
    "Busy",
    "FolderLock",
    "hold",
]

# A new file refused for one of these is the path's fault (exit 2), not the disk's.
PATH_ERRNOS = frozenset(
    (errno.EACCES, errno.EPERM, errno.ENOENT, errno.ENOTDIR, errno.EISDIR, errno.ELOOP)
    + (errno.ENAMETOOLONG,)
)
NAME_KEPT = 200  # characters of the target's name in the temporary's (a name has 255)
KINDS = (
    (stat.S_ISDIR, "a directory"),
    (stat.S_ISCHR, "a device"),
    (stat.S_ISBLK, "a device"),
    (stat.S_ISFIFO, "a FIFO"),
    (stat.S_ISSOCK, "a socket"),
)


class PathRefused(InputError, OSError):
    """The target is not a file the host may write (exit 2); ``errno`` as the system said."""

    def __init__(self, path, why, code=None):
        super().__init__(f"{path}: {why}")
        self.errno, self.strerror = code, why

    def __str__(self):
        return str(self.args[0])


class WriteError(HostFileError, OSError):
    """Writing ``path`` failed (exit 5); ``errno`` and ``strerror`` as the system said."""

    def __init__(self, path, exc, existed):
        why = exc.strerror or str(exc)
        kept = "the file is unchanged" if existed else "nothing written"
        super().__init__(f"{path}: cannot write: {why} ({kept})")
        self.errno, self.strerror, self.path = exc.errno, exc.strerror, str(path)

    def __str__(self):
        return str(self.args[0])


def _kind(mode):
    for test, name in KINDS:
        if test(mode):
            return name
    return None if stat.S_ISREG(mode) else "not a regular file"


def check_target(path):
    """The real path ``path`` names (symlinks followed), once it is known to be a regular
    file or a new name in an existing directory; ``PathRefused`` otherwise."""
    real = os.path.realpath(path)
    try:
        mode = os.stat(real).st_mode
    except FileNotFoundError:
        mode = None
    except OSError as exc:
        raise PathRefused(path, f"cannot write: {exc.strerror}", exc.errno) from None
    if mode is not None:
        kind = _kind(mode)
        if kind is not None:
            why = f"{kind}, not a regular file (an output is a new file or replaces one)"
            raise PathRefused(path, why)
        return real
    parent = os.path.dirname(real)
    if not os.path.isdir(parent):
        raise PathRefused(path, f"cannot write: no directory {parent}", errno.ENOENT)
    return real


def _open_temp(path, real, text, encoding, newline):
    """A new temporary beside ``real``, opened exclusively: (name, file)."""
    head, name = os.path.split(real)
    while True:
        tmp = os.path.join(head, f".{name[:NAME_KEPT]}.{secrets.token_hex(8)}.tmp")
        try:
            if text:
                return tmp, open(tmp, "x", encoding=encoding, newline=newline)
            return tmp, open(tmp, "xb")
        except FileExistsError:
            continue  # one chance in 2**64: draw again
        except OSError as exc:
            if exc.errno in PATH_ERRNOS:
                why = f"cannot write in {head}: {exc.strerror}"
                raise PathRefused(path, why, exc.errno) from None
            raise WriteError(path, exc, existed=os.path.exists(real)) from None


@contextlib.contextmanager
def atomic_write(path, text=False, encoding="utf-8", newline=None):
    """A file object to write ``path`` through; on leaving the block the target is
    replaced whole (module docstring), or left as it was when anything failed."""
    real = check_target(path)
    existed = os.path.exists(real)
    tmp, fh = _open_temp(path, real, text, encoding, newline)
    try:
        yield fh
        fh.flush()
        os.fsync(fh.fileno())
        _keep_mode(fh, real)
        fh.close()
        check_target(path)  # again, just before the rename: it may have changed meanwhile
        os.replace(tmp, real)
    except BaseException as exc:
        with contextlib.suppress(OSError):
            fh.close()  # (a flush that fails again is let go)
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        if isinstance(exc, OSError) and not isinstance(exc, HostFileError | InputError):
            raise WriteError(path, exc, existed) from None
        raise
    _sync_dir(os.path.dirname(real))


def write_bytes(path, data):
    """Replace ``path`` whole with ``data`` (bytes or str, UTF-8)."""
    text = isinstance(data, str)
    with atomic_write(path, text=text, newline="" if text else None) as fh:
        fh.write(data)


def _keep_mode(fh, real):
    """The replaced file's permission bits on the new one (a new file: the umask's)."""
    try:
        mode = stat.S_IMODE(os.stat(real).st_mode)
    except OSError:
        return
    with contextlib.suppress(OSError):  # not the owner: the umask's bits stay
        os.fchmod(fh.fileno(), mode)


def _sync_dir(directory):
    """fsync the directory so the rename survives a power cut, where the system allows."""
    try:
        fd = os.open(directory or ".", os.O_RDONLY | getattr(os, "O_DIRECTORY", 0))
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass  # not supported here (some file systems, Windows): the rename stands
    finally:
        os.close(fd)


LOCK_FILE = ".tactile.lock"
BUSY_ERRNOS = (errno.EWOULDBLOCK, errno.EAGAIN, errno.EACCES)
_HELD = {}  # (st_dev, st_ino) -> [FolderLock, count]: the folders this process holds


class Busy(HostFileError):
    """Another process holds the folder's lock (exit 5); nothing was written."""


def _refuse(path, exc, doing):
    cls = InputError if exc.errno in PATH_ERRNOS else HostFileError
    return cls(f"{path}: cannot {doing}: {exc.strerror}")


def _make(path):
    """Make ``path`` and its missing parents; the ones this call made, deepest first."""
    missing, p = [], os.path.abspath(path)
    while not os.path.lexists(p) and p != os.path.dirname(p):
        missing.append(p)
        p = os.path.dirname(p)
    made = []
    for d in reversed(missing):
        try:
            os.mkdir(d)
        except FileExistsError:
            continue  # another process made it: not ours to remove
        except OSError as exc:
            raise _refuse(path, exc, "create the folder") from None
        made.append(d)
    return made[::-1]


class FolderLock:
    """The lock on one folder; ``hold`` makes and takes it, ``release`` gives it back."""

    def __init__(self, path, create=False):
        self.path = os.fspath(path)
        self.create = create
        self.made = _make(path) if create else []  # folders this lock made, deepest first
        self.fd = None
        self.file = None  # the lock file's name where folders take no flock
        self.key = None

    def _open(self):
        try:
            return os.open(self.path, os.O_RDONLY | getattr(os, "O_DIRECTORY", 0))
        except OSError as exc:
            if exc.errno == errno.ENOTDIR:
                raise InputError(f"{self.path}: not a folder") from None
            raise _refuse(self.path, exc, "open the folder") from None

    def _flock(self, fd):
        """Lock the folder's ``fd``, else its lock file: the fd that holds the lock (the
        caller closes ``fd`` if it is not that one)."""
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            return fd
        except OSError as exc:
            if exc.errno in BUSY_ERRNOS:
                raise self._busy() from None
            if exc.errno not in (errno.EBADF, errno.ENOLCK, errno.EINVAL, errno.EOPNOTSUPP):
                raise _refuse(self.path, exc, "lock the folder") from None
        self.file = os.path.join(self.path, LOCK_FILE)  # no flock on a folder here
        try:
            lock_fd = os.open(self.file, os.O_RDWR | os.O_CREAT, 0o644)
        except OSError as exc:
            raise _refuse(self.path, exc, "make its lock file") from None
        try:
            fcntl.flock(lock_fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError as exc:
            os.close(lock_fd)
            if exc.errno in BUSY_ERRNOS:
                raise self._busy() from None
            raise _refuse(self.path, exc, "lock the folder") from None
        return lock_fd

    def _busy(self):
        return Busy(
            f"{self.path}: another tactile process is writing there (a record or an export"
            " holds its lock); nothing was written"
        )

    def acquire(self):
        """Take the lock (or join this process's hold); ``Busy`` when another has it."""
        while True:
            fd = self._open()
            key = _key(os.fstat(fd))
            if key in _HELD:
                os.close(fd)
                _HELD[key][1] += 1
                self.key = key
                return self
            try:
                locked = self._flock(fd)
            except BaseException:
                os.close(fd)
                raise
            if locked != fd:
                os.close(fd)  # the lock file holds the lock
                fd = locked
            if self._still_there(key):
                self.fd, self.key = fd, key
                _HELD[key] = [self, 1]
                return self
            os.close(fd)  # the folder was removed (or replaced) while we waited: again
            if self.create:
                self.made = _make(self.path) + self.made

    def _still_there(self, key):
        try:
            return _key(os.stat(self.path)) == key
        except OSError:
            return False

    def release(self):
        """Give back one hold; the last one removes the empty folders it made, and unlocks."""
        key, self.key = self.key, None  # a second release of this hold does nothing
        held = _HELD.get(key)
        if held is None:
            return
        held[1] -= 1
        if held[1] > 0:
            return
        del _HELD[key]
        owner = held[0]
        owner._remove_made()
        with contextlib.suppress(OSError):
            os.close(owner.fd)

    def _remove_made(self):
        if not self.made:
            return
        if self.file is not None and os.listdir(self.path) == [LOCK_FILE]:
            with contextlib.suppress(OSError):
                os.unlink(self.file)
        for d in self.made:
            try:
                os.rmdir(d)
            except OSError:
                return  # not empty (or not ours any more): kept

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.release()


def _key(st):
    return st.st_dev, st.st_ino


def hold(path, create=False):
    """Lock the folder ``path`` (made first with ``create``): a ``FolderLock``, also a
    context manager that releases it."""
    return FolderLock(path, create).acquire()  # refused: what it made stays (the holder's)
