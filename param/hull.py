"""Hull slivers: the long, thin faces a Delaunay triangulation of scattered points lays along its convex hull.

A scan triangulated from scattered points (a LiDAR tile, random samples of a height field) has an outline
made of the hull's chords: a side of a square tile is one edge from corner to corner, closed off by
slivers whose third corners are the points nearest that side. They carry no scanned surface, and they
hurt every stage: the conformal maps fold or distort along them, and an approximation, whose vertices
are scan vertices, cannot place one along such an edge, so the coarse face over it spans the whole
side and its tolerance stalls (a 1 km tile of 50k points: 2.05 m against 1.43 after 13 rounds; peeled,
met with 265 vertices, benchmarks/README.md). :func:`hull_sliver_faces` finds them the way they are
made: a face on the outline whose outline edge is at least :data:`HULL_EDGE_RATIO` times the spacing
of the points at the face's far corner (:func:`_spacing`) and at least :data:`HULL_SLIVER_ASPECT`
times the face's height over it, and peels them round by round, as each peeled face exposes the next
one behind it. The spacing is the smaller of the far corner's median edge and its component's: a
second component of another scale keeps its outline, but a thin face along a long outline edge of a
graded mesh's coarse part (a decimated terrain's flats) is peeled like a hull sliver.
"""
from __future__ import annotations

import numpy as np

from trispline.spline.topology import undirected_edges

from .tables import vertex_components

__all__ = ["HULL_EDGE_RATIO", "HULL_MAX_SHARE", "HULL_SLIVER_ASPECT", "hull_sliver_faces"]

#: An outline edge this many times the spacing at its face's far corner or longer is a hull chord
#: (the shared real scans' longest outline edges are 1.1-3.7 times the median edge of the mesh).
HULL_EDGE_RATIO = 4.0
#: ... when the face is this many times as long over it as it is high (an apex angle above ~113
#: degrees), or thinner (5 left chords of 14 median edges on a 1 km tile, whose z made them 4.6 high).
HULL_SLIVER_ASPECT = 3.0
#: More than this share of the faces would go: the mesh is made of such faces (a CAD fan), not
#: closed off by them; none is a hull sliver then.
HULL_MAX_SHARE = 0.1
#: Rounds of peeling at most (each round halves a hull chord, roughly: 12 rounds for a chord of 190
#: median edges).
MAX_HULL_ROUNDS = 256


def hull_sliver_faces(V: np.ndarray, F: np.ndarray, *, rounds: int = MAX_HULL_ROUNDS) -> np.ndarray:
    """``(nf,)`` bool: the hull slivers of ``V (nv, 3), F (nf, 3)`` (see the module docstring).

    Peeled for at most ``rounds`` rounds (1: only those on the outline now). Vectorised: only the
    half-edges long and thin enough to qualify are followed from round to round.
    """
    F = np.asarray(F, np.int64)
    nf = F.shape[0]
    out = np.zeros(nf, bool)
    if nf == 0:
        return out
    he, _, he_edge, count = undirected_edges(F, V.shape[0])
    length = np.linalg.norm(V[he[:, 0]] - V[he[:, 1]], axis=1)  # (3 nf,): row 3 f + k is face f's, opposite F[f, k]
    doubled_area = np.linalg.norm(np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]]), axis=1)
    height = np.repeat(doubled_area, 3) / np.maximum(length, np.finfo(float).tiny)
    spacing = _spacing(F, he, length, V.shape[0])
    chord = np.flatnonzero((length >= HULL_EDGE_RATIO * spacing) & (length >= HULL_SLIVER_ASPECT * height))
    faces_left = count.copy()
    for _ in range(rounds):
        live = chord[~out[chord // 3]]
        rim = live[faces_left[he_edge[live]] == 1]
        if not rim.size:
            break
        peeled = np.unique(rim // 3)
        out[peeled] = True
        np.subtract.at(faces_left, he_edge[(3 * peeled[:, None] + np.arange(3)).ravel()], 1)
    if out.sum() > HULL_MAX_SHARE * nf:
        out[:] = False
    return out


def _spacing(F: np.ndarray, he: np.ndarray, length: np.ndarray, nv: int) -> np.ndarray:
    """``(3 nf,)`` the spacing of the points at the corner opposite each half-edge ``he (3 nf, 2)``: the
    smaller of the median edge at that corner and the median edge of its connected component.

    The corner's own median: a coarse part of a graded mesh keeps its long outline edges. The
    component's: a far corner that a fan of slivers leaves too (2.5 m inside a 1 km tile: edges of
    1.3-17 m and four of 48-137 m, median 48) still sees the tile's spacing (12 m).
    """
    _, label = vertex_components(F, nv)
    at_vertex = _median_by(np.repeat(length, 2), he.ravel(), nv)  # an interior edge from both of its faces
    at_component = _median_by(length, label[he[:, 0]], int(label.max()) + 1)
    corner = F.ravel()
    return np.minimum(at_vertex[corner], at_component[label[corner]])


def _median_by(values: np.ndarray, group: np.ndarray, n: int) -> np.ndarray:
    """``(n,)`` the (upper) median of ``values (h,)`` in each ``group (h,)`` of ``0..n-1`` (0 where empty)."""
    order = np.lexsort((values, group))
    count = np.bincount(group, minlength=n)
    start = np.concatenate([[0], np.cumsum(count)[:-1]])
    out = np.zeros(n)
    used = count > 0
    out[used] = values[order][start[used] + count[used] // 2]
    return out
