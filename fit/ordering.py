"""A fill-reducing ordering of the normal matrix from its patches (nested dissection of the patch graph).

The normal matrix ``H`` is a finite-element matrix: every patch couples all of its unknowns
(:func:`~trispline.fit.energy.normal.upper_pattern`). PARDISO orders ``H`` by running METIS's
nested dissection on its graph (550k unknowns and 20M entries at 100k faces): 4 s of wall and
8 CPU s, three times its numerical factorisation. The same dissection done on the patches is
cheaper by the size of the graph and loses little fill:

1. the patch graph (two patches adjacent when they share unknowns; each unknown a hyperedge whose
   cut costs about the same whatever the number of its patches) is cut into ``2**depth`` parts of
   at most :data:`LEAF_PATCHES` patches by METIS's recursive bisection
   (``pymetis.part_graph``), whose part numbers are the bisection tree: parts ``p`` and ``q`` were
   split at the level of the highest bit in which they differ;
2. an unknown whose patches all lie in one part is eliminated with that leaf; an unknown whose
   patches span parts ``lo..hi`` belongs to the separator of the tree node that split them, and
   is eliminated after both of that node's halves (post-order of the tree).

At 100k faces: 1.7 CPU s for the ordering and 1.8 for PARDISO's symbolic phase on it, against
8.0 CPU s for PARDISO's own analysis; the factor is as large (102.0M entries, 891 MB, 69 GFlop
against 102.9M, 898 MB, 72 GFlop) and as fast to compute (benchmarks/README.md, issue 19).
"""
from __future__ import annotations

import contextlib
import ctypes
import functools
import importlib.util
import signal
import sys
import threading
from collections.abc import Iterator

import numpy as np
import scipy.sparse as sp

__all__ = ["EDGE_SCALE", "LEAF_PATCHES", "ORDERING_MIN_UNKNOWNS", "dissection_order", "patch_ordering"]

#: Patches per part of the dissection (at most; parts are a power of two): at 100k faces 6 (32k
#: parts) gave a factor of 891 MB, 8-12 (16k parts) 902 MB, 3 (64k parts) 887 MB for 10% more time.
LEAF_PATCHES = 6
#: Edge weight of a pair of patches per unknown they share with no other patch (see :func:`_parts`):
#: divisible by 1-6, 8, 9, 10 and 12, the ``s - 1`` of the unknowns of a mesh's patches.
EDGE_SCALE = 360.0
#: METIS 5's ``METIS_NOPTIONS`` and ``METIS_OK``.
METIS_NOPTIONS, METIS_OK = 40, 1
#: Fewer unknowns than this: PARDISO's own ordering (a few ms either way).
ORDERING_MIN_UNKNOWNS = 20_000


def patch_ordering(incidence: sp.csr_array, leaf: int = LEAF_PATCHES,
                   min_unknowns: int = ORDERING_MIN_UNKNOWNS) -> np.ndarray | None:
    """``(k,)`` elimination order (new position -> unknown) of the normal matrix whose patches touch
    the unknowns in ``incidence (n_patches, k)`` (:func:`~trispline.fit.energy.normal.patch_unknowns`);
    None (the solver orders it itself) below ``min_unknowns`` unknowns or without ``pymetis``."""
    n, k = incidence.shape
    if k < min_unknowns or n < 4 * leaf:
        return None
    if importlib.util.find_spec("pymetis") is None:  # an optional speed-up: PARDISO's own METIS orders it then
        return None
    depth = max(1, int(np.ceil(np.log2(n / leaf))))
    try:
        part = _parts(incidence, 1 << depth)
    except (RuntimeError, ValueError, MemoryError):  # METIS refused the graph: PARDISO orders it instead
        return None
    return dissection_order(incidence, part)


def _parts(incidence: sp.csr_array, n_parts: int) -> np.ndarray:
    """``(n_patches,)`` part of every patch: METIS's recursive bisection of the patch graph.

    An unknown shared by ``s`` patches is a hyperedge; its ``s (s - 1) / 2`` pairs each weigh
    ``1 / (s - 1)`` (times :data:`EDGE_SCALE`, rounded), so that cutting it costs about the same
    whatever ``s``: the cut then counts separator unknowns (at 100k faces 891 MB of factor against
    941 with the pairs weighted by their shared unknowns and 1,193 unweighted; PARDISO's own 898)."""
    B = sp.csr_array(incidence, dtype=np.float64)
    B.data[:] = 1
    share = np.asarray(B.sum(axis=0)).ravel()
    B = B * np.where(share > 1, EDGE_SCALE / np.maximum(share - 1, 1), 0.0)
    G = sp.csr_array(B @ (B.T > 0).astype(np.float64))
    G.setdiag(0)
    G.eliminate_zeros()
    weights = np.maximum(np.rint(G.data), 1)
    return _recursive_bisection(G.indptr, G.indices, weights, n_parts)


def _recursive_bisection(xadj: np.ndarray, adjncy: np.ndarray, weights: np.ndarray, n_parts: int) -> np.ndarray:
    """``METIS_PartGraphRecursive`` of the graph ``(xadj, adjncy)`` with edge ``weights``: ``(n,)`` parts.

    Called through ``ctypes``, which releases the GIL for the call, on the METIS library that
    ``pymetis`` carries (``pymetis.part_graph`` holds the GIL: at 100k faces 1.6 s in which the fit's
    assembly, running beside it in the main thread, could start no new work); the same partition,
    the same options.
    ``pymetis.part_graph`` where that library or its symbol is not found.
    """
    import pymetis

    idx = pymetis.zero_copy_dtype()  # METIS's idx_t
    lib = _metis_library()
    if lib is None:
        adjacency = pymetis.CSRAdjacency(xadj.astype(idx), adjncy.astype(idx))
        _, part = pymetis.part_graph(n_parts, adjacency=adjacency, eweights=weights.astype(idx), recursive=True)
        return np.asarray(part, np.int64)
    width = np.ctypeslib.as_ctypes_type(idx)
    xadj, adjncy, weights = (np.ascontiguousarray(a, idx) for a in (xadj, adjncy, weights))
    options = np.zeros(METIS_NOPTIONS, idx)
    pointer = ctypes.c_void_p
    lib.METIS_SetDefaultOptions(options.ctypes.data_as(pointer))
    n = xadj.size - 1
    part = np.zeros(n, idx)
    objective = width(0)
    with sigterm_kept():
        status = lib.METIS_PartGraphRecursive(
            ctypes.byref(width(n)), ctypes.byref(width(1)), xadj.ctypes.data_as(pointer),
            adjncy.ctypes.data_as(pointer), None, None, weights.ctypes.data_as(pointer),
            ctypes.byref(width(n_parts)), None, None, options.ctypes.data_as(pointer), ctypes.byref(objective),
            part.ctypes.data_as(pointer))
    if status != METIS_OK:
        raise RuntimeError(f"METIS_PartGraphRecursive returned {status}")
    return part.astype(np.int64)


#: Bytes of a C ``struct sigaction`` at most (glibc x86-64: 152); copied whole, never interpreted but for
#: its first field, the handler (a pointer: :data:`HANDLER` bytes).
SIGACTION_BYTES = 256
HANDLER = ctypes.sizeof(ctypes.c_void_p)
#: How often :func:`sigterm_kept` puts SIGTERM's disposition back while METIS runs (seconds).
SIGNAL_KEEP_INTERVAL = 0.002


@contextlib.contextmanager
def sigterm_kept() -> Iterator[None]:
    """While METIS runs in this thread, SIGTERM keeps the disposition it had before (the default: the
    process ends), put back every :data:`SIGNAL_KEEP_INTERVAL` by a watcher thread.

    Why: every METIS call installs GKlib's SIGTERM handler for its own error exits, a ``longjmp`` to the
    calling thread's saved context. The kernel delivers a ``kill`` to the main thread, where that handler
    jumps into a context it does not have: a SIGTERM during the ordering (1.7 s of a 100k-face fit, in the
    analysis thread) ended the process with a segmentation fault instead of exit -15 (1 in ~16 runs of the
    bad-input battery's signal test). Linux (glibc ``sigaction``) only; elsewhere nothing is done.
    """
    libc = _libc()
    saved = ctypes.create_string_buffer(SIGACTION_BYTES)
    if libc is None or libc.sigaction(signal.SIGTERM, None, saved) != 0:
        yield
        return
    stop = threading.Event()

    def keep() -> None:
        now = ctypes.create_string_buffer(SIGACTION_BYTES)
        while not stop.wait(SIGNAL_KEEP_INTERVAL):
            if libc.sigaction(signal.SIGTERM, None, now) == 0 and now.raw[:HANDLER] != saved.raw[:HANDLER]:
                libc.sigaction(signal.SIGTERM, saved, None)

    watcher = threading.Thread(target=keep, name="trispline-sigterm-kept", daemon=True)
    watcher.start()
    try:
        yield
    finally:
        stop.set()
        watcher.join()


@functools.cache
def _libc() -> ctypes.CDLL | None:
    """The C library (for ``sigaction``) on Linux, else None."""
    if not sys.platform.startswith("linux"):
        return None
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        libc.sigaction.argtypes = [ctypes.c_int, ctypes.c_void_p, ctypes.c_void_p]
        return libc
    except (OSError, AttributeError):
        return None


@functools.cache
def _metis_library() -> ctypes.CDLL | None:
    """The METIS inside ``pymetis``'s extension module (both entry points exported), or None."""
    try:
        import pymetis._internal as internal

        lib = ctypes.CDLL(internal.__file__)
        lib.METIS_PartGraphRecursive, lib.METIS_SetDefaultOptions  # noqa: B018 - both exported
    except (ImportError, OSError, AttributeError):
        return None
    return lib


def dissection_order(incidence: sp.csr_array, part: np.ndarray) -> np.ndarray:
    """``(k,)`` post-order elimination of the unknowns of ``incidence (n_patches, k)`` given each patch's
    leaf ``part (n_patches,)`` of a binary dissection tree (part numbers: paths from the root, as
    METIS's recursive bisection numbers them). Unknowns in no patch come first (they couple nothing)."""
    T = sp.csr_array(incidence).T.tocsr()  # (k, n_patches): the patches of every unknown
    count = np.diff(T.indptr)
    used = count > 0
    p = part[T.indices]
    start = T.indptr[:-1][used]
    lo = np.zeros(T.shape[0], np.int64)
    hi = np.zeros(T.shape[0], np.int64)
    lo[used] = np.minimum.reduceat(p, start)
    hi[used] = np.maximum.reduceat(p, start)
    level = np.frexp((lo ^ hi).astype(np.float64))[1].astype(np.int64)  # bit length: 0 when lo == hi
    node_end = (((lo >> level) + 1) << level) - 1  # the last leaf under the separating node
    node_end[~used] = -1
    # post-order: by the node's last leaf, a child (lower level) before its parent; stable in the unknowns
    return np.lexsort((level, node_end)).astype(np.int64)
