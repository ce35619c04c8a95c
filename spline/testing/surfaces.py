"""Exactly C1 spline surfaces to test with (exports, CAD, pictures, the command line)."""
from __future__ import annotations

import numpy as np

from ..polynomial import polynomial_control_net
from ..propagation import build_space
from ..surface import SplineSurface
from .domains import random_delaunay


def random_c1_surface(n: int = 40, holes: int = 1, seed: int = 0, wiggle: float = 2e-3,
                      graph: tuple[float, float, float] = (0.3, -0.2, 0.1)) -> SplineSurface:
    """An exactly C1 surface over a random Delaunay domain of ``n`` points with ``holes`` holes.

    The net of the polynomial graph ``(u, v, a u^2 + b u v + c v^3)`` with ``(a, b, c) = graph``,
    its free points then perturbed by ``wiggle`` (seeded; still exactly C1, no longer polynomial).
    """
    a, b, c = graph
    uv, faces = random_delaunay(n, holes=holes, seed=seed)
    space = build_space(uv, faces)
    ctrl0 = polynomial_control_net(
        uv, faces, lambda p: np.column_stack([p[:, 0], p[:, 1], a * p[:, 0] ** 2 + b * p[:, 0] * p[:, 1]
                                              + c * p[:, 1] ** 3]))
    points = np.zeros((space.n_points, 3))
    points[space.point_index] = ctrl0
    rng = np.random.default_rng(seed)
    free = space.free_from_points(points) + wiggle * rng.normal(size=(space.n_free, 3))
    return SplineSurface(uv, faces, space.control_points(free))
