"""Generated open 3D meshes for tests, examples and benchmarks (not part of the public ``trispline.param`` API)."""
from __future__ import annotations

from collections.abc import Callable

import numpy as np
from scipy.spatial import Delaunay

from trispline.spline.testing.domains import orient_ccw


def bumps(xy: np.ndarray) -> np.ndarray:
    """A smooth height ``(n,)`` over the plane: waves plus a Gaussian bump."""
    x, y = xy[:, 0], xy[:, 1]
    return 0.25 * np.sin(3.0 * x) * np.cos(2.0 * y) + 0.4 * np.exp(-4.0 * ((x - 0.3) ** 2 + y ** 2))


def lift(uv: np.ndarray, faces: np.ndarray,
         height: Callable[[np.ndarray], np.ndarray] = bumps) -> tuple[np.ndarray, np.ndarray]:
    """3D mesh ``(V (nv, 3), F (nf, 3))`` over a planar triangulation: ``z = height(uv)``."""
    uv = np.asarray(uv, dtype=np.float64)
    return np.column_stack([uv, height(uv)]), np.asarray(faces, dtype=np.int64).copy()


def polar_disk(n_rings: int, *, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Planar unit disk: a centre and ``n_rings`` rings of ``6 i`` points (radius
    ``i / n_rings``, jittered angles), Delaunay-triangulated: about ``6 n_rings^2`` faces."""
    rng = np.random.default_rng(seed)
    i = np.arange(1, n_rings + 1)
    counts = 6 * i
    ring = np.repeat(i, counts)
    k = np.arange(counts.sum()) - np.repeat(np.cumsum(counts) - counts, counts)
    offset = rng.uniform(0, 2 * np.pi, n_rings)
    jitter = np.where(ring < n_rings, rng.uniform(-0.2, 0.2, ring.size), 0.0)
    ang = (k + jitter) * 2 * np.pi / np.repeat(counts, counts) + offset[ring - 1]
    r = ring / n_rings
    uv = np.concatenate([[[0.0, 0.0]], np.column_stack([r * np.cos(ang), r * np.sin(ang)])])
    faces = Delaunay(uv).simplices.astype(np.int64)
    return uv, orient_ccw(uv, faces)


def bumpy_disk(n_faces: int, *, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Open 3D disk with about ``n_faces`` faces: :func:`polar_disk` lifted by :func:`bumps`."""
    n_rings = max(2, int(round(np.sqrt(n_faces / 6.0))))
    return lift(*polar_disk(n_rings, seed=seed))


def nearly_closed(n_points: int = 2000, *, opening: float = 0.35, holes: int = 2,
                  seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """A unit sphere of ``n_points`` jittered Fibonacci points, opened by a cap of angular radius
    ``opening`` (radians) around +z and ``holes`` small holes elsewhere: an open disk with holes
    whose conformal map shrinks the far side by orders of magnitude (like a nearly closed scan).

    Returns ``(V (nv, 3), F (nf, 3))``, unreferenced vertices dropped, outward-facing faces.
    """
    from scipy.spatial import ConvexHull

    rng = np.random.default_rng(seed)
    k = np.arange(n_points) + 0.5
    z = 1.0 - 2.0 * k / n_points
    phi = np.pi * (1.0 + 5.0 ** 0.5) * k + rng.uniform(-0.3, 0.3, n_points) / np.sqrt(n_points)
    r = np.sqrt(1.0 - z ** 2)
    P = np.column_stack([r * np.cos(phi), r * np.sin(phi), z])
    P /= np.linalg.norm(P, axis=1, keepdims=True)
    hull = ConvexHull(P)
    F = hull.simplices.astype(np.int64)
    flip = (np.cross(P[F[:, 1]] - P[F[:, 0]], P[F[:, 2]] - P[F[:, 0]]) * P[F].mean(1)).sum(1) < 0
    F[flip] = F[flip][:, [0, 2, 1]]
    c = P[F].mean(1)
    c /= np.linalg.norm(c, axis=1, keepdims=True)
    drop = c[:, 2] > np.cos(opening)
    for h in range(holes):  # small holes on a ring below the equator
        a = 2 * np.pi * h / max(holes, 1)
        centre = np.array([0.8 * np.cos(a), 0.8 * np.sin(a), -0.6])
        drop |= np.linalg.norm(c - centre / np.linalg.norm(centre), axis=1) < 2.5 / np.sqrt(n_points)
    F = F[~drop]
    used, inv = np.unique(F, return_inverse=True)
    return P[used], inv.reshape(-1, 3).astype(np.int64)
