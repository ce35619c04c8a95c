"""The outline faired as a curve (fit/curves.py) and the boundary patches' warp built from it (fit/boundary.py)."""
from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial import Delaunay
from trispline.fit.boundary import outline_warp
from trispline.fit.curves import bump_basis, bump_shapes, loop_bulges
from trispline.spline.index import DEGREE, EXPONENTS
from trispline.spline.topology import signed_areas


def _circle(n: int, radius: float = 1.0, jitter: float = 0.2, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    ang = 2 * np.pi * (np.arange(n) + rng.uniform(-jitter, jitter, n)) / n
    return radius * np.stack([np.cos(ang), np.sin(ang)], 1)


def test_the_bump_is_the_two_middle_bernstein_polynomials_flat_at_both_ends():
    t = np.linspace(0, 1, 11)
    np.testing.assert_allclose(bump_basis(t), np.stack([10 * t**2 * (1 - t) ** 3, 10 * t**3 * (1 - t) ** 2], 1))
    np.testing.assert_allclose(bump_shapes(0.3, 0.7), [10 * 0.3**3 * 0.7**2, 10 * 0.3**2 * 0.7**3])  # on the edge
    eps = 1e-6  # value and slope vanish at t = 0 and 1
    for end in (0.0, 1.0):
        assert np.abs(bump_basis(np.array([end]))).max() == 0.0
        assert np.abs(bump_basis(np.array([abs(end - eps)]))).max() < 1e-10


def test_inside_a_face_the_even_bump_is_quartic_and_flat_on_the_other_edges():
    """The bump of a = b is 10 a li^2 lj^2 (degree 4, so a quintic patch holds it exactly); both shapes
    vanish with their gradient on the edges li = 0 and lj = 0."""
    rng = np.random.default_rng(0)
    lam = rng.dirichlet(np.ones(3), 50)
    li, lj = lam[:, 0], lam[:, 1]
    np.testing.assert_allclose(bump_shapes(li, lj).sum(-1), 10 * li**2 * lj**2, atol=1e-15)
    eps, s = 1e-6, rng.uniform(0, 1, 20)
    for edge in (lambda x: (np.zeros_like(x) + eps, x * (1 - eps)), lambda x: (x * (1 - eps), np.zeros_like(x) + eps)):
        assert np.abs(bump_shapes(*edge(s))).max() < 10 * eps**2


def test_a_circle_bulges_outward_by_the_best_bump_of_its_sagitta():
    """Edges of a counter-clockwise circle: the bump that best matches the arc's offset from its chord
    (a = b = 1.8 S for the sagitta S), along the inner normal, so negative."""
    uv = _circle(60)
    P = np.column_stack([uv, np.zeros(len(uv))])
    a, b, miss = loop_bulges(P, uv)
    q = np.roll(uv, -1, 0)
    half = np.arcsin(np.linalg.norm(q - uv, axis=1) / 2)  # half the arc's angle (radius 1)
    sagitta = 1 - np.cos(half)
    np.testing.assert_allclose(a, -1.8 * sagitta, rtol=0.03)
    np.testing.assert_allclose(b, -1.8 * sagitta, rtol=0.03)
    assert miss.max() < 1e-3


def test_straight_sides_do_not_bulge_and_no_curve_reaches_round_a_corner():
    side = np.linspace(0, 1, 9)[:-1]
    uv = np.concatenate([np.column_stack([side, 0 * side]), np.column_stack([1 + 0 * side, side]),
                         np.column_stack([1 - side, 1 + 0 * side]), np.column_stack([0 * side, 1 - side])])
    P = np.column_stack([uv, uv[:, 0] * uv[:, 1]])  # a saddle over the square: its sides are straight lines
    a, b, _ = loop_bulges(P, uv)
    np.testing.assert_allclose(a, 0.0, atol=1e-12)
    np.testing.assert_allclose(b, 0.0, atol=1e-12)


def test_a_loop_too_short_for_a_curve_is_left_straight():
    uv = _circle(5)
    assert all((x == 0).all() for x in loop_bulges(np.column_stack([uv, 0 * uv[:, 0]]), uv))


@pytest.fixture(scope="module")
def disk():
    inner = np.random.default_rng(1).uniform(-0.6, 0.6, (120, 2))
    inner = inner[np.linalg.norm(inner, axis=1) < 0.8]
    uv = np.concatenate([_circle(40, jitter=0.1), inner])
    F = Delaunay(uv).simplices
    flip = signed_areas(uv, F) < 0
    F[flip] = F[flip][:, ::-1]
    return uv, F


def test_the_warp_moves_boundary_edges_onto_the_circle_and_leaves_the_rest(disk):
    uv, F = disk
    V = np.column_stack([uv, np.zeros(len(uv))])
    shift = outline_warp(V, uv, F)
    pts = np.einsum("gk,fkc->fgc", EXPONENTS / DEGREE, uv[F])
    on_circle = np.isclose(np.linalg.norm(uv, axis=1), 1.0)
    rim = on_circle[F].sum(1) == 2  # a face with one boundary edge (the disk's outline vertices)
    assert np.abs(shift[~on_circle[F].any(1)]).max() == 0.0  # no outline vertex: no shift
    for f in np.flatnonzero(rim):
        k = int(np.flatnonzero(~on_circle[F[f]])[0])  # the face's inner vertex; the outline edge is opposite
        i, j = (k + 1) % 3, (k + 2) % 3
        # no shift on the face's two inner edges (nor at its corners)
        assert np.abs(shift[f, (EXPONENTS[:, i] == 0) | (EXPONENTS[:, j] == 0)]).max() < 1e-15
        # the outline edge's middle domain points: a sagitta inside the circle, after the shift within a fifth of it
        edge = (EXPONENTS[:, k] == 0) & (EXPONENTS[:, i] > 0) & (EXPONENTS[:, j] > 0)
        before = 1 - np.linalg.norm(pts[f, edge], axis=1)
        after = 1 - np.linalg.norm(pts[f, edge] + shift[f, edge], axis=1)
        assert (before > 0).all()
        assert np.abs(after).max() < 0.2 * before.max()


def test_an_ear_takes_the_fit_of_the_nearest_vertex_off_the_outline():
    from trispline.fit.boundary import ear_substitutes

    # a 3 x 3 grid of squares, each split along the same diagonal: two opposite corners are ears
    g = np.stack(np.meshgrid(np.arange(4.0), np.arange(4.0), indexing="ij"), -1).reshape(-1, 2)
    idx = np.arange(16).reshape(4, 4)
    a, b, c, d = idx[:-1, :-1].ravel(), idx[1:, :-1].ravel(), idx[1:, 1:].ravel(), idx[:-1, 1:].ravel()
    F = np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)])
    sub = ear_substitutes(g, F, F)
    ears = np.flatnonzero(sub >= 0)
    assert {tuple(sorted(F[f])) for f in ears} == {(2, 3, 7), (8, 12, 13)}  # at the corners (0, 3) and (3, 0)
    assert {int(sub[f]) for f in ears} == {6, 9}  # the inner vertices (1, 2) and (2, 1)
    assert ear_substitutes(g, F, F[sub < 0]).max() == -1


def test_an_ears_substitute_is_near_in_the_mesh_where_the_map_covers_the_plane_twice():
    """LSCM winds a helicoidal ramp of three turns three times around its centre: the vertex nearest an
    end's ear in uv was a turn away, and the fit spiked there by 7.4% of the diagonal (now 4e-4)."""
    import jax

    jax.config.update("jax_enable_x64", True)
    from trispline.fit import fit_surface
    from trispline.fit.boundary import EAR_RINGS, ear_substitutes
    from trispline.fit.targets import vertex_rings
    from trispline.param import closest_points, parameterize
    from trispline.param.testing import helicoid_strip

    V, F = helicoid_strip()
    p = parameterize(V, F)
    sub = ear_substitutes(p.uv, F, F)
    ears = np.flatnonzero(sub >= 0)
    assert ears.size == 2  # the ramp's two lone corners
    R = vertex_rings(F, len(V), EAR_RINGS)
    assert all(R[F[f]].toarray().any(0)[sub[f]] for f in ears)
    res = fit_surface(V, F)
    sq = closest_points(res.surface.tessellate(8).vertices, V, F)[0]
    assert np.sqrt(sq.max()) < 2e-3 * np.linalg.norm(np.ptp(V, axis=0))


def test_ears_from_the_inner_fits_halve_a_rectangles_error(monkeypatch):
    """The corners of a rectangular domain are ears; their own fits are one-sided: with the nearest inner
    vertex's fit the error falls (measured on this barrel strip: RMS 3.9e-6 -> 1.3e-6)."""
    from trispline.fit import boundary, fit_surface
    from trispline.fit.datasets.analytic import analytic_mesh

    mesh = analytic_mesh("barrel240", 800)
    errors = []
    for on in (True, False):
        monkeypatch.setattr(boundary, "EAR_TARGETS", on)
        res = fit_surface(mesh.V, mesh.F)
        bary = np.array([[1 / 3, 1 / 3, 1 / 3], [0.6, 0.2, 0.2], [0.2, 0.6, 0.2], [0.2, 0.2, 0.6]])
        fi = np.repeat(np.arange(len(res.faces)), len(bary))
        P = res.surface.evaluate(fi, np.tile(bary, (len(res.faces), 1)))
        start = np.einsum("nk,fkd->fnd", bary, mesh.params[res.faces]).reshape(-1, 2)
        errors.append(np.sqrt(np.mean(mesh.surface.distance(P, start) ** 2)))
    assert errors[0] < 0.5 * errors[1]


@pytest.mark.parametrize("name", ["barrel240", "helicoid"])
def test_a_lone_corners_gradient_from_its_ears_substitute_is_closer_to_the_truth(name, monkeypatch):
    """``corner_gradients`` (the tilt hook): at a corner whose only face is an ear, the substitute fit's
    gradient beats the corner's own one-sided fit of ``fit_rings`` rings 15-500x (true parameters: the
    truth is the chart's; with the outline's extra ring, ``targets.OUTLINE_RING``, or its second fits,
    ``targets.OUTLINE_FITS``, the corner's own fit is closer: the substitute's median ratio 0.54-0.55 on
    the helicoid)."""
    from trispline.fit import FitWeights, targets
    monkeypatch.setattr(targets, "OUTLINE_RING", False)
    monkeypatch.setattr(targets, "OUTLINE_FITS", False)
    from trispline.fit.boundary import corner_gradients
    from trispline.fit.datasets.analytic import analytic_mesh
    from trispline.fit.energy import term_context
    from trispline.spline.propagation import build_space
    from trispline.spline.topology import Triangulation

    mesh = analytic_mesh(name, 800)
    ctx = term_context(build_space(Triangulation(mesh.params, mesh.F)), mesh.V, FitWeights())
    g = corner_gradients(ctx)
    d = mesh.surface.derivatives(mesh.params)
    truth = np.stack([d.du, d.dv], -1)  # (nv, 3, 2)
    changed = np.flatnonzero(np.abs(g - ctx.fit.grad).max((1, 2)) > 0)
    lone = np.flatnonzero(np.bincount(mesh.F.ravel(), minlength=len(mesh.V)) == 1)
    assert changed.size and set(changed) <= set(lone)
    err_new = np.linalg.norm(g[changed] - truth[changed], axis=(1, 2))
    err_own = np.linalg.norm(ctx.fit.grad[changed] - truth[changed], axis=(1, 2))
    assert np.median(err_new / err_own) < 0.2  # measured 0.002-0.07


def test_the_tilt_targets_of_a_lone_corner_come_from_its_ears_substitute():
    """``tilt`` takes :func:`~trispline.fit.boundary.corner_gradients` (wired in: barrel 808 RMS
    1.33e-6 -> 9.7e-7, docs/fit.md), not the corner's own one-sided fit."""
    from trispline.fit import FitWeights
    from trispline.fit.boundary import corner_gradients
    from trispline.fit.datasets.analytic import analytic_mesh
    from trispline.fit.energy import term_context, tilt
    from trispline.spline.propagation import build_space
    from trispline.spline.topology import Triangulation

    mesh = analytic_mesh("barrel240", 800)
    ctx = term_context(build_space(Triangulation(mesh.params, mesh.F)), mesh.V, FitWeights())
    a = tilt.setup(ctx)
    m = len(ctx.frame_vertices)
    g = corner_gradients(ctx)
    step = (ctx.frame_scale / 5.0)[:, None]
    np.testing.assert_allclose(a["target"][:m], ctx.V[ctx.frame_vertices] + g[:, :, 0] * step, rtol=0, atol=1e-15)
    assert (np.abs(g - ctx.fit.grad[ctx.frame_vertices]).max((1, 2)) > 0).any()
