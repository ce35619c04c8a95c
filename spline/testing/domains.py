"""Generated planar triangulations for tests, examples and benchmarks.

Every function returns ``uv: (nv, 2)`` and ``faces: (nf, 3)`` with faces
counter-clockwise and every vertex used. They cover the cases the spline core
must handle: random Delaunay meshes with holes, concave (L-shaped) and annular
domains, slivers, structured and criss-cross grids (exactly collinear edges,
singular vertices), a lone triangle and single-vertex fans.
"""
from __future__ import annotations

import numpy as np
from scipy.spatial import Delaunay

from ..topology import signed_areas


def orient_ccw(uv: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Return ``faces`` with clockwise rows reversed."""
    faces = np.array(faces, dtype=np.int64)
    neg = signed_areas(uv, faces) < 0
    faces[neg] = faces[neg][:, [0, 2, 1]]
    return faces


def compact(uv: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Drop unreferenced vertices, keeping the order of the others."""
    used = np.zeros(len(uv), bool)
    used[faces.ravel()] = True
    remap = np.cumsum(used) - 1
    return uv[used], remap[faces]


def grid(nx: int, ny: int | None = None, *, diagonal: str = "regular") -> tuple[np.ndarray, np.ndarray]:
    """Structured grid over the unit square.

    ``diagonal="regular"``: every quad split by the same diagonal (each interior
    vertex has valence 6 with three straight lines through it).
    ``diagonal="alternate"``: alternating diagonals (valence 4 and 8 vertices;
    the valence-4 ones are singular: four edges on two lines).
    ``diagonal="crisscross"``: each quad split into four by its centre (type-2
    triangulation; every quad centre is singular).
    """
    ny = nx if ny is None else ny
    xs, ys = np.linspace(0, 1, nx + 1), np.linspace(0, 1, ny + 1)
    X, Y = np.meshgrid(xs, ys, indexing="xy")
    uv = np.column_stack([X.ravel(), Y.ravel()])
    idx = np.arange((nx + 1) * (ny + 1)).reshape(ny + 1, nx + 1)
    a, b = idx[:-1, :-1].ravel(), idx[:-1, 1:].ravel()
    c, d = idx[1:, 1:].ravel(), idx[1:, :-1].ravel()
    if diagonal == "regular":
        faces = np.concatenate([np.column_stack([a, b, c]), np.column_stack([a, c, d])])
    elif diagonal == "alternate":
        ii, jj = np.meshgrid(np.arange(nx), np.arange(ny), indexing="xy")
        flip = ((ii + jj) % 2 == 1).ravel()
        f1 = np.where(flip[:, None], np.column_stack([a, b, d]), np.column_stack([a, b, c]))
        f2 = np.where(flip[:, None], np.column_stack([b, c, d]), np.column_stack([a, c, d]))
        faces = np.concatenate([f1, f2])
    elif diagonal == "crisscross":
        centres = 0.5 * (uv[a] + uv[c])
        m = len(uv) + np.arange(len(a))
        uv = np.concatenate([uv, centres])
        faces = np.concatenate(
            [np.column_stack([a, b, m]), np.column_stack([b, c, m]),
             np.column_stack([c, d, m]), np.column_stack([d, a, m])]
        )
    else:
        raise ValueError(f"unknown diagonal {diagonal!r}")
    return uv, orient_ccw(uv, faces)


def fan(n: int, *, closed: bool = True, radius_jitter: float = 0.0, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """``n`` triangles around one centre vertex (complete star if ``closed``)."""
    if n < (3 if closed else 1):
        raise ValueError("a closed fan needs at least 3 triangles")
    rng = np.random.default_rng(seed)
    span = 2 * np.pi if closed else np.pi * min(1.5, 0.3 * n)
    m = n if closed else n + 1
    ang = np.linspace(0, span, m, endpoint=not closed) if not closed else np.arange(n) * span / n
    # angular jitter of +-0.2 of the spacing keeps every gap below 1.4 * 2 pi / 3 < pi, so no
    # triangle of a closed 3-fan turns over (+-0.3 could, and orient_ccw then made it inconsistent)
    ang = ang + (rng.uniform(-0.2, 0.2, m) * span / m if radius_jitter else 0.0)
    r = 1.0 + radius_jitter * rng.uniform(-0.5, 0.5, m)
    uv = np.concatenate([[[0.0, 0.0]], np.column_stack([r * np.cos(ang), r * np.sin(ang)])])
    i = np.arange(n)
    faces = np.column_stack([np.zeros(n, int), 1 + i, 1 + (i + 1) % m])
    return uv, orient_ccw(uv, faces)


def lone_triangle() -> tuple[np.ndarray, np.ndarray]:
    return np.array([[0.0, 0.0], [1.0, 0.0], [0.3, 0.8]]), np.array([[0, 1, 2]])


def _delaunay_in(points: np.ndarray, inside) -> tuple[np.ndarray, np.ndarray]:
    tri = Delaunay(points)
    faces = tri.simplices
    cen = points[faces].mean(1)
    faces = faces[inside(cen)]
    uv, faces = compact(points, faces)
    faces = orient_ccw(uv, faces)
    # drop faces that are degenerate after clipping
    keep = signed_areas(uv, faces) > 1e-12 * np.abs(signed_areas(uv, faces)).mean()
    return compact(uv, faces[keep])


def random_delaunay(n: int, *, holes: int = 0, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Delaunay triangulation of ``n`` random points in the unit square with
    square boundary samples, optionally with ``holes`` disjoint circular holes."""
    rng = np.random.default_rng(seed)
    k = max(4, int(np.sqrt(n)))
    t = np.linspace(0, 1, k, endpoint=False)
    border = np.concatenate(
        [np.column_stack([t, 0 * t]), np.column_stack([1 + 0 * t, t]),
         np.column_stack([1 - t, 1 + 0 * t]), np.column_stack([0 * t, 1 - t])]
    )
    pts = np.concatenate([border, rng.uniform(0.02, 0.98, (n, 2))])
    centres, radii = [], []
    for _ in range(holes * 20):
        if len(centres) == holes:
            break
        c = rng.uniform(0.2, 0.8, 2)
        r = rng.uniform(0.05, 0.12)
        if all(np.linalg.norm(c - c2) > r + r2 + 0.05 for c2, r2 in zip(centres, radii)):
            centres.append(c)
            radii.append(r)
    for c, r in zip(centres, radii):
        m = max(8, int(2 * np.pi * r * np.sqrt(n)))
        a = np.linspace(0, 2 * np.pi, m, endpoint=False)
        pts = pts[np.linalg.norm(pts - c, axis=1) > r * 1.05]
        pts = np.concatenate([pts, c + r * np.column_stack([np.cos(a), np.sin(a)])])

    def inside(p):
        ok = np.ones(len(p), bool)
        for c, r in zip(centres, radii):
            ok &= np.linalg.norm(p - c, axis=1) > r
        return ok

    return _delaunay_in(pts, inside)


def l_shape(n: int = 200, *, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Concave L-shaped domain ``[0,1]^2 minus (0.5,1]^2``."""
    rng = np.random.default_rng(seed)
    k = max(4, int(np.sqrt(n)))
    pts = [rng.uniform(0, 1, (2 * n, 2))]
    t = np.linspace(0, 1, 2 * k + 1)
    h = np.linspace(0, 0.5, k + 1)
    pts += [np.column_stack([t, 0 * t]), np.column_stack([0 * t, t]), np.column_stack([1 + 0 * h, h]),
            np.column_stack([h, 1 + 0 * h]), np.column_stack([0.5 + h, 0.5 + 0 * h]),
            np.column_stack([0.5 + 0 * h, 0.5 + h])]
    p = np.concatenate(pts)
    p = p[~((p[:, 0] > 0.5 + 1e-9) & (p[:, 1] > 0.5 + 1e-9))]
    p = np.unique(np.round(p, 12), axis=0)
    return _delaunay_in(p, lambda c: ~((c[:, 0] > 0.5) & (c[:, 1] > 0.5)))


def annulus(n_radial: int = 4, n_angular: int = 24, r0: float = 0.4, r1: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    """Structured annulus (one hole), quads split by one diagonal."""
    r = np.linspace(r0, r1, n_radial + 1)
    a = np.linspace(0, 2 * np.pi, n_angular, endpoint=False)
    R, A = np.meshgrid(r, a, indexing="ij")
    uv = np.column_stack([(R * np.cos(A)).ravel(), (R * np.sin(A)).ravel()])
    idx = np.arange(uv.shape[0]).reshape(n_radial + 1, n_angular)
    i0 = idx[:-1]
    i1 = np.roll(idx[:-1], -1, axis=1)
    j0 = idx[1:]
    j1 = np.roll(idx[1:], -1, axis=1)
    faces = np.concatenate([np.column_stack([i0.ravel(), i1.ravel(), j1.ravel()]),
                            np.column_stack([i0.ravel(), j1.ravel(), j0.ravel()])])
    return uv, orient_ccw(uv, faces)


def slivers(n: int = 10, aspect: float = 200.0) -> tuple[np.ndarray, np.ndarray]:
    """A strip of ``2 n`` long thin triangles with aspect ratio about ``aspect``."""
    x = np.linspace(0, 1, n + 1)
    h = 1.0 / aspect
    uv = np.concatenate([np.column_stack([x, 0 * x]), np.column_stack([x + 0.5 / n, h + 0 * x])])
    a = np.arange(n)
    faces = np.concatenate([np.column_stack([a, a + 1, n + 1 + a]),
                            np.column_stack([a + 1, n + 2 + a, n + 1 + a])[: n - 1]])
    uv, faces = compact(uv, faces)
    return uv, orient_ccw(uv, faces)


def slivered_hull(n: int, k: int, low: float, degrees: float, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Delaunay mesh of ``n`` random points in the unit square and ``k`` more at heights
    ``10**low .. 10**(low + 2)`` above its bottom edge (hull slivers of aspect 1e3 .. 1e6, as random
    scattered data make), turned by ``degrees``: oblique slivers, whose signed areas cancel in double."""
    rng = np.random.default_rng(seed)
    P = np.r_[rng.random((n, 2)), np.c_[rng.random(k), 10.0 ** rng.uniform(low, low + 2, k)]]
    faces = Delaunay(P).simplices
    t = np.radians(degrees)
    uv = P @ np.array([[np.cos(t), np.sin(t)], [-np.sin(t), np.cos(t)]])
    return uv, orient_ccw(uv, faces)


def perturb(uv: np.ndarray, faces: np.ndarray, amount: float, seed: int = 0) -> np.ndarray:
    """Jitter interior vertices by ``amount`` times the local edge length, keeping faces CCW."""
    rng = np.random.default_rng(seed)
    e = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
    L = np.linalg.norm(uv[e[:, 0]] - uv[e[:, 1]], axis=1)
    h = np.full(len(uv), np.inf)
    np.minimum.at(h, e[:, 0], L)
    np.minimum.at(h, e[:, 1], L)
    key = np.sort(e, axis=1)
    _, cnt = np.unique(key, axis=0, return_counts=True)
    uniq = np.unique(key, axis=0)
    bnd = np.zeros(len(uv), bool)
    bnd[uniq[cnt == 1].ravel()] = True
    out = uv + (~bnd)[:, None] * amount * h[:, None] * rng.uniform(-1, 1, uv.shape)
    if (signed_areas(out, faces) <= 0).any():
        return uv.copy()
    return out
