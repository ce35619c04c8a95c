"""Fits over nearly singular domains (issue 14): snapped uv stored with its largest move, and reported.

The whole table (30 x 30, eps 0 ... 1e-2, against the double-only build) is
``benchmarks/bench_near_degenerate.py``; here one small height field at eps = 1e-13
(snapped) and one at 1e-7 (double-double pass, nothing moved).
"""
from __future__ import annotations

import numpy as np
import pytest

from trispline.fit.cli.check import _check_text, surface_report
from trispline.fit.datasets.franke import exponential
from trispline.fit.pipeline import fit_surface
from trispline.spline.index import lattice
from trispline.spline.surface import SplineSurface
from trispline.spline.testing import domains
from trispline.spline.tolerances import SNAP_TOL


def worst_xy_error(surface) -> float:
    """``max |(x, y)(u, v) - (u, v)|`` over 28 points per patch: a height field over ``uv = (x, y)``."""
    bary = lattice(6) / 6.0
    fi = np.repeat(np.arange(surface.faces.shape[0]), len(bary))
    bb = np.tile(bary, (surface.faces.shape[0], 1))
    dom = np.einsum("nk,nkd->nd", bb, surface.uv[surface.faces[fi]])
    return float(np.abs(surface.evaluate(fi, bb)[:, :2] - dom).max())


@pytest.mark.parametrize("eps", [1e-13, 1e-7])
def test_height_field_over_a_nearly_singular_grid(eps, tmp_path):
    uv, faces = domains.grid(8, diagonal="crisscross")
    uv = domains.perturb(uv, faces, eps, seed=1)
    V = np.column_stack([uv, exponential(uv[:, 0], uv[:, 1])])
    res = fit_surface(V, faces, uv=V[:, :2])
    stats = res.space.stats
    assert worst_xy_error(res.surface) <= 1e-12
    assert res.c1_residual < 1e-13
    ex = res.surface.extras
    if eps < 1e-12:  # snapped: the surface's uv is the triangulation used, the move is stated
        assert stats["snapped_vertices"] > 0
        np.testing.assert_array_equal(res.surface.uv, res.space.tri.uv)
        assert float(ex["domain_max_move"]) == stats["max_move"] == np.linalg.norm(res.surface.uv - uv, axis=1).max()
        assert float(ex["domain_max_relative_move"]) <= SNAP_TOL
        path = tmp_path / "s.npz"
        res.surface.save(path)
        report = surface_report(SplineSurface.load(path))
        assert report["domain_max_move"] == stats["max_move"] and report["ok"]
        assert "domain snapped onto exact crossings" in _check_text(dict(report, file=str(path)))
    else:  # double-double pass only: the domain is the input
        assert stats["snapped_vertices"] == 0 and stats["exact_vertices"] > 0
        assert "domain_max_move" not in ex
        np.testing.assert_array_equal(res.surface.uv, uv)


@pytest.mark.parametrize("seed", [0, 3])
def test_a_fit_over_oblique_hull_slivers_passes_check_with_room(seed):
    """Random scattered data make hull slivers (aspect ~1e5 here); turned off the axes their diamond
    coefficients cancel in double. Rounded from double-double, the fitted surface's sampled C1 jump stays
    10x below ``check``'s tolerance (seed 3 gave 1.2e-9: ``check`` failed on a surface ``fit`` wrote)."""
    from trispline.spline.tolerances import CHECK_TOLERANCE

    uv, faces = domains.slivered_hull(400, 40, -5.0, 40.0, seed)
    V = np.column_stack([uv, 0.2 * np.sin(2 * uv[:, 0]) * np.cos(uv[:, 1])])
    rep = surface_report(fit_surface(V, faces).surface)
    assert rep["ok"]
    assert rep["relative_residuals"]["c1_sampled"] < 0.1 * CHECK_TOLERANCE


def test_check_judges_a_net_near_the_origin_as_stored():
    """``check`` moves the net to its centre only in coordinates far from the origin: on a net near it the
    move gains no digit, and its rounding, over the height of a hull sliver, made a jump of its own.
    Random points 100x denser in one corner (seed 1): the stored surface's sampled jump 5.9e-12, the
    moved net's 1.1e-9, above the tolerance (``check`` failed a surface ``fit`` had just written)."""
    from scipy.spatial import Delaunay

    from trispline.fit.cli.check import _centre
    from trispline.spline.tolerances import CHECK_TOLERANCE

    rng = np.random.default_rng(1)
    P = np.r_[rng.random((400, 2)), 0.01 * rng.random((400, 2))]
    V = np.column_stack([P, 0.2 * np.sin(5 * P[:, 0])])
    surface = fit_surface(V, Delaunay(P).simplices).surface
    rep = surface_report(surface)
    assert rep["ok"] and rep["relative_residuals"]["c1_sampled"] < 0.1 * CHECK_TOLERANCE
    np.testing.assert_array_equal(rep["centre"], 0.0)
    # far from the origin the move is still made, coordinate by coordinate
    pts = np.asarray(surface.ctrl).reshape(-1, 3) + [1e6, 0.0, 0.0]
    assert _centre(pts)[0] == pytest.approx(1e6 + 0.5, abs=0.02) and (_centre(pts)[1:] == 0).all()
