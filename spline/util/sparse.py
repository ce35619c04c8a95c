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

import sys

import numpy as np
import scipy.sparse as sp

from . import parallel as _parallel

try:  # private, but unchanged since scipy 0.7; checked at first use below
    from scipy.sparse import _sparsetools
except ImportError:  # pragma: no cover - depends on the scipy build
    _sparsetools = None

#: Matrices with fewer stored entries go straight to ``M @ x``.
THREADED_NNZ = 1 << 20


def kernel_ok(M: sp.csr_array, x: np.ndarray) -> bool:
    """Whether scipy's private kernel can take ``M @ x`` (float64 CSR times float64 ``(n, d)``)."""
    return (_sparsetools is not None and x.ndim == 2 and x.dtype == np.float64
            and M.dtype == np.float64 and x.shape[0] == M.shape[1])


def matmul(M: sp.csr_array, x: np.ndarray, rows: tuple[int, int] | None = None) -> np.ndarray:
    """``M[lo:hi] @ x`` for ``M: (m, n)`` CSR float64 and ``x: (n, d)``; ``(hi - lo, d)`` float64.

    ``rows=(lo, hi)`` selects a range of rows (all rows by default) without copying ``M``.
    """
    x = np.asarray(x)
    lo, hi = rows if rows is not None else (0, M.shape[0])

    def plain() -> np.ndarray:  # scipy's own product (its row slice copies that part of M)
        return M @ x if rows is None else M[lo:hi] @ x

    if not kernel_ok(M, x) or M.indptr[hi] - M.indptr[lo] < THREADED_NNZ:
        return plain()
    with _parallel.Workers(hi - lo) as work:  # one core: the same ranges inline, still no copy of M
        d = x.shape[1]
        xs = np.ascontiguousarray(x).reshape(-1)
        out = np.empty((hi - lo, d))  # every range zeroes (first-touches) its own rows; the kernel adds

        def part(a: int, b: int) -> None:
            rows_into(M, xs, lo + a, lo + b, out[a:b])

        if not _over_rows(work, hi - lo, part):  # pragma: no cover - scipy changed its private API
            return plain()
    return out


def rows_into(M: sp.csr_array, xs: np.ndarray, lo: int, hi: int, out: np.ndarray) -> None:
    """``out[:] = M[lo:hi] @ x`` on the calling thread; ``xs``: ``x: (n, d)`` C-contiguous, raveled.

    ``out: (hi - lo, d)`` C-contiguous float64. scipy's kernel on a slice of ``indptr``
    (no copy of ``M``; releases the GIL); raises ``TypeError``/``ValueError`` where that
    private kernel refuses the call.
    """
    if _sparsetools is None:  # pragma: no cover - depends on the scipy build
        raise TypeError("scipy's sparsetools kernels are not available")
    if not out.flags.c_contiguous:
        raise ValueError("rows_into needs a C-contiguous output")
    d = out.shape[1]
    flat = out.reshape(-1)
    flat[:] = 0.0
    _sparsetools.csr_matvecs(hi - lo, M.shape[1], d, M.indptr[lo : hi + 1], M.indices, M.data, xs, flat)


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


def compact(M: sp.csr_array) -> None:
    """Shrink ``M.data`` and ``M.indices`` to ``M.nnz`` entries where they are views of longer buffers.

    ``sum_duplicates`` leaves them as prefix views of the COO-sized arrays (duplicates included:
    at 100k faces 80 MB more). A buffer that nothing else views is shrunk in place
    (``ndarray.resize``: ``realloc``, which returns the tail to the system without copying;
    a copy costs the fresh memory's page faults, 0.4 s for 84 MB on the development VM);
    any other is copied. The values are unchanged.
    """
    for name in ("data", "indices"):
        view = getattr(M, name)
        base, n = view.base, view.size
        if not (isinstance(base, np.ndarray) and base.base is None and base.flags.owndata and base.ndim == 1
                and view.ndim == 1 and base.dtype == view.dtype and view.ctypes.data == base.ctypes.data
                and view.flags.c_contiguous):
            if base is not None:
                setattr(M, name, view.copy())
            continue
        setattr(M, name, base)
        del view
        if sys.getrefcount(base) > 3:  # viewed elsewhere (M's attribute, this name, the call's argument)
            setattr(M, name, base[:n].copy())
            continue
        base.resize(n, refcheck=False)  # no other reference: checked just above
