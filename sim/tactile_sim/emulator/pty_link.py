"""The emulator's ``--link PATH``: a stable symlink to its current pty, and nothing else.

The link is replaced at every simulated reconnect (a new pty), so it must be a
path the emulator may overwrite.  Only an emulator's link is: nothing at the
path, or a symlink to a pseudo-terminal (``/dev/pts/N``; ``/dev/ttysN`` on
macOS), which a previous emulator left or this one made.  A regular file, a
directory or a symlink to anything else is refused with one line (exit 2), and
is never touched.  The new link is made under a temporary name and renamed
over the old one (no moment without a link); the temporary is removed on every
path out.
"""

import os
import re

from tactile_protocol.errors import InputError

_PTY = re.compile(r"^/dev/(pts/\d+|ttys\d+)$")


def is_ours(path):
    """True if ``path`` is a symlink to a pseudo-terminal (an emulator's link)."""
    try:
        return _PTY.match(os.readlink(path)) is not None
    except OSError:  # absent, or not a symlink
        return False


def _what(path):
    """What is at ``path`` (lstat: a symlink is not followed), in words; None if nothing."""
    if not os.path.lexists(path):
        return None
    if os.path.islink(path):
        return f"a symlink to {os.readlink(path)!r}, not to a pty"
    if os.path.isdir(path):
        return "a directory"
    if os.path.isfile(path):
        return "a file"
    return "not a symlink"


def check(path):
    """Raise InputError unless the emulator may make or replace a link at ``path``."""
    if is_ours(path):
        return
    what = _what(path)
    if what is not None:
        raise InputError(
            f"--link {path}: {what}; the emulator only replaces its own link to a pty "
            "(remove it or choose another path)"
        )
    parent = os.path.dirname(os.path.abspath(path))
    if not os.path.isdir(parent):
        raise InputError(f"--link {path}: no directory {parent}")


def point(path, target):
    """Make ``path`` a symlink to ``target`` (a pty), replacing only an emulator's link."""
    check(path)
    tmp = f"{path}.tmp{os.getpid()}"
    made = False
    try:
        if is_ours(tmp):  # left by a killed emulator that had the same pid
            os.unlink(tmp)
        os.symlink(target, tmp)
        made = True
        check(path)  # again, just before the rename: something may have appeared meanwhile
        os.replace(tmp, path)
        made = False
    except OSError as exc:
        raise InputError(f"--link {path}: cannot make the link: {exc.strerror}") from None
    finally:
        if made:
            os.unlink(tmp)


def remove(path):
    """Remove ``path`` if it is an emulator's link (at a disconnect and at exit)."""
    if is_ours(path):
        try:
            os.unlink(path)
        except FileNotFoundError:
            pass
