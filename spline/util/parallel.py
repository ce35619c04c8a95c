"""Vectorised work on ranges of a large array, on a thread per core.

numpy releases the GIL inside its loops (arithmetic, gathers, scatters), so a
stage written as "do this to rows ``lo:hi``" runs on every core when its ranges
are handed to threads. That splits the arithmetic and, as much, the page faults
of fresh memory, which on the 2-core development VM cost more than the
arithmetic at 1M faces (see ``_memory``). Small inputs run inline: a thread pool
costs ~0.1 ms to start.
"""
from __future__ import annotations

import os
from concurrent.futures import Future, ThreadPoolExecutor
from typing import Any, Callable

import numpy as np

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

    Use as a context manager; ``map`` waits for its ranges, ``submit`` returns a
    handle whose ``result()`` waits. Errors propagate to the caller.
    """

    def __init__(self, n: int) -> None:
        cores = min(os.cpu_count() or 1, 8)
        self.threads = cores if n >= PARALLEL_MIN and cores > 1 else 1
        self._pool = ThreadPoolExecutor(self.threads) if self.threads > 1 else None

    def map(self, fn: Callable[[int, int], Any], n: int, chunk: int | None = None) -> list[Any]:
        """``[fn(lo, hi) for lo, hi in ranges(n, chunk)]``, ranges run concurrently."""
        parts = ranges(n, chunk)
        if self._pool is None or len(parts) < 2:
            return [fn(lo, hi) for lo, hi in parts]
        futures = [self._pool.submit(fn, lo, hi) for lo, hi in parts]
        return [f.result() for f in futures]

    def submit(self, fn: Callable[..., Any], *args: Any) -> Future | _Done:
        """Start ``fn(*args)`` in the background (inline without threads)."""
        if self._pool is None:
            return _Done(fn(*args))
        return self._pool.submit(fn, *args)

    def __enter__(self) -> "Workers":
        return self

    def __exit__(self, *exc: object) -> None:
        if self._pool is not None:
            self._pool.shutdown(wait=True)


def concat(parts: list[np.ndarray], dtype=np.int64) -> np.ndarray:
    """``np.concatenate`` that accepts an empty list."""
    return np.concatenate(parts) if parts else np.zeros(0, dtype)
