"""True 3D deviation between a spline surface and points (closest point ON the surface) and a mesh;
the synthetic truth it is measured against."""
from __future__ import annotations

import numpy as np
import pytest

from trispline.fit.approx import mesh_deviation, summary, surface_deviation
from trispline.fit.approx.deviation import triangle_bary
from trispline.fit.datasets.truth import SURFACES, surface_derivatives, truth_scan
from trispline.param import closest_points, validate_mesh
from trispline.spline import SplineSurface, polynomial_control_net
from trispline.spline.errors import InputError
from trispline.spline.testing import domains


def paraboloid(p: np.ndarray) -> np.ndarray:
    """A quadric height field ``(u, v, q(u, v))``: its quintic control net is exact."""
    u, v = p[:, 0], p[:, 1]
    return np.column_stack([u, v, 0.4 * u * u - 0.3 * v * v + 0.2 * u * v])


@pytest.fixture(scope="module")
def surface() -> SplineSurface:
    uv, F = domains.random_delaunay(300, holes=1, seed=1)
    uv = 2.0 * uv - 1.0
    return SplineSurface(uv, F, polynomial_control_net(uv, F, paraboloid))


def diagonal(s: SplineSurface) -> float:
    c = s.ctrl.reshape(-1, 3)
    return float(np.linalg.norm(c.max(0) - c.min(0)))


def samples(s: SplineSurface, n: int, seed: int = 0):
    rng = np.random.default_rng(seed)
    face = rng.integers(0, s.n_faces, n)
    bary = rng.dirichlet([1.0, 1.0, 1.0], n)
    d = s.evaluate_derivatives(face, bary)
    nrm = np.cross(d.du, d.dv)
    return face, bary, d.values, nrm / np.linalg.norm(nrm, axis=1, keepdims=True)


def test_points_on_the_surface_are_at_distance_zero(surface):
    face, bary, P, _ = samples(surface, 20_000)
    dev = surface_deviation(surface, P)
    assert dev.distance.max() <= 1e-9 * diagonal(surface)
    np.testing.assert_allclose(dev.closest, P, atol=1e-9 * diagonal(surface))
    np.testing.assert_allclose(surface.evaluate(dev.face, dev.bary), dev.closest, atol=1e-12)


def test_points_offset_along_the_normal_are_at_that_distance(surface):
    _, _, P, nrm = samples(surface, 20_000, seed=1)
    d = np.random.default_rng(2).uniform(-0.05, 0.05, P.shape[0])  # well inside the radius of curvature
    dev = surface_deviation(surface, P + d[:, None] * nrm)
    np.testing.assert_allclose(dev.distance, np.abs(d), rtol=0, atol=1e-9 * diagonal(surface))
    np.testing.assert_allclose(dev.closest, P, atol=1e-8 * diagonal(surface))
    assert not dev.on_boundary.any()


def test_far_points_find_the_boundary_curve_and_beat_a_fine_tessellation(surface):
    P = np.random.default_rng(3).uniform(-1.6, 1.6, (3000, 3))
    dev = surface_deviation(surface, P)
    assert dev.on_boundary.any()  # beyond the outline and over the hole
    m = surface.tessellate(96)
    sq, _, _ = closest_points(P, m.vertices, m.triangles)
    # the r = 96 tessellation is within about kappa h^2 / 8 of the surface (h: its edge)
    np.testing.assert_allclose(dev.distance, np.sqrt(sq), atol=2e-6 * diagonal(surface))
    # never worse than the starting tessellation
    m6 = surface.tessellate(6)
    sq6, _, _ = closest_points(P, m6.vertices, m6.triangles)
    d_surface6 = np.linalg.norm(surface.evaluate(dev.face, dev.bary) - P, axis=1)
    np.testing.assert_array_equal(d_surface6, dev.distance)
    assert (dev.distance <= np.sqrt(sq6) + 1e-3 * diagonal(surface)).all()


def test_closest_points_are_stationary(surface):
    P = np.random.default_rng(4).uniform(-1.2, 1.2, (3000, 3))
    dev = surface_deviation(surface, P)
    inner = ~dev.on_boundary
    d = surface.evaluate_derivatives(dev.face[inner], dev.bary[inner])
    r = P[inner] - dev.closest[inner]
    for t in (d.du, d.dv):  # P - S(u) is normal to the surface at an interior closest point
        tangential = np.einsum("nd,nd->n", r, t) / np.linalg.norm(t, axis=1)
        assert np.abs(tangential).max() <= 1e-9 * diagonal(surface)


def test_chunks_do_not_change_the_result(surface):
    P = np.random.default_rng(5).uniform(-1.2, 1.2, (2000, 3))
    a = surface_deviation(surface, P)
    b = surface_deviation(surface, P, chunk=97)
    np.testing.assert_array_equal(a.distance, b.distance)
    np.testing.assert_array_equal(a.face, b.face)


def test_mesh_deviation_other_way(surface):
    m = surface.tessellate(12)
    assert mesh_deviation(surface, m.vertices, m.triangles, resolution=12).max() <= 1e-12
    shifted = m.vertices + np.array([0.0, 0.0, 0.01])
    d = mesh_deviation(surface, shifted, m.triangles, resolution=4)
    inner = np.abs(d - 0.01 * np.cos(np.arctan(1.0))) < 0.01  # slopes up to ~1: distance <= 0.01
    assert d.max() <= 0.01 + 1e-12 and inner.mean() > 0.5


def test_summary():
    s = summary(np.array([3.0, -4.0, 0.0, 5.0]))
    assert s["count"] == 4 and s["max"] == 5.0 and s["mean"] == 3.0
    assert s["rms"] == pytest.approx(np.sqrt(50.0 / 4))
    assert summary(np.array([1.0, 9.0]), mask=np.array([True, False]))["max"] == 1.0
    assert summary(np.empty(0))["count"] == 0


def test_bad_points(surface):
    with pytest.raises(InputError, match="points"):
        surface_deviation(surface, np.zeros((3, 2)))
    with pytest.raises(InputError, match="points"):
        surface_deviation(surface, np.array([[0.0, np.nan, 0.0]]))
    assert surface_deviation(surface, np.empty((0, 3))).distance.size == 0


def test_triangle_bary_reproduces_points():
    rng = np.random.default_rng(6)
    T = rng.normal(size=(100, 3, 3))
    w = rng.dirichlet([1, 1, 1], 100)
    np.testing.assert_allclose(triangle_bary(np.einsum("nk,nkd->nd", w, T), T), w, atol=1e-10)


# ------------------------------------------------------------------ synthetic truth
@pytest.mark.parametrize("name", sorted(SURFACES))
def test_truth_derivatives_match_finite_differences(name):
    st = np.random.default_rng(0).uniform([-0.9, -0.6], [0.9, 0.6], (50, 2))
    d = surface_derivatives(name, st)
    h = 1e-5
    for k, first, second in ((0, d.du, (d.uu, d.uv)), (1, d.dv, (d.uv, d.vv))):
        e = np.zeros(2)
        e[k] = h
        p, m = surface_derivatives(name, st + e), surface_derivatives(name, st - e)
        np.testing.assert_allclose((p.values - m.values) / (2 * h), first, atol=1e-8)
        np.testing.assert_allclose((p.du - m.du) / (2 * h), second[0], atol=1e-7)
        np.testing.assert_allclose((p.dv - m.dv) / (2 * h), second[1], atol=1e-7)


def test_truth_scan_is_a_valid_open_mesh_with_the_stated_noise():
    scan = truth_scan("bumps", 50_000, sigma=1e-3, outliers=0.005, outlier_sigmas=50, seed=0)
    vm = validate_mesh(scan.V, scan.F)
    assert vm.report["components"] == 1 and vm.report["boundary_loops"] == 2  # outline and the hole
    assert 45_000 < scan.V.shape[0] < 55_000 and abs(scan.F.shape[0] - 2 * scan.V.shape[0]) < 2000
    off = np.einsum("nd,nd->n", scan.V - scan.clean, scan.normals)
    np.testing.assert_allclose(np.linalg.norm(scan.V - scan.clean, axis=1), np.abs(off), atol=1e-15)
    assert scan.sigma == pytest.approx(1e-3 * scan.diagonal)
    assert np.std(off[~scan.outliers]) == pytest.approx(scan.sigma, rel=0.02)
    assert scan.outliers.sum() == round(0.005 * scan.V.shape[0])
    np.testing.assert_allclose(np.abs(off[scan.outliers]), 50 * scan.sigma)
    again = truth_scan("bumps", 50_000, sigma=1e-3, outliers=0.005, outlier_sigmas=50, seed=0)
    np.testing.assert_array_equal(again.V, scan.V)


def test_distance_to_truth_is_exact():
    scan = truth_scan("barrel", 20_000, sigma=1e-3, outliers=0.01, seed=1)
    d = scan.distance_to_truth(scan.V)
    np.testing.assert_allclose(d, np.linalg.norm(scan.V - scan.clean, axis=1), atol=1e-12)


def test_bending_energy_of_a_sphere():
    scan = truth_scan("cap", 50_000, sigma=0.0)
    T = scan.clean[scan.F]
    area = 0.5 * np.linalg.norm(np.cross(T[:, 1] - T[:, 0], T[:, 2] - T[:, 0]), axis=1).sum()
    assert scan.bending_energy() == pytest.approx(2.0 / 1.6**2 * area, rel=1e-4)  # k1 = k2 = 1 / R


def test_bad_truth_arguments():
    with pytest.raises(ValueError, match="sigma"):
        truth_scan("bumps", 1000, sigma=-1.0)
    with pytest.raises(ValueError, match="outliers"):
        truth_scan("bumps", 1000, outliers=2.0)
    with pytest.raises(ValueError, match="unknown surface"):
        truth_scan("torus", 1000)
