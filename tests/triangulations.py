"""Hypothesis strategies over planar triangulations (shared by the test modules).

Every case the spline core must handle: random Delaunay meshes with holes,
L-shaped (concave) and annular domains, slivers (aspect > 100), structured,
alternating and criss-cross grids (exactly collinear edges, singular vertices),
nearly collinear perturbations of those, a lone triangle, fans of 3..12 triangles.
"""
from __future__ import annotations

import numpy as np
from hypothesis import strategies as st

from trispline.spline.testing import domains


@st.composite
def triangulations(draw, max_faces: int = 400):
    kind = draw(st.sampled_from(
        ["delaunay", "holes", "lshape", "annulus", "slivers", "grid", "alternate", "crisscross",
         "near_alternate", "lone", "fan", "open_fan"]
    ))
    seed = draw(st.integers(0, 10_000))
    if kind == "delaunay":
        uv, f = domains.random_delaunay(draw(st.integers(5, 120)), seed=seed)
    elif kind == "holes":
        uv, f = domains.random_delaunay(draw(st.integers(60, 160)), holes=draw(st.integers(1, 3)), seed=seed)
    elif kind == "lshape":
        uv, f = domains.l_shape(draw(st.integers(20, 80)), seed=seed)
    elif kind == "annulus":
        uv, f = domains.annulus(draw(st.integers(1, 4)), draw(st.integers(6, 20)))
    elif kind == "slivers":
        uv, f = domains.slivers(draw(st.integers(2, 12)), aspect=draw(st.floats(100, 1e4)))
    elif kind in ("grid", "alternate", "crisscross"):
        n = draw(st.integers(1, 7))
        diag = {"grid": "regular"}.get(kind, kind)
        uv, f = domains.grid(n, draw(st.integers(1, 7)), diagonal=diag)
    elif kind == "near_alternate":
        uv, f = domains.grid(draw(st.integers(2, 6)), diagonal="alternate")
        uv = domains.perturb(uv, f, draw(st.sampled_from([1e-7, 1e-5, 1e-3])), seed=seed)
    elif kind == "lone":
        uv, f = domains.lone_triangle()
    elif kind == "fan":
        uv, f = domains.fan(draw(st.integers(3, 12)), radius_jitter=draw(st.sampled_from([0.0, 0.4])), seed=seed)
    else:
        uv, f = domains.fan(draw(st.integers(1, 12)), closed=False)
    # A random similarity keeps every property. Grids keep their exact collinearity
    # only under exact transforms (quarter turns, powers of two, integer shifts).
    exact = kind in ("grid", "alternate", "crisscross")
    if exact:
        ang = 0.5 * np.pi * draw(st.integers(0, 3))
        R = np.round(np.array([[np.cos(ang), -np.sin(ang)], [np.sin(ang), np.cos(ang)]]))
        shift = float(draw(st.integers(-10, 10)))
    else:
        ang = draw(st.floats(0, 2 * np.pi))
        R = np.array([[np.cos(ang), -np.sin(ang)], [np.sin(ang), np.cos(ang)]])
        shift = draw(st.floats(-10, 10))
    scale = draw(st.sampled_from([2.0**-10, 1.0, 2.0**10]))
    uv = scale * uv @ R.T + shift * scale
    return kind, uv, f


@st.composite
def scan_outlines(draw, size: float = 1.0):
    """``(kind, uv (n, 2), faces (m, 3), hole_centres (h, 2))``: a scan-sized planar domain whose outline a coarse
    domain must keep: random points with 1-3 holes, a concave L, or a grid with a round hole (a staircase
    outline); ``size`` scales the vertex counts."""
    from trispline.fit.datasets.truth import HOLE_CENTRE, grid_with_hole

    kind = draw(st.sampled_from(["holes", "lshape", "grid_hole"]))
    seed = draw(st.integers(0, 10_000))
    count = lambda lo, hi: draw(st.integers(int(lo * size), int(hi * size)))  # noqa: E731
    if kind == "holes":
        uv, f = domains.random_delaunay(count(800, 2500), holes=draw(st.integers(1, 3)), seed=seed)
        return kind, uv, f, np.empty((0, 2))
    if kind == "lshape":
        uv, f = domains.l_shape(count(400, 1200), seed=seed)
        return kind, uv, f, np.empty((0, 2))
    uv, f = grid_with_hole(count(800, 3000), seed=seed)
    return kind, uv, f, HOLE_CENTRE[None]


def lifted(uv: np.ndarray, noise: float = 0.0, seed: int = 0) -> np.ndarray:
    """``(n, 3)``: a smooth bumpy surface over the planar points ``uv (n, 2)``, with Gaussian noise along z."""
    z = 0.2 * np.sin(3 * uv[:, 0]) * np.cos(2 * uv[:, 1]) + 0.1 * uv[:, 0] * uv[:, 1]
    return np.column_stack([uv, z + np.random.default_rng(seed).normal(0.0, noise, z.shape)])


#: One quick example of every kind, by name (seeded), for tests that sample names.
SMALL_DOMAINS = {
    "lone": lambda s: domains.lone_triangle(),
    "delaunay": lambda s: domains.random_delaunay(30, seed=s),
    "holes": lambda s: domains.random_delaunay(80, holes=2, seed=s),
    "lshape": lambda s: domains.l_shape(40, seed=s),
    "annulus": lambda s: domains.annulus(2, 12),
    "slivers": lambda s: domains.slivers(6, 150.0),
    "grid": lambda s: domains.grid(3, diagonal="alternate"),
    "crisscross": lambda s: domains.grid(3, diagonal="crisscross"),
    "fan": lambda s: domains.fan(3 + s % 10),
}


def grid_scan(n: int, z) -> tuple[np.ndarray, np.ndarray]:
    """An ``n x n`` grid of the unit square (two triangles a cell) with heights ``z(x, y)``: ``(V, F)``;
    ``V[:, :2]`` is its own uv."""
    x, y = (a.ravel() for a in np.meshgrid(np.linspace(0, 1, n), np.linspace(0, 1, n)))
    q = np.arange(n * n).reshape(n, n)[:-1, :-1].ravel()
    F = np.concatenate([np.column_stack([q, q + 1, q + n + 1]), np.column_stack([q, q + n + 1, q + n])])
    return np.column_stack([x, y, z(x, y)]), F
