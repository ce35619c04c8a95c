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

import os

import numpy as np

from ..errors import ResourceError
from . import parallel as _parallel


def available_memory() -> int | None:
    """Bytes the system can give without swapping (``MemAvailable``), or None if unknown."""
    try:
        with open("/proc/meminfo") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except OSError:
        pass
    try:  # pragma: no cover - not Linux
        return int(os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE"))
    except (ValueError, OSError, AttributeError):  # pragma: no cover
        return None


def resident_memory() -> int:
    """Bytes this process holds in memory now (``/proc/self/statm``'s resident pages; 0 where unknown)."""
    try:
        with open("/proc/self/statm") as fh:
            return int(fh.read().split()[1]) * page_size()
    except (OSError, ValueError, IndexError):  # pragma: no cover - not Linux
        return 0


def thread_page_faults(tids: set[int], prefixes: tuple[str, ...] = ()) -> int | None:
    """Pages first touched so far (minor page faults, ``/proc/self/task/*/stat``) by this process's
    threads ``tids`` and those whose name starts with one of ``prefixes``; None where unknown.

    Cheap (one small read a thread): fit for polling while a library call writes a large array on its
    own threads, whose count of pages touched is how far the call has got, whatever other threads
    allocate meanwhile (see :meth:`trispline.fit.solve.SparseCholesky.factorize`).
    """
    total = 0
    try:
        names = os.listdir("/proc/self/task")
    except OSError:  # pragma: no cover - not Linux
        return None
    for name in names:
        try:
            with open(f"/proc/self/task/{name}/stat") as fh:
                stat = fh.read()
        except OSError:  # the thread ended meanwhile
            continue
        comm, rest = stat[stat.index("(") + 1: stat.rindex(")")], stat[stat.rindex(")") + 2:].split()
        if int(name) in tids or comm.startswith(prefixes):
            total += int(rest[7])  # minflt: the 10th field, the 8th after the name
    return total


def page_size() -> int:
    """Bytes of a memory page (4096 where the system does not say: Windows has no ``sysconf``)."""
    try:
        return int(os.sysconf("SC_PAGE_SIZE"))
    except (AttributeError, ValueError, OSError):  # pragma: no cover - not POSIX
        return 4096


def format_bytes(n: float) -> str:
    """``"1.2 GB"`` style (decimal units)."""
    for unit in ("bytes", "kB", "MB", "GB", "TB"):
        if abs(n) < 1000 or unit == "TB":
            return f"{n:.0f} {unit}" if unit == "bytes" else f"{n:.1f} {unit}"
        n /= 1000.0
    return f"{n:.1f} TB"  # pragma: no cover


def require_memory(nbytes: float, what: str, hint: str = "") -> None:
    """Refuse (:class:`~trispline.spline.errors.ResourceError`) work whose arrays need more than
    the available memory, before allocating anything; ``what`` names the work."""
    avail = available_memory()
    if avail is not None and nbytes > avail:
        raise ResourceError(f"{what} would need about {format_bytes(nbytes)} of memory, but only "
                            f"{format_bytes(avail)} are available{'; ' + hint if hint else ''}")


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
