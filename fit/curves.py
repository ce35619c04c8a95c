"""Boundary loops faired as curves (issue 17): how far each boundary edge of a planar map bulges.

    a, b = loop_bulges(P, uv)     # (n,) each: edge i = loop vertex i -> i + 1

The spline's boundary curves are images of the straight uv edges between boundary vertices,
so between two boundary vertices the outline is the image of a chord: off the true outline
by the chord's sagitta (``h^2 / 8R``). Here each loop of the uv outline is read as a smooth
curve: uv as a function of 3D arc length along the loop, a weighted least-squares polynomial
over the vertices near each edge (:func:`trispline.param.smooth.fit_weights`, the uv
smoothing's own fits; never across a corner of the outline). Its offset from the edge's
chord, normal to the chord, is matched by the bump ``10 t^2 (1 - t)^2 ((1 - t) a + t b)``
(``t`` along the edge): the quintic edge curve whose two middle Bezier points are moved by
``a`` and ``b`` along the chord's normal, value and slope unchanged at both ends (so the
corner frames, and with them the surface's first derivatives at the vertices, keep theirs).
A chord's sagitta ``4 S t (1 - t)`` is matched to 19% RMS by ``a = b = 1.8 S``.
"""
from __future__ import annotations

import numpy as np
from trispline.param.smooth import fit_weights, loop_corners

__all__ = ["DEGREE", "REACH", "SAMPLES", "bump_basis", "bump_shapes", "loop_bulges"]

#: Loop vertices each side of an edge in its curve fit (the edge's own two included).
REACH = 3
#: Degree of the curve fits.
DEGREE = 4
#: The bump is fitted to the curve's offset at this many points inside each edge.
SAMPLES = 7


def bump_shapes(li: np.ndarray, lj: np.ndarray) -> np.ndarray:
    """``(..., 2)`` the bump's two shape functions in a face of barycentric coordinates ``li``, ``lj`` (edge
    ``i -> j``): ``5 li^2 lj^2 (1 + li - lj)`` and ``5 li^2 lj^2 (1 - li + lj)``. On the edge
    (``li + lj = 1``) they are the two middle quintic Bernstein polynomials ``B_320 = 10 li^3 lj^2`` and
    ``B_230 = 10 li^2 lj^3``; inside the face the bump of ``a = b`` is the quartic ``10 a li^2 lj^2``
    (``B_320 + B_230`` is quintic: ``10 li^2 lj^2 (1 - lk)``), and only the difference ``a - b`` takes a
    quintic term. Why: the boundary patch's targets are the fits read through the warped domain, and a
    quintic interpolates that composition with an error of the warp's fifth derivative times the fit's
    second (``O(h^3)``); with a quartic bump it is ``O(h^4)``: the sphere cap at 800 vertices over a polynomial
    map, band RMS 1.3e-7 -> 2.8e-8 (docs/fit.md, "Boundary curves faired as curves"). Both vanish with their
    first derivatives on the face's other two edges (``li^2 lj^2``)."""
    li, lj = np.asarray(li, float)[..., None], np.asarray(lj, float)[..., None]
    return 5.0 * li**2 * lj**2 * np.concatenate([1.0 + li - lj, 1.0 - li + lj], -1)


def bump_basis(t: np.ndarray) -> np.ndarray:
    """``(..., 2)`` :func:`bump_shapes` along an edge: ``10 t^2 (1 - t)^3``, ``10 t^3 (1 - t)^2``."""
    t = np.asarray(t, float)
    return bump_shapes(1.0 - t, t)


def _window(n: int, corner: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(idx (n, 2 REACH), ok (n, 2 REACH))``: unwrapped loop indices of each edge's window and
    whether no corner lies between the vertex and the edge (a corner may end a window)."""
    off = np.arange(1 - REACH, REACH + 1)
    i = np.arange(n)[:, None]
    idx = i + off  # (n, 2R)
    cc = np.concatenate([[0], np.cumsum(np.tile(corner, 3))])  # cc[j + n]: corners at unwrapped indices < j
    before = cc[i + n + 1] - cc[np.minimum(idx, i) + n + 1]  # corners in (j, i] for j < i
    after = cc[np.maximum(idx, i + 1) + n] - cc[i + 1 + n]  # corners in [i + 1, j) for j > i + 1
    return idx, (before == 0) & (after == 0)


def loop_bulges(P: np.ndarray, uv: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Bump coefficients ``a, b (n,)`` of the edges ``i -> i + 1`` of a closed boundary loop: 3D
    points ``P (n, 3)``, uv ``(n, 2)``; offsets along the left normal of each uv edge, in uv units.
    Also ``miss (n,)``: how far the curve passes from the edge's two vertices (the larger), over
    the edge's uv length: small where the outline is smooth, large where it is ragged.

    Loops of fewer than ``2 REACH`` vertices, and edges whose window holds fewer than 4 points
    (between corners), get zeros (and ``miss`` 0).
    """
    n = len(P)
    if n < 2 * REACH:
        return np.zeros(n), np.zeros(n), np.zeros(n)
    seg = np.linalg.norm(np.roll(P, -1, 0) - P, axis=1)  # seg[i]: i -> i + 1, 3D
    arc = np.concatenate([[0.0], np.cumsum(seg)])
    idx, ok = _window(n, loop_corners(P))
    s = arc[idx % n] + np.floor_divide(idx, n) * arc[-1] - arc[:n, None]  # (n, 2R) from vertex i
    h = np.maximum(seg, np.finfo(float).tiny)[:, None]
    t = np.linspace(0.0, 1.0, SAMPLES + 2)  # the ends too: the curve's own chord
    x = (s[:, None, :] - t[None, :, None] * h[:, :, None]) / h[:, :, None]  # (n, Q, 2R)
    w = np.where(ok, np.exp(-((s - 0.5 * h) / (h * REACH)) ** 2), 0.0)
    Q = t.size
    wts = fit_weights(x.reshape(n * Q, -1, 1), np.repeat(w, Q, 0), DEGREE).reshape(n, Q, -1)
    gamma = np.matmul(wts, uv[idx % n])  # (n, Q, 2): the curve at the edge's samples
    chord = gamma[:, :1] + t[None, :, None] * (gamma[:, -1:] - gamma[:, :1])
    e = np.roll(uv, -1, 0) - uv
    length = np.maximum(np.linalg.norm(e, axis=1), np.finfo(float).tiny)
    nrm = np.stack([-e[:, 1], e[:, 0]], 1) / length[:, None]
    off = np.einsum("nqc,nc->nq", gamma - chord, nrm)[:, 1:-1]  # (n, SAMPLES)
    ab = off @ np.linalg.pinv(bump_basis(t[1:-1])).T  # (n, 2)
    ends = np.stack([gamma[:, 0] - uv, gamma[:, -1] - np.roll(uv, -1, 0)], 1)  # (n, 2, 2)
    miss = np.linalg.norm(ends, axis=2).max(1) / length
    enough = ok.sum(1) >= 4
    return np.where(enough, ab[:, 0], 0.0), np.where(enough, ab[:, 1], 0.0), np.where(enough, miss, 0.0)
