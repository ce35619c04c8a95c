"""The sparse factor backends agree, and auto-selection follows the measured size rule."""
from __future__ import annotations

import importlib.util

import numpy as np
import pytest
import scipy.sparse as sp

from trispline.fit import solve
from trispline.fit.solve import SparseCholesky

HAS_PARDISO = importlib.util.find_spec("pypardiso") is not None


def spd(n: int, seed: int = 0) -> sp.csr_matrix:
    """A sparse SPD matrix with a wide range of diagonal scales (like the fit's normal matrix)."""
    rng = np.random.default_rng(seed)
    A = sp.random(n, n, density=4.0 / n, random_state=rng, format="csr")
    D = sp.diags(10.0 ** rng.uniform(-3, 3, n))
    return (A.T @ A + D).tocsr()


@pytest.mark.parametrize("backend", ["cholespy", "splu", pytest.param(
    "pardiso", marks=pytest.mark.skipif(not HAS_PARDISO, reason="pypardiso not installed"))])
def test_backends_solve_to_rounding(backend):
    H = spd(400)
    b = np.random.default_rng(1).normal(size=(400, 3))
    x = SparseCholesky(H, backend).solve(b)
    np.testing.assert_allclose(H @ x, b, rtol=0, atol=1e-9 * np.abs(b).max())
    x1 = SparseCholesky(H, backend).solve(b[:, 0])
    np.testing.assert_allclose(x1, x[:, 0], rtol=1e-9, atol=1e-12)


def test_auto_picks_cholespy_for_small_and_pardiso_for_large(monkeypatch):
    monkeypatch.delenv("TRISPLINE_SOLVER", raising=False)
    assert SparseCholesky(spd(200)).backend == "cholespy"
    big = solve._pick_backend(None, solve.PARDISO_MIN_UNKNOWNS)
    assert big == ("pardiso" if HAS_PARDISO else "cholespy")
    monkeypatch.setenv("TRISPLINE_SOLVER", "splu")
    assert SparseCholesky(spd(50)).backend == "splu"


@pytest.mark.parametrize("backend", ["cholespy", pytest.param(
    "pardiso", marks=pytest.mark.skipif(not HAS_PARDISO, reason="pypardiso not installed"))])
def test_indefinite_matrix_is_refused(backend):
    A = sp.csr_matrix(np.array([[1.0, 2.0], [2.0, 1.0]]))
    with pytest.raises((np.linalg.LinAlgError, ValueError)):
        SparseCholesky(A, backend)


def test_unknown_backend_is_refused():
    with pytest.raises(ValueError, match="unknown solver backend"):
        SparseCholesky(spd(20), "magic")


def test_factor_solvers_of_two_factors_share_one_compile():
    """The factor travels as a traced handle: one trace serves two factors, each solving with its own."""
    import jax
    import jax.numpy as jnp
    import lineax as lx

    jax.config.update("jax_enable_x64", True)
    from trispline.fit.solve import FactorSolver

    f1, f2 = SparseCholesky(spd(30, seed=1)), SparseCholesky(spd(30, seed=2))
    s1, s2 = FactorSolver(f1), FactorSolver(f2)
    assert jax.tree_util.tree_structure(s1) == jax.tree_util.tree_structure(s2)
    assert s1.factor is f1 and s2.factor is f2
    traces = []

    @jax.jit
    def solve(solver, b):
        traces.append(1)
        op = lx.IdentityLinearOperator(jax.eval_shape(lambda: b))
        return solver.compute(solver.init(op, {}), b, {})[0]

    b = np.random.default_rng(0).normal(size=(30, 3))
    y1, y2 = solve(s1, jnp.asarray(b)), solve(s2, jnp.asarray(b))
    assert len(traces) == 1
    np.testing.assert_allclose(y1, f1.solve(b), rtol=1e-12)
    np.testing.assert_allclose(y2, f2.solve(b), rtol=1e-12)
    with pytest.raises(ValueError, match="mode"):
        FactorSolver(f1, mode="cg")


def test_spd_backend_threshold_is_per_call():
    """One rule: PARDISO from ``pardiso_min`` unknowns where installed (the uv smoothing lowers it to 0)."""
    from trispline.param.smooth import GLOBAL_PARDISO_MIN
    from trispline.spline.util.spd import SPD_PARDISO_MIN, spd_backend

    large = "pardiso" if HAS_PARDISO else "cholespy"
    assert spd_backend(None, SPD_PARDISO_MIN - 1) == "cholespy"
    assert spd_backend(None, SPD_PARDISO_MIN) == large
    assert spd_backend(None, 10, pardiso_min=GLOBAL_PARDISO_MIN) == large
    assert spd_backend("cholespy", 10**7) == "cholespy"


@pytest.mark.parametrize("backend", ["cholespy", pytest.param(
    "pardiso", marks=pytest.mark.skipif(not HAS_PARDISO, reason="pypardiso not installed"))])
def test_solve_spd_takes_several_right_hand_sides(backend):
    from trispline.spline.util.spd import solve_spd

    H = spd(300, seed=3)
    b = np.random.default_rng(4).normal(size=(300, 2))
    x = solve_spd(H, b, backend=backend)
    assert x.shape == (300, 2)
    np.testing.assert_allclose(H @ x, b, rtol=0, atol=1e-9 * np.abs(b).max())


@pytest.mark.parametrize("backend", ["cholespy", pytest.param(
    "pardiso", marks=pytest.mark.skipif(not HAS_PARDISO, reason="pypardiso not installed"))])
def test_a_kept_factor_solves_again_without_factoring_again(backend, monkeypatch):
    """``spd_factor`` (the spectral map's 21 solves): one factorisation, then solves only. pypardiso's ``solve()``
    alone factored again at every call (PARDISO phase 13 instead of 33: 0.23 s a solve at 100k faces)."""
    from trispline.spline.util.spd import spd_factor

    H = spd(300, seed=5)
    rng = np.random.default_rng(6)
    phases: list[int] = []
    if backend == "pardiso":
        import pypardiso

        phase = pypardiso.PyPardisoSolver.set_phase
        monkeypatch.setattr(pypardiso.PyPardisoSolver, "set_phase", lambda self, p: (phases.append(p), phase(self, p)))
    with spd_factor(H, backend=backend) as solve:
        for _ in range(3):
            b = rng.normal(size=300)
            np.testing.assert_allclose(H @ solve(b), b, rtol=0, atol=1e-9 * np.abs(b).max())
    if backend == "pardiso":
        assert phases[:4] == [12, 33, 33, 33]  # analysis + factorisation once, then three solves
