"""Quintic Bernstein basis on triangles: values and barycentric derivatives.

Evaluating many points on many patches is one matrix product: a basis matrix
``B: (n, 21)`` for a fixed set of barycentric samples times ``ctrl: (F, 21, 3)``.
Derivatives with respect to uv need each face's geometry; they are formed from
the barycentric-direction derivatives here and the face Jacobians in
:mod:`trispline.spline.patches`.
"""
from __future__ import annotations

from functools import lru_cache
from math import factorial

import numpy as np

from .checks import as_array
from .index import DEGREE, EXPONENTS, NCTRL, lattice

_MULTINOMIAL = np.array(
    [factorial(DEGREE) / (factorial(i) * factorial(j) * factorial(k)) for i, j, k in EXPONENTS]
)


#: Points whose basis is computed together: a large array is fresh memory each time (page faults cost
#: more than the arithmetic on a VM), a chunk's temporaries are reused.
CHUNK = 1 << 14


def _power_rows(bary: np.ndarray, degree: int) -> np.ndarray:
    """``(3, degree + 1, n)`` rows of ``bary[:, c] ** p``: products of whole rows are ~4x faster than
    per-sample gathers (call it on a few thousand samples at a time, which stay in cache)."""
    rows = np.ascontiguousarray(bary.T)  # (3, n)
    p = np.ones((3, degree + 1, rows.shape[1]))
    for d in range(1, degree + 1):
        np.multiply(p[:, d - 1], rows, out=p[:, d])
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
    out = np.empty((bary.shape[0], NCTRL))
    if tuple(order) == (0, 0, 0):  # the values: the same products in the same order, 4x faster
        for lo in range(0, bary.shape[0], CHUNK):
            out[lo : lo + CHUNK] = basis_of_degree(bary[lo : lo + CHUNK], DEGREE)
        return out
    for lo in range(0, bary.shape[0], CHUNK):  # the temporaries in reused heap memory (see CHUNK)
        s = slice(lo, lo + CHUNK)
        pw = _power_rows(bary[s], DEGREE)  # (3, 6, m)
        out[s] = _MULTINOMIAL
        for c in range(3):
            e = EXPONENTS[:, c]
            o = order[c]
            coef = _falling(e, o)
            ee = np.clip(e - o, 0, None)
            out[s] *= coef[None, :] * pw[c, ee].T
    return out


#: Degree of the product of two quintic Bernstein polynomials.
PRODUCT_DEGREE = 2 * DEGREE
#: Monomials of that degree in three coordinates.
PRODUCT_MONOMIALS = (PRODUCT_DEGREE + 1) * (PRODUCT_DEGREE + 2) // 2


@lru_cache(maxsize=1)
def _product_table() -> tuple[np.ndarray, np.ndarray]:
    """``ids (21, 21)``, ``coef (21, 21)``: ``B_a B_b = coef[a, b] * l^m`` with ``m = lattice(10)[ids[a, b]]``
    (``B_a = 5! / a! l^a``, so ``coef = 5!^2 / (a! b!)``)."""
    ids = {tuple(int(x) for x in e): n for n, e in enumerate(lattice(PRODUCT_DEGREE))}
    pairs = EXPONENTS[:, None, :] + EXPONENTS[None, :, :]  # (21, 21, 3)
    table = np.array([[ids[tuple(int(x) for x in e)] for e in row] for row in pairs], np.int64)
    coef = _MULTINOMIAL[:, None] * _MULTINOMIAL[None, :]
    for arr in (table, coef):
        arr.setflags(write=False)
    return table, coef


def product_monomials(bary: np.ndarray) -> np.ndarray:
    """``(66, n)`` the monomials ``l^m`` of degree 10 (``m`` in :func:`~.index.lattice` ``(10)`` order) at
    ``bary (n, 3)``, one row per monomial (see :func:`_power_rows`). Sums of them over samples give
    :func:`gram_from_moments` the samples' Gram matrix."""
    e = lattice(PRODUCT_DEGREE)
    p = _power_rows(as_array(bary, "bary", (None, 3)), PRODUCT_DEGREE)
    return p[0, e[:, 0]] * p[1, e[:, 1]] * p[2, e[:, 2]]


def gram_from_moments(moments: np.ndarray) -> np.ndarray:
    """``(..., 21, 21)`` ``sum w basis(l) basis(l)^T`` from the moments ``sum w l^m`` ``(..., 66)`` of
    :func:`product_monomials`: the Gram matrix of weighted samples with 66 sums per sample, not 441."""
    table, coef = _product_table()
    return np.asarray(moments)[..., table] * coef


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


@lru_cache(maxsize=8)
def _step_index(degree: int) -> np.ndarray:
    """``(3, m)`` storage ids in :func:`lattice` ``(degree)`` of ``e + 1_a`` for each ``e`` of ``lattice(degree - 1)``."""
    ids = {tuple(int(x) for x in e): n for n, e in enumerate(lattice(degree))}
    lower = lattice(degree - 1) if degree > 1 else np.zeros((1, 3), np.int64)
    out = np.array([[ids[tuple(int(x) for x in e + np.eye(3, dtype=np.int64)[a])] for e in lower] for a in range(3)],
                   np.int64)
    out.setflags(write=False)
    return out


@lru_cache(maxsize=8)
def _multinomials(degree: int) -> np.ndarray:
    """``(m,)`` ``degree! / (i! j! k!)`` over :func:`lattice` ``(degree)``."""
    out = np.array([factorial(degree) / (factorial(i) * factorial(j) * factorial(k)) for i, j, k in lattice(degree)])
    out.setflags(write=False)
    return out


def basis_of_degree(bary: np.ndarray, degree: int) -> np.ndarray:
    """``(n, m)`` the Bernstein polynomials of ``degree`` (1..5) at ``bary (n, 3)``, in :func:`lattice` order:
    the basis of the derivative nets of :func:`derivative_nets` (degree 4 and 3)."""
    e = lattice(degree)
    p = _power_rows(np.asarray(bary, dtype=np.float64), degree)
    out = _multinomials(degree)[:, None] * p[0, e[:, 0]]  # (m, n): whole-row products
    out *= p[1, e[:, 1]]
    out *= p[2, e[:, 2]]
    return np.ascontiguousarray(out.T)


@lru_cache(maxsize=1)
def _pair_index() -> np.ndarray:
    """``(3, 3, 10)`` storage ids in :func:`lattice` ``(5)`` of ``e + 1_a + 1_b`` for ``e`` in ``lattice(3)``."""
    up5, up4 = _step_index(DEGREE), _step_index(DEGREE - 1)
    out = np.stack([np.stack([up5[a][up4[b]] for b in range(3)]) for a in range(3)])
    out.setflags(write=False)
    return out


def derivative_nets(ctrl: np.ndarray, directions: np.ndarray, second: bool = False) -> tuple[np.ndarray, ...]:
    """Bernstein nets of the directional derivatives of quintic patches (blossoming).

    ``ctrl (k, 21, d)``, ``directions (k, 3, r)``: ``r`` directions per patch by their barycentric
    components (e.g. the face's ``d l_a / du``, ``d l_a / dv``). Returns ``first (k, r, 15, d)``, the
    quartic nets of ``D_i S = 5 sum_a D_ia c_(e + 1_a)``, and with ``second`` also ``(k, r (r + 1) / 2, 10,
    d)``, the cubic nets of ``D_i D_j S`` for ``i <= j`` in row order (``uu, uv, vv`` for ``r = 2``). Evaluate
    them with :func:`basis_of_degree` ``(bary, 4)`` and ``(bary, 3)``: per patch once, then 15 and 10 terms a
    point instead of de Casteljau's 55 points.
    """
    c = np.asarray(ctrl, dtype=np.float64)
    D = np.asarray(directions, dtype=np.float64)
    up = _step_index(DEGREE)  # (3, 15)
    first = DEGREE * np.einsum("kai,kamd->kimd", D, c[:, up])
    if not second:
        return (first,)
    r = D.shape[2]
    pairs = [(i, j) for i in range(r) for j in range(i, r)]
    DD = np.stack([D[:, :, None, i] * D[:, None, :, j] for i, j in pairs], axis=-1)  # (k, 3, 3, p)
    second_nets = (DEGREE * (DEGREE - 1)) * np.einsum("kabp,kabmd->kpmd", DD, c[:, _pair_index()])
    return first, second_nets


def bary_grid(resolution: int) -> np.ndarray:
    """Barycentric points of the regular grid with ``resolution`` steps per edge: ``lattice(r) / r``.

    Returns
    -------
    (n, 3) with n = (r + 1)(r + 2) / 2, ordered like the control points
    (first coordinate descending, then second descending); see :func:`~trispline.spline.index.lattice`.
    """
    return lattice(resolution) / int(resolution)
