"""Watertight tessellation with shared patch-boundary vertices and analytic normals."""
from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from trispline.spline.locate import Locator
from trispline.spline.testing import domains
from trispline.spline.errors import InputError
from trispline.spline.locate import locate
from trispline.spline.patches import evaluate_derivatives
from trispline.spline.polynomial import polynomial_control_net, random_polynomial
from trispline.spline.tessellate import patch_points, tessellate, tessellation_counts
from trispline.spline.topology import Triangulation
from triangulations import SMALL_DOMAINS

DOMAINS = SMALL_DOMAINS


def _unit(x):
    return x / np.linalg.norm(x, axis=1, keepdims=True)


def _edge_use(triangles):
    e = np.sort(triangles[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
    uniq, cnt = np.unique(e, axis=0, return_counts=True)
    return uniq, cnt


@settings(max_examples=25, deadline=None)
@given(name=st.sampled_from(sorted(DOMAINS)), seed=st.integers(0, 500), r=st.integers(1, 7))
def test_tessellation_is_watertight_and_exact(name, seed, r):
    uv, faces = DOMAINS[name](seed)
    tri = Triangulation(uv, faces)
    func = random_polynomial(5, 3, seed)
    ctrl = polynomial_control_net(uv, faces, func)
    mesh = tessellate(uv, faces, ctrl, r)
    m, t = tessellation_counts(tri.n_vertices, tri.n_edges, tri.n_faces, r)
    nv, ne, nf = tri.n_vertices, tri.n_edges, tri.n_faces
    assert m == nv + (r - 1) * ne + (r - 1) * (r - 2) // 2 * nf
    assert mesh.vertices.shape == (m, 3) and mesh.normals.shape == (m, 3) and mesh.uv.shape == (m, 2)
    assert mesh.triangles.shape == (t, 3) and t == r * r * nf
    # every vertex used, no duplicated uv point (shared, not repeated, boundary samples)
    assert np.unique(mesh.triangles).size == m
    assert np.unique(np.round(mesh.uv / np.abs(mesh.uv).max(), 11), axis=0).shape[0] == m
    # watertight: interior tessellation edges used twice, boundary ones once, r per domain boundary edge
    _, cnt = _edge_use(mesh.triangles)
    assert set(np.unique(cnt)) <= {1, 2}
    assert (cnt == 1).sum() == r * tri.boundary_edges.size
    # triangles counter-clockwise in uv, covering the domain area exactly
    a, b, c = (mesh.uv[mesh.triangles[:, i]] for i in range(3))
    area = 0.5 * ((b - a)[:, 0] * (c - a)[:, 1] - (b - a)[:, 1] * (c - a)[:, 0])
    assert (area > 0).all()
    np.testing.assert_allclose(area.sum(), tri.areas.sum(), rtol=1e-12)
    # patch f's triangles are rows f r^2 .. (f + 1) r^2, inside its face
    own = np.repeat(np.arange(nf), r * r)
    centroid = (a + b + c) / 3.0
    bary = Locator(uv, faces).bary_in(own, centroid)
    assert bary.min() > -1e-12
    # points and normals exact for a polynomial surface
    np.testing.assert_allclose(mesh.vertices, func(mesh.uv), atol=1e-11)
    gu, gv = func.gradient(mesh.uv)
    np.testing.assert_allclose(mesh.normals, _unit(np.cross(gu, gv)), atol=1e-8)
    np.testing.assert_allclose(np.linalg.norm(mesh.normals, axis=1), 1.0, atol=1e-12)


@settings(max_examples=15, deadline=None)
@given(name=st.sampled_from(sorted(DOMAINS)), seed=st.integers(0, 200), r=st.integers(1, 7))
def test_points_on_tessellation_triangles_name_their_patch_and_coordinates(name, seed, r):
    """patch_points: a point on a tessellation triangle is that patch's point, without a search."""
    uv, faces = DOMAINS[name](seed)
    func = random_polynomial(5, 3, seed)
    mesh = tessellate(uv, faces, polynomial_control_net(uv, faces, func), r)
    rng = np.random.default_rng(seed)
    tri = rng.integers(0, mesh.triangles.shape[0], 200)
    w = rng.dirichlet(np.ones(3), 200)
    w[:20] = np.eye(3)[rng.integers(0, 3, 20)]  # some at the triangles' vertices
    face, bary = patch_points(r, tri, w)
    np.testing.assert_array_equal(face, tri // (r * r))
    assert bary.min() >= 0.0 and np.allclose(bary.sum(1), 1.0, atol=1e-15)
    own_uv = np.einsum("nk,nkc->nc", bary, uv[faces[face]])
    np.testing.assert_allclose(own_uv, np.einsum("nk,nkc->nc", w, mesh.uv[mesh.triangles[tri]]), atol=1e-13)
    at_vertex = np.flatnonzero((w == 1.0).any(1))
    vertex = mesh.triangles[tri[at_vertex], w[at_vertex].argmax(1)]
    np.testing.assert_allclose(func(own_uv[at_vertex]), mesh.vertices[vertex], atol=1e-11)


def test_vertex_numbering_starts_with_domain_vertices():
    uv, faces = domains.random_delaunay(20, seed=1)
    ctrl = polynomial_control_net(uv, faces, random_polynomial(3, 3, 0))
    mesh = tessellate(uv, faces, ctrl, 4)
    np.testing.assert_array_equal(mesh.uv[: len(uv)], uv)


def test_corner_normal_formula_matches_derivatives():
    """Corner normals come from star points; compare with evaluate_derivatives at the corner."""
    uv, faces = domains.fan(7, radius_jitter=0.2, seed=3)
    ctrl = polynomial_control_net(uv, faces, random_polynomial(5, 3, 2))
    mesh = tessellate(uv, faces, ctrl, 3)
    fidx, bary = locate(uv, faces, uv)
    r = evaluate_derivatives(uv, faces, ctrl, fidx, bary)
    np.testing.assert_allclose(mesh.normals[: len(uv)], _unit(np.cross(r.du, r.dv)), atol=1e-10)


try:
    from trispline.spline.propagation import build_space
except ImportError:  # pragma: no cover
    build_space = None


@pytest.mark.skipif(build_space is None, reason="trispline.spline.propagation not available")
@settings(max_examples=10, deadline=None)
@given(name=st.sampled_from(["delaunay", "holes", "lshape", "annulus", "grid", "crisscross"]),
       seed=st.integers(0, 500))
def test_normals_continuous_across_patch_boundaries_of_a_c1_spline(name, seed):
    """A C1 spline that is not a polynomial: at every tessellation vertex on an interior
    edge both adjacent patches give the same unit normal as the tessellation."""
    uv, faces = DOMAINS[name](seed)
    space = build_space(uv, faces)
    ctrl = space.control_points(np.random.default_rng(seed).standard_normal((space.n_free, 3)))
    r = 4
    mesh = tessellate(uv, faces, ctrl, r)
    tri = Triangulation(uv, faces)
    nv, ne = tri.n_vertices, tri.n_edges
    ids = np.arange(nv, nv + (r - 1) * ne)
    p = mesh.uv[ids]
    normals = []
    for side in range(2):
        # the edge of each edge vertex: nearest-edge test by collinearity with its endpoints
        a, b = tri.uv[tri.edges[:, 0]], tri.uv[tri.edges[:, 1]]
        d = np.abs((b - a)[None, :, 0] * (p[:, None, 1] - a[None, :, 1])
                   - (b - a)[None, :, 1] * (p[:, None, 0] - a[None, :, 0]))
        s = np.einsum("nec,ec->ne", p[:, None, :] - a[None], b - a) / np.einsum("ec,ec->e", b - a, b - a)
        d[(s < 0) | (s > 1)] = np.inf
        e = np.argmin(d, axis=1)
        f = tri.edge_faces[e, side]
        keep = f >= 0
        t = tri.uv[tri.faces[f[keep]]]
        T = np.stack([t[:, 0] - t[:, 2], t[:, 1] - t[:, 2]], axis=2)  # (n, 2, 2)
        l01 = np.linalg.solve(T, (p[keep] - t[:, 2])[..., None])[..., 0]
        bary = np.column_stack([l01, 1 - l01.sum(1)])
        rr = evaluate_derivatives(uv, faces, ctrl, f[keep], bary)
        nrm = np.full((len(ids), 3), np.nan)
        nrm[keep] = _unit(np.cross(rr.du, rr.dv))
        normals.append(nrm)
    both = ~np.isnan(normals[0][:, 0]) & ~np.isnan(normals[1][:, 0])
    assert both.sum() == (r - 1) * tri.interior_edges.size
    np.testing.assert_allclose(normals[0][both], normals[1][both], atol=1e-8)
    np.testing.assert_allclose(mesh.normals[ids][both], normals[0][both], atol=1e-8)


def test_scalar_field_has_no_normals():
    uv, faces = domains.grid(2)
    ctrl = polynomial_control_net(uv, faces, lambda p: p[:, 0] ** 2)
    mesh = tessellate(uv, faces, ctrl, 3)
    assert mesh.vertices.shape[1] == 1 and mesh.normals.shape == (mesh.vertices.shape[0], 0)
    np.testing.assert_allclose(mesh.vertices[:, 0], mesh.uv[:, 0] ** 2, atol=1e-14)


def test_bad_resolution_and_ctrl_raise():
    uv, faces = domains.grid(2)
    ctrl = np.zeros((faces.shape[0], 21, 3))
    for bad in (0, -2, 2.5):
        with pytest.raises(InputError, match="resolution"):
            tessellate(uv, faces, ctrl, bad)
    with pytest.raises(InputError, match="control points"):
        tessellate(uv, faces, ctrl[:-1], 2)


def test_threaded_tasks_equal_the_single_threaded_tessellation(monkeypatch):
    """Large meshes run in face-range tasks on threads: same mesh as one inline pass."""
    import importlib

    from threadpoolctl import threadpool_info

    tess = importlib.import_module("trispline.spline.tessellate")  # the package re-exports the function

    uv, faces = domains.random_delaunay(11_000, seed=3)  # ~22k faces: several tasks per sample set
    func = random_polynomial(5, 3, 7)
    ctrl = polynomial_control_net(uv, faces, func)
    blas_before = [i["num_threads"] for i in threadpool_info() if i["user_api"] == "blas"]
    monkeypatch.setattr(tess, "TASK_PATCHES", 3000)
    threaded = tessellate(uv, faces, ctrl, 6)
    assert [i["num_threads"] for i in threadpool_info() if i["user_api"] == "blas"] == blas_before
    monkeypatch.setattr(tess, "PARALLEL_FACES", 10**9)  # one worker: everything inline
    inline = tessellate(uv, faces, ctrl, 6)
    np.testing.assert_array_equal(threaded.triangles, inline.triangles)
    np.testing.assert_array_equal(threaded.uv, inline.uv)
    np.testing.assert_allclose(threaded.vertices, inline.vertices, atol=1e-13)
    np.testing.assert_allclose(threaded.normals, inline.normals, atol=1e-12)
    np.testing.assert_allclose(threaded.vertices, func(threaded.uv), atol=1e-11)


def test_normals_are_zero_not_nan_where_the_surface_is_singular():
    uv, faces = domains.grid(3)
    ctrl = np.zeros((len(faces), 21, 3))
    ctrl[..., 0] = polynomial_control_net(uv, faces, random_polynomial(1, 1, 0))[..., 0]  # a curve: x only
    mesh = tessellate(uv, faces, ctrl, 4)
    assert np.isfinite(mesh.normals).all()
    np.testing.assert_array_equal(mesh.normals, 0.0)


def test_concurrent_tessellations_restore_the_blas_thread_count():
    """The one-thread BLAS limit is process-wide: overlapping calls must not leave it set."""
    from concurrent.futures import ThreadPoolExecutor

    from threadpoolctl import threadpool_info

    uv, faces = domains.random_delaunay(6_000, seed=5)  # ~12k faces: the threaded path
    ctrl = polynomial_control_net(uv, faces, random_polynomial(5, 3, 1))
    before = [i["num_threads"] for i in threadpool_info() if i["user_api"] == "blas"]
    with ThreadPoolExecutor(3) as pool:
        meshes = list(pool.map(lambda _: tessellate(uv, faces, ctrl, 4), range(6)))
    assert [i["num_threads"] for i in threadpool_info() if i["user_api"] == "blas"] == before
    for m in meshes[1:]:
        np.testing.assert_array_equal(m.vertices, meshes[0].vertices)
