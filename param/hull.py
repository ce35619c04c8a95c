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
graded mesh's coarse part (a decimated terrain's flats) is peeled like a hull sliver. A face whose
peeling would leave a vertex without faces stays (a sliver carries no point of its own): a coarse
column of a graded grid along its rim loses one face at each end, not the column. And a peel that would
cut the surface in two peels nothing: the steep faces of a cliff across a height field (a step of 100
spacings over one) are long and thin along the outline where the cliff meets it, and each peeled one
exposes the next, across the whole mesh; hull slivers only ever line the rim.
"""
from __future__ import annotations

import numpy as np

from trispline.spline.topology import undirected_edges

from .tables import vertex_components

__all__ = ["HULL_EDGE_RATIO", "HULL_MAX_SHARE", "HULL_SLIVER_ASPECT", "edge_lengths", "hull_sliver_faces"]

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


def hull_sliver_faces(V: np.ndarray, F: np.ndarray, *, rounds: int = MAX_HULL_ROUNDS,
                      tables: tuple | None = None) -> np.ndarray:
    """``(nf,)`` bool: the hull slivers of ``V (nv, 3), F (nf, 3)`` (see the module docstring).

    Peeled for at most ``rounds`` rounds (1: only those on the outline now). Vectorised: only the
    half-edges long and thin enough to qualify are followed from round to round, and the spacing is
    measured only at the far corners of the thin ones. ``tables``: :func:`edge_lengths` of the mesh,
    when known.
    """
    F = np.asarray(F, np.int64)
    nf = F.shape[0]
    out = np.zeros(nf, bool)
    if nf == 0:
        return out
    he, he_edge, count, length = edge_lengths(V, F) if tables is None else tables
    doubled_area = np.linalg.norm(np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]]), axis=1)
    thin = np.flatnonzero(length >= HULL_SLIVER_ASPECT * np.repeat(doubled_area, 3) / np.maximum(
        length, np.finfo(float).tiny))
    chord = thin[length[thin] >= HULL_EDGE_RATIO * _spacing(F, he, length, V.shape[0], F.ravel()[thin])]
    faces_left = count.copy()
    vertex_faces = np.bincount(F.ravel(), minlength=V.shape[0])
    for _ in range(rounds):
        live = chord[~out[chord // 3]]
        rim = live[faces_left[he_edge[live]] == 1]
        peeled = _keeping_vertices(F, np.unique(rim // 3), vertex_faces)
        if not peeled.size:
            break
        out[peeled] = True
        np.subtract.at(faces_left, he_edge[(3 * peeled[:, None] + np.arange(3)).ravel()], 1)
        vertex_faces -= np.bincount(F[peeled].ravel(), minlength=V.shape[0])
    if out.sum() > HULL_MAX_SHARE * nf:
        out[:] = False
    if out.any() and vertex_components(F[~out], V.shape[0])[0] > vertex_components(F, V.shape[0])[0]:
        out[:] = False  # the peel cut through the surface: a cliff of a height field, not a hull
    return out


def _keeping_vertices(F: np.ndarray, faces: np.ndarray, vertex_faces: np.ndarray) -> np.ndarray:
    """The faces ``faces (k,)`` whose peeling leaves each of their vertices a face (``vertex_faces (nv,)``:
    the faces each has now). A hull sliver carries no point of its own, so a vertex left with none is a
    sampled outline peeled away: a graded mesh's coarse column along its rim, not a hull."""
    emptied = vertex_faces - np.bincount(F[faces].ravel(), minlength=vertex_faces.size) <= 0
    return faces[~emptied[F[faces]].any(axis=1)]


def edge_lengths(V: np.ndarray, F: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``(he (3 nf, 2), he_edge (3 nf,), edge_count (ne,), length (3 nf,))``: the half-edges of ``F`` (row
    ``3 f + k`` is face ``f``'s, opposite ``F[f, k]``; :func:`~trispline.spline.topology.undirected_edges`)
    and their lengths over ``V``."""
    he, _, he_edge, count = undirected_edges(np.asarray(F, np.int64), V.shape[0])
    return he, he_edge, count, np.linalg.norm(V[he[:, 0]] - V[he[:, 1]], axis=1)


def _spacing(F: np.ndarray, he: np.ndarray, length: np.ndarray, nv: int, corner: np.ndarray) -> np.ndarray:
    """``(k,)`` the spacing of the points at the vertices ``corner (k,)``: the smaller of the median edge
    there (over the half-edges ``he (3 nf, 2)`` of ``length (3 nf,)``) and the median edge of its connected
    component.

    The corner's own median: a coarse part of a graded mesh keeps its long outline edges. The
    component's: a far corner that a fan of slivers leaves too (2.5 m inside a 1 km tile: edges of
    1.3-17 m and four of 48-137 m, median 48) still sees the tile's spacing (12 m).
    """
    if corner.size == 0:
        return np.zeros(0)
    _, label = vertex_components(F, nv)
    ends, values = he.ravel(), np.repeat(length, 2)  # an interior edge from both of its faces
    near = np.isin(ends, corner)
    at_vertex = _median_by(values[near], ends[near], nv)
    first = label[he[:, 0]]
    own = np.isin(first, label[corner])
    at_component = _median_by(length[own], first[own], int(label.max()) + 1)
    return np.minimum(at_vertex[corner], at_component[label[corner]])


def _median_by(values: np.ndarray, group: np.ndarray, n: int) -> np.ndarray:
    """``(n,)`` the (upper) median of ``values (h,)`` in each ``group (h,)`` of ``0..n-1`` (0 where empty).
    The order of ``np.lexsort((values, group))`` by two sorts, the second a stable one of integers: half
    the time (0.29 against 0.54 s for 3M values)."""
    order = np.argsort(values)
    order = order[np.argsort(group[order], kind="stable")]
    count = np.bincount(group, minlength=n)
    start = np.concatenate([[0], np.cumsum(count)[:-1]])
    out = np.zeros(n)
    used = count > 0
    out[used] = values[order][start[used] + count[used] // 2]
    return out
