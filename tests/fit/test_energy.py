"""Energy building blocks: Gram matrices, residual quadrature, derivative estimates, solver plumbing."""
from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import optimistix as optx
import pytest
import scipy.sparse as sp
from hypothesis import given, settings, strategies as st

jax.config.update("jax_enable_x64", True)

from trispline.fit import energy as en  # noqa: E402
from trispline.fit.datasets.franke import RENKA_BROWN, sample_points  # noqa: E402
from trispline.fit.energy.gram import thin_plate_gram, triangle_quadrature  # noqa: E402
from trispline.fit.targets import area_weighted_normals, fitted_normals, local_polynomial_fit  # noqa: E402
from trispline.fit.solve import FactorSolver, SparseCholesky  # noqa: E402
from trispline.spline.testing.domains import random_delaunay  # noqa: E402
from trispline.spline.polynomial import polynomial_control_net  # noqa: E402
from trispline.spline.topology import Triangulation  # noqa: E402


@pytest.fixture(scope="module")
def tri():
    uv, f = random_delaunay(40, seed=3)
    return Triangulation(uv, f)


def test_quadrature_exact_degree_6():
    bary, w = triangle_quadrature(4)
    assert np.isclose(w.sum(), 1.0)
    # mean of l1^a l2^b over the triangle = 2 a! b! / (a + b + 2)!
    from math import factorial

    for a, b in [(0, 0), (2, 3), (4, 2), (6, 0), (3, 3)]:
        exact = 2 * factorial(a) * factorial(b) / factorial(a + b + 2)
        assert np.isclose((w * bary[:, 1] ** a * bary[:, 2] ** b).sum(), exact, rtol=1e-13)


def test_gram_exact_on_polynomials(tri):
    G = thin_plate_gram(tri.bary_gradients, tri.areas)
    func = lambda p: np.column_stack([p[:, 0] ** 2, p[:, 0] * p[:, 1], 3 - p[:, 0] + 2 * p[:, 1]])  # noqa: E731
    c = polynomial_control_net(tri.uv, tri.faces, func)
    E = np.einsum("fic,fij,fjc->fc", c, G, c)
    tol = 1e-9 * np.einsum("fic,fic->f", np.abs(c), np.abs(c)) * np.abs(G).max(axis=(1, 2))
    assert np.all(np.abs(E[:, 0] - 4 * tri.areas) <= tol)  # u^2: F_uu = 2
    assert np.all(np.abs(E[:, 1] - 2 * tri.areas) <= tol)  # uv: 2 F_uv^2 = 2
    assert np.all(np.abs(E[:, 2]) <= tol)  # linear: zero
    # symmetric PSD with exactly a 3-dimensional null space
    assert np.allclose(G, G.transpose(0, 2, 1))
    ev = np.linalg.eigvalsh(G[:5])
    assert np.all(ev[:, :3] < 1e-9 * ev[:, -1:]) and np.all(ev[:, 3] > 1e-6 * ev[:, -1])


def test_residual_quadrature_matches_gram(tri):
    rng = np.random.default_rng(0)
    ctrl = rng.standard_normal((tri.n_faces, 21, 3))
    D, sqw = en.bend_tables()
    args = dict(bend_D=jnp.asarray(D), bend_W=jnp.asarray(en.bend_weights(tri.bary_gradients, tri.areas, 2.5)),
                bend_sqw=jnp.asarray(sqw))
    r = np.asarray(en.bend_residual(jnp.asarray(ctrl), args))
    G = thin_plate_gram(tri.bary_gradients, tri.areas)
    E = np.einsum("fic,fij,fjc->", ctrl, G, ctrl)
    assert np.isclose((r**2).sum(), 2.5 * E, rtol=1e-12)


def test_local_fit_reproduces_cubics():
    uv, f = random_delaunay(150, seed=2)
    x, y = uv.T
    vals = np.column_stack([1 + x**3 - 2 * x * y * y + x * y, 2 - x + 3 * y])
    fit = local_polynomial_fit(uv, vals, f, degree=3)
    g = np.stack([3 * x**2 - 2 * y * y + y, -4 * x * y + x], -1)
    H = np.array([[6 * x, 1 - 4 * y], [1 - 4 * y, -4 * x]]).transpose(2, 0, 1)
    full = fit.degree == 3
    assert full.mean() > 0.9
    np.testing.assert_allclose(fit.grad[full, 0], g[full], atol=1e-9)
    np.testing.assert_allclose(fit.hess[full, 0], H[full], atol=1e-7)
    # linear data exact everywhere, whatever degree was used
    np.testing.assert_allclose(fit.grad[:, 1], np.tile([-1.0, 3.0], (len(x), 1)), atol=1e-10)
    np.testing.assert_allclose(fit.hess[:, 1], 0.0, atol=1e-8)
    # the polynomial passes through the vertex data
    np.testing.assert_allclose(fit.evaluate(np.arange(len(x)), uv), vals, atol=1e-12)


def test_local_fit_rejects_bad_degree():
    uv, f = random_delaunay(20, seed=0)
    with pytest.raises(ValueError, match="degree"):
        local_polynomial_fit(uv, uv[:, 0], f, degree=4)


def test_normals_of_a_tilted_plane():
    uv, f = random_delaunay(60, seed=1)
    A = np.array([[1.0, 0.2], [0.3, 1.0], [0.5, -0.7]])
    V = uv @ A.T + [1.0, 2.0, 3.0]
    n_exact = np.cross(A[:, 0], A[:, 1])
    n_exact /= np.linalg.norm(n_exact)
    np.testing.assert_allclose(area_weighted_normals(V, f), np.tile(n_exact, (len(V), 1)), atol=1e-12)
    fit = local_polynomial_fit(uv, V, f)
    np.testing.assert_allclose(fitted_normals(fit), np.tile(n_exact, (len(V), 1)), atol=1e-10)


def test_franke_set_and_samples():
    p = sample_points(200, seed=1)
    assert p.shape == (200, 2) and p.min() >= 0 and p.max() <= 1
    for c in ([0, 0], [1, 0], [1, 1], [0, 1]):
        assert np.any(np.all(p == c, axis=1))
    assert len(RENKA_BROWN) == 10
    for fn in RENKA_BROWN.values():
        assert np.all(np.isfinite(fn(p[:, 0], p[:, 1])))
    assert np.isclose(RENKA_BROWN["gentle"](0.5, 0.5), 1 / 3)
    with pytest.raises(ValueError):
        sample_points(3)


def _ls_problem(seed: int, n: int = 60, m: int = 150):
    A = (sp.random(m, n, density=0.05, random_state=seed) + sp.eye(m, n)).tocoo()
    b = np.random.default_rng(seed).standard_normal((m, 3))
    args = dict(r=jnp.asarray(A.row), c=jnp.asarray(A.col), v=jnp.asarray(A.data), b=jnp.asarray(b))
    return A, b, args


def _res_linear(x, args):
    Ax = jnp.zeros_like(args["b"]).at[args["r"]].add(args["v"][:, None] * x[args["c"]])
    return Ax - args["b"]


def _res_nonlinear(x, args):
    return _res_linear(x, args), 0.5 * jnp.sin(x[:8]).ravel()


@settings(max_examples=5, deadline=None)
@given(st.integers(0, 1000))
def test_factor_solver_matches_lstsq(seed):
    A, b, args = _ls_problem(seed)
    fac = SparseCholesky((A.T @ A).tocsr())
    solver = optx.GaussNewton(rtol=1e-10, atol=1e-10, linear_solver=FactorSolver(fac))
    sol = optx.least_squares(_res_linear, solver, jnp.zeros((A.shape[1], 3)), args)
    ref = np.linalg.lstsq(A.toarray(), b, rcond=None)[0]
    np.testing.assert_allclose(np.asarray(sol.value), ref, atol=1e-10)
    assert int(sol.stats["num_steps"]) <= 3


def test_factor_pcg_converges_on_nonlinear_terms():
    A, b, args = _ls_problem(7)
    fac = SparseCholesky((A.T @ A).tocsr())
    solver = optx.GaussNewton(rtol=1e-10, atol=1e-10, linear_solver=FactorSolver(fac, mode="pcg"))
    sol = optx.least_squares(_res_nonlinear, solver, jnp.zeros((A.shape[1], 3)), args)
    grad = jax.grad(lambda x: 0.5 * sum(jnp.sum(r**2) for r in _res_nonlinear(x, args)))(sol.value)
    assert float(jnp.abs(grad).max()) < 1e-8
    # the direct mode ignores the nonlinear term's curvature: its answer is not stationary
    direct = optx.least_squares(_res_nonlinear, optx.GaussNewton(rtol=1e-10, atol=1e-10, linear_solver=FactorSolver(fac)),
                                jnp.zeros((A.shape[1], 3)), args, max_steps=2, throw=False)
    g2 = jax.grad(lambda x: 0.5 * sum(jnp.sum(r**2) for r in _res_nonlinear(x, args)))(direct.value)
    assert float(jnp.abs(g2).max()) > 1e-6


def test_sparse_cholesky_rejects_non_square():
    with pytest.raises(ValueError, match="square"):
        SparseCholesky(sp.random(3, 4, density=0.5))
