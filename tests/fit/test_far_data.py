"""Data far from the origin (UTM tiles, offsets of 1e6 and 1e9) fit through the Python API as well
as near it: corners exactly the data, the net C1 up to the rounding of its own coordinates."""
from __future__ import annotations

import numpy as np
import pytest

from trispline.fit.datasets.synthetic import synthetic_scan
from trispline.fit.approx import approximate_surface
from trispline.fit.pipeline import fit_surface
from trispline.spline import Triangulation, continuity_report
from trispline.spline.index import CORNER


@pytest.mark.parametrize("offset", [(5e5, 5e6, 100.0), (1e6, 1e6, 1e6), (1e9, -1e9, 1e9)])
def test_a_far_off_scan_is_interpolated_and_c1_to_the_rounding_of_its_coordinates(offset):
    V, F = synthetic_scan(120, seed=1)
    W = 10.0 * V + np.array(offset)  # a 20-unit patch
    r = fit_surface(W, F)
    corners = r.ctrl[np.arange(F.shape[0])[:, None], CORNER[None, :]]
    np.testing.assert_array_equal(corners, W[r.space.tri.faces])  # the data vertices, bit for bit
    centre = 0.5 * (W.min(0) + W.max(0))
    extent = float(np.ptp(W, axis=0).max())
    rounding = np.finfo(float).eps * float(np.abs(W).max()) / extent  # relative rounding of a coordinate
    c1 = continuity_report(r.space.tri, r.ctrl - centre)["c1_relative"]
    # measured: 0.5-0.6 x rounding about the centre; 8-18 x when the net is computed about the origin
    assert c1 < 3 * rounding, (c1, rounding)


@pytest.mark.parametrize("offset", [(5e5, 5e6, 100.0), (1e9, -1e9, 1e9)])
@pytest.mark.parametrize("corners", ["data", "fit"])
def test_a_far_off_scan_is_approximated_c1_to_the_rounding_of_its_coordinates(offset, corners):
    V, F = synthetic_scan(1500, seed=2)
    W = 10.0 * V + np.array(offset)
    r = approximate_surface(W, F, n_vertices=60, corners=corners)
    ctrl, faces = r.ctrl, r.faces
    tri = Triangulation(r.uv, faces)
    centre = 0.5 * (W.min(0) + W.max(0))
    rounding = np.finfo(float).eps * float(np.abs(W).max()) / float(np.ptp(W, axis=0).max())
    # about the centre below 3 x the rounding; 14-23 x when the net is computed about the origin
    assert continuity_report(tri, ctrl - centre)["c1_relative"] < 3 * rounding
    if corners == "data":  # the coarse corners are scan vertices, bit for bit
        corner_pts = ctrl[np.arange(tri.n_faces)[:, None], CORNER[None, :]]
        np.testing.assert_array_equal(corner_pts, W[r.vertices][faces])
