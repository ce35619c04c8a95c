"""Data-dependent edge flips of a coarse triangulation (fit.approx.flips)."""
from __future__ import annotations

import numpy as np
import pytest

from trispline.fit.approx import coarse_domain
from trispline.fit.approx.flips import FLIP_MIN_ANGLE, _sq_error, flip_to_data
from trispline.fit.approx.locate import ClampedLocator
from trispline.fit.approx.quality import face_angles
from trispline.spline.testing import domains
from trispline.spline.topology import Triangulation, signed_areas


def _edges(faces: np.ndarray) -> set:
    e = np.sort(np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]]), axis=1)
    return set(map(tuple, e))


def _boundary_edges(faces: np.ndarray) -> set:
    e = np.sort(np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]]), axis=1)
    u, c = np.unique(e, axis=0, return_counts=True)
    return set(map(tuple, u[c == 1]))


def _pl_sse(uv, faces, X, q, P) -> float:
    hit = ClampedLocator(uv, faces.copy())(q)
    inside = ~hit.clamped
    return float(_sq_error(P[inside], X, faces[hit.face[inside]], hit.bary[inside]).sum())


def _crease(p: np.ndarray, direction: np.ndarray) -> np.ndarray:
    """A folded sheet over uv ``p (m, 2)``: a ridge of turn 90 degrees along ``direction`` through (0.5, 0.5)."""
    n = np.array([-direction[1], direction[0]]) / np.linalg.norm(direction)
    return np.column_stack([p, 0.5 * np.abs((p - 0.5) @ n)])


@pytest.mark.parametrize("angle", [20.0, 35.0, 60.0, 110.0])
def test_flips_follow_a_crease_and_keep_the_triangulation_valid(angle):
    rng = np.random.default_rng(int(angle))
    uv, faces = domains.random_delaunay(150, holes=1, seed=int(angle))
    direction = np.array([np.cos(np.radians(angle)), np.sin(np.radians(angle))])
    lo, hi = uv.min(0), uv.max(0)
    q = lo + rng.random((20_000, 2)) * (hi - lo)
    unit = lambda p: (p - lo) / (hi - lo)  # noqa: E731
    X, P = _crease(unit(uv), direction), _crease(unit(q), direction)
    out = flip_to_data(uv, faces, X, q, P)
    assert out.shape == faces.shape and not np.array_equal(np.sort(out, 1), np.sort(faces, 1))
    Triangulation(uv, out)  # valid: manifold, every vertex used
    assert (signed_areas(uv, out) > 0).all()
    assert _boundary_edges(out) == _boundary_edges(faces)  # the constrained segments never flip
    new = np.array([f for f in map(tuple, out) if not ({tuple(sorted(e)) for e in
                                                        ((f[0], f[1]), (f[1], f[2]), (f[2], f[0]))} <= _edges(faces))])
    assert face_angles(uv, new).min() >= FLIP_MIN_ANGLE - 1e-9
    assert _pl_sse(uv, out, X, q, P) < 0.8 * _pl_sse(uv, faces, X, q, P)


def test_linear_data_and_zero_sweeps_flip_nothing():
    uv, faces = domains.random_delaunay(200, holes=2, seed=3)
    q = uv[faces].mean(1)
    lift = lambda p: np.column_stack([p, 0.3 * p[:, 0] - 0.7 * p[:, 1]])  # noqa: E731
    np.testing.assert_array_equal(flip_to_data(uv, faces, lift(uv), q, lift(q)), faces)
    X, P = _crease(uv, np.array([1.0, 1.0])), _crease(q, np.array([1.0, 1.0]))
    np.testing.assert_array_equal(flip_to_data(uv, faces, X, q, P, sweeps=0), faces)


def test_coarse_domain_of_a_folded_scan_puts_edges_along_the_fold():
    uv, F = domains.random_delaunay(4000, holes=0, seed=5)
    lo, hi = uv.min(0), uv.max(0)
    V = _crease((uv - lo) / (hi - lo), np.array([1.0, 0.3]))
    import trispline.fit.approx.flips as fl

    dom = coarse_domain(V, F, uv, n_vertices=120)
    sweeps, fl.FLIP_SWEEPS = fl.FLIP_SWEEPS, 0
    try:
        plain = coarse_domain(V, F, uv, n_vertices=120)
    finally:
        fl.FLIP_SWEEPS = sweeps
    np.testing.assert_array_equal(dom.vertices, plain.vertices)  # the flips change the edges only
    X = V[dom.vertices]
    assert _pl_sse(dom.uv, dom.faces, X, uv, V) < 0.9 * _pl_sse(plain.uv, plain.faces, X, uv, V)


def test_noise_share_tells_noise_from_model_error():
    """The calm-vertex preferences are for noise: weighed ~1 on a noisy scan, ~0 on clean or creased data."""
    from trispline.fit.approx import analyse_scan
    from trispline.fit.datasets.truth import truth_scan

    noisy = truth_scan("bumps", 20_000, sigma=1e-3, seed=4)
    assert analyse_scan(noisy.V, noisy.F, noisy.params).noise_share > 0.5
    clean = truth_scan("bumps", 20_000, sigma=0.0, seed=4)
    assert analyse_scan(clean.V, clean.F, clean.params).noise_share < 0.2
    uv, F = domains.random_delaunay(6000, holes=1, seed=2)
    V = _crease(uv, np.array([1.0, 0.4]))
    assert analyse_scan(V, F, uv).noise_share < 0.2


@pytest.mark.parametrize("n", [2_500, 20_000])
def test_noise_correlation_tells_noise_from_model_error(n):
    """Noise is independent vertex to vertex, a local quadric's model error is not: the residuals of
    neighbours correlate only on clean data, at any density (where the share of the noise
    estimates fails on a coarse noisy scan: 0.06 at 2,500 vertices)."""
    from trispline.fit.approx import analyse_scan
    from trispline.fit.datasets.truth import truth_scan

    noisy = truth_scan("bumps", n, sigma=1e-3, outliers=0.005, seed=4)
    assert analyse_scan(noisy.V, noisy.F, noisy.params).noise_correlation < 0.05
    clean = truth_scan("bumps", n, sigma=0.0, seed=4)
    assert analyse_scan(clean.V, clean.F, clean.params).noise_correlation > 0.2
