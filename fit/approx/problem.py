"""The approximation's least-squares problem: a coarse C1 spline fitted to every scan point.

The coarse spline space ``P = M @ free`` lives on the coarse domain; its corner points
either interpolate their scan vertices (``corners="data"``: fixed, ``P = c0 + M_u x``) or
move like every other free point (``corners="fit"``: ``x`` is every free point). Two terms
(:mod:`trispline.fit.energy`): ``bend``, the thin-plate energy over the coarse uv domain of
the surface **less a reference** (the scan's best-fit quadric over uv,
:func:`~.fit.quadric_reference`: so a quadric costs nothing and is reproduced exactly, and
the energy does not pull a curved scan toward a plane), and the data term over all scan
points located in the coarse domain, with the plain loss or a robust one
(:data:`~trispline.fit.energy.terms.DATA_LOSSES`).

The data term's per-point weight is ``n_coarse^2 / (A n_scan)`` (``A`` the uv area), so
its energy density is ``error^2 / h^4`` with ``h^2 = A / n_coarse`` the uv area per coarse
vertex, whatever the scan's density: against the thin-plate energy (``error^2 / l^4`` for
a wiggle of length ``l``) the data weight ``w`` sets the smoothing length, about
``h / w^(1/4)``, a fixed fraction of the coarse spacing.

Shapes are padded to a few sizes (:func:`padded`): the unknowns, the control points and
the patches, with inert entries (an identity row in ``H``, zero residuals), so a refit
after refinement usually reuses the compiled Gauss--Newton loop of an earlier round.
"""
from __future__ import annotations

import dataclasses
import functools
from dataclasses import dataclass

import jax
import jax.numpy as jnp
import numpy as np
import scipy.sparse as sp

from trispline.spline.index import NCTRL
from trispline.spline.propagation import SplineSpace

from .. import energy as en
from ..energy import bend
from ..energy.data import DataPoints
from ..energy.robust import RobustPoints
from ..energy.terms import DATA_LOSSES
from ..weights import FitWeights

__all__ = ["ApproxProblem", "PlainSystem", "plain_system", "setup_problem", "padded", "CORNER_MODES", "PAD_GROWTH"]

#: ``corners="data"``: corner points interpolate their scan vertices; ``"fit"``: they are fitted too.
CORNER_MODES = ("data", "fit")
#: Padded sizes grow by this factor (fewer compiles, at most this much more work).
PAD_GROWTH = 1.25
#: Smallest padded size.
PAD_MIN = 64


def padded(n: int) -> int:
    """The padded size ``>= n``: ``PAD_MIN * PAD_GROWTH^j`` rounded up, for the smallest such ``j``."""
    size = float(PAD_MIN)
    while size < n:
        size *= PAD_GROWTH
    return int(np.ceil(size))


@dataclass
class ApproxProblem:
    """Residual arrays and the plain (linearised) normal equations of one coarse fit.

    Attributes
    ----------
    host_args : the same pytree as :attr:`args` in NumPy arrays
    H : (kp, kp) sparse SPD normal matrix of the plain terms (one per coordinate; padding: identity)
    rhs : (kp, 3) its right-hand side; ``H^{-1} rhs`` is the plain loss's optimum
    unknowns : (k,) free ids of the unknowns (the first ``k`` of ``kp``)
    loss : the data loss (``"l2"``, ``"huber"``, ``"cauchy"``)
    terms : the terms' host arrays, unpadded (``bend``, ``data``, ``reference (f, 21, 3)``), for :meth:`energies`
    plain : the :class:`PlainSystem` it was made of (None: not kept)
    """

    host_args: dict
    H: sp.csr_array
    rhs: np.ndarray
    unknowns: np.ndarray
    loss: str
    terms: dict
    plain: PlainSystem | None = None

    @functools.cached_property
    def args(self) -> dict:
        """Pytree of JAX arrays for :func:`residuals` (padded shapes), made on first use: a plain or
        reweighted fit solves on the host and never needs it (1M scan points: 0.2 GB not copied)."""
        return jax.tree_util.tree_map(jnp.asarray, self.host_args)

    @property
    def nonlinear(self) -> bool:
        """A robust loss: Gauss--Newton iterates."""
        return not DATA_LOSSES[self.loss].LINEAR

    def energies(self, ctrl: np.ndarray, size: float = 1.0) -> dict[str, float]:
        """Energy of each term (data units) for patch control points ``ctrl (f, 21, 3)`` in normalised
        coordinates (data scaled by ``1 / size``), on the host."""
        data = DATA_LOSSES[self.loss]
        r_bend = bend.residual(ctrl - self.terms["reference"], None, self.terms["bend"])
        return {"bend": float(np.sum(r_bend**2)) * size**bend.SCALE_EXPONENT,
                "data": float(np.sum(data.residual(ctrl, None, self.terms["data"]) ** 2)) * size**data.SCALE_EXPONENT}


def _context(space: SplineSpace, weights: FitWeights, points: DataPoints, n_scan: int) -> en.TermContext:
    """The terms' context: every coarse patch, no frames, no local fits (bend and data need none)."""
    tri = space.tri
    area = float(tri.areas.sum())
    empty = np.zeros(0)
    return en.TermContext(
        weights=weights, areas=tri.areas, bary_gradients=tri.bary_gradients, faces=tri.faces, uv=tri.uv,
        V=np.zeros((tri.n_vertices, 3)), halo_faces=tri.faces, fit=None, frame_vertices=np.zeros(0, np.int64),
        frame_scale=empty, vertex_area=empty, data_points=points,
        sample_weight=tri.n_vertices**2 / (area * max(n_scan, 1)))


@dataclass
class PlainSystem:
    """The plain normal equations of one coarse domain, split by term (``H = H_bend + H_data``).

    Attributes
    ----------
    M_u : (n_points, k) the unknowns' columns of ``M``; c0 : (n_points, 3) the fixed corners' part
    unknowns : (k,) free ids; terms : the terms' host arrays (``bend``, ``data``, ``reference``)
    H_bend, H_data : (k, k) sparse; rhs_bend, rhs_data : (k, 3)
    patch_rows : ``(A, c)``, the patches' control points ``A @ x + c`` (``(f 21, k)`` sparse, ``(f 21, 3)``)
    """

    M_u: sp.csr_matrix
    c0: np.ndarray
    unknowns: np.ndarray
    terms: dict
    H_bend: sp.csr_array
    rhs_bend: np.ndarray
    H_data: sp.csr_array
    rhs_data: np.ndarray
    patch_rows: tuple[sp.csr_matrix, np.ndarray]


def plain_system(space: SplineSpace, points: DataPoints, corner_xyz: np.ndarray | None, weights: FitWeights,
                 loss: str, reference: np.ndarray, point_weight: np.ndarray | None = None,
                 bend_weight: np.ndarray | None = None, bend_of: PlainSystem | None = None) -> PlainSystem:
    """The split normal equations of :func:`setup_problem` (same parameters). ``bend_of``: an earlier
    system of the same space, corner mode, bend weights and reference, whose bend half is taken as it is
    (a reweighted or corrected refit changes only the data half)."""
    if bend_of is None:
        bend_of = _bend_half(space, weights, corner_xyz, reference, bend_weight)
    ctx = _context(space, weights, points, points.face.size)
    terms = dict(bend_of.terms, data=DATA_LOSSES[loss].setup(ctx))
    plain = dict(terms["data"])
    if point_weight is not None:
        plain["scale"] = plain["scale"] * np.sqrt(point_weight)
    parts = en.NormalParts.zeros(space.tri.n_faces, 0)
    DATA_LOSSES["l2"].add_normal(parts, plain)  # a robust term's linearisation at zero, reweighted
    A, c = bend_of.patch_rows
    H_data, rhs_data = en.normal_equations(A, c, np.zeros(0, np.int64), parts)
    return dataclasses.replace(bend_of, terms=terms, H_data=H_data, rhs_data=rhs_data)


def _bend_half(space: SplineSpace, weights: FitWeights, corner_xyz: np.ndarray | None, reference: np.ndarray,
               bend_weight: np.ndarray | None) -> PlainSystem:
    """A :class:`PlainSystem` with the bend term's half (the data half empty)."""
    if corner_xyz is None:
        unknowns = np.arange(space.n_free)
    else:
        fixed = np.zeros(space.n_free, bool)
        fixed[space.corner_free] = True
        unknowns = np.flatnonzero(~fixed)
    M = sp.csc_matrix(space.M)
    M_u = sp.csr_matrix(M[:, unknowns])
    c0 = np.zeros((space.n_points, 3)) if corner_xyz is None else np.asarray(M[:, space.corner_free] @ corner_xyz)
    terms = {"bend": bend.setup(_context(space, weights, None, 0)), "reference": reference}
    if bend_weight is not None:  # per patch: W carries sqrt(weight area)
        terms["bend"]["W"] = terms["bend"]["W"] * np.sqrt(np.asarray(bend_weight, float))[:, None, None]
    A = M_u[np.asarray(space.point_index).ravel()]
    c = c0[np.asarray(space.point_index).ravel()]
    parts = en.NormalParts.zeros(space.tri.n_faces, 0)
    bend.add_normal(parts, terms["bend"])
    parts.patch_rhs += np.einsum("fij,fjc->fic", parts.blocks, reference)  # |D^2 (P - reference)|^2
    H_bend, rhs_bend = en.normal_equations(A, c, np.zeros(0, np.int64), parts)
    return PlainSystem(M_u=M_u, c0=c0, unknowns=unknowns, terms=terms, H_bend=H_bend, rhs_bend=rhs_bend,
                       H_data=sp.csr_array(H_bend.shape), rhs_data=np.zeros_like(rhs_bend), patch_rows=(A, c))


def setup_problem(space: SplineSpace, points: DataPoints, corner_xyz: np.ndarray | None, weights: FitWeights,
                  loss: str, reference: np.ndarray, point_weight: np.ndarray | None = None,
                  bend_weight: np.ndarray | None = None, bend_of: PlainSystem | None = None) -> ApproxProblem:
    """The problem for scan ``points`` located in ``space``'s domain (normalised coordinates).

    Parameters
    ----------
    space : SplineSpace of the coarse domain
    points : DataPoints (``loss="l2"``) or RobustPoints: face (n,), bary (n, 3), xyz (n, 3)
    corner_xyz : (nv, 3) the corner points' fixed positions (``corners="data"``), or None (``"fit"``)
    weights : FitWeights (bend and data are used)
    loss : ``"l2"``, ``"huber"`` or ``"cauchy"`` (``points`` a RobustPoints for the robust ones)
    reference : (f, 21, 3) the bend term's reference surface, per patch
    point_weight : (n,) weights of the points in ``H`` and ``rhs`` only (iteratively reweighted
        least squares: the robust loss's weights at an earlier fit); the residuals keep the loss
    bend_weight : (f,) a factor of the thin-plate energy per patch (:func:`~.fit.bend_face_weights`:
        the map's area distortion taken out), or None (1)
    bend_of : see :func:`plain_system`; the problem's :attr:`~ApproxProblem.plain` is the system made
    """
    s = plain_system(space, points, corner_xyz, weights, loss, reference, point_weight, bend_weight, bend_of)
    H = sp.csr_array(s.H_bend + s.H_data)
    prob = _padded_problem(s.M_u, s.c0, space.point_index, s.terms, H, s.rhs_bend + s.rhs_data, s.unknowns, loss)
    return dataclasses.replace(prob, plain=s)


def _padded_problem(M_u: sp.csr_matrix, c0: np.ndarray, point_index: np.ndarray, terms: dict, H: sp.csr_array,
                    rhs: np.ndarray, unknowns: np.ndarray, loss: str) -> ApproxProblem:
    """Pad unknowns, points and patches to :func:`padded` sizes with inert entries."""
    k, n_points, nf = unknowns.size, c0.shape[0], point_index.shape[0]
    kp, pp, fp = padded(k), padded(n_points), padded(nf)
    Hp = sp.block_diag([H, sp.identity(kp - k)], format="csr")
    rhs_p = np.zeros((kp, 3))
    rhs_p[:k] = rhs
    c0_p = np.zeros((pp, 3))
    c0_p[:n_points] = c0
    pidx = np.zeros((fp, NCTRL), np.int64)
    pidx[:nf] = point_index
    W = np.zeros((fp,) + terms["bend"]["W"].shape[1:])
    W[:nf] = terms["bend"]["W"]  # padded patches: zero weight
    ref = np.zeros((fp, NCTRL, 3))
    ref[:nf] = terms["reference"]
    Mc = M_u.tocoo()
    args = dict(M_rows=Mc.row.astype(np.int64), M_cols=Mc.col.astype(np.int64), M_vals=Mc.data, c0=c0_p,
                point_index=pidx, bend=dict(terms["bend"], W=W), reference=ref, data=terms["data"])
    return ApproxProblem(host_args=args, H=Hp, rhs=rhs_p, unknowns=unknowns,
                         loss=loss, terms=terms)


def _residuals(x: jax.Array, args: dict, term) -> dict[str, jax.Array]:
    ctrl = en.control_points(x, args)[args["point_index"]]
    return {"bend": bend.residual(ctrl - args["reference"], None, args["bend"]),
            "data": term.residual(ctrl, None, args["data"])}


def plain_residuals(x: jax.Array, args: dict) -> dict[str, jax.Array]:
    """The optimistix residual with the plain data loss: ``{"bend": ..., "data": ...}``."""
    return _residuals(x, args, DATA_LOSSES["l2"])


def robust_residuals(x: jax.Array, args: dict) -> dict[str, jax.Array]:
    """The optimistix residual with a robust data loss (Huber or Cauchy, chosen by ``args``)."""
    return _residuals(x, args, DATA_LOSSES["huber"])


def residual_function(loss: str):
    """:func:`plain_residuals` or :func:`robust_residuals` (module-level: compiled once per shape)."""
    return plain_residuals if loss == "l2" else robust_residuals


def robust_points(face: np.ndarray, bary: np.ndarray, xyz: np.ndarray, loss: str, scale: float) -> DataPoints:
    """DataPoints for ``loss="l2"``, else RobustPoints with the loss scale ``scale``."""
    if loss == "l2":
        return DataPoints(face, bary, xyz)
    return RobustPoints(face, bary, xyz, loss=loss, scale=scale)
