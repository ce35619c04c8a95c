"""A nearly singular patch is judged against the scan's own map (``trispline.fit.approx.pinch``).

Two triangles over the unit square carry a polynomial map to space; the scan's vertices lie on a grid
of the square (the patches' sampling lattice among them) with the map's exact area element. A surface
that only follows a squeezed map is not pinched; one that collapses where the scan does not is.
"""
from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from trispline.fit.approx.fit import PINCHED
from trispline.fit.approx.pinch import area_ratios, relative_regularity
from trispline.spline.patches import regularity
from trispline.spline.polynomial import polynomial_control_net
from trispline.spline.surface import SplineSurface

UV = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 1.0]])
FACES = np.array([[0, 1, 2], [1, 3, 2]])


def _grid(n: int = 41) -> np.ndarray:
    """``(n^2, 2)`` a grid over the square (every 5th line through the patches' lattice of 8 steps)."""
    t = np.linspace(0.0, 1.0, n)
    return np.column_stack([a.ravel() for a in np.meshgrid(t, t)])


def _surface(x, y, z) -> SplineSurface:
    return SplineSurface(UV, FACES, polynomial_control_net(UV, FACES, lambda p: np.column_stack([x(p), y(p), z(p)])))


@given(a=st.floats(5.0, 200.0))
def test_a_surface_that_follows_a_squeezed_map_is_not_pinched(a):
    # x = (u + a u^2, v, 0): the area element 1 + 2 a u grows (1 + 2 a)-fold across a patch, the scan's too
    s = _surface(lambda p: p[:, 0] + a * p[:, 0] ** 2, lambda p: p[:, 1], lambda p: 0 * p[:, 0])
    uv = _grid()
    element = 1.0 + 2.0 * a * uv[:, 0]
    assert regularity(UV, FACES, s.ctrl).min() < PINCHED  # the plain ratio reads the map's squeeze as a pinch
    np.testing.assert_allclose(area_ratios(s, uv, element), 1.0, rtol=1e-9)
    np.testing.assert_allclose(relative_regularity(s, uv, element), 1.0, rtol=1e-9)


@given(b=st.floats(0.0, 0.02))
def test_a_surface_that_collapses_where_the_scan_does_not_is_pinched(b):
    # x = (u, (u + b) v, v^2): the area element falls to about b at the edge u = 0; the scan's is uniform
    s = _surface(lambda p: p[:, 0], lambda p: (p[:, 0] + b) * p[:, 1], lambda p: p[:, 1] ** 2)
    uv = _grid()
    rel = relative_regularity(s, uv, np.ones(len(uv)))
    assert rel.min() < PINCHED
    assert np.all(rel >= regularity(UV, FACES, s.ctrl) - 1e-12)  # over the median, not the largest


def test_a_scan_vertex_with_a_degenerate_uv_star_does_not_make_a_pinch():
    # a tiny own area element (its faces nearly flat in uv) makes one huge ratio: the median ignores it
    s = _surface(lambda p: p[:, 0], lambda p: p[:, 1], lambda p: 0 * p[:, 0])
    uv = _grid()
    element = np.ones(len(uv))
    element[0] = 1e-9
    np.testing.assert_allclose(relative_regularity(s, uv, element), 1.0, rtol=1e-12)


@pytest.mark.parametrize("resolution", [4, 8])
def test_the_lattice_samples_every_patch_at_its_corners_too(resolution):
    # the pinch sits at the corner (0, 0) of the first patch: the lattice reaches it at any resolution
    s = _surface(lambda p: p[:, 0], lambda p: p[:, 0] * p[:, 1] + p[:, 1] ** 2, lambda p: 0 * p[:, 0])
    uv = _grid()
    r = area_ratios(s, uv, np.ones(len(uv)), resolution)
    assert r.shape == (2, (resolution + 1) * (resolution + 2) // 2)
    assert r[0].min() < 1e-12
