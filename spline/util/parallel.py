"""Vectorised work on ranges of a large array, on a thread per core.

numpy releases the GIL inside its loops (arithmetic, gathers, scatters), so a
stage written as "do this to rows ``lo:hi``" runs on every core when its ranges
are handed to threads. That splits the arithmetic and, as much, the page faults
of fresh memory, which on the 2-core development VM cost more than the
arithmetic at 1M faces (see ``memory``). Small inputs run inline: a thread pool
costs ~0.1 ms to start. Work that calls BLAS from several threads at once holds
BLAS to one thread per call meanwhile (:func:`single_threaded_blas`).
"""
from __future__ import annotations

import contextlib
import os
import sys
import threading
from concurrent.futures import Future, ThreadPoolExecutor
from typing import Any, Callable, Iterator, TypeVar

import numpy as np

T = TypeVar("T")

#: Items per range: big enough that Python overhead per range is noise, small
#: enough that a range's temporaries stay in cache (~1 MB per float64 column).
CHUNK = 1 << 17
#: Inputs with fewer items run inline.
PARALLEL_MIN = 1 << 16


def ranges(n: int, chunk: int | None = None) -> list[tuple[int, int]]:
    """Consecutive ``(lo, hi)`` covering ``0..n`` in pieces of at most ``chunk`` (default ``CHUNK``)."""
    chunk = CHUNK if chunk is None else int(chunk)
    bounds = list(range(0, n, chunk)) + [n]
    return [(lo, hi) for lo, hi in zip(bounds[:-1], bounds[1:]) if hi > lo]


class _Done:
    """An already computed result with the ``Future.result`` interface."""

    def __init__(self, value: Any) -> None:
        self._value = value

    def result(self) -> Any:
        return self._value


class Workers:
    """A thread per core (at most 8) for inputs of ``n`` items, or inline work.

    Use as a context manager; ``map`` waits for its ranges, ``submit`` and ``start``
    return handles whose ``result()`` waits (and re-raises the task's error).
    ``parallel_min``: fewest items that get threads (default :data:`PARALLEL_MIN`);
    ``serial_blas``: hold BLAS to one thread per call while the threads run
    (:func:`single_threaded_blas`), for tasks that each call BLAS.
    """

    def __init__(self, n: int, *, parallel_min: int | None = None, serial_blas: bool = False) -> None:
        cores = min(os.cpu_count() or 1, 8)
        least = PARALLEL_MIN if parallel_min is None else parallel_min
        self.threads = cores if n >= least and cores > 1 else 1
        self._pool = ThreadPoolExecutor(self.threads) if self.threads > 1 else None
        self._blas = single_threaded_blas() if serial_blas and self._pool is not None else contextlib.nullcontext()

    def map(self, fn: Callable[[int, int], Any], n: int, chunk: int | None = None) -> list[Any]:
        """``[fn(lo, hi) for lo, hi in ranges(n, chunk)]``, ranges run concurrently."""
        parts = ranges(n, chunk)
        if self._pool is None or len(parts) < 2:
            return [fn(lo, hi) for lo, hi in parts]
        futures = [self._pool.submit(fn, lo, hi) for lo, hi in parts]
        return [f.result() for f in futures]

    def start(self, fn: Callable[[int, int], Any], n: int, chunk: int | None = None,
              offset: int = 0) -> list[Future | _Done]:
        """Start ``fn(offset + lo, offset + hi)`` for every range of ``n`` items without waiting."""
        return [self.submit(fn, offset + lo, offset + hi) for lo, hi in ranges(n, chunk)]

    def submit(self, fn: Callable[..., Any], *args: Any) -> Future | _Done:
        """Start ``fn(*args)`` in the background (inline without threads)."""
        if self._pool is None:
            return _Done(fn(*args))
        return self._pool.submit(fn, *args)

    def chunk(self, n: int, most: int) -> int:
        """A range length for ``n`` items: at most ``most``, and at least two ranges per thread."""
        return most if self._pool is None else max(1, min(most, -(-n // (2 * self.threads))))

    def __enter__(self) -> "Workers":
        self._blas.__enter__()
        return self

    def __exit__(self, *exc: object) -> None:
        try:
            if self._pool is not None:
                self._pool.shutdown(wait=True)
        finally:
            self._blas.__exit__(None, None, None)


def map_reporting(work: Workers, fn: Callable[[int, int], Any], n: int, chunk: int | None,
                  report: Callable[[float], None] | None = None) -> list[Any]:
    """``work.map(fn, n, chunk)``, ``report(done / n)`` (when given) as the ranges finish in order.

    Every range is queued at once, so a thread never waits for the other's last range of a batch
    (waiting for batches of two ranges per thread left ~1.3 core-seconds idle in a 100k-face fit's
    assembly); the pool runs a range per thread at a time, so no more temporaries are alive."""
    out: list[Any] = []
    for (_, hi), job in zip(ranges(n, chunk), work.start(fn, n, chunk)):
        out.append(job.result())
        if report is not None:
            report(hi / max(n, 1))
    return out


def once(make: Callable[[], T]) -> Callable[[], T]:
    """``make()`` computed by the first caller, from whichever thread; callers meanwhile wait for it,
    later ones get the same value. A call that raises leaves nothing behind (the next caller tries
    again and meets the same error in its own thread)."""
    lock = threading.Lock()
    box: list[T] = []

    def get() -> T:
        with lock:
            if not box:
                box.append(make())
            return box[0]

    return get


_blas_lock = threading.Lock()
_blas_state: dict = {"limiter": None, "users": 0, "controller": None, "modules": -1}


def _blas_controller():
    """A threadpoolctl controller that knows every BLAS loaded so far. Building one reads
    ``/proc/self/maps`` (1-5 ms with VTK and Open CASCADE loaded: more than a 1k-patch CAD
    conversion), so it is rebuilt only when modules were imported since (native libraries
    such as MKL through pypardiso arrive with an import); called under ``_blas_lock``."""
    from threadpoolctl import ThreadpoolController

    if _blas_state["controller"] is None or _blas_state["modules"] != len(sys.modules):
        _blas_state["controller"] = ThreadpoolController()
        _blas_state["modules"] = len(sys.modules)
    return _blas_state["controller"]


@contextlib.contextmanager
def single_threaded_blas() -> Iterator[None]:
    """Context in which BLAS runs on the calling thread only.

    Tasks that call BLAS from several Python threads at once oversubscribe the cores
    when BLAS threads each call as well (measured slower). The limit is process-wide;
    concurrent users share it, the first one in sets it and the last one out restores
    the original thread count.
    """
    try:
        import threadpoolctl  # noqa: F401
    except ImportError:  # pragma: no cover - threadpoolctl is a dependency
        yield
        return
    with _blas_lock:
        if _blas_state["users"] == 0:
            _blas_state["limiter"] = _blas_controller().limit(limits=1, user_api="blas")
        _blas_state["users"] += 1
    try:
        yield
    finally:
        with _blas_lock:
            _blas_state["users"] -= 1
            if _blas_state["users"] == 0:
                _blas_state["limiter"].restore_original_limits()
                _blas_state["limiter"] = None


def concat(parts: list[np.ndarray], dtype=np.int64) -> np.ndarray:
    """``np.concatenate`` that accepts an empty list."""
    return np.concatenate(parts) if parts else np.zeros(0, dtype)
