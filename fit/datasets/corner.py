"""A CAD-like scan with sharp creases: three faces of a cube meeting at a corner.

    from trispline.fit.datasets.corner import cube_corner
    V, F = cube_corner(20)      # (3 n^2 + 3 n + 1, 3) float64, (6 n^2, 3) int64

The faces ``x = 0``, ``y = 0`` and ``z = 0`` of the unit cube, each an ``n x n`` grid of squares cut
into two triangles, sharing the grid points of the three edges where they meet: an open disk whose
three creases turn by 90 degrees and meet at the corner (0, 0, 0). A C1 surface can only round such
a crease, over the patches beside it (docs/approximate.md, "Sharp creases").
"""
from __future__ import annotations

import numpy as np

__all__ = ["cube_corner"]


def cube_corner(n: int) -> tuple[np.ndarray, np.ndarray]:
    """``(V, F)``: the three grids of ``n x n`` squares (``n >= 1``), consistently oriented."""
    t = np.linspace(0.0, 1.0, n + 1)
    a, b = (g.ravel() for g in np.meshgrid(t, t, indexing="ij"))
    zero = np.zeros_like(a)
    pts = np.concatenate([np.column_stack([zero, a, b]), np.column_stack([a, zero, b]), np.column_stack([a, b, zero])])
    grid, index = np.unique(np.rint(pts * n).astype(np.int64), axis=0, return_inverse=True)  # shared edge points once
    ids = np.arange((n + 1) ** 2).reshape(n + 1, n + 1)
    quad = np.column_stack([ids[:-1, :-1].ravel(), ids[1:, :-1].ravel(), ids[1:, 1:].ravel(), ids[:-1, 1:].ravel()])
    tri = np.concatenate([quad[:, [0, 1, 2]], quad[:, [0, 2, 3]]])
    flip = (True, False, True)  # the grids of x = 0 and z = 0 run the other way round: every normal points out
    F = np.concatenate([index.ravel()[(tri[:, ::-1] if f else tri) + k * a.size] for k, f in enumerate(flip)])
    return grid / n, F.astype(np.int64)
