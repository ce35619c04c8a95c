"""Allocation of large arrays: compact index types, pages faulted in by a thread per core.

The first write to freshly mapped memory costs one page fault per page, paid on
the writing thread. For the few arrays of hundreds of megabytes that a 1M-face
build writes with single-threaded numpy scatters, touching the pages first on
every core divides that cost by the core count. It matters most on virtual
machines that hand idle guest memory back to the host (memory balloon / free
page reporting), where a fault costs ~10x more: measured on the 2-core
development VM, first-touching 2 GB took 5.3 s on one thread and 2.6 s on two.
"""
from __future__ import annotations

import numpy as np

from . import parallel as _parallel


def index_dtype(*counts: int) -> type:
    """``np.int32`` when every id below the largest of ``counts`` fits in it, else ``np.int64``."""
    return np.int32 if max(counts) < 2**31 - 1 else np.int64


#: Arrays below this many bytes are plain ``np.empty``.
PREFAULT_BYTES = 32 << 20


def full(shape: int | tuple[int, ...], value, dtype=np.float64) -> np.ndarray:
    """``np.full(shape, value, dtype)``; a large array is filled by a thread per core.

    Filling is the first touch of every page, so the page faults split over the cores.
    """
    out = np.empty(shape, dtype)
    flat = out.reshape(-1)
    if out.nbytes < PREFAULT_BYTES:
        flat.fill(value)
        return out
    with _parallel.Workers(flat.size) as work:

        def fill(lo: int, hi: int) -> None:
            flat[lo:hi] = value  # numpy releases the GIL for the fill

        work.map(fill, flat.size, chunk=-(-flat.size // (4 * work.threads)))
    return out


def empty(shape: int | tuple[int, ...], dtype=np.float64) -> np.ndarray:
    """A zero-filled array whose pages are touched in parallel when it is large."""
    return full(shape, 0, dtype)
