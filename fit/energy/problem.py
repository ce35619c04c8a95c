"""The global fit's least-squares problem over the non-corner free points.

The corner points are fixed to the data, so the control points are ``P = c0 + M_r x``
with ``x (k, 3)`` the other free points. :func:`residuals` is the optimistix residual:
a module-level function whose arrays all travel in ``args`` (a pytree of arrays, built
by :func:`setup_problem`), never closed over, so XLA does not constant-fold the mesh.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property, partial
from typing import Callable

import jax
import jax.numpy as jnp
import numpy as np
import scipy.sparse as sp

from trispline.spline.propagation import SplineSpace
from trispline.spline.topology import signed_areas
from trispline.spline.util.memory import index_dtype
from trispline.spline.util.parallel import once

from ..weights import FitWeights
from .context import frame_ids, term_context
from .data import DataPoints
from ..ordering import patch_ordering
from ..progress import Report, span
from ..solve import symmetric_from_upper
from .normal import normal_equations, patch_unknowns, upper_pattern
from .terms import MODULES, is_nonlinear, normal_parts, setup_terms, term_residuals

__all__ = ["Problem", "setup_problem", "control_points", "residuals", "energies", "energy_units",
           "normalised_energies"]


@dataclass
class Problem:
    """The fit's residual arrays and the normal equations of its linear terms.

    Attributes
    ----------
    args : pytree of JAX arrays for :func:`residuals`
    H_upper : (k, k) CSR upper triangle (diagonal included) of the sparse SPD normal matrix
        ``H`` of the linear terms (one per coordinate): all the factorisation reads
    rhs : (k, 3) their right-hand side: ``H^{-1} rhs`` minimises the linear terms
    free_r : (k,) free ids of the unknowns
    nonlinear : whether a nonlinear term has rows
    """

    args: dict
    H_upper: sp.csr_array
    rhs: np.ndarray
    free_r: np.ndarray
    nonlinear: bool

    @cached_property
    def H(self) -> sp.csr_array:
        """``(k, k)`` the full symmetric normal matrix (built from :attr:`H_upper` on first use)."""
        return symmetric_from_upper(self.H_upper)

    @property
    def H_nnz(self) -> int:
        """Stored entries of the full ``H`` (both triangles), without building it."""
        return 2 * int(self.H_upper.nnz) - int(np.count_nonzero(self.H_upper.diagonal()))

    def gradient(self, x: np.ndarray) -> np.ndarray:
        """``(k, 3)`` gradient ``H x - rhs`` of the linear terms' half sum of squares at ``x (k, 3)``."""
        U = self.H_upper
        return U @ x + U.T @ x - U.diagonal()[:, None] * x - self.rhs


def _space_products(space: SplineSpace, free_r: np.ndarray, V: np.ndarray
                    ) -> tuple[sp.csr_matrix, sp.csr_matrix, np.ndarray, np.ndarray]:
    """``(M_r, A, incidence, c0)``: ``M``'s columns of the solved unknowns ``free_r (k,)`` (CSR, sorted), its
    rows of the patches' points ``A (21 F, k)``, their patch–unknown incidence
    (:func:`~.normal.patch_unknowns`) and the fixed part ``c0 (n_points, 3)`` from the corners ``V``."""
    # columns of the CSR space.M selected as CSR (sorted as they were): no CSC copy of M (50 MB at 100k
    # faces) and 0.25 against 0.37 CPU s there; the same M_r and, with the rows' sums in the same order, c0
    M = sp.csr_matrix(space.M)
    M_r = sp.csr_matrix(M[:, free_r])
    M_r.sort_indices()
    c0 = np.asarray(M[:, space.corner_free] @ V)
    A = M_r[np.asarray(space.point_index).ravel()]  # (21 F, k) patch points per unknown
    return M_r, A, patch_unknowns(A), c0


def setup_problem(V: np.ndarray, space: SplineSpace, weights: FitWeights,
                  data_points: DataPoints | None = None, report: Report | None = None,
                  on_pattern: Callable[[Callable[[], sp.csr_array], Callable[[], np.ndarray | None]], None]
                  | None = None,
                  curved_outline: bool = False, smooth_map: bool | None = None) -> Problem:
    """Targets, residual arrays and normal equations for data vertices ``V (nv, 3)``.

    ``report``: progress (:mod:`trispline.fit.progress`): the local fits and targets take
    about 70% of the time, the normal equations most of the rest. ``on_pattern``: called
    before the terms are set up with a callable that makes the pattern of :attr:`Problem.H_upper`
    (:func:`~.normal.upper_pattern`) and one that makes its elimination order
    (:func:`~trispline.fit.ordering.patch_ordering`); the factorisation's analysis makes both and starts
    on them in its background thread (:class:`~trispline.fit.solve.PatternAnalysis`).
    ``curved_outline``, ``smooth_map``: as in :func:`~.context.term_context`.
    """
    is_fixed = np.zeros(space.n_free, bool)
    is_fixed[space.corner_free] = True
    free_r = np.flatnonzero(~is_fixed)
    pos = np.full(space.n_free, -1, np.int64)
    pos[free_r] = np.arange(free_r.size)
    # M's products are made by the first to need them: the analysis thread, beside the local fits, which
    # read only the mesh and its uv (the main thread made them alone before: 0.5 s on one core at 100k faces)
    products = once(partial(_space_products, space, free_r, np.asarray(V)))
    if on_pattern is not None:  # made where it is used: PatternAnalysis makes it in its own thread
        on_pattern(lambda get=products: upper_pattern(*get()[1:3]), lambda get=products: patch_ordering(get()[2]))
    ctx = term_context(space, V, weights, data_points=data_points, report=span(report, 0.0, 0.7),
                       curved_outline=curved_outline, smooth_map=smooth_map)
    terms = setup_terms(ctx)
    frame_pos = pos[frame_ids(space, ctx.frame_vertices)]
    parts = normal_parts(terms, space.tri.n_faces, frame_pos.size)
    span(report, 0.0, 0.8)(1.0)
    M_r, A, incidence, c0 = products()
    del products
    H_upper, rhs = normal_equations(A, c0[np.asarray(space.point_index).ravel()], frame_pos, parts, upper=True,
                                    report=span(report, 0.8, 0.95), incidence=incidence, release=True)
    del incidence

    Mc = M_r.tocoo()
    idx = index_dtype(Mc.shape[0], Mc.shape[1])  # int32 indices: half the memory of the gathers
    args = dict(M_rows=Mc.row.astype(idx), M_cols=Mc.col.astype(idx), M_vals=Mc.data, c0=c0,
                point_index=space.point_index, frame_pos=frame_pos, terms=terms)
    # one device_put of the whole tree: the same arrays (dtypes, weak types) in about half the time of
    # jnp.asarray leaf by leaf
    return Problem(args=jax.device_put(args), H_upper=H_upper, rhs=rhs, free_r=free_r,
                   nonlinear=is_nonlinear(terms))


def control_points(x: jax.Array, args: dict) -> jax.Array:
    """All control points ``(n_points, 3)`` = fixed part + ``M_r @ x``."""
    contrib = args["M_vals"][:, None] * x[args["M_cols"]]
    return args["c0"].at[args["M_rows"]].add(contrib)


def residuals(x: jax.Array, args: dict) -> dict[str, jax.Array]:
    """All residuals, one array per term (terms with no rows give empty arrays)."""
    ctrl = control_points(x, args)[args["point_index"]]
    return term_residuals(ctrl, x[args["frame_pos"]], args["terms"])


def energies(x: jax.Array, args: dict) -> dict[str, jax.Array]:
    """Energy (sum of squared residuals, weights included) of every term."""
    return {k: jnp.sum(v * v) for k, v in residuals(x, args).items()}


def energy_units(size: float) -> dict[str, float]:
    """Factor per term turning energies of data scaled by ``1 / size`` back into data units."""
    return {m.NAME: size ** m.SCALE_EXPONENT for m in MODULES}


def normalised_energies(energies: dict[str, float], V: np.ndarray, uv: np.ndarray, faces: np.ndarray
                        ) -> dict[str, float]:
    """Each term's energy (data units) as for the data scaled to a unit bounding-box diagonal, per
    unit area of the uv domain, so that numbers compare across meshes of any size and density.

    ``V (nv, 3)`` the data, ``uv (nv, 2)`` and ``faces (nf, 3)`` the domain the fit used.
    """
    diag = float(np.linalg.norm(np.ptp(V, axis=0))) or 1.0
    area = float(np.abs(signed_areas(uv, faces)).sum()) or 1.0
    units = energy_units(diag)
    return {k: float(v) / units.get(k, 1.0) / area for k, v in energies.items()}
