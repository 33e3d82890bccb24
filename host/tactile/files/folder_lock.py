"""One writer per folder: an advisory ``fcntl.flock`` on the folder itself.

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

from tactile.errors import HostFileError, InputError

__all__ = ["Busy", "FolderLock", "hold"]

LOCK_FILE = ".tactile.lock"
BUSY_ERRNOS = (errno.EWOULDBLOCK, errno.EAGAIN, errno.EACCES)
PATH_ERRNOS = (errno.EACCES, errno.EPERM, errno.ENOENT, errno.ENOTDIR, errno.ENAMETOOLONG)
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
