"""One outline-vertex mask for every layer: the vertices on an edge of exactly one face."""
from __future__ import annotations

import numpy as np
from hypothesis import given
from triangulations import triangulations

from trispline.spline.topology import Triangulation, outline_vertex_mask, undirected_edges


@given(triangulations())
def test_the_mask_marks_the_triangulations_boundary_vertices(case):
    _, uv, faces = case
    t = Triangulation(uv, faces)
    mask = outline_vertex_mask(faces, len(uv))
    assert np.array_equal(mask, t.boundary_vertex_mask)
    he, _, he_edge, count = undirected_edges(np.asarray(faces, np.int64), len(uv))
    assert np.array_equal(outline_vertex_mask(faces, len(uv), tables=(he, he_edge, count)), mask)


def test_a_closed_fan_has_only_its_rim_on_the_outline():
    ring = np.arange(1, 7)
    faces = np.column_stack([np.zeros(6, int), ring, np.roll(ring, -1)])
    mask = outline_vertex_mask(faces, 8)  # vertex 7 is unused
    assert mask.tolist() == [False] + [True] * 6 + [False]
