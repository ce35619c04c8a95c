"""A terrain tile of scattered points, Delaunay-triangulated as a LiDAR tile is: its hull slivers included.

    from trispline.fit.datasets.tile import scattered_tile
    V, F = scattered_tile(50_000, seed=0)      # (n + 4, 3) float64, (nf, 3) int64

Uniform random points over a square (and its four corners), heights of two scales of waves and
a little Gaussian noise, triangulated by ``scipy.spatial.Delaunay``. No point lies on a side
but the corners, so each side is one edge of the hull closed off by long slivers
(:mod:`trispline.param.hull`), as in a real scattered-point tile.
"""
from __future__ import annotations

import numpy as np
from scipy.spatial import Delaunay

__all__ = ["TILE_SIZE", "scattered_tile", "tile_height"]

#: Side of the tile (metres, say) and its offset (``origin``: a map projection's easting and northing).
TILE_SIZE = 1000.0


def tile_height(xy: np.ndarray) -> np.ndarray:
    """``(n,)`` the noise-free terrain over ``xy (n, 2)`` in tile units: hills of 80 and ripples of 15."""
    x, y = xy[:, 0], xy[:, 1]
    return 1200.0 + 80.0 * np.sin(x / 90.0) * np.cos(y / 130.0) + 15.0 * np.sin(x / 23.0 + y / 41.0)


def scattered_tile(n_points: int, *, seed: int = 0, noise: float = 0.05,
                   origin: tuple[float, float] = (0.0, 0.0)) -> tuple[np.ndarray, np.ndarray]:
    """``(V (n_points + 4, 3), F (nf, 3))``: ``n_points`` random points of a :data:`TILE_SIZE` square
    and its corners, at :func:`tile_height` plus Gaussian ``noise``, shifted by ``origin`` in x and y;
    the faces counter-clockwise seen from +z."""
    if int(n_points) != n_points or n_points < 1:
        raise ValueError(f"n_points must be a positive integer, got {n_points}")
    rng = np.random.default_rng(seed)
    corners = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 1.0]])
    xy = np.concatenate([rng.random((int(n_points), 2)), corners]) * TILE_SIZE
    F = Delaunay(xy).simplices.astype(np.int64)
    e1, e2 = xy[F[:, 1]] - xy[F[:, 0]], xy[F[:, 2]] - xy[F[:, 0]]
    cw = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0] < 0
    F[cw] = F[cw][:, [0, 2, 1]]
    z = tile_height(xy) + rng.normal(0.0, noise, xy.shape[0])
    return np.column_stack([xy + np.asarray(origin, float), z]), F
