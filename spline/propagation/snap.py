"""Stage 0 of the build: nearly singular vertices moved onto the crossing of their two lines.

A vertex is *singular* -- its ``i = 1`` system loses rank by one and the spline space
gains a dimension -- when it is interior, has four edges, and these lie on two
straight lines: the vertex sits on the crossing of its two diagonals (the lines
through opposite neighbours). Near such a configuration the rank is a coin toss in
floating point (a pivot of 1e-13 is neither clearly zero nor clearly not), so a
vertex closer to its crossing than ``snap_tol`` times its mean edge length is moved
onto the crossing (computed in double-double, rounded to double) and counted
singular. The domain is ours: the spline does not care where a vertex sits to
1e-12 of an edge, and the build returns the triangulation it actually used.

Vertices within one unit in the last place of their crossing stay where they are
(exact grids keep every bit). Two nearly singular neighbours are both moved from
the original positions: each then sits on its crossing only to about the other's
move (at most ``snap_tol`` of an edge).
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from ..topology import Triangulation
from ..util import ddouble
from ..util.ddouble import DD


class Snap(NamedTuple):
    """What the snap stage did."""

    tri: Triangulation  # the triangulation actually used (``uv`` moved where ``moved``)
    singular: np.ndarray  # (V,) bool: on the crossing of their two lines (moved or not)
    moved: np.ndarray  # (k,) int64 vertex ids moved
    max_move: float  # largest move, uv units
    max_relative_move: float  # largest move / the moved vertex's mean edge length


def _cross(a: np.ndarray | DD, b: np.ndarray | DD) -> np.ndarray | DD:
    """``a_x b_y - a_y b_x`` of ``(n, 2)`` vectors."""
    return a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]


def crossings(uv: np.ndarray | DD, ring: np.ndarray) -> tuple[np.ndarray | DD, np.ndarray | DD]:
    """Crossing ``(n, 2)`` of the lines ``ring[:, 0] ring[:, 2]`` and ``ring[:, 1] ring[:, 3]``,
    and the determinant ``(n,)`` of the two directions (0 for parallel lines); ``ring: (n, 4)``."""
    r0, r1, r2, r3 = (ddouble.rows(uv, ring[:, j]) for j in range(4))
    d02, d13 = r2 - r0, r3 - r1
    det = _cross(d02, d13)
    safe = ddouble.where(ddouble.magnitude(det) > 0, det, 1.0)
    t = _cross(r1 - r0, d13) / safe
    return r0 + d02 * t[:, None], det


def _rings(tri: Triangulation) -> tuple[np.ndarray, np.ndarray]:
    """Interior vertices with four edges ``(n,)`` and their neighbours ``(n, 4)`` counter-clockwise."""
    n_c = np.diff(tri.fan_ptr)
    verts = np.flatnonzero((n_c == 4) & ~tri.boundary_vertex_mask)
    corners = tri.fan_corners[tri.fan_ptr[verts][:, None] + np.arange(4)]
    f, k = np.divmod(corners, 3)
    return verts, tri.faces[f, (k + 1) % 3]


def snap(tri: Triangulation, frame_scale: np.ndarray, tol: float) -> Snap:
    """Move the interior valence-4 vertices within ``tol * frame_scale[v]`` of their crossing onto it.

    The crossing is found in double for every candidate, then again in double-double for
    those near enough and not exactly on it; the decision and the move use the latter.
    """
    singular = np.zeros(tri.n_vertices, bool)
    verts, ring = _rings(tri)
    if verts.size:
        x, det = crossings(tri.uv, ring)
        dist = np.linalg.norm(x - tri.uv[verts], axis=1)
        on = (det != 0) & (dist == 0)
        singular[verts[on]] = True
        near = (det != 0) & (dist > 0) & (dist <= 2 * tol * frame_scale[verts])
        verts, ring = verts[near], ring[near]
    if not verts.size:
        return Snap(tri, singular, np.zeros(0, np.int64), 0.0, 0.0)
    x, _ = crossings(DD(tri.uv), ring)
    s = tri.uv[verts]
    move = ddouble.to_double(x - s)
    rel = np.linalg.norm(move, axis=1) / frame_scale[verts]
    hit = rel <= tol
    singular[verts[hit]] = True
    target = ddouble.to_double(x)
    go = hit & (np.abs(target - s) > np.spacing(np.abs(s))).any(axis=1)  # more than one ulp away
    if not go.any():
        return Snap(tri, singular, np.zeros(0, np.int64), 0.0, 0.0)
    uv = tri.uv.copy()
    uv[verts[go]] = target[go]
    moved = np.linalg.norm(target[go] - s[go], axis=1)
    return Snap(Triangulation(uv, tri.faces), singular, verts[go], float(moved.max()),
                float((moved / frame_scale[verts[go]]).max()))
