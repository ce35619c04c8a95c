"""Exact control nets of global polynomials (the reproduction oracle)."""
from __future__ import annotations

from math import factorial

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from trispline.spline.testing import domains
from trispline.spline.index import EXPONENTS
from trispline.spline.bernstein import basis
from trispline.spline.errors import InputError
from trispline.spline.polynomial import polynomial_control_net, random_polynomial
from triangulations import SMALL_DOMAINS

DOMAINS = {name: make for name, make in SMALL_DOMAINS.items() if name != "grid"}


def _naive_eval(ctrl_f: np.ndarray, bary: np.ndarray) -> np.ndarray:
    """Factorial-formula Bernstein sum for one patch: (21, d), (n, 3) -> (n, d)."""
    out = np.zeros((bary.shape[0], ctrl_f.shape[1]))
    for n, (i, j, k) in enumerate(EXPONENTS):
        c = factorial(5) / (factorial(i) * factorial(j) * factorial(k))
        out += (c * bary[:, 0] ** i * bary[:, 1] ** j * bary[:, 2] ** k)[:, None] * ctrl_f[n]
    return out


def _random_bary(rng, n):
    b = rng.dirichlet(np.ones(3), n)
    return b


@settings(max_examples=25, deadline=None)
@given(name=st.sampled_from(sorted(DOMAINS)), seed=st.integers(0, 1000), degree=st.integers(0, 5))
def test_net_reproduces_polynomial(name, seed, degree):
    uv, faces = DOMAINS[name](seed)
    func = random_polynomial(degree, 3, seed)
    ctrl = polynomial_control_net(uv, faces, func)
    assert ctrl.shape == (faces.shape[0], 21, 3)
    rng = np.random.default_rng(seed)
    nf = faces.shape[0]
    fidx = rng.integers(0, nf, 200)
    bary = _random_bary(rng, 200)
    vals = np.einsum("nk,nkd->nd", basis(bary), ctrl[fidx])
    pts = np.einsum("nk,nkc->nc", bary, uv[faces[fidx]])
    ref = func(pts)
    scale = np.abs(func(uv)).max() + 1.0
    np.testing.assert_allclose(vals, ref, rtol=0, atol=1e-12 * scale)


def test_net_matches_naive_oracle_on_lone_triangle():
    uv, faces = domains.lone_triangle()
    func = random_polynomial(5, 2, 7)
    ctrl = polynomial_control_net(uv, faces, func)
    bary = _random_bary(np.random.default_rng(1), 50)
    pts = bary @ uv[faces[0]]
    np.testing.assert_allclose(_naive_eval(ctrl[0], bary), func(pts), atol=1e-12)


def test_linear_function_net_is_domain_points():
    """For f(u, v) = (u, v) the net is the domain points (i a + j b + k c) / 5."""
    uv, faces = domains.random_delaunay(20, seed=3)
    ctrl = polynomial_control_net(uv, faces, lambda p: p)
    ex = EXPONENTS / 5.0
    expect = np.einsum("gk,fkc->fgc", ex, uv[faces])
    np.testing.assert_allclose(ctrl, expect, atol=1e-14)


def test_scalar_func_gives_d1():
    uv, faces = domains.grid(2)
    ctrl = polynomial_control_net(uv, faces, lambda p: p[:, 0] * p[:, 1])
    assert ctrl.shape == (faces.shape[0], 21, 1)


def test_degree_six_is_not_reproduced():
    """Negative control: a sextic is not a quintic, so the net cannot reproduce it."""
    uv, faces = domains.lone_triangle()
    f = lambda p: (p[:, 0] ** 6)[:, None]  # noqa: E731
    ctrl = polynomial_control_net(uv, faces, f)
    bary = _random_bary(np.random.default_rng(0), 100)
    err = np.abs(basis(bary) @ ctrl[0] - f(bary @ uv[faces[0]])).max()
    assert err > 1e-6


def test_polynomial_gradient_matches_finite_differences():
    func = random_polynomial(5, 3, 11)
    p = np.random.default_rng(0).uniform(0, 1, (20, 2))
    h = 1e-6
    gu, gv = func.gradient(p)
    fdu = (func(p + [h, 0]) - func(p - [h, 0])) / (2 * h)
    fdv = (func(p + [0, h]) - func(p - [0, h])) / (2 * h)
    np.testing.assert_allclose(gu, fdu, atol=1e-6)
    np.testing.assert_allclose(gv, fdv, atol=1e-6)


def test_bad_func_output_raises():
    uv, faces = domains.lone_triangle()
    with pytest.raises(InputError, match="func must map"):
        polynomial_control_net(uv, faces, lambda p: np.zeros((3, 3)))
    with pytest.raises(InputError, match="uv must have shape"):
        polynomial_control_net(uv[:, :1], faces, lambda p: p)
    with pytest.raises(InputError, match="degree"):
        random_polynomial(-1)
