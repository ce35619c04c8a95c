"""Exact quadrature of the thin-plate integrand on a quintic patch: tables shared by every consumer.

For a patch ``F = sum_i b_i B_i`` over a uv triangle with barycentric gradients
``g_a`` (``(3, 2)``), the uv Hessian is ``d^2 F = sum_ab g_a g_b^T D_ab F`` with
``D_ab`` the second barycentric partials. Second derivatives of a quintic have
degree 3, so the degree-6 integrand ``|d^2 F|^2`` is integrated exactly by a
16-point collapsed Gauss rule; the tables here are the rule and the six symmetric
pair partials ``D_P B_i`` (``P = (a, b)``, ``a <= b``) at its points, and the same
compressed to the 10 rows that the cubics need.
"""
from __future__ import annotations

from functools import lru_cache

import numpy as np

from trispline.spline.bernstein import basis_hessian_bary

__all__ = ["PAIRS", "triangle_quadrature", "pair_hessians", "pair_hessian_rows", "pair_moments"]

#: The six symmetric barycentric second-derivative pairs (a <= b).
PAIRS = np.array([(0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2)])


@lru_cache(maxsize=None)
def triangle_quadrature(n: int = 4) -> tuple[np.ndarray, np.ndarray]:
    """Collapsed (Duffy) Gauss--Legendre rule on the triangle, exact for degree ``2 n - 2``.

    Returns
    -------
    bary : (n*n, 3) barycentric points
    weights : (n*n,) weights summing to one (integral = area * sum w f)
    """
    x, w = np.polynomial.legendre.leggauss(n)
    s = 0.5 * (x + 1.0)
    ws = 0.5 * w
    S, T = np.meshgrid(s, s, indexing="ij")
    WS, WT = np.meshgrid(ws, ws, indexing="ij")
    # map the square (s, t) to the triangle: l1 = s, l2 = t (1 - s); Jacobian (1 - s)
    l1 = S.ravel()
    l2 = (T * (1 - S)).ravel()
    wt = (WS * WT * (1 - S)).ravel() * 2.0  # reference triangle area 1/2 -> weights sum to 1
    bary = np.column_stack([1.0 - l1 - l2, l1, l2])
    wt.setflags(write=False)
    bary.setflags(write=False)
    return bary, wt


@lru_cache(maxsize=None)
def pair_hessians() -> tuple[np.ndarray, np.ndarray]:
    """The pair partials at the quadrature points.

    Returns
    -------
    D : (Q, 6, 21) ``D_P B_i`` for the pairs of :data:`PAIRS`
    sqw : (Q,) square roots of the quadrature weights
    """
    bary, w = triangle_quadrature(4)
    h = basis_hessian_bary(bary)  # (3, 3, Q, 21)
    D = np.ascontiguousarray(np.transpose(h, (2, 0, 1, 3))[:, PAIRS[:, 0], PAIRS[:, 1], :])
    sqw = np.sqrt(w)
    D.setflags(write=False)
    sqw.setflags(write=False)
    return D, sqw


@lru_cache(maxsize=None)
def pair_hessian_rows() -> tuple[np.ndarray, np.ndarray]:
    """The quadrature compressed to 10 rows: ``D (10, 6, 21)`` and unit weights ``(10,)``.

    The second derivatives of a quintic are cubics, a 10-dimensional space, so the 16
    sqrt-weighted rows of :func:`pair_hessians` have rank 10: rotated onto their row space
    (SVD), 10 rows carry every inner product of the 16 exactly (to rounding). The bend
    residual then has 10 rows per patch and coordinate instead of 16, for the same energy.
    """
    D, sqw = pair_hessians()
    R = (sqw[:, None, None] * D).reshape(D.shape[0], -1)
    U = np.linalg.svd(R, full_matrices=False)[0][:, :10]
    rows = np.ascontiguousarray((U.T @ R).reshape(10, *D.shape[1:]))
    ones = np.ones(10)
    rows.setflags(write=False)
    ones.setflags(write=False)
    return rows, ones


@lru_cache(maxsize=None)
def pair_moments() -> np.ndarray:
    """``(6, 6, 21, 21)`` triangle means of ``D_P B_i D_R B_j``: the Gram form of the quadrature."""
    D, _ = pair_hessians()
    out = np.einsum("q,qpi,qrj->prij", triangle_quadrature(4)[1], D, D)
    out.setflags(write=False)
    return out
