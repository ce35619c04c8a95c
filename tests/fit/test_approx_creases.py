"""Thin strips of coarse patches along a clean scan's creases (fit.approx.creases)."""
from __future__ import annotations

import numpy as np
from scipy.spatial import Delaunay

from trispline.fit.approx import coarse_domain, fit_domain, surface_deviation
from trispline.fit.approx.creases import crease_chains, crease_edges
from trispline.spline.topology import signed_areas


def _folded(n: int, seed: int, noise: float = 0.0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A unit square folded along the line through (0.5, 0.5) in direction (1, 0.3) (turn about 53
    degrees), its Delaunay mesh with vertices along the fold (as a CAD-like scan has edges there):
    ``(V (n', 3), F, uv)``, Gaussian noise along z."""
    rng = np.random.default_rng(seed)
    d = np.array([1.0, 0.3]) / np.linalg.norm([1.0, 0.3])
    h = 1.0 / np.sqrt(n)
    t = np.arange(-0.75, 0.75, h)
    line = 0.5 + t[:, None] * d
    line = line[(line > h).all(1) & (line < 1 - h).all(1)]
    s = np.arange(0.0, 1.0, h)
    edge = np.concatenate([np.column_stack([s, 0 * s]), np.column_stack([1 + 0 * s, s]),
                           np.column_stack([1 - s, 1 + 0 * s]), np.column_stack([0 * s, 1 - s])])
    inner = h + rng.random((n, 2)) * (1 - 2 * h)
    inner = inner[np.abs((inner - 0.5) @ np.array([-d[1], d[0]])) > 0.5 * h]
    uv = np.concatenate([edge, line, inner])
    F = Delaunay(uv).simplices.astype(np.int64)
    F[signed_areas(uv, F) < 0] = F[signed_areas(uv, F) < 0][:, [0, 2, 1]]
    z = 0.5 * np.abs((uv - 0.5) @ np.array([-d[1], d[0]]))
    return np.column_stack([uv, z + rng.normal(0.0, noise, z.shape)]), F, uv


def test_chains_split_at_junctions_and_close_loops():
    edges = np.array([[0, 1], [1, 2], [2, 3], [2, 4], [5, 6], [6, 7], [5, 7]])
    chains = sorted(map(tuple, crease_chains(edges, 8)))
    assert chains == [(0, 1, 2), (2, 3), (2, 4), (5, 6, 7, 5)]
    assert crease_chains(np.empty((0, 2), np.int64), 3) == []


def test_strips_along_a_fold_lower_the_deviation_at_the_fold():
    V, F, uv = _folded(6000, seed=5)
    fold = np.zeros(V.shape[0], bool)
    fold[crease_edges(V, F).ravel()] = True
    assert 0 < fold.mean() < 0.1
    new = coarse_domain(V, F, uv, n_vertices=120)
    old = coarse_domain(V, F, uv, n_vertices=120, creases=False)
    assert new.creases.shape[0] >= 4 and old.creases.shape[0] == 0
    assert new.stats.n_vertices <= 120
    strip = np.isin(new.vertices, new.creases)
    assert not fold[new.vertices[strip]].any()  # the sides are off the fold
    edges = {tuple(sorted(e)) for f in new.faces for e in ((f[0], f[1]), (f[1], f[2]), (f[2], f[0]))}
    local = {int(s): i for i, s in enumerate(new.vertices)}
    assert all(tuple(sorted((local[a], local[b]))) in edges for a, b in new.creases)  # the segments are edges
    rms = {}
    for name, dom in (("new", new), ("old", old)):
        fit = fit_domain(dom, V, loss="l2", corners="data", gauss_newton=False)
        d = surface_deviation(fit.surface, V).distance
        rms[name] = float(np.sqrt(np.mean(d[fold] ** 2)))
    assert rms["new"] < 0.7 * rms["old"]  # 0.56-0.58 (seeds 5, 7, 9)


def test_no_strips_on_a_noisy_scan():
    V, F, uv = _folded(6000, seed=6, noise=3e-3)
    assert coarse_domain(V, F, uv, n_vertices=120).creases.shape[0] == 0
