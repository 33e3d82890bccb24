"""Many patches at once: ``analyze_patches``, each result ``analyze_patch``'s to round-off
(tested), at a fraction of its cost a patch.

Each patch is prepared as ``analyze_patch`` prepares it (patches of one size together,
``patch_input.prepare_stack``); the crease and tilt checks are screened for each size at
once (``check_screens``; only the patches not cleared run ``edges.check`` and
``tilt.untilt``); then a stack is fitted by one ``local_jet.fit`` call on a padded stack
with a row mask, and ``jet_answers.outcomes`` runs on the whole stack; the curvature-jump
test is screened the same way (``check_screens.no_jump``), and the edge
``edges.check_answer`` looks for beside a ``plane`` (``check_screens.no_turn``); only the
assembly of each result is per patch.  A patch that is refused or malformed gives its
exception in its place (without its traceback, which would hold the stack's arrays) and the
others still come out.  ``method="spline"`` runs one patch at a time.  ``keep_heap`` is the
allocator setting an application that fits many stacks may opt into.
"""

import contextlib
import ctypes
import functools
import gc

import numpy as np

from tactile.ep2 import check_screens, edges, jet_answers, local_jet, patch_input, tilt
from tactile.ep2.api import PatchResult, analyze_patch
from tactile.errors import DataError, InputError

STACK = 256  # patches per fit call
WINDOW = 16  # stacks' worth of patches sorted by size together
STACK_ROWS = patch_input.MAX_ROWS  # rows of a padded stack (patches x the largest's rows)
_OWN = ("noise_pos", "noise_normal")  # options a patch dict may set for itself


def analyze_patches(patches, *, chunk=STACK, **kw):
    """[PatchResult or DataError/InputError] for ``patches``, an iterable of (points,
    normals) pairs or dicts with ``points``, ``normals`` and optionally ``finger``,
    ``lines``, ``noise_pos``, ``noise_normal`` (the patch's own, over the keyword's).
    Keyword options are ``analyze_patch``'s and apply to every patch.  Patches are read
    ``WINDOW`` stacks at a time and fitted in stacks of like size (less padding)."""
    req = patch_input.keywords(**kw)
    out, todo = [], []
    for p in patches:
        todo.append(p)
        if len(todo) == chunk * WINDOW:
            out += _window(todo, chunk, req)
            todo = []
    return out + (_window(todo, chunk, req) if todo else [])


def _window(patches, chunk, req):
    """``_stack`` over ``patches`` sorted by size, the results in the patches' order."""
    sizes = [_size(p) for p in patches]
    order = sorted(range(len(patches)), key=sizes.__getitem__)
    out = [None] * len(patches)
    for idx in stacks(order, sizes, chunk):
        with _gc_paused():
            done = _stack([patches[j] for j in idx], req)
        for j, res in zip(idx, done, strict=True):
            out[j] = res
    return out


@contextlib.contextmanager
def _gc_paused():
    """The cyclic garbage collector off for one stack (none of its objects form cycles):
    a stack's thousands of small objects then cost one young-generation pass, not one per
    700 allocations (6 % of the CPU); cycles, if any, wait until the stack is done."""
    was = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if was:
            gc.enable()


HEAP_PAD = 32 << 20  # bytes of freed heap glibc keeps for the next stack's temporaries
_M_TOP_PAD, _M_MMAP_THRESHOLD = -2, -3  # (glibc's mallopt parameters)


@functools.cache
def keep_heap():
    """Have glibc keep ``HEAP_PAD`` of freed memory at the top of the heap (``mallopt``
    M_TOP_PAD) and serve blocks up to that size from the heap (M_MMAP_THRESHOLD), once a
    process: by default it hands the heap's top back to the system as a stack's temporaries
    (MBs each) are freed, and the next stack's fault their pages in again, about 10 page
    faults a patch (a tenth of the CPU, mostly in the kernel).  The pad is reused, not added:
    peak RSS through the CLI measured the same at 10k and 100k patches.

    It sets the whole process's allocator, so the library never calls it by itself: an
    application that fits many stacks opts in (``tactile ep2 analyze`` does, before its
    workers fork, which inherit it).  True once set; without glibc's mallopt, False."""
    try:
        libc = ctypes.CDLL(None)
        return libc.mallopt(_M_MMAP_THRESHOLD, HEAP_PAD) == libc.mallopt(_M_TOP_PAD, HEAP_PAD) == 1
    except (OSError, AttributeError, TypeError):  # (no C library, no mallopt: not glibc)
        return False


def stacks(order, sizes, chunk, rows=STACK_ROWS):
    """``order`` (indices by ascending size) cut into stacks of at most ``chunk`` patches
    whose padded rows (count x the last's size) stay within ``rows``, or one patch alone:
    memory in proportion to the rows fitted, however unlike the patches' sizes."""
    out = []
    for j in order:
        if out and len(out[-1]) < chunk and (len(out[-1]) + 1) * sizes[j] <= rows:
            out[-1].append(j)
        else:
            out.append([j])
    return out


def _size(p):
    try:
        return len(_unpack(p)[0])
    except Exception:  # (malformed: ``_stack`` says why, in its place)
        return 0


def _unpack(p):
    if isinstance(p, dict):
        return p["points"], p["normals"], p.get("finger"), p.get("lines")
    points, normals = p
    return points, normals, None, None


def _own(p, req):
    """The ``Request`` of patch ``p``: ``req`` with the patch's own noise over it."""
    if not isinstance(p, dict):
        return req
    return req.with_noise(**{k: p[k] for k in _OWN if k in p})


def _owns(patches, req):
    """``_own`` of each patch, one ``Request`` (frozen) per distinct noise of the stack."""
    seen, out = {}, []
    for p in patches:
        own = tuple((k, type(p[k]), p[k]) for k in _OWN if k in p) if isinstance(p, dict) else ()
        try:
            if own not in seen:
                seen[own] = _own(p, req)
            out.append(seen[own])
        except TypeError:  # (unhashable: that patch's own)
            out.append(_own(p, req))
    return out


def _stack(patches, req):
    if req.method == "spline":
        return [_one(p, _own(p, req)) for p in patches]
    results, tilted = [None] * len(patches), {}
    unpacked = [_unpack(p) for p in patches]
    reqs = _owns(patches, req)
    quick = patch_input.prepare_stack(unpacked, reqs)
    preps, prepared = {}, []
    for j, (item, req_j) in enumerate(zip(unpacked, reqs, strict=True)):
        try:
            preps[j] = quick[j] or patch_input.prepare(*item, req_j)
        except (DataError, InputError) as exc:
            results[j] = exc
    clear_edge, clear_tilt, no_turn = _screens(preps)
    for j, prep in preps.items():
        try:
            if not clear_edge[j]:
                edges.check(prep)
            prep, tilted[j] = (prep, None) if clear_tilt[j] else tilt.untilt(prep)
            prepared.append((j, prep))
        except (DataError, InputError) as exc:
            results[j] = exc
    if prepared:
        P, N, mask = _padded(prepared)
        fits = _fit(prepared, req.jet, P, N, mask)
        smooth = _smooth(fits, P, N, mask)
        for b, ((j, prep), res) in enumerate(zip(prepared, fits, strict=True)):
            try:
                passes = smooth.get(b, True) if _curved(res) else no_turn[j] and not tilted[j]
                if not passes:  # (screened: ``check_answer`` would pass ``res``)
                    edges.check_answer(prep, res)
            except DataError as exc:
                res = exc
            if not isinstance(res, DataError):
                res = PatchResult.of(res, prep, "jet", req.maps, tilted[j])
            results[j] = res
    return [_bare(r) for r in results]


def _bare(res):
    """``res``, or the refusal without its traceback: that holds the frames it was raised
    through, and so the whole stack's arrays, for as long as the caller keeps the result."""
    return res.with_traceback(None) if isinstance(res, BaseException) else res


def _padded(prepared):
    """(points, normals (B, n, 3), mask (B, n)) of the prepared patches ((j, Prepared) each)
    as one stack padded to the largest (padding: normal z, masked out)."""
    n = max(len(prep.points) for _, prep in prepared)
    P = np.zeros((len(prepared), n, 3))
    N = np.zeros((len(prepared), n, 3))
    N[..., 2] = 1.0  # padding: finite and masked out
    mask = np.zeros((len(prepared), n), bool)
    for b, (_, prep) in enumerate(prepared):
        m = len(prep.points)
        P[b, :m], N[b, :m], mask[b, :m] = prep.points, prep.normals, True
    return P, N, mask


def _fit(prepared, jet, P, N, mask):
    """``jet_answers.outcomes`` of the prepared patches ((j, Prepared) each) fitted as the
    padded stack ``P``, ``N``, ``mask`` (``_padded``; ``jet``: the options they share, all
    but the noise)."""
    noise = [[np.nan if (v := getattr(p.jet, k)) is None else v for _, p in prepared] for k in _OWN]
    stack = local_jet.fit(P, N, mask, *noise, jet.max_normal_angle)
    return jet_answers.outcomes(stack, jet, [prep.names for _, prep in prepared])


def _screens(preps):
    """({j: bool} x 3): which prepared patches surely pass ``edges.check``, are surely left
    as they are by ``tilt.untilt`` and have normals ``edges.check_answer`` surely finds no
    edge in (``check_screens``, a stack per size; the last holds while no tilt is taken out)."""
    got = _by_size(preps, _screen)
    return tuple({j: v[k] for j, v in got.items()} for k in range(3))


def _screen(P, N, opts):
    return np.stack(check_screens.screens(P, N, opts), -1)


def _by_size(preps, screen):
    """{j: screen's verdict} of the prepared patches ({j: Prepared}), ``screen`` called on
    the points, normals (b, n, 3) and options of each size's stack (a stack per size)."""
    out, groups = {}, {}
    for j, prep in preps.items():
        groups.setdefault(len(prep.points), []).append(j)
    for idx in groups.values():
        P = np.stack([preps[j].points for j in idx])
        N = np.stack([preps[j].normals for j in idx])
        out.update(zip(idx, screen(P, N, [preps[j].jet for j in idx]).tolist(), strict=True))
    return out


def _curved(res):
    """Whether ``edges.check_answer`` looks only for a curvature jump in ``res``: a fitted
    answer, not ``plane`` (else only for an edge, by ``edges.find``, loose)."""
    return not isinstance(res, DataError) and res.centre.shape != "plane"


def _smooth(fits, P, N, mask):
    """{b: ``check_screens.no_jump``} of the fitted answers ``curvature_jump.check`` looks
    at (``_curved``, not ``uncertain``) in the padded stack ``P``, ``N``, ``mask``."""
    look = [b for b, res in enumerate(fits) if _curved(res) and res.centre.shape != "uncertain"]
    if not look:
        return {}
    return dict(zip(look, check_screens.no_jump(P[look], N[look], mask[look]).tolist()))


def _one(p, req):
    points, normals, finger, lines = _unpack(p)
    try:
        return analyze_patch(points, normals, finger=finger, lines=lines, **req.keywords())
    except (DataError, InputError) as exc:
        return _bare(exc)
