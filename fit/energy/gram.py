"""Exact per-patch Gram matrices of the thin-plate energy of quintic patches.

For a patch ``F(u, v) = sum_i b_i B_i`` over a uv triangle with barycentric
gradients ``g_a`` (``(3, 2)``), the uv Hessian is
``d^2 F = sum_ab g_a g_b^T D_ab F`` with ``D_ab`` the second barycentric
partials. The thin-plate energy

    E = int_T |F_uu|^2 + 2 |F_uv|^2 + |F_vv|^2 dA = b^T G b

has ``G[i, j] = sum_abcd (g_a . g_c)(g_b . g_d) int_T D_ab B_i D_cd B_j``; the
integrals over the triangle are ``area`` times constants (barycentric moments),
computed once by a collapsed Gauss rule exact for degree 6.

The same quadrature gives the *residual* form used in the optimiser:
``r = sqrt(w_q area) [F_uu, sqrt(2) F_uv, F_vv]`` at the quadrature points, so
``|r|^2 = E`` exactly (second derivatives of a quintic have degree 3).
"""
from __future__ import annotations

from functools import lru_cache

import numpy as np

from trispline.spline.bernstein import basis_hessian_bary

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
def hessian_table() -> tuple[np.ndarray, np.ndarray]:
    """Second barycentric partials of the basis at the quadrature points.

    Returns
    -------
    D : (Q, 3, 3, 21) ``D_ab B_i`` at each quadrature point
    w : (Q,) quadrature weights (sum 1)
    """
    bary, w = triangle_quadrature(4)
    h = basis_hessian_bary(bary)  # (3, 3, Q, 21)
    D = np.ascontiguousarray(np.transpose(h, (2, 0, 1, 3)))
    D.setflags(write=False)
    return D, w


@lru_cache(maxsize=None)
def _moments() -> np.ndarray:
    """``(6, 6, 21, 21)`` mean over the triangle of ``D_P B_i D_Q B_j`` for pairs P, Q.

    Off-diagonal pairs (a != b) are pre-multiplied by 2 (they appear twice in the
    sum over ordered ``a, b``).
    """
    D, w = hessian_table()
    mult = np.where(PAIRS[:, 0] == PAIRS[:, 1], 1.0, 2.0)
    Dp = D[:, PAIRS[:, 0], PAIRS[:, 1], :] * mult[None, :, None]  # (Q, 6, 21)
    out = np.einsum("q,qpi,qrj->prij", w, Dp, Dp)
    out.setflags(write=False)
    return out


def uv_hessian_weights(bary_grad: np.ndarray) -> np.ndarray:
    """Coefficients turning barycentric second partials into uv second partials.

    Parameters
    ----------
    bary_grad : (F, 3, 2) gradients of the barycentric coordinates.

    Returns
    -------
    (F, 3, 3, 3): ``[f, a, b, s]`` with ``s`` = uu, uv, vv, so that
    ``F_s = sum_ab W[f, a, b, s] D_ab F``.
    """
    g = np.asarray(bary_grad, float)
    uu = g[:, :, None, 0] * g[:, None, :, 0]
    uv = g[:, :, None, 0] * g[:, None, :, 1]
    vv = g[:, :, None, 1] * g[:, None, :, 1]
    return np.stack([uu, uv, vv], axis=-1)


def thin_plate_gram(bary_grad: np.ndarray, areas: np.ndarray) -> np.ndarray:
    """Exact thin-plate Gram matrix of every patch.

    Parameters
    ----------
    bary_grad : (F, 3, 2) barycentric gradients (``Triangulation.bary_gradients``)
    areas : (F,) uv areas

    Returns
    -------
    (F, 21, 21) symmetric positive semidefinite, null space = the linear functions
    (and nothing else): ``ctrl_f^T G_f ctrl_f`` is the patch's thin-plate energy.
    """
    g = np.asarray(bary_grad, float)
    areas = np.asarray(areas, float)
    dots = np.einsum("fai,fbi->fab", g, g)  # (F, 3, 3) g_a . g_c
    a, b = PAIRS[:, 0], PAIRS[:, 1]
    # sum over ordered (a,b),(c,d) of (g_a.g_c)(g_b.g_d); for symmetric D this equals,
    # per unordered pair P=(a,b), Q=(c,d): the symmetrised product below
    coef = 0.5 * (
        dots[:, a[:, None], a[None, :]] * dots[:, b[:, None], b[None, :]]
        + dots[:, a[:, None], b[None, :]] * dots[:, b[:, None], a[None, :]]
    )  # (F, 6, 6)
    mom = _moments().reshape(36, 21 * 21)
    G = (coef.reshape(-1, 36) * areas[:, None]) @ mom
    return G.reshape(-1, 21, 21)


def thin_plate_energy_ctrl(ctrl: np.ndarray, bary_grad: np.ndarray, areas: np.ndarray) -> np.ndarray:
    """Thin-plate energy per patch and coordinate, ``(F, d)``, for ``ctrl: (F, 21, d)``."""
    G = thin_plate_gram(bary_grad, areas)
    return np.einsum("fic,fij,fjc->fc", ctrl, G, ctrl)
