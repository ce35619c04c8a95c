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


def helicoid_strip(turns: float = 3.0, n_around: int = 200, n_across: int = 6, *, pitch: float = 0.1
                   ) -> tuple[np.ndarray, np.ndarray]:
    """A narrow helicoidal ramp (radius 1 to 1.3) of ``turns`` turns, a grid of ``n_around x n_across``
    vertices: a valid disk whose conformal (LSCM) map winds around its centre once per turn and so
    covers part of the plane several times, as does its ``(x, y)``."""
    t = np.linspace(0.0, 2 * np.pi * turns, n_around)
    w = np.linspace(0.0, 0.3, n_across)
    T, W = np.meshgrid(t, w, indexing="ij")
    V = np.column_stack([((1 + W) * np.cos(T)).ravel(), ((1 + W) * np.sin(T)).ravel(), (pitch * T).ravel()])
    idx = np.arange(n_around * n_across).reshape(n_around, n_across)
    a, b, c, d = idx[:-1, :-1].ravel(), idx[1:, :-1].ravel(), idx[1:, 1:].ravel(), idx[:-1, 1:].ravel()
    return V, np.concatenate([np.column_stack([a, b, c]), np.column_stack([a, c, d])])


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


def broken_scan(n_faces: int = 300, *, seed: int = 0) -> tuple[np.ndarray, np.ndarray, dict[str, int]]:
    """A scan with everything :func:`~trispline.param.repair_mesh` repairs, around one good disk.

    The disk is :func:`bumpy_disk` (its faces come first, its vertices keep their ids); glued
    to it: three small disks each sharing one boundary vertex (bowties), a fin of two faces
    on one interior edge (a non-manifold edge), two duplicate faces and one reversed
    duplicate, a zero-area face on a boundary edge, and a separate small disk.

    Returns ``(V, F, expected)``: ``expected`` holds the disk's ``faces`` and ``vertices``
    and the counts ``bowtie_vertices``, ``duplicate_faces``, ``zero_area_faces``.
    """
    from .validate import validate_mesh

    V0, F0 = bumpy_disk(n_faces, seed=seed)
    loop = validate_mesh(V0, F0).boundary_loops[0]
    Vs, Fs, nv = [V0], [F0], V0.shape[0]
    for k in range(3):  # small disks touching the big one at one boundary vertex each
        V1, F1 = bumpy_disk(40, seed=seed + k + 1)
        b1 = validate_mesh(V1, F1).boundary_loops[0][0]
        target = loop[k * len(loop) // 3]
        V1 = (V1 - V1[b1]) * 0.3 + V0[target]
        keep = np.arange(len(V1)) != b1
        remap = np.full(len(V1), -1)
        remap[keep] = nv + np.arange(keep.sum())
        remap[b1] = target
        Vs.append(V1[keep])
        Fs.append(remap[F1])
        nv += int(keep.sum())
    V, F = np.concatenate(Vs), np.concatenate(Fs)
    interior = np.flatnonzero(~np.isin(F0, loop).any(1))[0]
    a, b = F0[interior, 0], F0[interior, 1]
    mid = 0.5 * (V[a] + V[b])
    V = np.vstack([V, mid + [0.0, 0.0, 0.5], mid + [0.1, 0.0, 0.6]])
    F = np.vstack([F, [[a, b, nv], [b, nv + 1, nv]]])  # the fin
    F = np.vstack([F, F0[[5, 6]], F0[[7]][:, [0, 2, 1]]])  # duplicates, one reversed
    p, q = loop[1], loop[2]
    V = np.vstack([V, 0.5 * (V[p] + V[q])])
    F = np.vstack([F, [[q, p, V.shape[0] - 1]]])  # zero area, on a boundary edge
    V2, F2 = bumpy_disk(20, seed=seed + 9)
    F = np.vstack([F, F2 + V.shape[0]])
    V = np.vstack([V, V2 + 5.0])
    expected = dict(faces=F0.shape[0], vertices=V0.shape[0], bowtie_vertices=3, duplicate_faces=3,
                    zero_area_faces=1)
    return V, F.astype(np.int64), expected
