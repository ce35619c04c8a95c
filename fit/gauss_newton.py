"""Minimising the fit's energy with optimistix Gauss--Newton, its linear solve the host factor.

* Quadratic energy (the default terms): Gauss--Newton is exact in one step from zero,
  ``x = H^{-1} J^T r`` with ``J^T J = H`` (the factor). :class:`QuadraticStep` runs exactly
  that one optimistix step and the terms' energies at its result in one compiled
  program. Its shapes are known once the problem is assembled, so it is traced and
  compiled in a background thread while the host factorises (tracing is Python, XLA's
  compile and the factorisation release the GIL): at 100k faces the 1.5 s compile
  hides behind the factorisation's analysis, which runs on one core.
* Nonlinear terms (``angle``) or a solver of the caller's: iterate from the linear
  terms' optimum (one host solve) until optimistix converges, with the factor as the
  preconditioner of CG on ``J^T J`` (:class:`~trispline.fit.solve.FactorSolver` ``"pcg"``)
  and a backtracking line search (:class:`DescentGaussNewton`, also the approximation's robust fit's).

Both check convergence independently of optimistix: the gradient relative to the
gradient at zero (``H x - rhs`` for a quadratic, JAX's gradient otherwise).
"""
from __future__ import annotations

import threading
from typing import Any, Callable

import jax
import jax.numpy as jnp
import numpy as np
import optimistix as optx

from trispline.spline.tolerances import CONVERGED_GRAD_RTOL, GN_ATOL, GN_RTOL

from . import energy as en
from .solve import FactorSolver, SparseCholesky, apply_factor, release_free_heap

__all__ = ["QuadraticStep", "iterate", "DescentGaussNewton"]


def _quiet(**info) -> None:
    """optimistix's per-step report: nothing."""


class DescentGaussNewton(optx.AbstractGaussNewton):
    """Gauss--Newton with a backtracking Armijo line search (optimistix's ``GaussNewton`` takes every full step).

    The fit layer's descending Gauss--Newton: a step whose linear solve underestimates the curvature
    overshoots, and the search halves it until it lowers the objective enough, so the iteration
    descends to the same minimum from any start. The approximation's robust fit
    (:mod:`trispline.fit.approx.fit`) solves with the reweighted factor of its start, whose weights are
    the robust loss's at an earlier fit: where a residual has fallen below its scale since, that factor
    underestimates the curvature (by up to the old residual over the scale). Without the search it
    climbed: on the noise-free 1M generated scan with ``corners="fit"`` (10k coarse vertices) its 50
    steps ended at 23x the start's objective and 41x farther from the true surface (RMS 1.0e-5 of the
    diagonal against 2.5e-7; with the search 1.1e-7), at 100k faces 2% above it (7.7e-6 against
    2.1e-6); a 60-vertex bumps scan started at mismatched weights climbed to 11x.
    """

    rtol: float
    atol: float
    norm: Callable
    descent: optx.NewtonDescent
    search: optx.BacktrackingArmijo
    verbose: Callable

    def __init__(self, rtol: float, atol: float, norm: Callable, linear_solver: FactorSolver):
        self.rtol, self.atol, self.norm = rtol, atol, norm
        self.descent = optx.NewtonDescent(linear_solver=linear_solver)
        self.search = optx.BacktrackingArmijo()
        self.verbose = _quiet


def _gauss_newton(linear_solver: FactorSolver) -> optx.GaussNewton:
    return optx.GaussNewton(rtol=GN_RTOL, atol=GN_ATOL, norm=optx.rms_norm, linear_solver=linear_solver)


def _residuals_aux(x: jax.Array, args: dict) -> tuple[dict[str, jax.Array], None]:
    return en.residuals(x, args), None


def _half_sum_squares(x: jax.Array, args: dict) -> jax.Array:
    return 0.5 * sum(jnp.sum(r * r) for r in en.residuals(x, args).values())


def _one_step(x0: jax.Array, args: dict, handle: jax.Array) -> tuple[jax.Array, dict]:
    """One optimistix Gauss--Newton step from ``x0 (k, 3)``, refined once, and the energies at its result.

    The solver's own ``init`` and ``step``, without ``optimistix.least_squares``'s loop:
    the loop would evaluate the step's result only in a second step (to test convergence),
    which a quadratic does not need, and its carried state cost 190 MB of XLA temporaries
    at 100k faces (769 against 581 MB). The step's proposed point ``x1 = state.y_eval`` is
    refined once against ``J`` with the same factor, ``x = x1 - H^{-1} J^T r(x1)``, so linear
    data come back to rounding: the refinement of ``FactorSolver(refine=1)`` (there
    ``J^T (r(x0) - J y)``, for a linear ``r`` the same ``J^T r(x1)``), here taken after the step,
    where the step's residuals at ``x0`` are dead: at 100k faces 412 against 510 MiB of XLA
    temporaries, the control points equal to ~1e-15 of their size.
    """
    solver = _gauss_newton(FactorSolver(handle, mode="direct"))
    f_struct = jax.eval_shape(en.residuals, x0, args)
    state = solver.init(_residuals_aux, x0, args, {}, f_struct, None, frozenset())
    _, state, _ = solver.step(_residuals_aux, x0, args, {}, state, frozenset())
    x1 = state.y_eval
    x = x1 - apply_factor(handle, jax.grad(_half_sum_squares)(x1, args))
    return x, en.energies(x, args)


#: XLA:CPU options for the step, tried in this order (an XLA that lacks one refuses it; then the next):
#: its memory-optimised scheduler (at 100k faces 508 against 613 MB of temporaries) and no
#: XNNPACK/YNNPACK dot fusions (their packed operands lie outside those temporaries: the process's
#: rise during the step 0.58 against 0.74-0.78 GB; 10% less CPU; other roundings of the dots, the step
#: equal to 2e-13 of its largest value), then the scheduler alone (bit-identical to the default compile).
#: First of all also without XLA's common-subexpression pass: it merged the step's equal zero arrays (the
#: bases of the transposed gathers' scatters, 93 MB at 100k faces), so each scatter wrote into a copy
#: while the one broadcast stayed alive to the end (with the refinement after the step: 282.6 against
#: 412.0 MiB of temporaries at 100k faces; the same numbers)
CPU_COMPILER_OPTIONS: tuple[dict[str, str], ...] = (
    {"xla_cpu_scheduler_type": "CPU_SCHEDULER_TYPE_MEMORY_OPTIMIZED",
     "xla_cpu_experimental_ynn_fusion_type": "", "xla_cpu_experimental_xnn_fusion_type": "",
     "xla_disable_hlo_passes": "cse"},
    {"xla_cpu_scheduler_type": "CPU_SCHEDULER_TYPE_MEMORY_OPTIMIZED",
     "xla_cpu_experimental_ynn_fusion_type": "", "xla_cpu_experimental_xnn_fusion_type": ""},
    {"xla_cpu_scheduler_type": "CPU_SCHEDULER_TYPE_MEMORY_OPTIMIZED"},
)


def _compile(lowered: Any) -> Any:
    """``lowered.compile()`` with the first of :data:`CPU_COMPILER_OPTIONS` XLA accepts (CPU backend only)."""
    if jax.default_backend() == "cpu":
        for options in CPU_COMPILER_OPTIONS:
            try:
                return lowered.compile(compiler_options=options)
            except (RuntimeError, ValueError):  # pragma: no cover - an XLA without the option
                continue
    return lowered.compile()


class QuadraticStep:
    """The quadratic energy's minimum by one Gauss--Newton step, compiled in the background.

    ``QuadraticStep(prob)`` starts tracing and compiling for the problem's shapes at once;
    :meth:`run` waits for the compile (re-raising its errors) and runs the step.
    """

    #: Solves with the factor in one step (:func:`_one_step`: the step's, then the refinement's).
    HOST_SOLVES = 2

    def __init__(self, prob: en.Problem) -> None:
        self.prob = prob
        x0 = jax.ShapeDtypeStruct(prob.rhs.shape, jnp.float64)
        handle = jax.ShapeDtypeStruct((), jnp.int64)
        self._compiled: Any = None
        self._error: BaseException | None = None

        def compile_step() -> None:
            try:
                self._compiled = _compile(jax.jit(_one_step).lower(x0, prob.args, handle))
            except BaseException as exc:  # noqa: BLE001 - re-raised by run()
                self._error = exc

        self._thread = threading.Thread(target=compile_step, name="trispline-compile", daemon=True)
        self._thread.start()

    def close(self) -> None:
        """Wait for the compile (where the fit stops before :meth:`run`: XLA's thread still compiling at the
        interpreter's exit aborted it, "terminate called ... FATAL: exception not rethrown")."""
        self._thread.join()

    def run(self, factor: SparseCholesky) -> tuple[np.ndarray, dict[str, float], int, bool]:
        """``(x (k, 3), energies, steps = 1, converged)`` with the factor of ``prob.H``."""
        self._thread.join()
        if self._error is not None:
            raise self._error
        release_free_heap()  # what the compile and the factorisation's analysis freed
        prob = self.prob
        x, energies = self._compiled(jnp.zeros(prob.rhs.shape), prob.args, jnp.asarray(factor.handle, jnp.int64))
        x = np.asarray(x)
        gref = float(np.abs(prob.rhs).max()) or 1.0
        ok = float(np.abs(prob.gradient(x)).max()) <= CONVERGED_GRAD_RTOL * gref
        return x, {k: float(v) for k, v in energies.items()}, 1, bool(ok)


_gradient_jit = jax.jit(jax.grad(_half_sum_squares))
_energies_jit = jax.jit(en.energies)


def iterate(prob: en.Problem, factor: SparseCholesky, solver: optx.AbstractLeastSquaresSolver | None,
            max_steps: int) -> tuple[np.ndarray, dict[str, float], int, bool]:
    """Gauss--Newton iterations from the linear terms' optimum: ``(x (k, 3), energies, steps, converged)``.

    ``solver`` None: :class:`DescentGaussNewton` with factor-preconditioned CG. Full steps climbed on
    a rough scan (``synthetic_scan(2000, noise=0.03)``, ``angle=100``: the objective 0.67 -> 0.70 of
    the start at step 3, after 50 steps 0.2% above the line search's; ``angle=1000`` 0.17 -> 0.25,
    23% above; neither converged in 50 steps); on the smooth scan both reach the same minimum.
    ``steps`` counts rejected trials too.
    """
    if solver is None:
        solver = DescentGaussNewton(GN_RTOL, GN_ATOL, optx.rms_norm, FactorSolver(factor, mode="pcg"))
    x0 = jnp.asarray(factor.solve(prob.rhs))
    sol = optx.least_squares(en.residuals, solver, x0, prob.args, max_steps=max_steps, throw=False)
    x = sol.value
    steps = int(sol.stats["num_steps"])
    gnorm = float(jnp.abs(_gradient_jit(x, prob.args)).max())
    gref = float(jnp.abs(_gradient_jit(jnp.zeros_like(x), prob.args)).max()) or 1.0
    ok = sol.result == optx.RESULTS.successful and gnorm <= CONVERGED_GRAD_RTOL * gref
    energies = {k: float(v) for k, v in _energies_jit(x, prob.args).items()}
    return np.asarray(x), energies, steps, bool(ok)
