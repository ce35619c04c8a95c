"""A local fit tries only kernels whose polynomial part its points determine.

Points on three lines (a strip three vertices wide) leave a cubic that vanishes on all of them: an
interpolant with a cubic polynomial part may add any multiple of it. In exact uv the system is singular
and the kernel was passed over; in a map's uv, a hair off the lines, it was solved, and the strip's fit
came out with gradients 3e4 times the data's and a surface 6.7 bounding-box diagonals outside the scan.
"""
from __future__ import annotations

import jax
import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

jax.config.update("jax_enable_x64", True)

from trispline.fit import fit_surface  # noqa: E402
from trispline.fit.reach import surface_reach  # noqa: E402
from trispline.fit.targets import UNISOLVENT_RTOL, _monomial_gram, _monomials, _unisolvent, local_rbf_fit  # noqa: E402


def _gram(X: np.ndarray) -> np.ndarray:
    """The scaled Gram matrix ``(1, 10, 10)`` of the cubic monomials of points ``X (k, 2)``."""
    return _monomial_gram(_monomials(X[None, :, 0], X[None, :, 1], 3))


def _rows(n_rows: int, per_row: int = 9, tilt: float = 0.0) -> np.ndarray:
    u, v = np.meshgrid(np.arange(per_row) - per_row // 2, np.arange(n_rows) - n_rows // 2)
    a = np.radians(tilt)
    return np.column_stack([u.ravel(), v.ravel()]) @ np.array([[np.cos(a), np.sin(a)], [-np.sin(a), np.cos(a)]])


@pytest.mark.parametrize("tilt", [0.0, 0.29, 17.0])
def test_points_on_three_lines_determine_a_quadratic_but_not_a_cubic(tilt):
    G = _gram(_rows(3, tilt=tilt))
    assert _unisolvent(G[:, :6, :6]).all() and _unisolvent(G[:, :3, :3]).all()
    assert not _unisolvent(G).any()
    assert _unisolvent(_gram(_rows(4, tilt=tilt))).all()  # a fourth line: no cubic vanishes on all


@given(seed=st.integers(0, 2**16))
def test_scattered_points_determine_a_cubic(seed):
    X = np.random.default_rng(seed).uniform(-3.0, 3.0, (33, 2))
    G = _gram(X)
    assert _unisolvent(G).all() and np.linalg.eigvalsh(G[0])[0] > UNISOLVENT_RTOL


def test_a_batch_with_one_degenerate_neighbourhood_judges_each_on_its_own():
    G = np.concatenate([_gram(_rows(4)), _gram(_rows(3, tilt=0.29)), _gram(_rows(5))])
    assert _unisolvent(G).tolist() == [True, False, True]


def _strip(tilt_degrees: float = 0.29) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A wavy strip 100 x 0.5 on a grid three vertices wide, and its uv turned a little (as a map leaves it)."""
    x, y = np.meshgrid(np.linspace(0.0, 100.0, 400), np.linspace(0.0, 0.5, 3))
    V = np.column_stack([x.ravel(), y.ravel(), 0.1 * np.sin(x.ravel())])
    i = np.arange(399)
    a, b, c, d = i, i + 1, i + 401, i + 400
    F = np.concatenate([np.column_stack([a, b, c]), np.column_stack([a, c, d]),
                        np.column_stack([a, b, c]) + 400, np.column_stack([a, c, d]) + 400])
    t = np.radians(tilt_degrees)
    uv = V[:, :2] @ np.array([[np.cos(t), np.sin(t)], [-np.sin(t), np.cos(t)]])
    return V, F, uv


def test_a_strip_three_vertices_wide_gets_the_gradients_of_its_data():
    V, F, uv = _strip()
    fit = local_rbf_fit(uv, V, F, outline_fits=True)
    assert np.abs(fit.grad).max() < 1.5  # |d(x, y, z) / d(u, v)| <= 1 on the strip (an isometric uv)
    res = fit_surface(V, F, uv=uv)
    assert surface_reach(np.asarray(res.surface.ctrl), V, 0.1) < 0.01
    assert res.c1_residual < 1e-12
