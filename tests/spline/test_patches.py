"""Patch evaluation, uv-derivatives, the fixed-sample fast path and numeric continuity."""
from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from trispline.spline.testing import domains
from trispline.spline.errors import InputError
from trispline.spline.patches import evaluate, evaluate_derivatives, evaluate_grid, numeric_continuity
from trispline.spline.bernstein import (PRODUCT_MONOMIALS, bary_grid, basis, basis_gradient_bary, basis_hessian_bary,
                                        basis_of_degree, gram_from_moments, product_monomials)
from trispline.spline.polynomial import polynomial_control_net, random_polynomial
from trispline.spline.topology import Triangulation, face_bary_gradients
from triangulations import SMALL_DOMAINS

DOMAINS = SMALL_DOMAINS
domain_names = st.sampled_from(sorted(DOMAINS))


def _queries(rng, nf, n):
    return rng.integers(0, nf, n), rng.dirichlet(np.ones(3), n)


def _uv_of(uv, faces, fidx, bary):
    return np.einsum("nk,nkc->nc", bary, uv[faces[fidx]])


@settings(max_examples=25, deadline=None)
@given(name=domain_names, seed=st.integers(0, 500))
def test_polynomial_reproduced_with_derivatives(name, seed):
    uv, faces = DOMAINS[name](seed)
    func = random_polynomial(5, 3, seed)
    ctrl = polynomial_control_net(uv, faces, func)
    rng = np.random.default_rng(seed)
    fidx, bary = _queries(rng, faces.shape[0], 100)
    p = _uv_of(uv, faces, fidx, bary)
    r = evaluate_derivatives(uv, faces, ctrl, fidx, bary, second=True)
    np.testing.assert_allclose(evaluate(uv, faces, ctrl, fidx, bary), func(p), atol=1e-11)
    np.testing.assert_allclose(r.values, func(p), atol=1e-11)
    for got, (du, dv) in [(r.du, (1, 0)), (r.dv, (0, 1)), (r.uu, (2, 0)), (r.uv, (1, 1)), (r.vv, (0, 2))]:
        ref = func.derivative(p, du, dv)
        # derivative rounding grows like 1/h^order for small (sliver) faces
        h = np.sqrt(Triangulation(uv, faces).areas.min())
        scale = (np.abs(ref).max() + 1.0) * max(1.0, h ** -(du + dv))
        np.testing.assert_allclose(got, ref, atol=1e-10 * scale, err_msg=f"d{du}{dv}")


def test_derivatives_match_finite_differences_of_random_net():
    """Chain rule checked without the polynomial oracle: a random (non-polynomial) net."""
    uv, faces = domains.random_delaunay(20, seed=4)
    rng = np.random.default_rng(0)
    ctrl = rng.standard_normal((faces.shape[0], 21, 3))
    fidx = rng.integers(0, faces.shape[0], 50)
    bary = 0.2 + 0.4 * rng.dirichlet(np.ones(3), 50)  # well inside: all coords >= 0.2
    bary /= bary.sum(1, keepdims=True)
    G = face_bary_gradients(uv, faces)[fidx]  # (n, 3, 2)
    r = evaluate_derivatives(uv, faces, ctrl, fidx, bary, second=True)
    h = 1e-5 * np.sqrt(Triangulation(uv, faces).areas.mean())

    def at(shift):
        return evaluate(uv, faces, ctrl, fidx, bary + shift)

    su, sv = h * G[:, :, 0], h * G[:, :, 1]
    fd_u = (at(su) - at(-su)) / (2 * h)
    fd_v = (at(sv) - at(-sv)) / (2 * h)
    scale = np.abs(r.du).max() + np.abs(r.dv).max()
    np.testing.assert_allclose(r.du, fd_u, atol=1e-6 * scale)
    np.testing.assert_allclose(r.dv, fd_v, atol=1e-6 * scale)
    fd_uv = (evaluate_derivatives(uv, faces, ctrl, fidx, bary + sv).du
             - evaluate_derivatives(uv, faces, ctrl, fidx, bary - sv).du) / (2 * h)
    fd_uu = (evaluate_derivatives(uv, faces, ctrl, fidx, bary + su).du
             - evaluate_derivatives(uv, faces, ctrl, fidx, bary - su).du) / (2 * h)
    s2 = np.abs(r.uu).max() + np.abs(r.uv).max()
    np.testing.assert_allclose(r.uv, fd_uv, atol=1e-5 * s2)
    np.testing.assert_allclose(r.uu, fd_uu, atol=1e-5 * s2)


@settings(max_examples=10, deadline=None)
@given(seed=st.integers(0, 1000), per_patch=st.sampled_from([1, 3, 200]))
def test_derivative_nets_equal_the_basis_derivatives_contracted(seed, per_patch):
    """uv-derivatives from per-patch nets (degree 4 and 3) equal the quintic basis' barycentric
    derivatives contracted with the control points and the face Jacobians, one patch per query or many."""
    uv, faces = domains.random_delaunay(15, seed=seed % 7)
    rng = np.random.default_rng(seed)
    ctrl = rng.standard_normal((faces.shape[0], 21, 3))
    fidx = np.repeat(rng.permutation(faces.shape[0]), per_patch)[: 20 * faces.shape[0]]
    bary = rng.dirichlet(np.ones(3), fidx.size)
    r = evaluate_derivatives(uv, faces, ctrl, fidx, bary, second=True)
    G = face_bary_gradients(uv, faces)[fidx]  # (n, 3, 2)
    c = ctrl[fidx]
    grad = np.einsum("anm,nmd->and", basis_gradient_bary(bary), c)  # (3, n, d)
    hess = np.einsum("abnm,nmd->abnd", basis_hessian_bary(bary), c)
    scale = np.abs(grad).max() * np.abs(G).max()
    np.testing.assert_allclose(r.du, np.einsum("and,na->nd", grad, G[:, :, 0]), atol=1e-13 * scale)
    np.testing.assert_allclose(r.dv, np.einsum("and,na->nd", grad, G[:, :, 1]), atol=1e-13 * scale)
    scale2 = np.abs(hess).max() * np.abs(G).max() ** 2
    for got, i, j in [(r.uu, 0, 0), (r.uv, 0, 1), (r.vv, 1, 1)]:
        ref = np.einsum("abnd,na,nb->nd", hess, G[:, :, i], G[:, :, j])
        np.testing.assert_allclose(got, ref, atol=1e-13 * scale2)
    np.testing.assert_array_equal(r.values, evaluate(uv, faces, ctrl, fidx, bary))  # the same bits


@pytest.mark.parametrize("degree", [1, 2, 3, 4, 5])
def test_bernstein_polynomials_of_each_degree_partition_unity(degree):
    bary = np.random.default_rng(degree).dirichlet(np.ones(3), 500)
    B = basis_of_degree(bary, degree)
    assert B.shape == (500, (degree + 1) * (degree + 2) // 2) and B.min() >= 0.0
    np.testing.assert_allclose(B.sum(1), 1.0, atol=1e-14)
    if degree == 5:
        np.testing.assert_array_equal(B, basis(bary))


def test_partition_of_unity():
    uv, faces = domains.l_shape(30)
    ctrl = np.ones((faces.shape[0], 21, 1))
    fidx, bary = _queries(np.random.default_rng(1), faces.shape[0], 64)
    r = evaluate_derivatives(uv, faces, ctrl, fidx, bary, second=True)
    np.testing.assert_allclose(r.values, 1.0, atol=1e-13)
    for a in (r.du, r.dv, r.uu, r.uv, r.vv):
        np.testing.assert_allclose(a, 0.0, atol=1e-9)


def test_grid_fast_path_matches_scattered_evaluation():
    uv, faces = domains.random_delaunay(25, holes=1, seed=5)
    rng = np.random.default_rng(2)
    ctrl = rng.standard_normal((faces.shape[0], 21, 3))
    g = bary_grid(4)
    (vals,) = evaluate_grid(ctrl, g)
    v2, du, dv = evaluate_grid(ctrl, g, uv=uv, faces=faces)
    nf, n = faces.shape[0], g.shape[0]
    fidx = np.repeat(np.arange(nf), n)
    r = evaluate_derivatives(uv, faces, ctrl, fidx, np.tile(g, (nf, 1)))
    np.testing.assert_allclose(vals.reshape(-1, 3), r.values, atol=1e-12)
    np.testing.assert_allclose(v2.reshape(-1, 3), r.values, atol=1e-12)
    np.testing.assert_allclose(du.reshape(-1, 3), r.du, rtol=1e-10, atol=1e-10 * np.abs(r.du).max())
    np.testing.assert_allclose(dv.reshape(-1, 3), r.dv, rtol=1e-10, atol=1e-10 * np.abs(r.dv).max())


def test_bary_gradients_match_triangulation():
    uv, faces = domains.annulus(2, 10)
    np.testing.assert_allclose(face_bary_gradients(uv, faces), Triangulation(uv, faces).bary_gradients, rtol=1e-13)


def test_evaluate_input_errors():
    uv, faces = domains.grid(2)
    ctrl = np.zeros((faces.shape[0], 21, 3))
    with pytest.raises(InputError, match="control points must have shape"):
        evaluate(uv, faces, ctrl[:, :20], np.array([0]), np.array([[1.0, 0, 0]]))
    with pytest.raises(InputError, match="face_idx refer to ids outside"):
        evaluate(uv, faces, ctrl, np.array([0, faces.shape[0]]), np.full((2, 3), 1 / 3))
    with pytest.raises(InputError, match="bary must have shape"):
        evaluate(uv, faces, ctrl, np.array([0, 1]), np.full((3, 3), 1 / 3))
    with pytest.raises(InputError, match="face_idx must hold integers"):
        evaluate(uv, faces, ctrl, np.array([0.0]), np.full((1, 3), 1 / 3))


# ----------------------------------------------------------------- continuity
@settings(max_examples=20, deadline=None)
@given(name=domain_names, seed=st.integers(0, 500))
def test_polynomial_surface_is_numerically_c1(name, seed):
    uv, faces = DOMAINS[name](seed)
    ctrl = polynomial_control_net(uv, faces, random_polynomial(5, 3, seed))
    r = numeric_continuity(uv, faces, ctrl)
    assert r["c0_relative"] < 1e-12
    # slivers: gradients of a patch are ~1/width times its control point differences
    assert r["c1_relative"] < 1e-9
    assert r["c0_per_edge"].shape == r["edges"].shape


def _perturbed_off_edge(uv, faces, ctrl):
    """Move the flip point f(b^2 c^2 a) of a face with an interior edge bc (off that edge)."""
    tri = Triangulation(uv, faces)
    e = tri.interior_edges[0]
    f, k = tri.edge_faces[e, 0], tri.edge_opposite[e, 0]
    from trispline.spline.index import FLIP

    bad = ctrl.copy()
    bad[f, FLIP[k]] += 0.1 * np.linalg.norm(np.ptp(ctrl.reshape(-1, 3), axis=0))
    return bad, e


def test_negative_control_c1_jump_without_c0_jump():
    uv, faces = domains.random_delaunay(30, holes=1, seed=7)
    ctrl = polynomial_control_net(uv, faces, random_polynomial(5, 3, 1))
    bad, e = _perturbed_off_edge(uv, faces, ctrl)
    r = numeric_continuity(uv, faces, bad)
    assert r["c0_relative"] < 1e-12
    assert r["c1_relative"] > 1e-3
    worst = r["edges"][np.argmax(r["c1_per_edge"])]
    assert worst == e


def test_random_per_patch_nets_are_discontinuous():
    uv, faces = domains.grid(3)
    ctrl = np.random.default_rng(0).standard_normal((faces.shape[0], 21, 3))
    r = numeric_continuity(uv, faces, ctrl)
    assert r["c0_relative"] > 1e-2 and r["c1_relative"] > 1e-2


def test_lone_triangle_has_no_interior_edges():
    uv, faces = domains.lone_triangle()
    r = numeric_continuity(uv, faces, np.zeros((1, 21, 3)))
    assert r["c0_max"] == 0.0 and r["edges"].size == 0
    with pytest.raises(InputError, match="n_samples"):
        numeric_continuity(uv, faces, np.zeros((1, 21, 3)), n_samples=1)


try:  # the lead's propagation map: C1 splines that are not polynomials
    from trispline.spline.propagation import build_space
except ImportError:  # pragma: no cover
    build_space = None

needs_space = pytest.mark.skipif(build_space is None, reason="trispline.spline.propagation not available")


@needs_space
@settings(max_examples=15, deadline=None)
@given(name=st.sampled_from(["delaunay", "holes", "lshape", "annulus", "grid", "crisscross", "fan"]),
       seed=st.integers(0, 500))
def test_spline_from_space_is_c1_and_perturbation_breaks_only_c1(name, seed):
    uv, faces = DOMAINS[name](seed)
    space = build_space(uv, faces)
    free = np.random.default_rng(seed).standard_normal((space.n_free, 3))
    ctrl = space.control_points(free)
    r = numeric_continuity(uv, faces, ctrl)
    assert r["c0_relative"] < 1e-12
    assert r["c1_relative"] < 1e-9
    bad, _ = _perturbed_off_edge(uv, faces, ctrl)
    rb = numeric_continuity(uv, faces, bad)
    assert rb["c0_relative"] < 1e-12
    assert rb["c1_relative"] > 1e-4


@given(seed=st.integers(0, 10_000), n=st.integers(1, 50), spread=st.sampled_from([0.0, 0.3]))
@settings(max_examples=30)
def test_gram_from_degree_10_moments_equals_sum_of_basis_products(seed, n, spread):
    """Sums of weighted ``basis basis^T`` over samples (also outside the triangle) come from 66 moments."""
    rng = np.random.default_rng(seed)
    bary = rng.dirichlet([1.0, 1.0, 1.0], n) + spread * rng.normal(size=(n, 3))
    w = rng.uniform(0.1, 3.0, n)
    B = basis(bary)
    expected = np.einsum("n,ni,nj->ij", w, B, B)
    got = gram_from_moments(product_monomials(bary) @ w)
    assert product_monomials(bary).shape == (PRODUCT_MONOMIALS, n)
    np.testing.assert_allclose(got, expected, rtol=1e-12, atol=1e-13 * np.abs(expected).max())


@settings(max_examples=10, deadline=None)
@given(name=domain_names, seed=st.integers(0, 500))
def test_regularity_is_one_for_an_affine_map_and_zero_where_a_patch_degenerates(name, seed):
    """A patch's smallest area element over its largest: 1 where the map to space is affine (constant
    ``F_u x F_v``); 0 where its frame at a corner collapses (the corner's two edge neighbours moved onto it)."""
    from trispline.spline.patches import regularity
    from trispline.spline.index import CORNER, STAR

    uv, faces = DOMAINS[name](seed)
    A = np.random.default_rng(seed).normal(size=(2, 3))
    ctrl = polynomial_control_net(uv, faces, lambda p: p @ A)
    np.testing.assert_allclose(regularity(uv, faces, ctrl), 1.0, atol=1e-9)
    pinched = ctrl.copy()
    pinched[0, STAR[0, 1:]] = pinched[0, CORNER[0]]  # both derivatives at the first corner vanish
    r = regularity(uv, faces, pinched)
    assert r[0] < 1e-12 and np.allclose(r[1:], 1.0, atol=1e-9)
