"""Data-dependent edge flips of a coarse triangulation: coarse edges along the scan's creases.

    faces = flip_to_data(uv, faces, X, scan_uv, P)   # (f, 3), same vertices, some interior edges flipped

The constrained Delaunay triangulation of the chosen vertices is isotropic in uv: it
ignores the surface's anisotropy, so on creased or panelled scans (CAD-like parts) its
edges cut across the creases, where a quadric decimation puts them along. An interior
edge is flipped when the piecewise-linear interpolant of the coarse vertices' 3D
positions ``X`` over the two faces fits the scan points in them (``P`` at ``scan_uv``)
with at least :data:`FLIP_GAIN` less sum of squares across the other diagonal, and both
new faces keep an angle of at least :data:`FLIP_MIN_ANGLE` in uv (the spline stays well
conditioned). Each sweep flips an independent set (every flipped edge the best of both
its faces), the points relocated in the two new faces; :data:`FLIP_SWEEPS` sweeps at most.
Boundary edges (the constrained segments) never flip: no face across a hole, loops and
corners kept.
"""
from __future__ import annotations

import numpy as np

from .locate import ClampedLocator
from .quality import triangle_angles

__all__ = ["flip_to_data", "FLIP_SWEEPS", "FLIP_GAIN", "FLIP_MIN_ANGLE", "FLIP_POINTS", "FLIP_FLOOR"]

#: Sweeps of flips at most (0: the constrained Delaunay triangulation as it is).
FLIP_SWEEPS = 8
#: A flip must lower its quad's sum of squares by at least this fraction.
FLIP_GAIN = 0.25
#: Smallest uv angle (degrees) of a face made by a flip.
FLIP_MIN_ANGLE = 15.0
#: A quad whose points are within this fraction of the coarse vertices' extent of the linear interpolant (RMS)
#: flips nothing (exact planar data: rounding, not shape).
FLIP_FLOOR = 1e-9
#: At most this many scan points per coarse face (every k-th of the scan) judge the flips (locating them is
#: most of the cost: ~0.3 s for 50k points on an idle core).
FLIP_POINTS = 40


def _interior_edges(faces: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Interior edges as half-edge pairs: ``(f1, j1, f2, j2)`` each ``(e,)``; half-edge ``(f, j)`` runs
    from ``faces[f, j]`` to ``faces[f, (j + 1) % 3]``."""
    a, b = faces.ravel(), faces[:, [1, 2, 0]].ravel()
    key = np.minimum(a, b) * (int(faces.max()) + 1) + np.maximum(a, b)
    order = np.argsort(key, kind="stable")
    k = key[order]
    first = np.flatnonzero(k[1:] == k[:-1])
    h1, h2 = order[first], order[first + 1]
    return h1 // 3, h1 % 3, h2 // 3, h2 % 3


def _is_fixed(a: np.ndarray, b: np.ndarray, fixed: np.ndarray, k: int) -> np.ndarray:
    """``(e,)`` bool: whether the edges ``(a, b)`` (each ``(e,)``) are among ``fixed (s, 2)``, either way round."""
    key = lambda p, q: np.minimum(p, q) * k + np.maximum(p, q)  # noqa: E731
    return np.isin(key(a, b), key(fixed[:, 0], fixed[:, 1]))


def _bary(p: np.ndarray, A: np.ndarray, B: np.ndarray, C: np.ndarray) -> np.ndarray:
    """Barycentric coordinates ``(m, 3)`` of uv points ``p (m, 2)`` in triangles ``(A, B, C)`` (each ``(m, 2)``)."""
    e1, e2, q = B - A, C - A, p - A
    det = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]
    det = np.where(det == 0, 1e-300, det)
    l1 = (q[:, 0] * e2[:, 1] - q[:, 1] * e2[:, 0]) / det
    l2 = (e1[:, 0] * q[:, 1] - e1[:, 1] * q[:, 0]) / det
    return np.column_stack([1.0 - l1 - l2, l1, l2])


def _sq_error(P: np.ndarray, X: np.ndarray, tri: np.ndarray, bary: np.ndarray) -> np.ndarray:
    """``(m,)`` squared distance of ``P (m, 3)`` from the linear interpolant of ``X`` at ``bary`` in ``tri (m, 3)``."""
    return ((P - np.einsum("mj,mjd->md", bary, X[tri])) ** 2).sum(1)


def flip_to_data(uv: np.ndarray, faces: np.ndarray, X: np.ndarray, scan_uv: np.ndarray, P: np.ndarray,
                 sweeps: int | None = None, fixed: np.ndarray | None = None) -> np.ndarray:
    """``faces (f, 3)`` with interior edges flipped toward the data; see the module docstring.

    uv : (k, 2) coarse vertices; faces : (f, 3) counter-clockwise; X : (k, 3) their 3D positions
    scan_uv : (n, 2), P : (n, 3) the scan points that judge the flips (outside the domain: ignored)
    fixed : (s, 2) vertex pairs (into ``uv``) of edges that never flip (constrained segments)
    """
    sweeps = FLIP_SWEEPS if sweeps is None else sweeps
    faces = np.array(faces, np.int64, copy=True)
    if sweeps <= 0 or faces.shape[0] < 2:
        return faces
    step = max(1, scan_uv.shape[0] // (FLIP_POINTS * faces.shape[0]))
    q, P = scan_uv[::step], P[::step]
    hit = ClampedLocator(uv, faces.copy())(q)  # (the locator freezes its arrays)
    keep = ~hit.clamped
    q, P, face, bary = q[keep], P[keep], hit.face[keep].copy(), hit.bary[keep].copy()
    err = _sq_error(P, X, faces[face], bary)
    f = faces.shape[0]
    floor = (FLIP_FLOOR * float(np.ptp(X, axis=0).max())) ** 2  # a point's square error that is rounding
    for _ in range(sweeps):
        f1, j1, f2, j2 = _interior_edges(faces)
        if f1.size == 0:
            break
        a, b, c = faces[f1, j1], faces[f1, (j1 + 1) % 3], faces[f1, (j1 + 2) % 3]
        d = faces[f2, (j2 + 2) % 3]
        n1 = np.column_stack([a, d, c])  # the quad a, d, b, c counter-clockwise, split along c d
        n2 = np.column_stack([d, b, c])
        ok = triangle_angles(uv[n1]).min(1) >= FLIP_MIN_ANGLE
        if fixed is not None and fixed.size:
            ok &= ~_is_fixed(a, b, fixed, uv.shape[0])
        ok &= triangle_angles(uv[n2]).min(1) >= FLIP_MIN_ANGLE
        for t in (n1, n2):  # both counter-clockwise: the quad is convex
            e1, e2 = uv[t[:, 1]] - uv[t[:, 0]], uv[t[:, 2]] - uv[t[:, 0]]
            ok &= e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0] > 0
        # every point against each interior edge of its face: its error across the other diagonal
        edge_of = np.full((f, 3), -1, np.int64)
        edge_of[f1, j1] = np.arange(f1.size)
        edge_of[f2, j2] = np.arange(f1.size)
        pe = edge_of[face]  # (m, 3)
        pt, slot = np.nonzero(pe >= 0)
        e = pe[pt, slot]
        e, pt = e[ok[e]], pt[ok[e]]
        b1 = _bary(q[pt], uv[n1[e, 0]], uv[n1[e, 1]], uv[n1[e, 2]])
        side1 = b1[:, 0] >= 0  # on a's side of c d: in (a, d, c), else in (d, b, c)
        b2 = _bary(q[pt], uv[n2[e, 0]], uv[n2[e, 1]], uv[n2[e, 2]])
        new_tri = np.where(side1[:, None], n1[e], n2[e])
        new_bary = np.where(side1[:, None], b1, b2)
        e_new = _sq_error(P[pt], X, new_tri, new_bary)
        sse_new = np.bincount(e, e_new, minlength=f1.size)
        per_face = np.bincount(face, err, minlength=f)
        sse_old = per_face[f1] + per_face[f2]
        gain = sse_old - sse_new
        good = ok & (sse_new < (1.0 - FLIP_GAIN) * sse_old) & (sse_old > floor * np.bincount(e, minlength=f1.size))
        if not good.any():
            break
        # an independent set: each flipped edge the best (largest gain, then lowest id) of both its faces
        score = np.where(good, gain, -np.inf)
        rank = np.empty(f1.size, np.int64)
        rank[np.lexsort((-np.arange(f1.size), score))] = np.arange(f1.size)  # higher: better
        best = np.full(f, -1, np.int64)
        np.maximum.at(best, f1, np.where(good, rank, -1))
        np.maximum.at(best, f2, np.where(good, rank, -1))
        flip = np.flatnonzero(good & (best[f1] == rank) & (best[f2] == rank))
        # relocate the points of the flipped faces, then flip
        moved = np.isin(e, flip)
        pm, em = pt[moved], e[moved]
        face[pm] = np.where(side1[moved], f1[em], f2[em])
        bary[pm] = new_bary[moved]
        err[pm] = e_new[moved]
        faces[f1[flip]] = n1[flip]
        faces[f2[flip]] = n2[flip]
    return faces
