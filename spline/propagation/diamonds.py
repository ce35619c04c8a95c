"""Stage 1 of the build: the diamonds of the interior edges and the corner-region frames.

A diamond is the pair of faces ``A = (p, r, s)``, ``B = (q, s, r)`` of an interior
edge ``(r, s)``; its C1 relation ``X_q = λ X_p + μ X_r + ν X_s`` (docs/design.md §2) gives
the ``i = 1`` equation at each end of the edge and the flips' ``i = 2`` condition.
Every star point is affine in its vertex's frame (:func:`star_weights`).
:func:`diamond_coefficients` and :func:`star_weights` take float64 or double-double
(:class:`~trispline.spline.util.ddouble.DD`) coordinates: one formula for both precisions.
"""
from __future__ import annotations

from functools import partial

import numpy as np

from ..net import NetLayout
from ..tolerances import EXACT_DIAMOND_ULPS
from ..topology import Triangulation, triangle_areas
from ..util import ddouble, gather as _gather, memory as _memory, parallel as _parallel
from ..util.ddouble import DD


def diamond_coefficients(p: np.ndarray | DD, q: np.ndarray | DD, r: np.ndarray | DD, s: np.ndarray | DD
                         ) -> np.ndarray | DD:
    """Normalised coefficients of the C1 relation of a diamond; ``p, q, r, s``: ``(n, 2)``.

    With ``q = λ p + μ r + ν s`` the condition ``X_q - λ X_p - μ X_r - ν X_s = 0``
    is scaled by ``|area(p, r, s)| / (|area(p, r, s)| + |area(q, s, r)|)`` so that
    all coefficients are dimensionless and O(1).

    Returns
    -------
    (n, 4) coefficients of ``(X_q, X_p, X_r, X_s)``; they sum to zero.
    """
    T = triangle_areas(p, r, s)
    lam = triangle_areas(q, r, s) / T
    mu = triangle_areas(p, q, s) / T
    nu = triangle_areas(p, r, q) / T
    scale = abs(T) / (abs(T) + abs(triangle_areas(q, s, r)))
    return ddouble.stack([scale, -lam * scale, -mu * scale, -nu * scale], axis=1)


def diamond_ids(tri: Triangulation, e: np.ndarray) -> tuple[np.ndarray, ...]:
    """For interior edges ``e: (n,)`` joining ``(a, b)``: ``a, b, f0, f1, k0, k1``, each ``(n,)``.

    ``f0`` is the face left of ``a -> b`` with ``a, b`` at its local corners
    ``k0 + 1, k0 + 2``; in ``f1`` they sit at ``k1 + 2, k1 + 1``. The diamond's
    outer vertices are ``p = F[f0, k0]`` and ``q = F[f1, k1]``.
    """
    ab, ef, eo = (_gather.rows(table, e) for table in (tri.edges, tri.edge_faces, tri.edge_opposite))
    return ab[:, 0], ab[:, 1], ef[:, 0], ef[:, 1], eo[:, 0], eo[:, 1]


def area_cancellation(p: np.ndarray, q: np.ndarray, r: np.ndarray, s: np.ndarray) -> np.ndarray:
    """``(n,)`` bound on the rounding of :func:`diamond_coefficients` in units of the last place: the
    largest sum of the absolute products of its five signed areas over the normaliser
    ``|area(p, r, s)| + |area(q, s, r)|`` (1-4 on nice triangles, the aspect ratio on a sliver)."""
    def products(a: np.ndarray, b: np.ndarray, c: np.ndarray) -> np.ndarray:
        u, v = b - a, c - a
        return np.abs(u[:, 0] * v[:, 1]) + np.abs(u[:, 1] * v[:, 0])

    worst = np.maximum.reduce([products(*t) for t in ((p, r, s), (q, r, s), (p, q, s), (p, r, q))])
    norm = np.abs(triangle_areas(p, r, s)) + np.abs(triangle_areas(q, s, r))
    with np.errstate(divide="ignore", invalid="ignore"):
        return 0.5 * worst / norm


def edge_coefficients(tri: Triangulation, ids: tuple[np.ndarray, ...], uv: np.ndarray | DD) -> np.ndarray | DD:
    """:func:`diamond_coefficients` ``(n, 4)`` of the interior edges whose :func:`diamond_ids` are ``ids``,
    from the coordinates ``uv: (V, 2)`` (``tri.uv``, or its double-double copy). In double, the
    diamonds whose :func:`area_cancellation` exceeds
    :data:`~trispline.spline.tolerances.EXACT_DIAMOND_ULPS` are computed in double-double and
    rounded: their coefficients are then right to the last place, so the C1 conditions that the
    build and the checks use are those of the triangles themselves."""
    a, b, f0, f1, k0, k1 = ids
    p, q = _gather.at(tri.faces, f0, k0), _gather.at(tri.faces, f1, k1)
    pts = [ddouble.rows(uv, v) for v in (p, q, a, b)]
    c = diamond_coefficients(*pts)
    if isinstance(uv, DD):
        return c
    bad = np.flatnonzero(~(area_cancellation(*pts) <= EXACT_DIAMOND_ULPS))
    if bad.size:
        c[bad] = ddouble.to_double(diamond_coefficients(*(DD(_gather.rows(x, bad)) for x in pts)))
    return c


def weak(c_mid: np.ndarray, c_q: np.ndarray, c_p: np.ndarray, inner_weight: float, tol: float) -> np.ndarray:
    """Equations whose middle point is no good pivot: its coefficient ``c_mid`` is below
    ``inner_weight`` times the larger inner-point coefficient, or below ``tol`` (all one shape)."""
    cm = np.abs(c_mid)
    return ~((cm >= inner_weight * np.maximum(np.abs(c_q), np.abs(c_p))) & (cm > tol))


def flip_pair(lay: NetLayout, f0: np.ndarray, k0: np.ndarray, f1: np.ndarray, k1: np.ndarray,
              c: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The two flips of interior edges: ``(computed, free, q_side_computed)``, each ``(n,)``.

    Of the flips ``f(p ...)`` (face ``f0``) and ``f(q ...)`` (face ``f1``) of a diamond with
    coefficients ``c: (n, 4)`` of ``(q, p, r, s)``, the one with the larger coefficient is
    computed (no division by a small number); the other is free.
    """
    q_dep = np.abs(c[:, 0]) >= np.abs(c[:, 1])
    flip_p, flip_q = lay.flip(f0, k0), lay.flip(f1, k1)
    return np.where(q_dep, flip_q, flip_p), np.where(q_dep, flip_p, flip_q), q_dep


def star_weights(uv: np.ndarray | DD, frame_scale: np.ndarray, s: np.ndarray, w: np.ndarray) -> np.ndarray | DD:
    """Weights of ``(z_s, frame_s,x, frame_s,y)`` in the star points ``f(s^4 w)``, ``(..., 3)``.

    A star is affine in its vertex's frame: ``f(s^4 w) = (1 - x - y) z_s + x frame_s,x
    + y frame_s,y`` with ``(x, y) = (w - s) / d_s``; ``s, w`` are vertex ids of one shape.
    """
    d = (ddouble.rows(uv, w) - ddouble.rows(uv, s)) / frame_scale[s][..., None]
    x, y = d[..., 0], d[..., 1]
    return ddouble.stack([1.0 - x - y, x, y], axis=-1)


def frame_scales(tri: Triangulation) -> np.ndarray:
    """``d_v: (V,)``, the mean length of the edges at each vertex (well-conditioned frames)."""
    edges, nv = tri.edges, tri.n_vertices
    elen = np.linalg.norm(_gather.rows(tri.uv, edges[:, 0]) - _gather.rows(tri.uv, edges[:, 1]), axis=1)
    return np.bincount(edges.ravel(), weights=np.repeat(elen, 2), minlength=nv) / np.bincount(
        edges.ravel(), minlength=nv)


def diamonds(work: _parallel.Workers, tri: Triangulation, inner_weight: float, singular_tol: float
             ) -> tuple[np.ndarray, np.ndarray]:
    """Coefficients of every interior edge's diamond and the weak equations per vertex.

    One diamond per interior edge ``ie[n]`` (``p, q, r = a, s = b``): the ``i = 1``
    equation at end 1 and the flips' ``i = 2`` condition; the equation at end 0
    (``r = b, s = a``) has the ``r`` and ``s`` coefficients swapped (the signed areas
    change sign exactly: bit-identical). A vertex needs elimination when one of its
    equations' middle-point coefficient is :func:`weak`; elsewhere weighted complete
    pivoting would pick every middle point (a middle column lives in one row only).

    Returns
    -------
    c2 : (E_int, 4) coefficients of ``(q, p, r, s)``, by position in ``tri.interior_edges``
    n_weak : (V,) int64, weak equations per vertex
    """
    ie = tri.interior_edges
    c2 = _memory.empty((ie.size, 4))
    weak_ends = work.map(partial(_diamond_range, tri, c2, inner_weight, singular_tol), ie.size)
    return c2, np.bincount(_parallel.concat(weak_ends), minlength=tri.n_vertices)


def _diamond_range(tri: Triangulation, c2: np.ndarray, inner_weight: float, singular_tol: float,
                   lo: int, hi: int) -> np.ndarray:
    """Write ``c2[lo:hi]``; returns the vertex of each weak equation of those edges."""
    ids = diamond_ids(tri, tri.interior_edges[lo:hi])
    a, b = ids[0], ids[1]
    c = edge_coefficients(tri, ids, tri.uv)
    c2[lo:hi] = c
    return np.concatenate([s[weak(c[:, mid_col], c[:, 0], c[:, 1], inner_weight, singular_tol)]
                           for s, mid_col in ((a, 3), (b, 2))])
