"""Holes of a scan that its map squeezes shut: spanned by faces before the approximation.

A hole only a sliver wide (a folded flap that ``--repair`` cut out of a noisy scattered-point scan, a
crack between two scan passes) may come out of a free-boundary map with almost no area, or turned
inside out: no triangle of the map folds, but the hole's loop runs counter-clockwise or nearly
collapses. The coarse domain's constrained triangulation cannot keep such a hole (it fills it, and the
domain has fewer loops than the scan). An approximation has no reason to: the hole is far narrower
than the spacing of its vertices. :func:`folded_holes` finds those the map turns inside out or leaves
less than ``SPAN_HOLE_AREA`` of a median triangle per vertex of the loop (the pipeline spans the
others only where the coarse domain loses them: :class:`~.domain.LostHolesError`), and
:func:`span_holes` closes each by a fan of faces over its own vertices (no vertex is added, no edge
doubled), so that the map made again covers them.
"""
from __future__ import annotations

import numpy as np

from trispline.param import polygon_area
from trispline.param.tables import SMALL_HOLE, boundary_loops
from trispline.param.tables import small_holes as loop_small_holes
from trispline.spline.topology import signed_areas, undirected_edges

__all__ = ["SMALL_HOLE", "SPAN_HOLE_AREA", "WIDE_HOLE", "folded_holes", "hole_width", "small_holes", "span_holes",
           "wide_holes"]

#: A hole whose signed uv area (clockwise: negative) is above ``-SPAN_HOLE_AREA`` times the median uv
#: face area per vertex of its loop is folded shut: a thousandth of a triangle per vertex (halftunnel's
#: smaller hole, 16 vertices squeezed by LSCM to 0.12 of a triangle, is a hole to keep; a hole of 4
#: vertices squeezed to 0.007 of one was lost by the coarse domain, which the pipeline then spans).
SPAN_HOLE_AREA = 1e-3
#: A hole at least this many of its loop's edge lengths wide in space (:func:`hole_width`) is an opening of the
#: scan, not a crack: a map that squeezes it shut has failed (LSCM takes an open tube's second end to a point), and
#: spanning it would close the opening with surface the scan does not have (the tube's end: a cap standing 0.2
#: diagonals out). A square hole is half an edge wide, a crack as wide as its gap, a tube's end its radius.
WIDE_HOLE = 2.0


def small_holes(V: np.ndarray, F: np.ndarray, max_vertices: int = SMALL_HOLE) -> list[np.ndarray]:
    """The hole loops of ``V (n, 3)``, ``F (m, 3)`` with at most ``max_vertices`` vertices around (surface on
    their left; the longest loop in 3D is the outline and never one of them: :func:`trispline.param.tables.small_holes`).

    A dropout of a few triangles must keep at least three coarse vertices and leaves a hole in the
    approximation; spanned first (:func:`span_holes`, ``approximate_surface(fill_holes=)``), the surface
    goes over it, as over the rest of the scan between its vertices."""
    if max_vertices < 3:
        return []
    he, _, he_edge, count = undirected_edges(F, V.shape[0])
    return loop_small_holes(boundary_loops(V, F, he_edge, count), max_vertices)


def folded_holes(uv: np.ndarray, faces: np.ndarray, loops: list[np.ndarray]) -> list[np.ndarray]:
    """The loops of ``loops`` (the outer loop first, then the holes, surface on the left) whose hole
    the map ``uv (n, 2)``, ``faces (m, 3)`` folds shut (see the module docstring)."""
    unit = float(np.median(np.abs(signed_areas(uv, faces))))
    return [h for h in loops[1:] if polygon_area(uv[h]) > -SPAN_HOLE_AREA * unit * h.size]


def _width_and_length(V: np.ndarray, loop: np.ndarray) -> tuple[float, float]:
    """``(hole_width, length)`` of the loop ``loop (k,)`` in space (``V (n, 3)``)."""
    P = V[loop] - V[loop].mean(0)
    Q = np.roll(P, -1, axis=0)
    length = float(np.linalg.norm(Q - P, axis=1).sum())
    return float(np.linalg.norm(np.cross(P, Q).sum(0))) / max(length, np.finfo(float).tiny), length


def hole_width(V: np.ndarray, loop: np.ndarray) -> float:
    """Twice the loop's vector area over its length, in space (``V (n, 3)``, ``loop (k,)``): a circle's radius,
    the gap of a crack between two long sides."""
    return _width_and_length(V, loop)[0]


def wide_holes(V: np.ndarray, holes: list[np.ndarray]) -> list[np.ndarray]:
    """The holes of ``holes`` at least :data:`WIDE_HOLE` of their mean edge lengths wide (:func:`hole_width`)."""
    measured = [(h, *_width_and_length(V, h)) for h in holes]
    return [h for h, width, length in measured if width >= WIDE_HOLE * length / h.size]


def span_holes(F: np.ndarray, holes: list[np.ndarray]) -> np.ndarray:
    """``(m + sum(k - 2), 3)``: ``F`` and a fan of faces over each hole loop ``(k,)``, oriented as the faces
    beside it (the loop has the surface on its left: each face runs it backwards).

    The fan's apex is the first vertex of the loop whose diagonals are no edge of ``F`` already (an edge
    of three faces is no surface); a hole that has no such vertex is left open.
    """
    F = np.asarray(F, np.int64)
    n = int(F.max()) + 1 if F.size else 0
    _, edges, _, _ = undirected_edges(F, n)
    existing = edges[:, 0] * n + edges[:, 1]
    fans = []
    for hole in holes:
        for r in range(hole.size):
            h = np.roll(hole, -r)
            diagonal = np.sort(np.column_stack([np.full(h.size - 3, h[0]), h[2:-1]]), axis=1)
            if not np.isin(diagonal[:, 0] * n + diagonal[:, 1], existing).any():
                fans.append(np.column_stack([np.full(h.size - 2, h[0]), h[2:], h[1:-1]]))
                break
    return np.concatenate([F, *fans]) if fans else F
