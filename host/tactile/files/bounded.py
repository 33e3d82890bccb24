"""Opening a file the host does not trust: a regular file, read within a stated bound.

Every reader of a user-supplied path goes through here (CSV through ``tactile.files.tabular``,
calibrations, ``meta.json``, scenes, a recording's capture):

- ``open_regular(path, max_bytes, what)``: a binary handle, opened non-blocking so that a
  FIFO is refused at once instead of waiting for a writer; a device (``/dev/zero``), FIFO,
  socket or directory is refused, and so is a file larger than ``max_bytes``;
- ``read_bytes``: the whole file, never more than ``max_bytes`` read even if it grows;
- ``parse_json`` / ``read_json``: JSON with no NaN or Infinity, integers of at most
  ``MAX_INT_DIGITS`` digits and nesting at most ``MAX_DEPTH`` deep, so that neither
  Python's integer limit nor its recursion limit reaches the user as a traceback.

Every refusal is an ``InputError`` (exit 2) of one line naming the file (and line and
column where there is one); ``Missing`` (an ``InputError``) is a path that does not exist.
"""

import json
import os
import re
import stat

from tactile.errors import InputError, where

__all__ = ["MAX_DEPTH", "MAX_INT_DIGITS", "Missing", "open_regular", "parse_json", "read_bytes"]

MAX_DEPTH = 64  # nesting of JSON arrays and objects
MAX_INT_DIGITS = 400  # a longer integer is beyond any float (1.8e308 has 309 digits)


class Missing(InputError):
    """The path does not exist (a reader may treat that as 'none yet')."""


def size_text(n_bytes):
    """64 MiB, 16 GiB, 1024 KiB: a limit for a message."""
    for unit, size in (("GiB", 2**30), ("MiB", 2**20), ("KiB", 2**10)):
        if n_bytes >= size:
            return f"{n_bytes // size} {unit}"
    return f"{n_bytes} bytes"


def too_big(path, max_bytes, hint="the limit for one file"):
    return f"{path}: larger than {size_text(max_bytes)} ({hint})"


def open_regular(path, max_bytes=None, what="a file", hint="the limit for one file"):
    """A binary handle on the regular file ``path`` of at most ``max_bytes`` (None: any
    size, for a reader that streams), or ``InputError``; ``what`` names the kind of file in
    the message ("a CSV"), ``hint`` follows the size limit."""
    try:
        fd = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0))
    except FileNotFoundError:
        raise Missing(f"{path}: cannot read: No such file or directory") from None
    except OSError as exc:
        raise InputError(f"{path}: cannot read: {exc.strerror}") from None
    try:
        info = os.fstat(fd)
        if not stat.S_ISREG(info.st_mode):
            kind = "a directory" if stat.S_ISDIR(info.st_mode) else "not a regular file"
            raise InputError(f"{path}: {kind} ({what} must be a regular file)")
        if max_bytes is not None and info.st_size > max_bytes:
            raise InputError(too_big(path, max_bytes, hint))
    except BaseException:
        os.close(fd)
        raise
    return os.fdopen(fd, "rb")


def read_bytes(path, max_bytes, what="a file", hint="the limit for one file"):
    """The bytes of the regular file ``path``: at most ``max_bytes`` are read, even from a
    file that grows while it is read."""
    with open_regular(path, max_bytes, what, hint) as fh:
        try:
            data = fh.read(max_bytes + 1)
        except OSError as exc:
            raise InputError(f"{path}: cannot read: {exc.strerror}") from None
    if len(data) > max_bytes:
        raise InputError(too_big(path, max_bytes, hint))
    return data


def read_json(path, max_bytes, what="a JSON file", **hooks):
    """``parse_json`` of the bytes of ``path`` (``read_bytes``)."""
    return parse_json(path, read_bytes(path, max_bytes, what), **hooks)


def parse_json(path, data, **hooks):
    """The JSON document in ``data`` (bytes, UTF-8 with or without BOM) read from ``path``.

    NaN and Infinity are refused, and so are an integer of more than ``MAX_INT_DIGITS``
    digits (unless ``hooks``, passed to ``json.loads``, give their own ``parse_int``) and
    nesting deeper than ``MAX_DEPTH``."""
    try:
        text = data.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        line = data[: exc.start].count(b"\n") + 1
        raise InputError(
            f"{where(path, line)}: not UTF-8 text (byte 0x{data[exc.start]:02x})"
        ) from None
    hooks = {"parse_constant": _no_constant(path), "parse_int": _int(path, text), **hooks}
    try:
        doc = json.loads(text, **hooks)
    except json.JSONDecodeError as exc:
        raise InputError(
            f"{where(path, exc.lineno)}: column {exc.colno}: not valid JSON: {exc.msg}"
        ) from None
    except RecursionError:  # nested deeper than Python recurses
        raise InputError(_too_deep(path)) from None
    if not _shallow(doc):
        raise InputError(_too_deep(path))
    return doc


def _too_deep(path):
    return f"{path}: JSON nested more than {MAX_DEPTH} deep (the limit)"


def _no_constant(path):
    def refuse(name):
        raise InputError(f"{path}: {name} is not a finite number (JSON's NaN and Infinity)")

    return refuse


def _int(path, text):
    def parse(digits):
        if len(digits.lstrip("-")) <= MAX_INT_DIGITS:
            return int(digits)
        found = re.search(rf"\d{{{MAX_INT_DIGITS + 1},}}", text, re.ASCII)
        start = found.start() if found else 0
        line = text.count("\n", 0, start) + 1
        column = start - text.rfind("\n", 0, start)
        raise InputError(
            f"{where(path, line)}: column {column}: an integer of {len(digits.lstrip('-')):,}"
            f" digits (at most {MAX_INT_DIGITS}: a longer one is beyond any float)"
        )

    return parse


def _shallow(doc):
    """True if ``doc`` nests arrays and objects at most ``MAX_DEPTH`` deep (no recursion)."""
    stack = [(doc, 0)]
    while stack:
        value, depth = stack.pop()
        if isinstance(value, dict):
            value = value.values()
        elif not isinstance(value, list):
            continue
        if depth == MAX_DEPTH:
            return False
        stack.extend((v, depth + 1) for v in value)
    return True
