"""One sparse symmetric positive definite solve for the layers below ``fit`` (param's LSCM).

``fit.solve.FactorSolver`` is the fit's own factorisation (kept factors, memory checks,
lineax); ``param`` may not import ``fit``, so its one-shot solves come here: MKL PARDISO
(METIS ordering, multithreaded) through ``pypardiso`` where installed and the system is
large, else cholespy's CHOLMOD. Measured on the LSCM system of a 1M-face scan (1M
unknowns, 2 cores): PARDISO 5.3 s, CHOLMOD 18 s, libigl's own ``igl.lscm`` 76 s.
"""
from __future__ import annotations

import ctypes
import functools
import importlib.util
import os
import sys
import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager

import numpy as np
import scipy.sparse as sp

__all__ = ["SPD_BACKENDS", "SPD_PARDISO_MIN", "c_stdout_silenced", "point_pypardiso_at_mkl", "solve_spd", "spd_backend",
           "spd_factor"]

#: The backends of :func:`solve_spd`.
SPD_BACKENDS = ("pardiso", "cholespy")
#: Unknowns from which PARDISO is used when installed (here and by ``fit.solve``): below, its
#: ~0.3 s start-up costs more than CHOLMOD. Measured on fit matrices (factor + solve, cholespy vs
#: PARDISO): 4.5k unknowns 0.04 vs 0.31 s, 11k 0.12 vs 0.35 s, 55k 1.07 vs 0.75 s, 165k 6.5 vs 1.9 s.
SPD_PARDISO_MIN = 30_000


@functools.lru_cache(maxsize=None)
def point_pypardiso_at_mkl() -> None:
    """Tell pypardiso where MKL's runtime library is (its documented ``PYPARDISO_MKL_RT``), once.

    Where ``ctypes`` cannot find ``mkl_rt`` (a wheel install), pypardiso walks every folder under
    ``sys.prefix`` for it each time a solver is made, its import included (0.35 s of a 100k-face
    LSCM, 1-2 s of a fit). The wheel puts it in ``sys.prefix/lib``. Used by ``fit.solve`` too.
    """
    if os.environ.get("PYPARDISO_MKL_RT"):
        return
    import ctypes.util
    import glob
    import sys

    found = min(glob.glob(f"{sys.prefix}/lib/libmkl_rt*"), key=len, default=None) or ctypes.util.find_library("mkl_rt")
    if found:
        os.environ["PYPARDISO_MKL_RT"] = found


def spd_backend(requested: str | None, n: int, *, pardiso_min: int = SPD_PARDISO_MIN) -> str:
    """The backend for ``n`` unknowns: ``requested``, or PARDISO from ``pardiso_min`` unknowns
    (default :data:`SPD_PARDISO_MIN`; a caller whose matrix fills more, like the uv smoothing's,
    lowers it) when installed, else cholespy (one rule for both layers: ``fit.solve`` asks it too)."""
    if requested is not None:
        if requested not in SPD_BACKENDS:
            raise ValueError(f"unknown backend {requested!r}; choose from {', '.join(SPD_BACKENDS)}")
        return requested
    if n >= pardiso_min and importlib.util.find_spec("pypardiso") is not None:
        return "pardiso"
    return "cholespy"


def solve_spd(A: sp.spmatrix, b: np.ndarray, *, backend: str | None = None,
              pardiso_min: int = SPD_PARDISO_MIN) -> np.ndarray:
    """``A^{-1} b`` for a sparse symmetric positive definite ``A (n, n)`` and ``b (n,)`` or
    ``(n, k)``; the same shape.

    Only ``A``'s upper triangle is read. ``backend``: ``"pardiso"``, ``"cholespy"`` or None
    (:func:`spd_backend`'s rule, with ``pardiso_min``). Raises :class:`numpy.linalg.LinAlgError`
    when ``A`` is not positive definite (either backend).
    """
    with spd_factor(A, backend=backend, pardiso_min=pardiso_min) as solve:
        return solve(b)


@contextmanager
def spd_factor(A: sp.spmatrix, *, backend: str | None = None, pardiso_min: int = SPD_PARDISO_MIN
               ) -> Iterator[Callable[[np.ndarray], np.ndarray]]:
    """:func:`solve_spd`'s factorisation of ``A (n, n)`` kept for several right-hand sides: yields
    ``solve(b) -> A^{-1} b`` (``b (n,)`` or ``(n, k)``), valid inside the ``with`` block (PARDISO's
    memory is freed at its end). Raises :class:`numpy.linalg.LinAlgError` when ``A`` is not positive
    definite (at the factorisation or, for PARDISO, the first solve)."""
    n = A.shape[0]
    U = sp.triu(sp.csr_matrix(A, dtype=np.float64), format="csr")
    U.sum_duplicates()
    U.sort_indices()
    if spd_backend(backend, n, pardiso_min=pardiso_min) == "pardiso":
        point_pypardiso_at_mkl()  # before the import: importing pypardiso makes a solver
        import pypardiso

        solver = pypardiso.PyPardisoSolver(mtype=2)  # real symmetric positive definite: the upper triangle
        error = pypardiso.pardiso_wrapper.PyPardisoError  # -4: a zero or negative pivot

        def solve(b: np.ndarray) -> np.ndarray:  # the kept factor (pypardiso compares U with the factored matrix)
            try:
                return np.asarray(solver.solve(U, np.ascontiguousarray(b, dtype=np.float64)), dtype=np.float64)
            except error as exc:
                raise np.linalg.LinAlgError(f"the matrix is not positive definite (PARDISO error {exc})") from exc

        try:
            try:
                solver.factorize(U)  # once: solve() alone factors again at every call (0.23 s a solve at 100k faces)
            except error as exc:
                raise np.linalg.LinAlgError(f"the matrix is not positive definite (PARDISO error {exc})") from exc
            yield solve
        finally:
            solver.free_memory(everything=True)
        return
    import cholespy

    L = sp.csr_matrix(U.T)  # cholespy reads the lower triangle of a CSR matrix
    L.sort_indices()
    try:
        with c_stdout_silenced():  # CHOLMOD prints its own warning to stdout before raising
            factor = cholespy.CholeskySolverD(n, L.indptr.astype(np.int32), L.indices.astype(np.int32),
                                              np.ascontiguousarray(L.data), cholespy.MatrixType.CSR)
    except ValueError as exc:  # cholespy's "Matrix is not positive definite!"
        if "positive definite" not in str(exc):
            raise
        raise np.linalg.LinAlgError(f"the matrix is not positive definite ({exc})") from exc

    def solve(b: np.ndarray) -> np.ndarray:
        b = np.ascontiguousarray(b, dtype=np.float64)
        x = np.zeros_like(b)
        factor.solve(b, x)
        return x

    yield solve


#: One redirection of descriptor 1 at a time: two overlapping ones would restore each other's null device.
_STDOUT_LOCK = threading.Lock()


@contextmanager
def c_stdout_silenced() -> Iterator[None]:
    """File descriptor 1 onto the null device while C code runs (C's buffers flushed on both sides), so
    that a library's ``printf`` cannot add a stray line to the command line's one message."""
    libc = ctypes.CDLL(None)
    with _STDOUT_LOCK:
        if sys.stdout is not None:
            sys.stdout.flush()
        libc.fflush(None)
        try:
            saved = os.dup(1)
        except OSError:  # no descriptor 1 at all: nothing to keep clean
            saved = None
        if saved is None:
            yield
            return
        null = os.open(os.devnull, os.O_WRONLY)
        try:
            os.dup2(null, 1)
            yield
        finally:
            libc.fflush(None)
            os.dup2(saved, 1)
            os.close(saved)
            os.close(null)
