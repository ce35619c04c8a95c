"""The outline warp: the scan's parameters put its outline on the coarse domain's boundary chords."""
from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from trispline.fit.approx import approximate_surface, coarse_domain
from trispline.fit.approx.warp import outline_targets
from trispline.fit.datasets.truth import grid_with_hole
from trispline.param import parameterize
from trispline.spline.testing import domains
from trispline.spline.topology import signed_areas
from triangulations import lifted, scan_outlines


@st.composite
def scans(draw):
    """``(V, F, uv, fraction)``: a scan outline (:func:`~triangulations.scan_outlines`) lifted and parameterized
    by LSCM (its outline is jagged against any coarse chord), and a vertex fraction."""
    _, st_, F, _ = draw(scan_outlines(size=0.6))
    V = lifted(st_)
    p = parameterize(V, F, method="lscm")
    return V, p.faces, p.uv, draw(st.sampled_from([0.04, 0.1]))


def boundary_distance(dom, points: np.ndarray) -> np.ndarray:
    """``(m,)`` uv distance of ``points (m, 2)`` to the coarse domain's boundary."""
    return np.linalg.norm(dom.locator.project(points)[2] - points, axis=1)


def staircase_free(dom) -> np.ndarray:
    """Scan ids of the outline runs that turn back and forth by at most 90 degrees in all (what the warp calls
    smooth), written out here from the outline's headings."""
    out = []
    for kept, loop in zip(dom.boundary, dom.loops):
        p = dom.scan_uv[loop]
        d = np.roll(p, -1, axis=0) - p
        heading = np.unwrap(np.arctan2(d[:, 1], d[:, 0]))
        start = np.flatnonzero(np.isin(loop, kept))
        for i, j in zip(start, np.r_[start[1:], start[0] + loop.size]):
            h = heading[np.arange(i - 1, j) % loop.size]  # the edges into and out of the run's inner points
            turns = np.angle(np.exp(1j * np.diff(h)))
            if np.abs(turns).sum() - abs(turns.sum()) <= np.radians(90.0):
                out.append(loop[np.arange(i, j + 1) % loop.size])
    return np.unique(np.concatenate(out)) if out else np.empty(0, np.int64)


@settings(max_examples=8)
@given(scans())
def test_the_warp_puts_the_outline_on_the_chords_and_folds_nothing(scan):
    V, F, uv, frac = scan
    dom = coarse_domain(V, F, uv, n_vertices=max(20, int(frac * V.shape[0])))
    w = dom.warped_uv
    extent = float(np.ptp(uv, axis=0).max())
    np.testing.assert_array_equal(w[dom.vertices], dom.uv)  # coarse vertices keep their parameters
    outline = np.concatenate(dom.loops)
    ears = np.isin(F, outline).all(1)
    assert (signed_areas(w, F)[~ears] > 0).all()  # no scan triangle folds (an ear on its chord is flat)
    # the outline where its runs send it (no fold held the warp back, which these maps never need) ...
    ids, target = outline_targets(dom)
    np.testing.assert_allclose(w[ids], target, atol=1e-9 * extent)
    # ... a smooth run onto its chord, a jagged one (a staircase) off it by its teeth alone
    on_chord = boundary_distance(dom, target) <= 1e-9 * extent
    smooth_runs = staircase_free(dom)
    assert on_chord[np.isin(ids, smooth_runs)].all()
    if smooth_runs.size == ids.size:  # every scan point in the domain: none clamped, none left out of the fit
        assert boundary_distance(dom, w[dom.locate(w).clamped]).max(initial=0.0) <= 1e-9 * extent
    # the warp stays in the boundary patches' band: a point in a face with no boundary vertex keeps its uv
    nb = sum(b.size for b in dom.boundary)
    hit = dom.locate(uv)
    deep = ~hit.clamped & (dom.faces[hit.face] >= nb).all(1)
    np.testing.assert_array_equal(w[deep], uv[deep])


def test_outline_points_keep_their_order_along_the_chords():
    """Each loop's warped outline walks its coarse polygon once, never back: its length is the polygon's."""
    st_, F = domains.l_shape(600, seed=3)
    V = lifted(st_)
    p = parameterize(V, F, method="lscm")
    dom = coarse_domain(V, p.faces, p.uv, n_vertices=25)
    closed = lambda x: np.linalg.norm(np.diff(np.vstack([x, x[:1]]), axis=0), axis=1).sum()  # noqa: E731
    for kept, loop in zip(dom.boundary, dom.loops):
        assert kept.size < loop.size  # some outline vertices were moved onto chords
        np.testing.assert_allclose(closed(dom.warped_uv[loop]), closed(dom.scan_uv[kept]), rtol=1e-12)


def test_a_staircase_outline_keeps_its_teeth_but_loses_its_bulge():
    """A hole cut from a grid has a staircase outline: its runs lose their smooth bulge (the offsets left are
    orthogonal to the cubic bump, so they sit on both sides of the chord) and are not flattened onto it."""
    st_, F = grid_with_hole(3000, seed=2)
    V = lifted(st_)
    p = parameterize(V, F, method="lscm")
    dom = coarse_domain(V, p.faces, p.uv, n_vertices=60)
    ids, target = outline_targets(dom)
    stairs = np.setdiff1d(ids, staircase_free(dom))
    assert stairs.size > 20  # the hole's runs are jagged
    w = dom.warped_uv[stairs]
    extent = float(np.ptp(p.uv, axis=0).max())
    off = boundary_distance(dom, w)
    assert off.max() > 1e-4 * extent  # teeth kept off the chords
    inside = ~dom.locate(w).clamped & (off > 1e-9 * extent)
    assert 0.2 < inside.mean() < 0.8  # on both sides of them


def test_the_approximation_leaves_no_point_outside_and_fits_closer(monkeypatch):
    """On an L-shaped scan parameterized by LSCM, the warp leaves no scan point unreached and brings the
    scan closer to the surface (data -> model) than the scan's own uv do."""
    import trispline.fit.approx.warp as warp

    st_, F = domains.l_shape(1500, seed=5)
    V = lifted(st_)
    rms = {}
    for on in (True, False):
        monkeypatch.setattr(warp, "OUTLINE_WARP", on)
        res = approximate_surface(V, F, n_vertices=40, loss="l2", max_rounds=1)
        rms[on] = res.stats["deviation"]["rms"]
        if on:
            assert res.stats["unreached"] == 0
    assert rms[True] < rms[False]


def test_a_plane_with_a_round_hole_is_still_reproduced():
    """The warp bends the map but not the data: a planar scan's surface stays in its plane, and every scan
    vertex off the outline lies on it (the outline's jagged teeth, in the plane, are as far off the surface's
    smooth boundary curve as a chord leaves them: within the outline's own step)."""
    st_, F = grid_with_hole(1500, seed=4)
    V = np.column_stack([st_, 0.3 * st_[:, 0] - 0.2 * st_[:, 1] + 0.1])
    res = approximate_surface(V, F, n_vertices=40, corners="fit", loss="l2", max_rounds=1)
    assert res.domain.warped and res.stats["unreached"] == 0
    diag = float(np.linalg.norm(np.ptp(V, axis=0)))
    normal = np.array([0.3, -0.2, -1.0]) / np.linalg.norm([0.3, -0.2, -1.0])
    assert np.abs((res.ctrl - V[0]) @ normal).max() <= 1e-12 * diag  # every control point in the plane
    outline = np.zeros(V.shape[0], bool)
    outline[np.concatenate(res.domain.loops)] = True
    assert res.deviation.distance[~outline].max() <= 1e-9 * diag
    step = np.linalg.norm(V[F[:, 0]] - V[F[:, 1]], axis=1).max()
    assert res.deviation.distance[outline].max() <= step


def test_an_outline_kept_whole_is_not_moved():
    """Every boundary vertex kept: no run has inner points, no target moves (and nothing divides by zero)."""
    import dataclasses

    st_, F = domains.l_shape(60, seed=1)
    V = lifted(st_)
    p = parameterize(V, F, method="lscm")
    dom = coarse_domain(V, p.faces, p.uv, n_vertices=20)
    whole = dataclasses.replace(dom, boundary=dom.loops)
    ids, target = outline_targets(whole)
    np.testing.assert_array_equal(target, dom.scan_uv[ids])
