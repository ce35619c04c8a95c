"""A map smooth by construction (param/polymap.py): uv as a low-degree polynomial of the position in space,
kept where it is measurably smoother than the smoothed discrete map."""
from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial import Delaunay
from trispline.fit.datasets.analytic import analytic_mesh
from trispline.param import parameterize
from trispline.param.distortion import fold_mask
from hypothesis import given, settings
from hypothesis import strategies as st
from trispline.param.polymap import map_roughness, plane_projection, polynomial_map, smoothest_map
from trispline.param.testing import bumpy_disk


@pytest.mark.parametrize("degree", [2, 3, 4])
def test_a_polynomial_of_the_position_is_reproduced_even_where_the_monomials_are_dependent(degree):
    """On a sphere x^2 + y^2 + z^2 is constant, so the monomials of degree >= 2 are dependent: the
    minimum-norm fit still reproduces a map that is a polynomial of the position (to rounding)."""
    mesh = analytic_mesh("cap", 400)
    X = mesh.V
    uv = np.stack([X[:, 0] + 0.1 * X[:, 0] * X[:, 2], X[:, 1] - 0.05 * X[:, 2] ** 2 + 0.02 * X[:, 0] * X[:, 1]], 1)
    np.testing.assert_allclose(polynomial_map(X, uv, degree), uv, atol=1e-12)


def test_roughness_is_small_for_a_smooth_map_and_grows_with_jitter():
    """The cap read through its true parameters is nearly a local quartic (measured 1.5e-5 of an edge);
    jitter of 1e-3 of an edge in the map is what the measure sees (about that much misfit)."""
    mesh = analytic_mesh("cap", 800)
    smooth = map_roughness(mesh.V, mesh.F, mesh.params)
    jitter = mesh.params + np.random.default_rng(0).normal(scale=1e-3 * mesh.spacing, size=mesh.params.shape)
    rough = map_roughness(mesh.V, mesh.F, jitter)
    assert smooth < 5e-5 and 3e-4 < rough < 3e-3
    assert map_roughness(mesh.V, mesh.F, mesh.params, seed=1) == pytest.approx(smooth, rel=0.5)  # a sample


def test_a_height_field_takes_its_projection_and_reads_as_smooth_as_its_height():
    """The monkey saddle is a cubic height over the plane: read through its projection it is a cubic of
    uv, up to the tilt of its sampled vector area (roughness 3e-8), through the smoothed LSCM 9.4e-4 and its degree-2 polynomial 1.0e-4."""
    mesh = analytic_mesh("monkey", 800)
    p = parameterize(mesh.V, mesh.F, polynomial=False)
    uv, info = smoothest_map(mesh.V, p.faces, p.uv)
    assert info["polynomial"] == 1 and info["roughness"][1] < 1e-6 < 1e-5 < info["roughness"][2]
    assert not np.logical_or(*fold_mask(uv, p.faces)).any()
    np.testing.assert_allclose(uv, plane_projection(mesh.V, p.faces, p.uv))


@settings(max_examples=10, deadline=None)
@given(seed=st.integers(0, 2**31 - 1))
def test_the_projection_of_a_turned_height_field_is_its_plane_turned_onto_the_map(seed):
    """A height field over the unit disk whose outline is flat (height 0 there: its vector area is normal to
    the disk), turned anywhere in space, projects to a similarity of its (s, t): rotation, mirror and
    scale onto the map, the map's centroid kept."""
    rng = np.random.default_rng(seed)
    t = np.linspace(0, 2 * np.pi, 40, endpoint=False)
    r, a = np.sqrt(rng.uniform(0, 0.9, 300)), rng.uniform(0, 2 * np.pi, 300)
    S = np.r_[np.c_[np.cos(t), np.sin(t)], np.c_[r * np.cos(a), r * np.sin(a)]]
    F = Delaunay(S).simplices
    c = rng.normal(size=4)
    h = (1 - (S**2).sum(1)) * (c[0] + c[1] * S[:, 0] + c[2] * S[:, 1] ** 2 + c[3] * S[:, 0] ** 3)
    Q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    uv = S @ np.array([[2.0, 0.3], [-0.1, 1.5]]) + rng.normal(size=2)  # any map will do
    P = plane_projection(np.c_[S, h] @ Q.T, F, uv)
    S0 = S - S.mean(0)
    A, *_ = np.linalg.lstsq(S0, P - P.mean(0), rcond=None)
    np.testing.assert_allclose(S0 @ A, P - P.mean(0), atol=1e-12)
    np.testing.assert_allclose(A @ A.T, A[0] @ A[0] * np.eye(2), atol=1e-12)  # a similarity
    np.testing.assert_allclose(P.mean(0), uv.mean(0), atol=1e-12)


@pytest.mark.parametrize("name", ["torus", "barrel240"])
def test_where_no_low_degree_follows_the_map_it_is_kept(name):
    """A 240-degree barrel or a torus patch: the low-degree polynomials fold or are rougher."""
    mesh = analytic_mesh(name, 800)
    p = parameterize(mesh.V, mesh.F, polynomial=False)
    uv, info = smoothest_map(mesh.V, p.faces, p.uv)
    assert info["polynomial"] == 0 and uv is p.uv
    assert all(r > info["roughness"][0] for d, r in info["roughness"].items() if d)


def test_parameterize_reports_the_polynomial_map_and_not_for_the_harmonic_map():
    V, F = bumpy_disk(800)
    p = parameterize(V, F)
    assert p.smoothing["polynomial"] in (1, 2, 3, 4)
    assert any("polynomial of degree" in m or "projection onto the mesh's mean plane" in m for m in p.messages)
    assert not np.logical_or(*fold_mask(p.uv, F)).any()
    assert parameterize(V, F, method="harmonic").smoothing["polynomial"] == 0
    assert parameterize(V, F, polynomial=False).smoothing["polynomial"] == 0


def test_where_the_roughness_cannot_be_measured_the_map_is_kept():
    """One row of tall triangles around a cylinder: no 4-ring holds the 20 points of a local cubic, every
    roughness is 0, and no candidate is measurably smoother (a tie keeps the map)."""
    t = np.linspace(0.0, 2 * np.pi, 64, endpoint=False)
    V = np.r_[np.c_[np.cos(t), np.sin(t), 0 * t], np.c_[np.cos(t), np.sin(t), 0 * t + 3.0]]
    i = np.arange(64)
    F = np.r_[np.c_[i, (i + 1) % 64, 64 + i], np.c_[(i + 1) % 64, 64 + (i + 1) % 64, 64 + i]]
    p = parameterize(V, F, method="harmonic")
    uv, info = smoothest_map(V, p.faces, p.uv)
    assert info["polynomial"] == 0 and uv is p.uv and set(info["roughness"].values()) == {0.0}
