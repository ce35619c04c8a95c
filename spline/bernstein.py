"""Quintic Bernstein basis on triangles: values and barycentric derivatives.

Evaluating many points on many patches is one matrix product: a basis matrix
``B: (n, 21)`` for a fixed set of barycentric samples times ``ctrl: (F, 21, 3)``.
Derivatives with respect to uv need each face's geometry; they are formed from
the barycentric-direction derivatives here and the face Jacobians in
:mod:`trispline.spline.patches`.
"""
from __future__ import annotations

from math import factorial

import numpy as np

from .checks import as_array
from .index import DEGREE, EXPONENTS, NCTRL, lattice

_MULTINOMIAL = np.array(
    [factorial(DEGREE) / (factorial(i) * factorial(j) * factorial(k)) for i, j, k in EXPONENTS]
)


def _powers(bary: np.ndarray, degree: int) -> np.ndarray:
    """``(n, 3, degree + 1)`` table of ``bary[:, c] ** p`` (with ``0**0 == 1``)."""
    p = np.ones(bary.shape + (degree + 1,))
    for d in range(1, degree + 1):
        p[..., d] = p[..., d - 1] * bary
    return p


def _falling(n: int, d: int) -> np.ndarray:
    """``n (n-1) ... (n-d+1)`` elementwise for integer arrays ``n``."""
    out = np.ones(n.shape, dtype=np.float64)
    for t in range(d):
        out = out * (n - t)
    return out


def basis(bary: np.ndarray, order: tuple[int, int, int] = (0, 0, 0)) -> np.ndarray:
    """Partial derivative of the 21 quintic Bernstein polynomials.

    Parameters
    ----------
    bary : (n, 3) float
        Barycentric coordinates (need not sum to one: the polynomials are
        treated as homogeneous functions of the three coordinates).
    order : (3,) int
        Derivative order with respect to each barycentric coordinate.

    Returns
    -------
    (n, 21) float
        ``d^|order| B_ijk / dl_a^oa dl_b^ob dl_c^oc`` in storage order.
    """
    bary = as_array(bary, "bary", (None, 3))
    pw = _powers(bary, DEGREE)
    out = np.broadcast_to(_MULTINOMIAL, (bary.shape[0], NCTRL)).copy()
    for c in range(3):
        e = EXPONENTS[:, c]
        o = order[c]
        coef = _falling(e, o)
        ee = np.clip(e - o, 0, None)
        out *= coef[None, :] * pw[:, c, :][:, ee]
    return out


def basis_gradient_bary(bary: np.ndarray) -> np.ndarray:
    """First barycentric partials: ``(3, n, 21)`` for ``d/dl_a, d/dl_b, d/dl_c``."""
    return np.stack([basis(bary, o) for o in ((1, 0, 0), (0, 1, 0), (0, 0, 1))])


def basis_hessian_bary(bary: np.ndarray) -> np.ndarray:
    """Second barycentric partials: ``(3, 3, n, 21)``, symmetric in the first two axes."""
    n = np.asarray(bary).shape[0]
    h = np.empty((3, 3, n, NCTRL))
    for a in range(3):
        for b in range(a, 3):
            o = [0, 0, 0]
            o[a] += 1
            o[b] += 1
            h[a, b] = h[b, a] = basis(bary, tuple(o))
    return h


def bary_grid(resolution: int) -> np.ndarray:
    """Barycentric points of the regular grid with ``resolution`` steps per edge: ``lattice(r) / r``.

    Returns
    -------
    (n, 3) with n = (r + 1)(r + 2) / 2, ordered like the control points
    (first coordinate descending, then second descending); see :func:`~trispline.spline.index.lattice`.
    """
    return lattice(resolution) / int(resolution)
