"""Large CSR work on ranges of rows in threads: ``M @ x`` and sorting the column indices.

scipy multiplies on one thread into a freshly allocated output. At 1M faces the
propagation map has 45M entries and the output 300 MB; splitting the rows over
the cores splits both the arithmetic and the first-touch page faults of the
output (each range first-touches its own rows). Each range runs
scipy's own kernel (``csr_matvecs``, which releases the GIL) on a slice of
``indptr``, so the result is bit-identical to ``M @ x``. That kernel lives in a
private scipy module: where it is missing or refuses the call, this falls back
to ``M @ x``.
"""
from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from . import _parallel

try:  # private, but unchanged since scipy 0.7; checked at first use below
    from scipy.sparse import _sparsetools
except ImportError:  # pragma: no cover - depends on the scipy build
    _sparsetools = None

#: Matrices with fewer stored entries go straight to ``M @ x``.
THREADED_NNZ = 1 << 20


def matmul(M: sp.csr_array, x: np.ndarray) -> np.ndarray:
    """``M @ x`` for ``M: (m, n)`` CSR float64 and ``x: (n, d)``; returns ``(m, d)`` float64."""
    x = np.asarray(x)
    if (
        _sparsetools is None
        or x.ndim != 2
        or x.dtype != np.float64
        or M.dtype != np.float64
        or M.nnz < THREADED_NNZ
        or x.shape[0] != M.shape[1]
    ):
        return M @ x
    with _parallel.Workers(M.shape[0]) as work:
        if work.threads < 2:
            return M @ x
        m, n = M.shape
        d = x.shape[1]
        xs = np.ascontiguousarray(x).reshape(-1)
        out = np.empty((m, d))  # every range zeroes (first-touches) its own rows; the kernel adds
        out_flat = out.reshape(-1)
        indptr, indices, data = M.indptr, M.indices, M.data

        def rows(lo: int, hi: int) -> None:
            out_flat[lo * d : hi * d] = 0.0
            _sparsetools.csr_matvecs(hi - lo, n, d, indptr[lo : hi + 1], indices, data, xs, out_flat[lo * d : hi * d])

        if not _over_rows(work, m, rows):  # pragma: no cover - scipy changed its private API
            return M @ x
    return out


def sort_indices(M: sp.csr_array, work: _parallel.Workers) -> None:
    """``M.sort_indices()`` with ranges of rows sorted in threads (same kernel, same result)."""
    n = M.shape[0]
    if _sparsetools is None or work.threads < 2 or M.nnz < THREADED_NNZ or M.has_sorted_indices:
        M.sort_indices()
        return
    indptr, indices, data = M.indptr, M.indices, M.data

    def rows(lo: int, hi: int) -> None:
        _sparsetools.csr_sort_indices(hi - lo, indptr[lo : hi + 1], indices, data)

    if _over_rows(work, n, rows):
        M.has_sorted_indices = True
    else:  # pragma: no cover - scipy changed its private API
        M.sort_indices()


def _over_rows(work: _parallel.Workers, n: int, rows) -> bool:
    """Run ``rows(lo, hi)`` (a scipy kernel on a row range, idempotent) over all ``n`` rows.

    The first row runs alone first: a kernel that refuses the call (a scipy release that
    changed its private API) raises there, before any thread runs, and ``False`` says
    to use the public method instead.
    """
    try:
        rows(0, min(n, 1))
    except (TypeError, ValueError, AttributeError):  # pragma: no cover - depends on scipy
        return False
    work.map(rows, n)
    return True
