"""The EP2 contacts CSV contract (issue 3), read in bounded memory (issue 13).

Header row; columns ``x,y,z,nx,ny,nz`` required, ``finger`` and ``patch`` optional, other
columns ignored, ``#`` comment lines allowed; any consistent length unit.  Rows are grouped
by ``patch`` (first-appearance order; no column means one patch) and kept in file order
within a patch, which is the sweep order the discontinuity check relies on.  A patch's
rows may be scattered through the file.

``ContactsFile(path)`` reads the file twice.  The first pass checks all of it (every
error ``read_contacts`` ever gave, before any patch is used) and keeps, per patch id, a
code, a row count and the box of its points: a few hundred bytes a patch, nothing a row.
Iterating then reads it again in blocks and yields each patch as soon as it and every
patch before it are complete, so memory holds the patches under way, not the file.
``read_contacts(path)`` is the list of them, within ``tabular``'s limits for one file.
"""

from dataclasses import dataclass

import numpy as np

from tactile.ep2 import patch_input
from tactile.errors import InputError, where
from tactile.files import tabular
from tactile.files.csv_dialect import show
from tactile.files.tabular import CsvBlocks

REQUIRED = ("x", "y", "z", "nx", "ny", "nz")
MAX_BYTES = 16 * 2**30  # a streamed file (`ep2 analyze`)
MAX_ROWS = 200_000_000
MAX_PATCHES = 2_000_000  # ~250 bytes a patch are kept between the passes
MAX_ID_CHARS = 64 * 2**20  # the distinct patch ids, all together
MAX_OPEN_ROWS = tabular.MAX_ROWS  # rows of the patches under way at any line
# |coordinate| outside these (0 aside) is needed for a spread ``spread_problem`` refuses:
# above 1e300 a side reaches 5e299, under 1e-300 two floats differ by that only below 9e-285
ODD_COORDINATE = (1e-280, 1e299)


@dataclass
class Contacts:
    """One patch's contacts: points and normals (n, 3), finger labels or None, source lines."""

    patch: str | None
    points: np.ndarray
    normals: np.ndarray
    finger: list | None
    lines: list


def read_contacts(path):
    """Read ``path`` into a list of ``Contacts`` (one per patch)."""
    rows = tabular.MAX_ROWS
    return list(ContactsFile(path, max_bytes=tabular.MAX_FILE_BYTES, max_rows=rows, max_open=rows))


class ContactsFile:
    """A contacts CSV checked whole (``InputError`` naming file, line, column), whose
    patches are read again, in blocks, each time it is iterated.  ``len()`` is the number
    of patches.  Limits: bytes and rows of the file, rows of the patches under way;
    ``progress(bytes checked)`` is called as the checking pass goes."""

    def __init__(
        self, path, *, max_bytes=MAX_BYTES, max_rows=MAX_ROWS, max_open=None, progress=None
    ):
        self.path, self.limits = path, dict(max_bytes=max_bytes, max_rows=max_rows)
        self._stamp = _stamp(path)
        self._scan = _Scan(path)
        blocks = self._blocks()
        for block in blocks:
            self._scan.add(block, blocks.texts)
            if progress is not None:
                progress(blocks.bytes_read)
        self._scan.finish(blocks, MAX_OPEN_ROWS if max_open is None else max_open)
        self._check_extent()
        self._scan.first = self._scan.last = None  # the second pass needs codes and counts

    def __len__(self):
        return len(self._scan.count)

    def __iter__(self):
        if _stamp(self.path) != self._stamp:
            raise InputError(_changed(self.path))
        return _Gather(self).patches()

    def _blocks(self):
        return CsvBlocks(self.path, REQUIRED, ("finger", "patch"), **self.limits)

    def _check_extent(self):
        """Refuse a patch whose coordinates EP2 cannot represent (``spread_problem``), at the row
        that sets its spread; the first such patch in file order.  Only a patch with a
        coordinate near the ends of the float range can have one: those are read again."""
        odd = self._scan.odd
        for code, g in enumerate(self if odd else ()):
            problem = patch_input.spread_problem(g.points) if code in odd else None
            if problem is not None:
                row, axis, why = problem
                name = "" if g.patch is None else f"patch {show(g.patch)}: "
                raise InputError(
                    f"{where(self.path, g.lines[row], patch_input.AXES[axis])}: {name}{why}"
                )
            if code == max(odd):
                return


class _Scan:
    """The first pass: per patch (code = order of first appearance) its row count, first
    and last line; the patches with a coordinate where ``spread_problem`` may refuse them; the
    first zero-length normal."""

    def __init__(self, path):
        self.path = path
        self.code_of = {}  # patch id -> code ({None: 0} without a patch column)
        self.id_chars = 0
        self.count = np.zeros(0, np.int64)
        self.first = np.zeros(0, np.int64)  # line of the first row
        self.last = np.zeros(0, np.int64)  # line of the last row
        self.odd = set()  # patches with a coordinate beyond ODD_COORDINATE
        self.zero_normal = None  # line of the first zero-length normal

    def add(self, block, texts):
        if self.zero_normal is None:
            bad = np.flatnonzero(~(np.max(np.abs(block.numbers[:, 3:]), axis=1) > 0))
            self.zero_normal = int(block.lines[bad[0]]) if bad.size else None
        codes = self.codes(block, "patch" in texts)
        order, starts, uc = sorted_groups(codes)
        lines = block.lines[order]
        new = self.count[uc] == 0
        self.first[uc[new]] = lines[starts[new]]
        self.last[uc] = lines[np.append(starts[1:], len(order)) - 1]
        self.count[uc] += np.diff(np.append(starts, len(order)))
        a = np.abs(block.numbers[:, :3])
        odd = ((a > ODD_COORDINATE[1]) | ((a < ODD_COORDINATE[0]) & (a > 0))).any(axis=1)
        self.odd.update(codes[odd].tolist())

    def codes(self, block, has_patch):
        """Each row's patch code, new ids coded in order of first appearance."""
        n = len(block.lines)
        if not has_patch:
            if not self.code_of:
                self._new([None])
            return np.zeros(n, np.int64)
        ids = block.texts["patch"]
        fresh = [p for p in dict.fromkeys(ids) if p not in self.code_of]
        if fresh:
            self._within_limits(fresh, block)
            self._new(fresh)
        return np.fromiter(map(self.code_of.__getitem__, ids), np.int64, n)

    def _within_limits(self, fresh, block):
        """``InputError`` at the first row of the first new id past a limit."""
        chars = self.id_chars + np.cumsum([len(p) for p in fresh])
        if len(self.code_of) + len(fresh) > MAX_PATCHES:
            i, why = MAX_PATCHES - len(self.code_of), f"more than {MAX_PATCHES:,} patches"
        elif chars[-1] > MAX_ID_CHARS:
            i = int(np.argmax(chars > MAX_ID_CHARS))
            why = f"the patch ids hold more than {MAX_ID_CHARS:,} characters in all"
        else:
            self.id_chars = int(chars[-1])
            return
        line = block.lines[np.flatnonzero(block.texts["patch"] == fresh[i])[0]]
        raise InputError(
            f"{where(self.path, line, 'patch')}: {why} (the limit for one file; split it)"
        )

    def _new(self, fresh):
        """Code ids never seen before; the per-patch arrays grow by doubling."""
        old = len(self.code_of)
        self.code_of.update(zip(fresh, range(old, old + len(fresh))))
        n = len(self.code_of)
        if n > len(self.count):
            size = max(n, 2 * len(self.count))
            for name in ("count", "first", "last"):
                grown = np.zeros(size, np.int64)
                grown[:old] = getattr(self, name)[:old]
                setattr(self, name, grown)

    def finish(self, blocks, max_open):
        """Trim to the patches seen; the checks that need the whole file."""
        n = len(self.code_of)
        self.count = self.count[:n].copy()
        self.first, self.last = self.first[:n], self.last[:n]
        if self.zero_normal is not None:
            raise InputError(
                f"{where(self.path, self.zero_normal, 'nx')}: zero-length normal (nx,ny,nz)"
            )
        self._check_patch_rows("patch" in blocks.texts)
        self._check_open_rows("patch" in blocks.texts, max_open)

    def _check_patch_rows(self, has_patch):
        """No patch over ``patch_input.MAX_ROWS`` contacts: refused at its first line, before
        any of its rows is gathered."""
        over = np.flatnonzero(self.count > patch_input.MAX_ROWS)
        if not over.size:
            return
        k = int(over[0])
        name = next(p for p, c in self.code_of.items() if c == k)
        at = where(self.path, self.first[k], "patch" if has_patch else None)
        label = f"patch {show(name)}: " if has_patch else ""
        raise InputError(f"{at}: {label}{patch_input.too_many_rows(int(self.count[k]))}")

    def _check_open_rows(self, has_patch, max_open):
        """At most ``max_open`` rows wait at any line: a patch's rows, counted from its
        first line, wait until it and every patch before it are complete."""
        done = np.maximum.accumulate(self.last)  # the line at which each is given out
        # the most rows wait just after a patch's first line: every row of that patch and
        # of those before it, but those already given out (``first`` and ``done`` both grow)
        cum = np.cumsum(self.count)
        out = np.searchsorted(done, self.first)  # patches given out before each first line
        held = cum - np.where(out > 0, cum[np.maximum(out, 1) - 1], 0)
        over = np.flatnonzero(held > max_open)
        if not over.size:
            return
        k = int(out[over[0]])  # the first patch not given out then: everything waits for it
        if not has_patch:
            raise InputError(
                f"{where(self.path, self.first[0])}: more than {max_open:,} rows in"
                " one patch (the file has no patch column: add one, or split the file)"
            )
        name = next(p for p, c in self.code_of.items() if c == k)
        raise InputError(
            f"{where(self.path, self.first[k], 'patch')}: patch {show(name)} ends only at line"
            f" {self.last[k]}, and more than {max_open:,} rows would wait for it (the"
            " limit): sort the file by patch, or split it"
        )


class _Gather:
    """The second pass: rows into per-patch pieces; a patch given out when it and every
    patch before it are complete."""

    def __init__(self, source):
        self.source, self.scan = source, source._scan
        self.missing = self.scan.count.copy()
        self.pieces = {}  # code -> [Block-like pieces]
        self.ready = {}  # code -> Contacts
        self.next = 0

    def patches(self):
        blocks = self.source._blocks()
        for block in blocks:
            has_patch = "patch" in blocks.texts
            codes = self._codes(block, has_patch)
            order, starts, uc = sorted_groups(codes)
            ends = np.append(starts[1:], len(order))
            for code, a, b in zip(uc.tolist(), starts.tolist(), ends.tolist()):
                self._piece(code, block, order[a:b], has_patch, "finger" in blocks.texts)
            while self.next in self.ready:
                yield self.ready.pop(self.next)
                self.next += 1
        if self.next != len(self.missing):
            raise InputError(_changed(self.source.path))

    def _codes(self, block, has_patch):
        if not has_patch:
            return np.zeros(len(block.lines), np.int64)
        try:
            return np.fromiter(map(self.scan.code_of.__getitem__, block.texts["patch"]), np.int64)
        except KeyError:
            raise InputError(_changed(self.source.path)) from None

    def _piece(self, code, block, rows, has_patch, has_finger):
        piece = (
            block.numbers[rows],
            block.lines[rows],
            block.texts["finger"][rows] if has_finger else None,
            block.texts["patch"][rows[0]] if has_patch else None,
        )
        self.missing[code] -= len(rows)
        if self.missing[code] < 0:
            raise InputError(_changed(self.source.path))
        parts = self.pieces.setdefault(code, [])
        parts.append(piece)
        if self.missing[code] == 0:
            self.ready[code] = _contacts(self.pieces.pop(code))


def _contacts(parts):
    numbers = np.concatenate([p[0] for p in parts])
    lines = np.concatenate([p[1] for p in parts])
    finger = None if parts[0][2] is None else np.concatenate([p[2] for p in parts]).tolist()
    return Contacts(parts[0][3], numbers[:, :3], numbers[:, 3:], finger, lines.tolist())


def sorted_groups(codes):
    """(order, starts, codes present): ``codes[order]`` is sorted, stable (file order kept
    within a code), and the group of ``codes present[j]`` begins at ``starts[j]``."""
    order = np.argsort(codes, kind="stable")
    sc = codes[order]
    starts = np.flatnonzero(np.r_[True, sc[1:] != sc[:-1]])
    return order, starts, sc[starts]


def group_rows(ids):
    """Group row indices by id in one pass: (ids in order of first appearance, one int64
    index array per id with its rows in file order).  Linear in the rows, however the ids
    are interleaved (a stable sort of small integer codes)."""
    code_of = {}
    codes = np.fromiter((code_of.setdefault(p, len(code_of)) for p in ids), np.int64, len(ids))
    order = np.argsort(codes, kind="stable")
    ends = np.cumsum(np.bincount(codes, minlength=len(code_of)))
    return list(code_of), np.split(order, ends[:-1])


def _stamp(path):
    import os

    try:
        info = os.stat(path)
    except OSError as exc:
        raise InputError(f"{path}: cannot read: {exc.strerror}") from None
    return info.st_size, info.st_mtime_ns


def _changed(path):
    return f"{path}: the file changed while it was read (read it again once it is complete)"
