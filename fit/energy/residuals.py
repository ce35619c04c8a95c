"""Fairness energy terms: JAX residual functions and their host-side normal matrices.

Every term is a sum of squared residuals; :func:`residuals` returns them as a
dict (one array per term) for optimistix. The arrays the residuals need travel
in ``args`` (a dict of arrays, see :func:`make_args`) -- never closed over, so
XLA does not constant-fold the mesh.

Terms (weights in :class:`trispline.fit.pipeline.FitWeights`):

``bend``
    Thin-plate energy ``int |F_uu|^2 + 2|F_uv|^2 + |F_vv|^2`` over the uv domain,
    exact per patch (16-point rule, exact for the degree-6 integrand).
``tilt``
    Each corner frame (the two frame points of vertex ``v``, i.e. the tangent
    plane and the first derivatives of the surface at ``v``) pulled toward the
    local polynomial fit of the data around ``v``: residual
    ``(frame - target) / d_v`` with ``d_v`` the frame scale.
``local``
    Every other control point pulled toward a blend of the local polynomial fits
    of its patch's three vertices (second derivatives at the corners, the
    cross-boundary derivatives along the edges): residual ``(P - target) / h_f``.
``data``
    Extra sample points ``(face, bary) -> xyz``: residual
    ``(F(face, bary) - xyz) / h`` with ``h^2 = domain area / n_vertices``.
``angle`` (nonlinear)
    ``unit(t_u x t_v) - n_v`` for the frame vectors ``t_u, t_v`` of each vertex and
    a data normal ``n_v``, scaled by the data's slope scale.

All terms except ``angle`` are linear in the free points and separate into the
three coordinates, so their Gauss--Newton matrix is ``I_3 (x) H`` with one
sparse ``H`` (:func:`assemble_normal_matrix`).
"""
from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import scipy.sparse as sp

from trispline.spline.index import EXPONENTS, NCTRL
from trispline.spline.bernstein import bary_grid, basis

from .gram import PAIRS, hessian_table

TERMS = ("bend", "tilt", "local", "data", "angle")


# ----------------------------------------------------------------------------- JAX side
def control_points(x: jax.Array, args: dict) -> jax.Array:
    """All control points ``(n_points, 3)`` = fixed part + ``M_r @ x``."""
    contrib = args["M_vals"][:, None] * x[args["M_cols"]]
    return args["c0"].at[args["M_rows"]].add(contrib)


def bend_residual(ctrl: jax.Array, args: dict) -> jax.Array:
    """``(F, Q, 3, 3)``: sqrt-weighted ``F_uu, sqrt2 F_uv, F_vv`` at the quadrature points."""
    # D: (Q, 6, 21); W: (F, 6, 3) pair -> (uu, uv, vv), already scaled by sqrt(w area)
    d2 = jnp.einsum("qpi,fic->fqpc", args["bend_D"], ctrl)
    return jnp.einsum("fqpc,fps,q->fqsc", d2, args["bend_W"], args["bend_sqw"])


def angle_residual(x: jax.Array, args: dict) -> jax.Array:
    """``(nv, 3)``: scaled difference between the frame's unit normal and the target normal."""
    z = args["angle_z"]
    tu = x[args["angle_frame"][:, 0]] - z
    tv = x[args["angle_frame"][:, 1]] - z
    n = jnp.cross(tu, tv)
    length = jnp.sqrt(jnp.sum(n * n, axis=1, keepdims=True) + 1e-300)
    return args["angle_scale"][:, None] * (n / length - args["angle_normal"])


def residuals(x: jax.Array, args: dict) -> dict[str, jax.Array]:
    """All residuals, one array per term (terms with no rows give empty arrays)."""
    pts = control_points(x, args)
    ctrl = pts[args["point_index"]]
    out = {"bend": bend_residual(ctrl, args)}
    out["tilt"] = args["tilt_scale"][:, None] * (x[args["tilt_pos"]] - args["tilt_target"])
    out["local"] = args["local_scale"][:, None] * (pts[args["local_idx"]] - args["local_target"])
    vals = jnp.einsum("nk,nkc->nc", args["data_basis"], ctrl[args["data_face"]])
    out["data"] = args["data_scale"][:, None] * (vals - args["data_target"])
    out["angle"] = angle_residual(x, args)
    return out


def energies(x: jax.Array, args: dict) -> dict[str, jax.Array]:
    """Energy (sum of squared residuals, weights included) of every term."""
    return {k: jnp.sum(v * v) for k, v in residuals(x, args).items()}


# ---------------------------------------------------------------------------- host side
def bend_weights(bary_grad: np.ndarray, areas: np.ndarray, weight: float) -> np.ndarray:
    """``(F, 6, 3)`` coefficients turning pair derivatives ``D_P F`` into sqrt-weighted
    ``F_uu, sqrt(2) F_uv, F_vv`` (multiplied by ``sqrt(weight * area)``)."""
    g = np.asarray(bary_grad, float)
    a, b = PAIRS[:, 0], PAIRS[:, 1]
    mult = np.where(a == b, 1.0, 2.0)
    uu = g[:, a, 0] * g[:, b, 0]
    uv = 0.5 * (g[:, a, 0] * g[:, b, 1] + g[:, b, 0] * g[:, a, 1]) * np.sqrt(2.0)
    vv = g[:, a, 1] * g[:, b, 1]
    W = np.stack([uu, uv, vv], axis=-1) * mult[None, :, None]
    return W * np.sqrt(weight * np.asarray(areas, float))[:, None, None]


def bend_tables() -> tuple[np.ndarray, np.ndarray]:
    """``D: (Q, 6, 21)`` pair second partials at the quadrature points, ``sqrt(w_q): (Q,)``."""
    D, w = hessian_table()
    return np.ascontiguousarray(D[:, PAIRS[:, 0], PAIRS[:, 1], :]), np.sqrt(w)


def blended_targets(
    uv: np.ndarray, faces: np.ndarray, evaluate_fit, *, power: float = 2.0
) -> np.ndarray:
    """Per-patch target nets from the three vertices' local polynomials.

    ``evaluate_fit(vertex_ids (F,), points (F, 21, 2)) -> (F, 21, d)`` evaluates the
    local fit of ``vertex_ids[f]`` at the 21 domain points of patch ``f`` (the grouped
    form of :meth:`trispline.fit.targets.LocalRBFFit.evaluate`). The target of control point ``b_ijk`` is the blend
    ``sum_k e_k^power N_k / sum_k e_k^power`` of the three polynomials' exact
    quintic nets ``N_k`` on the patch (``e`` the point's exponents), so points near
    a corner follow that corner's fit.

    Returns
    -------
    (F, 21, d)
    """
    faces = np.asarray(faces, np.int64)
    nf = faces.shape[0]
    grid = bary_grid(5)
    pts = np.einsum("gk,fkc->fgc", grid, uv[faces])  # (F, 21, 2)
    Binv = np.linalg.inv(basis(grid))  # (21, 21) values at grid -> control points
    e = EXPONENTS.astype(float) ** power
    beta = e / e.sum(1, keepdims=True)  # (21, 3)
    out = None
    for k in range(3):
        vals = evaluate_fit(faces[:, k], pts)  # (F, 21, d)
        net = np.einsum("ij,fjd->fid", Binv, vals)
        term = beta[None, :, k, None] * net
        out = term if out is None else out + term
    return out


def patch_expansion(M_r: sp.csr_matrix, point_index: np.ndarray) -> sp.csr_matrix:
    """``A = M_r[point_index.ravel()]``: ``(21 F, n_r)`` free-to-patch-point map."""
    return M_r[np.asarray(point_index).ravel()]


def assemble_normal_matrix(
    A: sp.csr_matrix,
    gram: np.ndarray,
    w_bend: float,
    point_weight: np.ndarray,
    extra: list[sp.spmatrix] | None = None,
) -> sp.csr_matrix:
    """``H = A^T (w_bend blkdiag(G_f) + diag(point_weight)) A + sum(extra)``.

    Parameters
    ----------
    A : (21F, n) patch expansion of the free-to-control map
    gram : (F, 21, 21) thin-plate Gram matrices
    point_weight : (21F,) squared scales of per-patch-point residuals (local term)
    extra : further (n, n) matrices (tilt, data)
    """
    nf = gram.shape[0]
    blk = gram * w_bend
    idx = np.arange(NCTRL)
    blk[:, idx, idx] += np.asarray(point_weight).reshape(nf, NCTRL)
    n = NCTRL * nf
    indptr = np.arange(0, n * NCTRL + 1, NCTRL, dtype=np.int64)
    indices = (np.arange(nf)[:, None, None] * NCTRL + idx[None, None, :]).repeat(NCTRL, axis=1).ravel()
    B = sp.csr_matrix((blk.ravel(), indices, indptr), shape=(n, n))
    H = (A.T @ (B @ A)).tocsr()
    for E in extra or []:
        H = H + E
    H = sp.csr_matrix(H)
    H.sum_duplicates()
    return H
