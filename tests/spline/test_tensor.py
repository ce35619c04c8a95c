"""Exact conversion of quintic triangles into bi-quintic tensor patches (no CAD library needed).

Oracles: the triangle patch itself (evaluated through the Bernstein basis at the quads'
barycentric points) and, for a global quintic polynomial, the tensor Bézier coefficients
of ``p o Q_k`` found independently by collocation on a 6 x 6 grid.
"""
from __future__ import annotations

from math import comb

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from trispline.spline.errors import InputError
from trispline.spline.patches import evaluate, evaluate_derivatives
from trispline.spline.polynomial import polynomial_control_net, random_polynomial
from trispline.spline.propagation import build_space
from trispline.spline.tensor import EDGE_POINTS, FACE_POINTS, QUAD_CORNERS, quad_bary, tensor_net
from trispline.spline.testing import domains
from trispline.spline.topology import Triangulation
from triangulations import SMALL_DOMAINS

#: (4, 2, 2) start and end (s, t) of a quad's sides, counter-clockwise from (0, 0).
SIDES = np.array([[(0, 0), (1, 0)], [(1, 0), (1, 1)], [(1, 1), (0, 1)], [(0, 1), (0, 0)]], float)


def bernstein(x: np.ndarray, order: int = 0) -> np.ndarray:
    """``(n, 6)`` quintic Bernstein polynomials (or their ``order``-th derivative) at ``x (n,)``."""
    def b(n, i):
        return comb(n, i) * x**i * (1 - x) ** (n - i) if 0 <= i <= n else 0 * x

    if order == 0:
        return np.stack([b(5, i) for i in range(6)], -1)
    return np.stack([5 * (b(4, i - 1) - b(4, i)) for i in range(6)], -1)


def tensor_eval(P: np.ndarray, st_: np.ndarray, ds: int = 0, dt: int = 0) -> np.ndarray:
    """Tensor patches ``P (n, 6, 6, d)`` (or one ``(6, 6, d)`` for all) at ``st_ (n, 2)``."""
    Bs, Bt = bernstein(st_[:, 0], ds), bernstein(st_[:, 1], dt)
    return np.einsum("ni,nj,nijd->nd", Bs, Bt, np.broadcast_to(P, (len(st_),) + P.shape[-3:]))


def c1_spline(uv, faces, seed=0):
    """An exactly C1 spline: random free points through the propagation map."""
    space = build_space(uv, faces)
    return space.control_points(np.random.default_rng(seed).normal(size=(space.n_free, 3)))


def quad_uv(tri: Triangulation) -> np.ndarray:
    """``(3 F, 2, 2, 2)`` uv of corner ``P_pq`` of every quad."""
    return np.einsum("kpqc,fcx->fkpqx", QUAD_CORNERS, tri.uv[tri.faces]).reshape(-1, 2, 2, 2)


def quad_jacobian(corners: np.ndarray, st_: np.ndarray) -> np.ndarray:
    """``(n, 2, 2)`` d(uv)/d(s, t) of the bilinear quads ``corners (n, 2, 2, 2)`` at ``st_ (n, 2)``."""
    s, t = st_[:, :1], st_[:, 1:]
    du = (1 - t) * (corners[:, 1, 0] - corners[:, 0, 0]) + t * (corners[:, 1, 1] - corners[:, 0, 1])
    dv = (1 - s) * (corners[:, 0, 1] - corners[:, 0, 0]) + s * (corners[:, 1, 1] - corners[:, 1, 0])
    return np.stack([du, dv], axis=-1)


def shared_sides(tri: Triangulation) -> np.ndarray:
    """``(m, 4)`` rows ``(patch a, side a, patch b, side b)``: sides of two quads on one uv segment."""
    corners = quad_uv(tri)
    ends = np.stack([corners[:, 0, 0], corners[:, 1, 0], corners[:, 1, 1], corners[:, 0, 1]], 1)  # (P, 4, 2)
    a, b = ends, np.roll(ends, -1, axis=1)
    scale = np.abs(tri.uv).max() + 1.0
    key = lambda p, q: [tuple(np.round(np.concatenate([p, q]) / scale, 9))]  # noqa: E731
    seen, out = {}, []
    for n in range(ends.shape[0]):
        for s in range(4):
            other = seen.get(key(b[n, s], a[n, s])[0])  # the neighbour runs the side the other way
            if other is not None:
                out.append((*other, n, s))
            seen[key(a[n, s], b[n, s])[0]] = (n, s)
    return np.array(out)


def side_rows(P: np.ndarray, side: int) -> np.ndarray:
    """Control points of side ``side`` of ``P (..., 6, 6, d)``, counter-clockwise."""
    return [P[..., :, 0, :], P[..., -1, :, :], P[..., ::-1, -1, :], P[..., 0, ::-1, :]][side]


# ------------------------------------------------------------------ tables
def test_quad_corners_and_orientation():
    c = QUAD_CORNERS
    np.testing.assert_array_equal(c.sum(-1), 1.0)
    for k in range(3):
        np.testing.assert_array_equal(c[k, 0, 0], np.eye(3)[k])
        np.testing.assert_array_equal(c[k, 1, 1], np.full(3, 1 / 3))
    # s then t turns counter-clockwise like the face
    corners = quad_uv(Triangulation(*domains.lone_triangle()))
    J = quad_jacobian(corners, np.full((3, 2), 0.5))
    assert (np.linalg.det(J) > 0).all()
    np.testing.assert_allclose(quad_bary(np.array([[0.0, 0.0], [1.0, 1.0]]))[:, 1], 1 / 3, rtol=1e-15)


def test_point_counts_and_sharing():
    uv, faces = domains.random_delaunay(30, holes=1)
    tri = Triangulation(uv, faces)
    net = tensor_net(uv, faces, c1_spline(uv, faces), triangulation=tri)
    nv, ne, nf = tri.n_vertices, tri.n_edges, tri.n_faces
    assert (EDGE_POINTS, FACE_POINTS) == (9, 61)
    assert net.points.shape == (nv + 9 * ne + 61 * nf, 3)
    assert net.patches.shape == (3 * nf, 6, 6) and net.n_patches == 3 * nf
    # every point used: a vertex by one quad per face around it, a point inside an edge by one
    # quad on each side (the midpoint by two), a face's own 61 points by 1 (inside a quad),
    # 2 (on a spoke) or 3 (the centroid) quads
    use = np.bincount(net.patches.ravel(), minlength=net.points.shape[0])
    np.testing.assert_array_equal(use[:nv], np.bincount(faces.ravel(), minlength=nv))
    sides = np.where(tri.boundary_edge_mask, 1, 2)
    edge_use = use[nv:nv + 9 * ne].reshape(9, ne)
    np.testing.assert_array_equal(edge_use, sides * np.where(np.arange(9) == 4, 2, 1)[:, None])
    face_use = use[nv + 9 * ne:].reshape(61, nf)
    assert (face_use == face_use[:, :1]).all()
    assert np.bincount(face_use[:, 0]).tolist() == [0, 48, 12, 1]
    np.testing.assert_array_equal(np.unique(net.patches[:, 0, 0]), np.arange(nv))  # quad corners P00


# ------------------------------------------------------------------ exactness
@settings(max_examples=12, deadline=None)
@given(name=st.sampled_from(sorted(SMALL_DOMAINS)), seed=st.integers(0, 200))
def test_tensor_patches_reproduce_the_triangle_patches(name, seed):
    uv, faces = SMALL_DOMAINS[name](seed)
    ctrl = c1_spline(uv, faces, seed)
    P = tensor_net(uv, faces, ctrl).patch_points()  # (3F, 6, 6, 3)
    nf = faces.shape[0]
    st_ = np.random.default_rng(seed).random((3 * nf, 2))
    bary = quad_bary(st_)  # (3, 3F, 3): row n of quad k
    k = np.arange(3 * nf) % 3
    ref = evaluate(uv, faces, ctrl, np.arange(3 * nf) // 3, bary[k, np.arange(3 * nf)])
    scale = np.abs(ctrl).max()
    np.testing.assert_allclose(tensor_eval(P, st_), ref, rtol=0, atol=1e-13 * scale)


def test_threaded_ranges():
    """A mesh big enough for the threaded ranges (faces and edges) converts like a small one."""
    uv, faces = domains.grid(91, 91)  # 16,562 faces: three ranges of faces, five of edges
    ctrl = polynomial_control_net(uv, faces, random_polynomial(5, 3, seed=3))
    P = tensor_net(uv, faces, ctrl).patch_points()
    st_ = np.random.default_rng(4).random((P.shape[0], 2))
    n = np.arange(P.shape[0])
    ref = evaluate(uv, faces, ctrl, n // 3, quad_bary(st_)[n % 3, n])
    np.testing.assert_allclose(tensor_eval(P, st_), ref, rtol=0, atol=1e-13 * np.abs(ctrl).max())


def test_polynomial_converts_to_its_tensor_representation():
    """Oracle: collocation of ``p(Q_k(s, t))`` on a 6 x 6 grid, solved with the 1D Bernstein matrix."""
    uv, faces = domains.random_delaunay(30, holes=1, seed=2)
    poly = random_polynomial(5, 3, seed=7)
    P = tensor_net(uv, faces, polynomial_control_net(uv, faces, poly)).patch_points()
    x = np.linspace(0, 1, 6)
    B = bernstein(x)  # (6 nodes, 6)
    S, T = np.meshgrid(x, x, indexing="ij")
    st_ = np.column_stack([S.ravel(), T.ravel()])
    corners = quad_uv(Triangulation(uv, faces))  # (3F, 2, 2, 2)
    s, t = st_[None, :, :1], st_[None, :, 1:]
    q = ((1 - s) * (1 - t) * corners[:, None, 0, 0] + s * (1 - t) * corners[:, None, 1, 0]
         + (1 - s) * t * corners[:, None, 0, 1] + s * t * corners[:, None, 1, 1])  # (3F, 36, 2)
    vals = poly(q.reshape(-1, 2)).reshape(-1, 6, 6, 3)
    Binv = np.linalg.inv(B)
    oracle = np.einsum("ai,bj,nijd->nabd", Binv, Binv, vals)
    np.testing.assert_allclose(P, oracle, rtol=0, atol=1e-11 * np.abs(oracle).max())


# ------------------------------------------------------------------ watertight and C1
@pytest.mark.parametrize("name", ["holes", "crisscross", "slivers", "fan"])
def test_shared_sides_are_bit_identical(name):
    uv, faces = SMALL_DOMAINS[name](1)
    tri = Triangulation(uv, faces)
    ctrl = c1_spline(uv, faces)
    # duplicates of a shared control point that differ in the last bits still give one side
    ctrl = ctrl * (1 + 1e-15 * np.random.default_rng(0).standard_normal(ctrl.shape))
    P = tensor_net(uv, faces, ctrl, triangulation=tri).patch_points()
    pairs = shared_sides(tri)
    n_spokes, n_halves = 3 * tri.n_faces, 2 * tri.interior_edges.size
    assert pairs.shape[0] == n_spokes + n_halves
    for a, sa, b, sb in pairs:
        np.testing.assert_array_equal(side_rows(P[a], sa), side_rows(P[b], sb)[::-1])


@pytest.mark.parametrize("name", ["holes", "crisscross", "lshape"])
def test_c1_across_every_side(name):
    """uv-gradients ``[S_s S_t] J^-1`` agree from both quads of every shared side (with a negative control)."""
    uv, faces = SMALL_DOMAINS[name](3)
    tri = Triangulation(uv, faces)
    ctrl = c1_spline(uv, faces, 3)
    P = tensor_net(uv, faces, ctrl, triangulation=tri).patch_points()
    pairs = shared_sides(tri)
    corners = quad_uv(tri)
    w = np.linspace(0, 1, 7)

    def gradient(P, n, side, w):
        st_ = SIDES[side, 0] + w[:, None] * (SIDES[side, 1] - SIDES[side, 0])
        J = quad_jacobian(np.broadcast_to(corners[n], (len(w), 2, 2, 2)), st_)
        dS = np.stack([tensor_eval(P[n], st_, 1, 0), tensor_eval(P[n], st_, 0, 1)], -1)  # (m, 3, 2)
        return tensor_eval(P[n], st_), dS @ np.linalg.inv(J)

    def jumps(P):
        c0, c1 = [], []
        for a, sa, b, sb in pairs:
            va, ga = gradient(P, a, sa, w)
            vb, gb = gradient(P, b, sb, 1 - w)
            c0.append(np.abs(va - vb).max())
            c1.append(np.abs(ga - gb).max())
        return np.array(c0), np.array(c1)

    r = evaluate_derivatives(uv, faces, ctrl, np.arange(len(faces)), np.full((len(faces), 3), 1 / 3))
    gscale = np.abs(np.concatenate([r.du, r.dv])).max()
    c0, c1 = jumps(P)
    assert c0.max() < 1e-13 * np.abs(ctrl).max()
    assert c1.max() < 1e-11 * gscale
    # negative control: moving an inner point next to side 1 (the spoke) of quad 0 breaks C1 there only
    bad = P.copy()
    bad[0, 4, 2] += 1e-3 * np.abs(ctrl).max()
    c0_bad, c1_bad = jumps(bad)
    hit = (pairs[:, 0] == 0) & (pairs[:, 1] == 1) | (pairs[:, 2] == 0) & (pairs[:, 3] == 1)
    assert hit.sum() == 1 and c1_bad[hit].max() > 1e3 * max(c1.max(), 1e-300)
    np.testing.assert_array_equal(c0_bad, c0)


def test_refuses_bad_control_points():
    uv, faces = domains.lone_triangle()
    with pytest.raises(InputError, match=r"ctrl must have shape \(1, 21, n\)"):
        tensor_net(uv, faces, np.zeros((1, 20, 3)))
    with pytest.raises(InputError, match="st must have shape"):
        quad_bary(np.zeros(3))
