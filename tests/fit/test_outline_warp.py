"""The outline faired as a curve (fit.boundary.outline_warp) never folds a boundary patch.

A scan with many small holes has short, zigzag outline loops: a curve fitted along one bulged its
edges across their faces, and the fits evaluated there spiked (|H| 6e5 times the data's on a
30 x 30 grid with 10% of its faces missing). Each face's warp is capped at
:data:`~trispline.fit.boundary.WARP_MAX` of its uv height.
"""
from __future__ import annotations

import numpy as np
import pytest
from folded_meshes import rough_holey_grid

from trispline.fit import boundary, fit_surface
from trispline.fit.render.geometry import surface_curvatures
from trispline.param import repair_mesh
from trispline.spline.index import lattice


def _max_curvature(r) -> float:
    bary = lattice(4) / 4
    nf = r.space.tri.n_faces
    H = surface_curvatures(r.surface, np.repeat(np.arange(nf), len(bary)), np.tile(bary, (nf, 1)))[0]
    return float(np.abs(H).max())


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_the_warp_adds_no_curvature_to_a_scan_full_of_small_holes(seed, monkeypatch):
    rm = repair_mesh(*rough_holey_grid(30, roughness=0.0, drop=0.1, seed=seed))
    warped = fit_surface(rm.V, rm.F)
    assert warped.curved_outline
    monkeypatch.setattr(boundary, "CURVE_WARP", False)
    plain = fit_surface(rm.V, rm.F)
    assert _max_curvature(warped) <= 1.5 * _max_curvature(plain)


def test_the_cap_bounds_every_faces_shift_by_its_height():
    rm = repair_mesh(*rough_holey_grid(30, roughness=0.0, drop=0.1, seed=1))
    r = fit_surface(rm.V, rm.F)
    shift = boundary.outline_warp(rm.V, r.uv, r.faces)
    p = r.uv[r.faces]
    e = np.roll(p, -1, 1) - p
    height = np.abs(e[:, 0, 0] * e[:, 1, 1] - e[:, 0, 1] * e[:, 1, 0]) / np.linalg.norm(e, axis=2).max(1)
    assert (np.linalg.norm(shift, axis=2).max(1) <= boundary.WARP_MAX * height * (1 + 1e-12)).all()
    assert np.count_nonzero(shift) > 0
