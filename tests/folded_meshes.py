"""Generated meshes with the defects of real scans (shared by the repair, inspect, agreement and CLI tests)."""
from __future__ import annotations

import numpy as np


def folded_grid(n: int, flaps: list[int], *, seed: int = 0) -> tuple[np.ndarray, np.ndarray, int]:
    """A bumpy ``n x n`` grid with single-face flaps glued to the bottom boundary edges ``flaps`` and
    folded back over the surface (each flap's normal about opposite its neighbour's), and one
    two-face flap on the top edge. Returns ``(V, F, nf_clean)``: the grid's faces come first."""
    rng = np.random.default_rng(seed)
    x, y = np.meshgrid(np.linspace(0, 1, n), np.linspace(0, 1, n))
    V = np.column_stack([x.ravel(), y.ravel(), 0.05 * np.sin(3 * x.ravel()) * np.cos(2 * y.ravel())])
    i, j = np.meshgrid(np.arange(n - 1), np.arange(n - 1))
    a = (j * n + i).ravel()
    F = np.vstack([np.column_stack([a, a + 1, a + n + 1]), np.column_stack([a, a + n + 1, a + n])])
    nf = F.shape[0]
    extra_v, extra_f = [], []
    for k in flaps:  # bottom edge (k, k + 1), the grid's face (k, k + 1, k + n + 1) above it
        p = V[k + n] * [1, 1, 0] + [0.3 / n, 0.0, 0.01 + 0.01 * rng.random()]
        extra_f.append([k + 1, k, V.shape[0] + len(extra_v)])
        extra_v.append(p)
    t = n * (n - 1) + n // 2  # top edge (t, t + 1): a flap of two faces folded down over the grid
    q = V.shape[0] + len(extra_v)
    extra_v += [V[t - n] + [0.0, 0.0, 0.01], V[t - n + 1] + [0.0, 0.0, 0.01]]
    extra_f += [[t, t + 1, q], [q, t + 1, q + 1]]
    return np.vstack([V, extra_v]), np.vstack([F, extra_f]).astype(np.int64), nf


def rough_holey_grid(n: int, *, roughness: float = 0.5, drop: float = 0.1,
                     seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """A jittered ``n x n`` grid over a smooth bump whose heights carry noise of ``roughness`` edge
    lengths (standard deviation), with a share ``drop`` of its faces removed at random (many small
    holes, most vertices on an outline), like a rough registered scan. Returns ``(V, F)``,
    not yet repaired (the holes leave bowtie vertices)."""
    rng = np.random.default_rng(seed)
    h = 1.0 / (n - 1)
    x, y = np.meshgrid(np.linspace(0, 1, n), np.linspace(0, 1, n))
    x = x + 0.1 * h * rng.normal(size=x.shape)
    y = y + 0.1 * h * rng.normal(size=y.shape)
    z = 0.3 * np.sin(3 * x) * np.cos(2 * y) + roughness * h * rng.normal(size=x.shape)
    i, j = np.meshgrid(np.arange(n - 1), np.arange(n - 1))
    a = (j * n + i).ravel()
    F = np.vstack([np.column_stack([a, a + 1, a + n + 1]), np.column_stack([a, a + n + 1, a + n])])
    return np.column_stack([x.ravel(), y.ravel(), z.ravel()]), F[rng.random(F.shape[0]) >= drop]
