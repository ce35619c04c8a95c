"""Energy building blocks: Gram matrices, residual quadrature, one definition per term, normals, solver plumbing."""
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
from trispline.fit.energy import bend  # noqa: E402
from trispline.fit.energy.quadrature import pair_hessians, triangle_quadrature  # noqa: E402
from trispline.fit.targets import area_weighted_normals, fitted_normals, local_rbf_fit  # noqa: E402
from trispline.fit.weights import TERM_WEIGHTS, FitWeights  # noqa: E402
from trispline.fit.solve import FactorSolver, SparseCholesky  # noqa: E402
from trispline.spline.testing.domains import random_delaunay  # noqa: E402
from trispline.spline.polynomial import polynomial_control_net  # noqa: E402
from trispline.spline.propagation import build_space  # noqa: E402
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
    G = en.thin_plate_gram(tri.bary_gradients, tri.areas)
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
    D, sqw = pair_hessians()
    a = dict(D=D, W=en.bend_weights(tri.bary_gradients, tri.areas, 2.5), sqw=sqw)
    r = np.asarray(bend.residual(jnp.asarray(ctrl), None, jax.tree_util.tree_map(jnp.asarray, a)))
    G = en.thin_plate_gram(tri.bary_gradients, tri.areas)
    E = np.einsum("fic,fij,fjc->", ctrl, G, ctrl)
    assert np.isclose((r**2).sum(), 2.5 * E, rtol=1e-12)
    # the same definition on the host (numpy) gives the same residual
    np.testing.assert_allclose(bend.residual(ctrl, None, a), r, rtol=0, atol=1e-12 * np.abs(r).max())


def test_term_registry_follows_the_weights():
    assert en.TERMS == TERM_WEIGHTS
    for m in en.MODULES:
        assert m.LINEAR == hasattr(m, "add_normal"), m.NAME


def _half_sum_squares(x, args):
    return 0.5 * sum(jnp.sum(r * r) for r in en.residuals(x, args).values())


_gradient = jax.jit(jax.grad(_half_sum_squares))


@pytest.mark.parametrize("weights", [FitWeights(), FitWeights(bend=0.5, tilt=0.0, local=7.0, data=3.0)])
def test_normal_equations_are_the_residuals_jacobian(weights):
    """H = J^T J and rhs = -J^T r(0) of the JAX residuals (all terms linear here).

    The gradient of the linear least-squares energy is ``J^T (J x + r(0)) = H x - rhs``
    coordinate by coordinate; random ``x`` probe every entry of ``H`` and any coupling
    between the coordinates.
    """
    uv, f = random_delaunay(25, seed=4)
    V = np.column_stack([uv, np.sin(2 * uv[:, 0]) + uv[:, 1] ** 2])
    space = build_space(uv, f)
    rng = np.random.default_rng(2)
    face = rng.integers(0, space.tri.n_faces, 30)
    dp = en.DataPoints(face, rng.dirichlet([1, 1, 1], 30), rng.normal(size=(30, 3)))
    prob = en.setup_problem(V, space, weights, dp)
    assert not prob.nonlinear
    k = prob.free_r.size
    g0 = np.asarray(_gradient(jnp.zeros((k, 3)), prob.args))
    np.testing.assert_allclose(g0, -prob.rhs, rtol=0, atol=1e-10 * np.abs(prob.rhs).max())
    for _ in range(2):
        x = rng.normal(size=(k, 3))
        g = np.asarray(_gradient(jnp.asarray(x), prob.args))
        np.testing.assert_allclose(g - g0, prob.H @ x, rtol=0, atol=1e-10 * np.abs(prob.H @ x).max())


def test_normals_of_a_tilted_plane():
    uv, f = random_delaunay(60, seed=1)
    A = np.array([[1.0, 0.2], [0.3, 1.0], [0.5, -0.7]])
    V = uv @ A.T + [1.0, 2.0, 3.0]
    n_exact = np.cross(A[:, 0], A[:, 1])
    n_exact /= np.linalg.norm(n_exact)
    np.testing.assert_allclose(area_weighted_normals(V, f), np.tile(n_exact, (len(V), 1)), atol=1e-12)
    fit = local_rbf_fit(uv, V, f)
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
    # padded with zero entries to one length for every seed: one compile serves all problems
    pad = int(0.05 * m * n) + n - A.nnz
    rows, cols, vals = (np.concatenate([a, np.zeros(pad, a.dtype)]) for a in (A.row, A.col, A.data))
    args = dict(r=jnp.asarray(rows), c=jnp.asarray(cols), v=jnp.asarray(vals), b=jnp.asarray(b))
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
