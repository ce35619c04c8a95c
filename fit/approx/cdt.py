"""The only module that calls Triangle (Shewchuk's, the ``triangle`` wheel): constrained Delaunay meshes of loops.

    segments = loop_segments([len(a), len(b)])          # (s, 2) closing chords of stacked loops
    holes = hole_seeds([P[a], P[b]])                    # (h, 2) a point inside each clockwise loop
    faces, extra = constrained(P, segments, holes)      # switch p: no point inserted, except at crossings
    vertices, faces = quality_mesh(P, segments, holes, area)   # switches p Y q a, refined (r) by area(points)

Loops are given with the domain on their left (outer counter-clockwise, holes
clockwise); Triangle eats the triangles from each hole seed out to the segments.
"""
from __future__ import annotations

from typing import Callable

import numpy as np
import triangle as tr

from trispline.param import loop_successors, polygon_area
from trispline.spline.topology import signed_areas, triangle_areas

__all__ = ["loop_segments", "hole_seeds", "constrained", "quality_mesh"]


def loop_segments(sizes: list[int]) -> np.ndarray:
    """``(s, 2)`` closing chords of consecutive loops of the given sizes, stacked in one vertex list."""
    return np.column_stack([np.arange(int(np.sum(sizes, dtype=np.int64))), loop_successors(sizes)])


def _pslg(P: np.ndarray, segments: np.ndarray, holes: np.ndarray) -> dict:
    pslg = {"vertices": P, "segments": segments}
    if holes.size:
        pslg["holes"] = holes
    return pslg


def hole_seeds(loops: list[np.ndarray]) -> np.ndarray:
    """One point strictly inside each hole ``(h, 2)``: each clockwise loop ``(k, 2)`` triangulated on its own,
    the centroid of its largest triangle (robust for any simple polygon, unlike an offset from an edge)."""
    seeds = []
    for p in loops:
        if polygon_area(p) >= 0:  # counter-clockwise: outer
            continue
        t = tr.triangulate(_pslg(p, loop_segments([p.shape[0]]), np.empty(0)), "p")
        T = t["vertices"][t["triangles"]]
        seeds.append(T[np.argmax(np.abs(triangle_areas(T[:, 0], T[:, 1], T[:, 2])))].mean(0))
    return np.array(seeds).reshape(-1, 2)


def constrained(P: np.ndarray, segments: np.ndarray, holes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Constrained Delaunay triangulation of ``P (k, 2)`` with ``segments``, holes eaten from ``holes``.

    Returns faces ``(f, 3)`` int64, counter-clockwise (indices into ``P`` and, past its
    end, into the points Triangle had to insert) and those points ``(e, 2)``: with
    switch ``p`` alone Triangle inserts a point only where two segments cross.
    """
    t = tr.triangulate(_pslg(P, segments, holes), "p")
    faces = np.asarray(t.get("triangles", np.zeros((0, 3))), np.int64).reshape(-1, 3)  # none: every one eaten
    allp = t["vertices"]
    neg = signed_areas(allp, faces) < 0
    faces[neg] = faces[neg][:, [0, 2, 1]]
    return faces, allp[P.shape[0]:]


def quality_mesh(P: np.ndarray, segments: np.ndarray, holes: np.ndarray, area: Callable[[np.ndarray], np.ndarray],
                 min_angle: float, rounds: int) -> tuple[np.ndarray, np.ndarray]:
    """Triangle's quality mesh inside the loops: vertices ``(k + s, 2)`` (``P`` first, then the ``s`` points
    Triangle added, none on a segment: switch ``Y``) and triangles ``(t, 3)``.

    ``area(points (m, 2)) -> (m,)`` is the largest triangle area wanted at a point; the
    first mesh takes its maximum over ``P``, then up to ``rounds`` refinements (``r``)
    impose it at every triangle's centroid. ``min_angle`` in degrees (``q``).
    """
    t = tr.triangulate(_pslg(P, segments, holes), f"pYq{min_angle}a{float(area(P).max()):.17g}")
    for _ in range(rounds):
        T = t["vertices"][t["triangles"]]
        target = area(T.mean(1))
        if (np.abs(triangle_areas(T[:, 0], T[:, 1], T[:, 2])) <= target).all():
            break
        t = tr.triangulate({**t, "triangle_max_area": target}, f"rpYq{min_angle}a")
    return t["vertices"], np.asarray(t["triangles"], np.int64)
