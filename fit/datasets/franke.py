"""Scattered-data test functions on the unit square (Franke 1982; Renka & Brown 1999).

``F1`` .. ``F6`` are Franke's six functions (exponential, cliff, saddle, gentle,
steep, sphere); ``F7`` .. ``F10`` complete the Renka--Brown set of ACM Algorithm 792
(trig, Gaussian, cloverleaf, cosine peak). Each takes ``x, y`` arrays of any
(broadcastable) shape and returns values of that shape.
"""
from __future__ import annotations

from typing import Callable

import numpy as np


def exponential(x, y):
    """F1, Franke's exponential: two peaks and a dip."""
    x, y = np.asarray(x, float), np.asarray(y, float)
    return (
        0.75 * np.exp(-((9 * x - 2) ** 2 + (9 * y - 2) ** 2) / 4)
        + 0.75 * np.exp(-((9 * x + 1) ** 2) / 49 - (9 * y + 1) / 10)
        + 0.5 * np.exp(-((9 * x - 7) ** 2 + (9 * y - 3) ** 2) / 4)
        - 0.2 * np.exp(-((9 * x - 4) ** 2) - (9 * y - 7) ** 2)
    )


def cliff(x, y):
    """F2: a smoothed step along the diagonal."""
    return (np.tanh(9 * np.asarray(y, float) - 9 * np.asarray(x, float)) + 1) / 9


def saddle(x, y):
    """F3."""
    x, y = np.asarray(x, float), np.asarray(y, float)
    return (1.25 + np.cos(5.4 * y)) / (6 * (1 + (3 * x - 1) ** 2))


def gentle(x, y):
    """F4: a wide Gaussian bump."""
    x, y = np.asarray(x, float), np.asarray(y, float)
    return np.exp(-81 / 16 * ((x - 0.5) ** 2 + (y - 0.5) ** 2)) / 3


def steep(x, y):
    """F5: a narrow Gaussian bump."""
    x, y = np.asarray(x, float), np.asarray(y, float)
    return np.exp(-81 / 4 * ((x - 0.5) ** 2 + (y - 0.5) ** 2)) / 3


def sphere(x, y):
    """F6: a spherical cap."""
    x, y = np.asarray(x, float), np.asarray(y, float)
    return np.sqrt(64 - 81 * ((x - 0.5) ** 2 + (y - 0.5) ** 2)) / 9 - 0.5


def trig(x, y):
    """F7: oscillating trigonometric surface."""
    x, y = np.asarray(x, float), np.asarray(y, float)
    return 2 * np.cos(10 * x) * np.sin(10 * y) + np.sin(10 * x * y)


def gaussian(x, y):
    """F8: two Gaussian ridges and their product."""
    x, y = np.asarray(x, float), np.asarray(y, float)
    gx = np.exp(-((5 - 10 * x) ** 2) / 2)
    gy = np.exp(-((5 - 10 * y) ** 2) / 2)
    return gx + 0.75 * gy + 0.75 * gx * gy


def cloverleaf(x, y):
    """F9: Renka--Brown's asymmetric cloverleaf."""
    x, y = np.asarray(x, float), np.asarray(y, float)
    t1 = np.exp((10 - 20 * x) / 3)
    t2 = np.exp((10 - 20 * y) / 3)
    t3 = 1 / (1 + t1)
    t4 = 1 / (1 + t2)
    return ((20 / 3) ** 3 * t1 * t2) ** 2 * (t3 * t4) ** 5 * (t1 - 2 * t3) * (t2 - 2 * t4)


def cosine_peak(x, y):
    """F10: a damped cosine with a cone point at the centre."""
    x, y = np.asarray(x, float), np.asarray(y, float)
    d = np.sqrt((80 * x - 40) ** 2 + (90 * y - 45) ** 2)
    return np.exp(-0.04 * d) * np.cos(0.15 * d)


#: Franke's six functions, by name.
FRANKE: dict[str, Callable] = {
    "exponential": exponential,
    "cliff": cliff,
    "saddle": saddle,
    "gentle": gentle,
    "steep": steep,
    "sphere": sphere,
}

#: The Renka--Brown set: Franke's six plus four.
RENKA_BROWN: dict[str, Callable] = {
    **FRANKE,
    "trig": trig,
    "gaussian": gaussian,
    "cloverleaf": cloverleaf,
    "cosine_peak": cosine_peak,
}


def sample_points(n: int, *, seed: int = 0, boundary_fraction: float | None = None) -> np.ndarray:
    """``n`` points in the unit square: the four corners, points on the sides, the rest random.

    About ``4 sqrt(n)`` points go on the boundary (spaced like the interior points),
    so a Delaunay triangulation covers the whole square without long thin rims.

    Returns
    -------
    (n, 2) float64
    """
    if n < 8:
        raise ValueError(f"need at least 8 points, got {n}")
    rng = np.random.default_rng(seed)
    nb = int(round(4 * np.sqrt(n))) if boundary_fraction is None else int(round(boundary_fraction * n))
    nb = max(min(nb, n - 4), 4)
    per_side = nb // 4
    sides = []
    for s in range(4):
        t = np.sort(rng.uniform(0.02, 0.98, per_side))
        t = (t + np.linspace(0, 1, per_side, endpoint=False) + 0.5 / per_side) / 2  # jittered
        if s == 0:
            sides.append(np.column_stack([t, np.zeros_like(t)]))
        elif s == 1:
            sides.append(np.column_stack([np.ones_like(t), t]))
        elif s == 2:
            sides.append(np.column_stack([t, np.ones_like(t)]))
        else:
            sides.append(np.column_stack([np.zeros_like(t), t]))
    corners = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    bnd = np.concatenate([corners] + sides)
    inner = rng.uniform(0.0, 1.0, (n - len(bnd), 2))
    return np.concatenate([bnd, inner])
