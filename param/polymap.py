"""A map that is smooth by construction: uv as one low-degree polynomial of the position in space.

    uv2, info = smoothest_map(V, F, uv)   # (nv, 2): uv itself, or a polynomial map that beats it

Why (issue 17): the spline interpolates the mesh over its map, so its accuracy is that of
``x(uv)``, the surface read through the map. A discrete map (LSCM), even smoothed vertex by
vertex (:mod:`trispline.param.smooth`), keeps an irregularity that the fit follows, most near the
outline, where every local fit is one-sided. A polynomial ``f`` of the 3D position, restricted to
a smooth surface, is a smooth map with no irregularity at all and no outline of its own: the
least-squares polynomial of degree 2-4 of the map (:func:`polynomial_map`), where it is
fold-free, is such a map close to it; so is the projection onto the mesh's mean plane
(:func:`plane_projection`, the candidate of degree 1), under which a height field reads as its
height function (a cubic height field as a cubic: the monkey saddle's fit 3.3e-9 -> 1.3e-9 RMS at
3,205 vertices, its interior 3.0e-9 -> 3.5e-11). Measured on ``bench_accuracy3d.py``'s sphere cap at 800
vertices (fits with the outline treated as a given map's): the smoothed LSCM 1.2e-7 RMS, the
true parameters 3.6e-8, the degree-2 polynomial of the LSCM 7.9e-9 (docs/param.md).

Which map is kept is measured, not guessed: :func:`map_roughness` is how far the surface is
from a local quartic of the map's uv over the 4-ring of a seeded sample of vertices (RMS over
the local edge length). It ranked the candidates as the fits' errors did on the 8 analytic
surfaces (polynomials of the map win on height-field-like surfaces; on a torus patch, a
240-degree barrel and Enneper's surface no low degree follows the conformal map and the
smoothed map stays). A polynomial map is kept when it is fold-free and its roughness is below
:data:`MARGIN` times the map's (a tie, e.g. where no neighbourhood is large enough to measure, keeps the map).
"""
from __future__ import annotations

import itertools

import numpy as np
import scipy.sparse as sp

from .distortion import fold_mask
from .smooth import _monomials
from .tables import ring_step, undirected_edges
from .validate import face_aspects

__all__ = ["ASPECT_GROWTH", "DEGREES", "MARGIN", "SAMPLE", "ROUGH_RINGS", "ROUGH_DEGREE", "map_roughness", "polynomial_map",
           "plane_projection", "smoothest_map"]

#: Degrees of the maps tried: 1 is :func:`plane_projection`, 2-4 :func:`polynomial_map` (a degree-6 map of the cap
#: was 10x rougher than degree 2-4: on a quadric or a quartic surface the monomials of higher degree are
#: dependent and the fit wiggles).
DEGREES = (1, 2, 3, 4)
#: A polynomial map is kept when its :func:`map_roughness` is below this times the map's (the two measured on
#: the same sampled vertices). 0.9: on the 24 cases of ``bench_accuracy3d.py`` only the helicoid at 803
#: vertices lies between 0.8 and 0.9 (degree 3 at 0.84: its fit 3.35e-7 -> 1.07e-7 RMS); the shared real
#: meshes have none there (docs/param.md).
MARGIN = 0.9
#: ... and when its thinnest triangle (longest edge over height) is at most this times the map's.
ASPECT_GROWTH = 2.0
#: Vertices (a seeded sample) whose neighbourhoods :func:`map_roughness` measures.
SAMPLE = 2000
#: Rings of a sampled vertex's neighbourhood and the degree of its local fit in :func:`map_roughness`.
ROUGH_RINGS = 4
ROUGH_DEGREE = 4
#: Relative eigenvalue below which a direction of the monomials' normal matrix is dropped (on a sphere
#: ``x^2 + y^2 + z^2`` is constant: without the cut the coefficients cancel to rounding noise).
EIG_CUT = 1e-20
#: :func:`grid_centre` rounds to this many bits below the mesh's size.
CENTRE_BITS = 20
#: Rows of the 3D monomials formed at once.
CHUNK = 1 << 16


def _monomials3(X: np.ndarray, degree: int) -> np.ndarray:
    """``(n, p)`` every monomial of ``X (n, 3)`` up to ``degree``, constant first."""
    cols = [np.ones(len(X))]
    for k in range(1, degree + 1):
        cols += [np.prod(X[:, list(c)], axis=1) for c in itertools.combinations_with_replacement(range(3), k)]
    return np.stack(cols, 1)


def grid_centre(V: np.ndarray) -> np.ndarray:
    """``(d,)`` the bounding-box centre of ``V (n, d)`` rounded to a power of two :data:`CENTRE_BITS` below
    its size: ``V - grid_centre(V)`` is then exact, and the same for a tile stored at map coordinates
    (``V + 5e6``) as for the same stored data moved to the origin (a plain centre differs by the offset's
    rounding), so that what is computed from it does not depend on where the tile lies."""
    size = max(float(np.ptp(V, axis=0).max()), np.finfo(float).tiny)
    grid = 2.0 ** (np.floor(np.log2(size)) - CENTRE_BITS)
    return np.round(0.5 * (V.min(0) + V.max(0)) / grid) * grid


def polynomial_map(V: np.ndarray, uv: np.ndarray, degree: int) -> np.ndarray:
    """``(nv, 2)`` the least-squares polynomial of degree ``degree`` in the (centred, scaled) positions
    ``V (nv, 3)`` that best fits ``uv (nv, 2)``, at the vertices: minimum-norm where the monomials are
    dependent on the surface (:data:`EIG_CUT`)."""
    size = max(float(np.ptp(V, axis=0).max()), np.finfo(float).tiny)
    # the minimum-norm fit is not shift-invariant where the monomials are dependent (a sphere cap): a centre
    # off by a UTM offset's rounding (1e-10 of the size) moved the map by 6e-7 and the surface by 1e-5 of the diagonal
    X = (V - grid_centre(V)) / size
    p = _monomials3(X[:1], degree).shape[1]
    G, B = np.zeros((p, p)), np.zeros((p, 2))
    for lo in range(0, len(X), CHUNK):
        A = _monomials3(X[lo:lo + CHUNK], degree)
        G += A.T @ A
        B += A.T @ uv[lo:lo + CHUNK]
    w, Q = np.linalg.eigh(G)
    keep = w > EIG_CUT * max(w[-1], np.finfo(float).tiny)
    coef = Q[:, keep] @ ((Q[:, keep].T @ B) / w[keep, None])
    return np.concatenate([_monomials3(X[lo:lo + CHUNK], degree) @ coef for lo in range(0, len(X), CHUNK)])


def plane_projection(V: np.ndarray, F: np.ndarray, uv: np.ndarray) -> np.ndarray:
    """``(nv, 2)`` the orthogonal projection of ``V (nv, 3)`` onto the plane across the mesh's vector area
    (the sum of its faces' area vectors), turned, mirrored and scaled onto ``uv (nv, 2)`` (Procrustes): the
    natural map of a height field, under which its surface is as smooth as its height function (a
    polynomial height stays one). Zero where the vector area vanishes (a closed-up strip: no plane)."""
    e = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]]).sum(0)
    length = float(np.linalg.norm(e))
    if not length > 0:
        return np.zeros_like(uv)
    n = e / length
    a = np.cross(n, np.eye(3)[np.argmin(np.abs(n))])
    a /= np.linalg.norm(a)
    P = (V - V.mean(0)) @ np.stack([a, np.cross(n, a)], 1)
    c = uv.mean(0)
    U, s, Wt = np.linalg.svd(P.T @ (uv - c))
    scale = s.sum() / max(float((P * P).sum()), np.finfo(float).tiny)
    return scale * P @ (U @ Wt) + c


def _adjacency(F: np.ndarray, nv: int) -> sp.csr_matrix:
    """:func:`~trispline.param.tables.ring_step` of the mesh ``F``'s edges (a step of :func:`_sample_rings`)."""
    return ring_step(undirected_edges(np.asarray(F, np.int64), nv)[1], nv)


def _sample_rings(A: sp.csr_matrix, centre: np.ndarray, rings: int) -> sp.csr_matrix:
    """``(k, nv)`` CSR: row ``i`` marks the vertices within ``rings`` edges of ``centre[i]`` (itself too);
    ``A``: :func:`_adjacency`."""
    nv = A.shape[0]
    R = sp.csr_matrix((np.ones(centre.size), (np.arange(centre.size), centre)), shape=(centre.size, nv))
    for _ in range(rings):
        R = R @ A
        R.data[:] = 1.0
    R.sort_indices()
    return R


def map_roughness(V: np.ndarray, F: np.ndarray, uv: np.ndarray, *, sample: int = SAMPLE, seed: int = 0,
                  adjacency: sp.csr_matrix | None = None) -> float:
    """How far the surface ``V (nv, 3)`` read through the map ``uv (nv, 2)`` of ``F (nf, 3)`` is from smooth:
    the RMS, over a seeded sample of vertices, of the residual of the least-squares polynomial of degree
    :data:`ROUGH_DEGREE` in uv through the positions of the vertex's :data:`ROUGH_RINGS`-ring, over its mean
    distance to them (rows with too few points for that degree take degree 3, fewer still are skipped).
    ``adjacency``: :func:`_adjacency` of ``F``, when known."""
    nv = len(V)
    centre = np.sort(np.random.default_rng(seed).choice(nv, min(sample, nv), replace=False))
    R = _sample_rings(_adjacency(F, nv) if adjacency is None else adjacency, centre, ROUGH_RINGS)
    counts = np.diff(R.indptr)
    nbr = np.zeros((centre.size, int(counts.max())), np.int64)
    valid = np.arange(nbr.shape[1])[None, :] < counts[:, None]
    nbr[valid] = R.indices
    d = np.where(valid[..., None], uv[nbr] - uv[centre][:, None, :], 0.0)
    d /= np.maximum(np.linalg.norm(d, axis=2).max(1), np.finfo(float).tiny)[:, None, None]
    dx = np.where(valid[..., None], V[nbr] - V[centre][:, None, :], 0.0)
    h = np.linalg.norm(dx, axis=2).sum(1) / np.maximum(counts - 1, 1)
    out, upper = [], np.inf
    for degree in (ROUGH_DEGREE, ROUGH_DEGREE - 1):  # each row the highest degree it holds twice over
        need = (degree + 1) * (degree + 2)
        rows = np.flatnonzero((counts >= need) & (counts < upper))
        upper = need
        if not rows.size:
            continue
        A = _monomials(d[rows], degree) * valid[rows][..., None]
        res = dx[rows] - np.matmul(A, _batched_lstsq(A, dx[rows]))
        out.append(np.sqrt((res**2).sum((1, 2)) / counts[rows]) / np.maximum(h[rows], np.finfo(float).tiny))
    r = np.concatenate(out) if out else np.zeros(0)
    return float(np.sqrt(np.mean(r**2))) if r.size else 0.0


def _batched_lstsq(A: np.ndarray, B: np.ndarray) -> np.ndarray:
    """``(n, p, d)`` least-squares solutions of ``A (n, m, p) c = B (n, m, d)`` by the normal equations
    (``A``'s coordinates are O(1): a vertex's neighbours scaled to the unit disk), a relative ridge of
    ``1e-12`` where the points cannot support the degree."""
    At = A.transpose(0, 2, 1)
    G = np.matmul(At, A)
    G += 1e-12 * np.trace(G, axis1=1, axis2=2)[:, None, None] * np.eye(G.shape[1])
    return np.linalg.solve(G, np.matmul(At, B))


def smoothest_map(V: np.ndarray, F: np.ndarray, uv: np.ndarray, *, degrees: tuple[int, ...] = DEGREES
                  ) -> tuple[np.ndarray, dict]:
    """``uv (nv, 2)`` itself, or the fold-free :func:`polynomial_map` of it (one of ``degrees``; no triangle
    thinner than :data:`ASPECT_GROWTH` times the map's thinnest) whose :func:`map_roughness` is lowest, where
    that is below :data:`MARGIN` times the map's. ``info``:
    ``polynomial`` (the degree kept, 0 for none) and ``roughness`` (per candidate, ``0`` the map's)."""
    A = _adjacency(F, len(V))
    rough, maps = {0: map_roughness(V, F, uv, adjacency=A)}, {0: uv}
    for d in degrees:
        cand = plane_projection(V, F, uv) if d == 1 else polynomial_map(V, uv, d)
        if np.isfinite(cand).all() and not np.logical_or(*fold_mask(cand, F)).any():
            maps[d], rough[d] = cand, map_roughness(V, F, cand, adjacency=A)
    best, thinnest = 0, None
    for d in sorted((d for d in rough if d and rough[d] < MARGIN * rough[0]), key=rough.get):  # measurably smoother
        thinnest = ASPECT_GROWTH * face_aspects(uv, F).max() if thinnest is None else thinnest
        if face_aspects(maps[d], F).max() <= thinnest:  # no new slivers
            best = d
            break
    return maps[best], dict(polynomial=int(best), roughness={int(k): float(v) for k, v in rough.items()})
