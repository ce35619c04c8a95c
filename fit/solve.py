"""Solver plumbing: a host sparse Cholesky inside optimistix's Gauss--Newton step.

The fitting problem is a least-squares problem ``min_x |r(x)|^2`` over the free
points ``x: (n, 3)``. Its quadratic, coordinate-separable part has the normal
matrix ``I_3 (x) H`` with one sparse SPD ``H: (n, n)`` shared by the three
coordinates. :class:`SparseCholesky` factors ``H`` once on the host (CHOLMOD via
``cholespy``, float64); :class:`FactorSolver` is a ``lineax`` linear solver that
optimistix's :class:`optimistix.GaussNewton` calls with the residual's Jacobian
``J``. It forms ``J^T r`` in JAX and then either

* ``mode="direct"``: applies ``H^{-1}`` through :func:`jax.pure_callback` -- exact
  when every residual is linear and separable (one Gauss--Newton step solves it);
* ``mode="pcg"``: runs conjugate gradients on ``J^T J`` preconditioned by ``H^{-1}``
  -- for nonlinear or coordinate-coupling terms (an angle-based tilt), whose
  Gauss--Newton matrix differs from ``H`` by a small, low-rank-ish update.

The solver reaches its factor through an integer handle (a traced array) and one
module-level host callback, never through a static field or a closure: so a second
problem of the same shapes reuses the compiled Gauss--Newton loop instead of tracing
and compiling it again (1-2 s per small fit).
"""
from __future__ import annotations

import ctypes
import itertools
import os
import sys
import threading
import time
import weakref
from typing import Any, Callable

import equinox as eqx
import jax
import jax.numpy as jnp
import lineax as lx
import numpy as np
import scipy.sparse as sp
from trispline.spline.util.memory import available_memory, page_size, thread_page_faults
from trispline.spline.util.spd import SPD_PARDISO_MIN, c_stdout_silenced, point_pypardiso_at_mkl, spd_backend

from .errors import NotPositiveDefinite, X64Error
from .limits import refuse_above
from .progress import Report, silent, span, watching

__all__ = ["SparseCholesky", "PatternAnalysis", "FactorSolver", "require_x64", "symmetric_from_upper", "estimate_factor_bytes",
           "pardiso_factor_bytes", "check_memory", "release_free_heap", "apply_factor"]

#: Live factors by handle (weak: a factor lives as long as its owner keeps it).
_FACTORS: "weakref.WeakValueDictionary[int, SparseCholesky]" = weakref.WeakValueDictionary()
_HANDLES = itertools.count()


def require_x64() -> None:
    """Raise :class:`X64Error` unless ``jax_enable_x64`` is on (fits need float64)."""
    if not jax.config.jax_enable_x64:
        raise X64Error(
            "trispline fits in float64: enable it first with "
            "jax.config.update('jax_enable_x64', True) (the CLI and tests do this)"
        )


#: Factorisation backends in order of preference; override with TRISPLINE_SOLVER.
BACKENDS = ("pardiso", "cholespy", "splu")


#: Below this many unknowns cholespy is faster (``spline.util.spd``, one home for both layers).
PARDISO_MIN_UNKNOWNS = SPD_PARDISO_MIN


def _pick_backend(requested: str | None, n: int) -> str:
    import importlib.util

    want = requested or os.environ.get("TRISPLINE_SOLVER") or "auto"
    if want not in ("auto",) + BACKENDS:
        raise ValueError(f"unknown solver backend {want!r}; choose from auto, {', '.join(BACKENDS)}")
    if want != "auto":
        return want
    choice = spd_backend(None, n)  # the same rule as the spline layer's SPD solves
    if choice == "cholespy" and importlib.util.find_spec("cholespy") is None:
        return "splu"  # pragma: no cover - cholespy is a dependency
    return choice


def symmetric_from_upper(U: sp.spmatrix) -> sp.csr_array:
    """The full symmetric matrix ``U + U^T - diag(U)`` of an upper triangle ``U (n, n)``, CSR."""
    H = sp.csr_array(U + U.T - sp.diags_array(U.diagonal()))
    H.sum_duplicates()
    H.sort_indices()
    return H


#: Factor entries per unknown and per ``log2`` of the unknowns: the fit matrices' nested-dissection
#: fill. PARDISO's analysis (METIS ordering) of the benchmark scans found 8.7, 9.0, 9.4, 9.8, 9.9
#: at 10k, 25k, 50k, 100k, 200k faces (55k to 1.1M unknowns).
FILL_PER_LOG2 = 10.0
#: Bytes per factor entry: PARDISO's numerical phase allocated 9.1 per entry of its factor
#: (a float64 value and its share of the supernode tables).
FACTOR_ENTRY_BYTES = 9
#: Bytes of one factor entry's value (float64): the numerical phase's progress is the share of
#: ``FACTOR_VALUE_BYTES * nnz(L)`` written (:meth:`SparseCholesky._factor_pardiso`).
FACTOR_VALUE_BYTES = 8
#: Names of the threads MKL's OpenMP runtime (Intel's) runs PARDISO's numerical phase on.
MKL_THREAD_PREFIXES = ("openmp_worker", "omp_")


def estimate_factor_bytes(n: int, nnz_upper: int) -> int:
    """Estimated bytes of a sparse Cholesky factor of an ``(n, n)`` fit matrix, without analysing it.

    The fit's normal matrices are 2D-mesh matrices (each unknown couples with ~38 others);
    nested dissection fills them to about ``FILL_PER_LOG2 n log2 n`` entries, or at least
    their upper triangle's ``nnz_upper``. Used for the backends that report nothing
    before factoring (cholespy, splu); PARDISO reports its own (:func:`pardiso_factor_bytes`).
    """
    fill = FILL_PER_LOG2 * n * np.log2(max(n, 2))
    return int(FACTOR_ENTRY_BYTES * max(fill, nnz_upper))


def pardiso_factor_bytes(iparm: np.ndarray) -> int:
    """Bytes PARDISO's numerical factorisation will allocate, from its analysis report ``iparm``.

    MKL (0-based ``iparm`` after phase 11): ``iparm[16]`` is the memory of the numerical
    factorisation and solution in KB; the analysis's own (``iparm[14]`` peak, ``iparm[15]``
    kept) is already allocated by then.
    """
    return 1024 * int(iparm[16])


def release_free_heap() -> None:
    """Hand the C heap's free memory back to the system (glibc ``malloc_trim``; elsewhere nothing),
    and MKL's unused buffers first where PARDISO has run (``mkl_free_buffers``).

    The assembly's chunks, run on a thread each, leave freed memory in the threads' malloc
    arenas: at 100k faces 430 MB of the 1.2 GB resident after assembling, which the
    factorisation would otherwise sit on top of. MKL keeps what PARDISO's analysis freed in
    its own pools: ~50 MB of the 100k-face fit's peak (the step), measured as the mean of four runs.
    """
    if "pypardiso" in sys.modules and os.environ.get("PYPARDISO_MKL_RT"):  # MKL loaded by PARDISO already
        try:
            ctypes.CDLL(os.environ["PYPARDISO_MKL_RT"]).mkl_free_buffers()
        except (OSError, AttributeError):  # pragma: no cover - another MKL
            pass
    try:
        ctypes.CDLL("libc.so.6").malloc_trim(0)
    except (OSError, AttributeError):  # pragma: no cover - not glibc
        pass


def check_memory(estimate: int, max_bytes: int | str | None) -> None:
    """Raise :class:`~trispline.fit.errors.FactorMemoryError` when ``estimate`` bytes exceed ``max_bytes``.

    ``max_bytes``: bytes, ``"available"`` (:func:`trispline.spline.util.memory.available_memory`
    now) or None (no check).
    """
    refuse_above(estimate, available_memory() if max_bytes == "available" else max_bytes,
                 "the sparse factorisation of this fit")


class SparseCholesky:
    """Sparse Cholesky factor of an SPD matrix, solved on the host.

    Parameters
    ----------
    H : scipy sparse (n, n), symmetric positive definite: both triangles stored, or only
        the upper one (diagonal included) with ``upper=True``
    backend : ``"pardiso"``, ``"cholespy"``, ``"splu"`` or None (auto: PARDISO from
        :data:`PARDISO_MIN_UNKNOWNS` unknowns when installed, else cholespy; env ``TRISPLINE_SOLVER``)
    upper : ``H`` holds only its upper triangle
    max_bytes : refuse with :class:`~trispline.fit.errors.FactorMemoryError` when the
        factorisation's estimated memory (:attr:`estimate`, known after the symbolic
        analysis and before any numerical work) exceeds this; ``"available"``: the
        memory the system has available now (:func:`available_memory`); None: no check
    report : progress (:mod:`trispline.fit.progress`): PARDISO's analysis done
    defer : stop after the analysis and the memory check; :meth:`factorize` finishes
    ordering : ``(n,)`` elimination order (new position -> row) for PARDISO instead of its own
        METIS ordering (:func:`~trispline.fit.ordering.patch_ordering`); the other backends order
        the matrix themselves

    Notes
    -----
    Backends, fastest first (measured on the 50k-face fit matrix, 277k unknowns,
    47M nonzeros in the factor, 24.5 GFlop, same machine and load):
    ``pardiso`` (MKL PARDISO via the ``pypardiso`` wheel: METIS ordering, optimised
    BLAS, threads) 5.5 s; ``cholespy`` (bundled CHOLMOD, which links the reference
    netlib BLAS) 15.5 s; ``scipy.sparse.linalg.splu`` as the last resort.
    PARDISO analyses first (phase 11: ordering and symbolic factorisation, which
    report the factor's size) and factors numerically after the memory check (phase
    22); the other backends are estimated by :func:`estimate_factor_bytes`.
    """

    def __init__(self, H: sp.spmatrix, backend: str | None = None, *, upper: bool = False,
                 max_bytes: int | str | None = None, report: Report | None = None, defer: bool = False,
                 ordering: np.ndarray | None = None) -> None:
        H = sp.csr_matrix(H, dtype=np.float64)
        if H.shape[0] != H.shape[1]:
            raise ValueError(f"H must be square, got {H.shape}")
        H.sum_duplicates()
        H.sort_indices()
        self.n = int(H.shape[0])
        self.handle = next(_HANDLES)
        _FACTORS[self.handle] = self
        self.backend = _pick_backend(backend, self.n)
        self.analysis_seconds = 0.0
        #: Called after every solve (also those of a compiled step's host callbacks): progress.
        self.on_solve: Callable[[], None] | None = None
        U = H if upper else sp.triu(H, format="csr")
        #: Estimated bytes of the numerical factorisation (PARDISO: its own analysis).
        self.estimate = estimate_factor_bytes(self.n, U.nnz)
        if self.backend == "pardiso":
            self._analyse_pardiso(U, ordering)
            (report or silent)(0.5)  # the analysis takes about half of the time
        check_memory(self.estimate, max_bytes)
        self._pending: sp.csr_matrix | None = U
        if not defer:
            self.factorize(span(report, 0.5, 1.0))

    def factorize(self, report: Report | None = None) -> None:
        """The numerical factorisation (done by the constructor unless ``defer``; then once, here).

        ``report``: progress while PARDISO factors (:meth:`_factor_pardiso`); the other backends report
        nothing until they end."""
        U, self._pending = self._pending, None
        if U is None:
            return
        if self.backend == "pardiso":
            self._factor_pardiso(report)
        elif self.backend == "cholespy":
            import cholespy

            L = sp.csr_matrix(U.T)  # cholespy reads the lower triangle of a CSR matrix
            L.sort_indices()
            try:
                with c_stdout_silenced():  # CHOLMOD prints its own warning to stdout before raising
                    self._solver = cholespy.CholeskySolverD(self.n, L.indptr.astype(np.int32),
                                                            L.indices.astype(np.int32), np.ascontiguousarray(L.data),
                                                            cholespy.MatrixType.CSR)
            except ValueError as exc:  # "Matrix is not positive definite!"
                raise NotPositiveDefinite(f"the normal matrix is not positive definite ({exc})") from exc
        else:
            import scipy.sparse.linalg as spla

            self._solver = spla.splu(symmetric_from_upper(U).tocsc())

    def same_pattern(self, H_upper: sp.spmatrix) -> bool:
        """Whether the upper triangle ``H_upper`` has the pattern this (deferred) factor was analysed on."""
        U = self._pending
        return (U is not None and H_upper.shape == U.shape and H_upper.nnz == U.nnz
                and np.array_equal(H_upper.indptr, U.indptr) and np.array_equal(H_upper.indices, U.indices))

    def set_values(self, H_upper: sp.spmatrix) -> None:
        """Factor the upper triangle ``H_upper`` instead of the matrix analysed: same pattern (checked),
        other values. For a factor made with ``defer``, before :meth:`factorize`; the analysis reads
        only the pattern (see :class:`PatternAnalysis`)."""
        if not self.same_pattern(H_upper):
            raise ValueError("set_values needs a matrix of the analysed pattern, before factorize()")
        U = sp.csr_matrix(H_upper, dtype=np.float64)
        self._pending = U
        if self.backend == "pardiso":
            self._hold(U)  # the pattern's own arrays are released

    def refactor(self, H_upper: sp.spmatrix) -> bool:
        """Factor the upper triangle ``H_upper`` in place of this factor's matrix, reusing PARDISO's
        analysis (the numerical phase alone): True; False, with nothing done, for another backend, a
        deferred factor or another pattern. For a sequence of matrices of one pattern (the data weights
        of a cross-validation, 12 factors of 27k unknowns: 2.5 s against 11-13 s afresh)."""
        if self.backend != "pardiso" or self._pending is not None:
            return False
        U = sp.csr_matrix(H_upper, dtype=np.float64)
        U.sum_duplicates()
        U.sort_indices()
        H = self._upper
        if not (U.shape == H.shape and U.nnz == H.nnz and np.array_equal(U.indptr, H.indptr)
                and np.array_equal(U.indices, H.indices)):
            return False
        self._hold(U)
        self._factor_pardiso()
        return True

    def _hold(self, U: sp.csr_matrix) -> None:
        """Keep the upper triangle ``U`` that PARDISO reads in every phase, with its indices as int32
        (the matrix's own arrays where they are int32: pypardiso's call made one-based copies on every phase)."""
        self._upper = U
        self._ia = np.ascontiguousarray(U.indptr, dtype=np.int32)
        self._ja = np.ascontiguousarray(U.indices, dtype=np.int32)

    def _analyse_pardiso(self, U: sp.csr_matrix, ordering: np.ndarray | None = None) -> None:
        """PARDISO phase 11 on the upper triangle ``U`` (in the elimination ``ordering``, or METIS's);
        sets :attr:`estimate` from its report."""
        point_pypardiso_at_mkl()  # before the import: importing pypardiso makes a solver
        import pypardiso

        self._hold(U)
        self._solver = pypardiso.PyPardisoSolver(mtype=2)  # real symmetric positive definite
        # PARDISO's defaults for the type (pypardiso leaves iparm[0] = 0, which makes PARDISO
        # ignore every other setting), then no iterative refinement in its solves: two steps
        # by default, each a product with H and a solve, which made a solve 3-4x slower and
        # bought nothing -- H as assembled is the limit (FactorSolver.refine works against J)
        solver = self._solver
        solver.libmkl.pardisoinit(solver.pt.ctypes.data_as(ctypes.c_void_p), ctypes.byref(ctypes.c_int32(2)),
                                  solver.iparm.ctypes.data_as(ctypes.c_void_p))
        solver.iparm[7] = 0
        solver.iparm[34] = 1  # zero-based indices: the matrix's own (no one-based copies, 44 MB at 100k faces)
        if ordering is not None:
            if ordering.shape != (self.n,):
                raise ValueError(f"ordering must have shape ({self.n},), got {ordering.shape}")
            solver.perm = np.ascontiguousarray(ordering, dtype=np.int32)  # PARDISO reads new position -> row
            solver.iparm[4] = 1  # the caller's ordering
        start = time.perf_counter()
        self._pardiso(11)
        #: Wall seconds of PARDISO's analysis (0 for the other backends).
        self.analysis_seconds = time.perf_counter() - start
        self.estimate = pardiso_factor_bytes(self._solver.iparm)

    def _factor_pardiso(self, report: Report | None = None) -> None:
        """PARDISO phase 22: the numerical factorisation.

        ``report``: the share of the factor's entries written so far: the pages first touched by the
        calling thread and MKL's OpenMP workers (:data:`MKL_THREAD_PREFIXES`), which write the factor's
        columns as they compute them (at 50k faces 92k pages = 370 MB against 360 MB of entries, rising
        through the whole phase), polled beside the call (:func:`~trispline.fit.progress.watching`); the
        pages other threads touch meanwhile (the step's compile) do not count. MKL's own progress
        callback cost 16 us a call and is called ~10^5 times (at 100k faces the phase 1.3 -> 3.0 s).
        """
        import pypardiso

        entries = FACTOR_VALUE_BYTES * max(int(self._solver.iparm[17]), 1) / page_size()  # pages of values
        caller: set[int] = set()
        start = thread_page_faults(caller, MKL_THREAD_PREFIXES)

        def factor() -> None:
            caller.add(threading.get_native_id())
            self._pardiso(22)

        def written() -> float:
            now = thread_page_faults(caller, MKL_THREAD_PREFIXES)
            return 0.0 if now is None or start is None else (now - start) / entries

        try:
            watching(factor, written, report)
        except pypardiso.pardiso_wrapper.PyPardisoError as exc:  # -4: zero or negative pivot
            raise NotPositiveDefinite(f"the normal matrix is not positive definite ({exc})") from exc

    def _pardiso(self, phase: int, b: np.ndarray | None = None) -> np.ndarray:
        """One PARDISO phase on the stored upper triangle; ``b (n, k)`` Fortran order for phase 33.

        MKL's ``pardiso`` called directly with the matrix's zero-based int32 indices
        (pypardiso's ``_call_pardiso`` makes one-based copies each time).
        """
        import pypardiso

        s, U = self._solver, self._upper
        b = np.zeros((self.n, 1)) if b is None else b
        x = np.zeros_like(b)
        err = ctypes.c_int32(0)
        i32, f64 = ctypes.POINTER(ctypes.c_int32), ctypes.POINTER(ctypes.c_double)
        one = ctypes.byref(ctypes.c_int32(1))
        s._mkl_pardiso(s.pt.ctypes.data_as(ctypes.POINTER(s._pt_type[0])), one, one,  # maxfct, mnum
                       ctypes.byref(ctypes.c_int32(s.mtype)), ctypes.byref(ctypes.c_int32(phase)),
                       ctypes.byref(ctypes.c_int32(self.n)), U.data.ctypes.data_as(f64),
                       self._ia.ctypes.data_as(i32), self._ja.ctypes.data_as(i32), s.perm.ctypes.data_as(i32),
                       ctypes.byref(ctypes.c_int32(b.shape[1] if b.ndim == 2 else 1)),
                       s.iparm.ctypes.data_as(i32), ctypes.byref(ctypes.c_int32(0)),  # msglvl: silent
                       b.ctypes.data_as(f64), x.ctypes.data_as(f64), ctypes.byref(err))
        if err.value != 0:
            raise pypardiso.pardiso_wrapper.PyPardisoError(err.value)
        return x

    def solve(self, b: np.ndarray) -> np.ndarray:
        """``H^{-1} b`` for ``b: (n,)`` or ``(n, k)``; calls :attr:`on_solve` (when set) after it."""
        x = self._solve(b)
        if self.on_solve is not None:
            self.on_solve()
        return x

    def _solve(self, b: np.ndarray) -> np.ndarray:
        if self.backend == "pardiso":  # one copy in (Fortran order), one out
            b = np.asarray(b, dtype=np.float64)
            x = self._pardiso(33, np.asfortranarray(b.reshape(self.n, -1)))
            return np.ascontiguousarray(x).reshape(b.shape)
        b = np.array(b, dtype=np.float64, order="C", copy=True)
        if self.backend == "splu":
            return self._solver.solve(b)
        x = np.zeros_like(b)
        self._solver.solve(b, x)
        return x

    def __del__(self) -> None:
        if getattr(self, "backend", None) == "pardiso" and hasattr(self, "_solver"):
            try:
                self._solver.free_memory(everything=True)
            except Exception:  # pragma: no cover - interpreter shutdown
                pass

    def jax_solve(self, b: jax.Array) -> jax.Array:
        """``H^{-1} b`` inside traced JAX code (host callback)."""
        return apply_factor(jnp.asarray(self.handle), b)


class PatternAnalysis:
    """The factorisation's analysis started on the normal matrix's pattern alone, in a background thread.

    PARDISO's analysis (the METIS ordering and the symbolic factorisation: at 100k faces 4 s of
    the factor stage's 6, mostly on one core) reads only the pattern, which the mesh fixes before
    any term is set up: started then (:meth:`start`), it runs while the assembly computes the
    values, whose own stages leave a core idle for a good part of their time. :meth:`factor`
    waits for it, checks the memory the numerical phase needs, and factors the assembled values.
    The factor is the one a plain :class:`SparseCholesky` of the values makes (same ordering,
    same numbers); without a started analysis, or for another pattern, :meth:`factor` is exactly that.
    """

    def __init__(self) -> None:
        self._thread: threading.Thread | None = None
        self._factor: SparseCholesky | None = None
        self._error: BaseException | None = None
        self.wait_seconds = 0.0

    def start(self, pattern: sp.spmatrix | Callable[[], sp.spmatrix],
              ordering: Callable[[], np.ndarray | None] | None = None) -> None:
        """Start analysing the upper triangle ``pattern (k, k)`` (diagonal included; values unused), or the
        one a callable ``pattern()`` returns: then it is made in the background thread too (the fit's
        :func:`~trispline.fit.energy.normal.upper_pattern`, 1-2 CPU s at 100k faces on one core, which
        the main thread had run alone before the terms' setup could start). ``ordering()``: the elimination
        order (:func:`~trispline.fit.ordering.patch_ordering`, made in the background thread after the
        pattern), or None for PARDISO's own."""
        def analyse() -> None:
            try:
                # the factor's float64 copy made here, so that a caller's (float32 counts: 41 MB at 100k
                # faces) is not held beside it for the whole analysis
                upper = sp.csr_matrix(pattern() if callable(pattern) else pattern, dtype=np.float64)
                order = None if ordering is None else ordering()
                self._factor = SparseCholesky(upper, upper=True, defer=True, ordering=order)
            except BaseException as exc:  # noqa: BLE001 - re-raised by factor()
                self._error = exc

        self._thread = threading.Thread(target=analyse, name="trispline-analysis", daemon=True)
        self._thread.start()

    def factor(self, H_upper: sp.spmatrix, *, max_bytes: int | str | None = None,
               report: Report | None = None) -> SparseCholesky:
        """The factor of the upper triangle ``H_upper`` (see :class:`SparseCholesky` for the arguments)."""
        if self._thread is not None:
            start = time.perf_counter()
            self._thread.join()
            #: Seconds :meth:`factor` waited for the analysis (the rest of it overlapped the assembly).
            self.wait_seconds = time.perf_counter() - start
            fac, self._factor, self._thread = self._factor, None, None
            if self._error is not None:
                raise self._error
            if fac.same_pattern(H_upper):
                (report or silent)(0.5)
                check_memory(fac.estimate, max_bytes)
                fac.set_values(H_upper)
                fac.factorize(span(report, 0.5, 1.0))
                return fac
        return SparseCholesky(H_upper, upper=True, max_bytes=max_bytes, report=report)


def _host_solve(handle: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The one host callback: solve with the live factor ``handle``."""
    return _FACTORS[int(handle)].solve(np.asarray(b, dtype=np.float64))


def apply_factor(handle: jax.Array, b: jax.Array) -> jax.Array:
    """``H^{-1} b`` for ``b (n, ...)`` with the factor ``handle``, from traced code."""
    x = jax.pure_callback(_host_solve, jax.ShapeDtypeStruct((b.shape[0], b.size // max(b.shape[0], 1)), jnp.float64),
                          handle, b.reshape(b.shape[0], -1), vmap_method="sequential")
    return x.reshape(b.shape)


def _dot(a: jax.Array, b: jax.Array) -> jax.Array:
    return jnp.vdot(a, b)


class FactorSolver(lx.AbstractLinearSolver):
    """Least-squares solve ``J y ~ r`` through the normal equations with a fixed factor.

    Parameters
    ----------
    factor : SparseCholesky of ``H``, the (exact or approximate) ``J^T J`` per coordinate
        (kept alive by the caller; the solver holds its handle only), or such a factor's
        handle (an integer array, possibly traced: one compiled program serves any factor)
    mode : ``"direct"`` (``y = H^{-1} J^T r``) or ``"pcg"``
    rtol : relative residual tolerance of the preconditioned CG
    max_steps : CG iteration cap
    refine : ``"direct"`` only: steps of iterative refinement against ``J`` itself,
        ``y += H^{-1} J^T (r - J y)``. The factor is of ``H`` as assembled, whose rounding
        limits a plain solve to ``~cond(H) eps`` (5e-12 on a 150-vertex height field whose
        x and y must come back exactly); one refinement step against the residuals' own
        Jacobian brings the solve to their rounding (1e-15), for one more ``J``, ``J^T``
        product and host solve.
    """

    handle: jax.Array
    mode: str = eqx.field(static=True)
    rtol: float = eqx.field(static=True)
    max_steps: int = eqx.field(static=True)
    refine: int = eqx.field(static=True)

    def __init__(self, factor: SparseCholesky | jax.Array | int, mode: str = "direct", rtol: float = 1e-8,
                 max_steps: int = 200, refine: int = 0):
        if mode not in ("direct", "pcg"):
            raise ValueError(f"mode must be 'direct' or 'pcg', got {mode!r}")
        self.handle = jnp.asarray(factor.handle if isinstance(factor, SparseCholesky) else factor)
        self.mode = mode
        self.rtol = rtol
        self.max_steps = max_steps
        self.refine = int(refine)

    @property
    def factor(self) -> SparseCholesky:
        """The factor (outside traced code)."""
        return _FACTORS[int(self.handle)]

    def init(self, operator: lx.AbstractLinearOperator, options: dict[str, Any]):
        return operator

    def compute(self, state, vector, options):
        J = state
        JT = J.transpose()
        g = JT.mv(vector)
        apply_h_inv = lambda v: apply_factor(self.handle, v)  # noqa: E731
        if self.mode == "direct":
            y = apply_h_inv(g)
            for _ in range(self.refine):
                y = y + apply_h_inv(JT.mv(jax.tree_util.tree_map(jnp.subtract, vector, J.mv(y))))
            return y, lx.RESULTS.successful, {"cg_steps": jnp.asarray(0)}
        normal = lambda v: JT.mv(J.mv(v))  # noqa: E731
        y0 = apply_h_inv(g)
        r0 = g - normal(y0)
        z0 = apply_h_inv(r0)
        gnorm = jnp.sqrt(_dot(g, g))
        tol = self.rtol * gnorm

        def cond(c):
            _, r, _, _, _, k = c
            return (jnp.sqrt(_dot(r, r)) > tol) & (k < self.max_steps)

        def body(c):
            y, r, z, p, rz, k = c
            Ap = normal(p)
            alpha = rz / _dot(p, Ap)
            y = y + alpha * p
            r = r - alpha * Ap
            z = apply_h_inv(r)
            rz_new = _dot(r, z)
            p = z + (rz_new / rz) * p
            return y, r, z, p, rz_new, k + 1

        rz0 = _dot(r0, z0)
        y, r, _, _, _, k = jax.lax.while_loop(cond, body, (y0, r0, z0, z0, rz0, jnp.asarray(0)))
        # an inexact step is still a descent direction (inexact Gauss--Newton); the
        # outer iteration and fit_surface's stationarity check decide convergence
        return y, lx.RESULTS.successful, {"cg_steps": k}

    def transpose(self, state, options):
        return state.transpose(), options

    def conj(self, state, options):
        return state, options

    def assume_full_rank(self) -> bool:
        return True
