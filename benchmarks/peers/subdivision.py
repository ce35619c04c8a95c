"""Subdivision surfaces of a triangle mesh with boundary: modified Butterfly and Loop, vectorised.

    r = subdivide(V, F, levels=3, scheme="butterfly", carry=st)
    r.V (n, 3)        # refined vertices (Loop: pushed to their limit positions)
    r.carry (n, k)    # ``carry`` (e.g. surface parameters) refined linearly, edge midpoints
    r.lattice         # (nf, (R+1)(R+2)/2) ids of each input face's lattice(R) points, R = 2**levels
    r.normals (n, 3)  # area-weighted vertex normals of the refined mesh

Each level splits every triangle into four. ``butterfly`` (interpolating; Zorin, Schroeder
and Sweldens 1996): an edge between regular interior vertices (valence 6) or boundary
vertices takes the ten-point stencil ``1/2, 1/2, 1/8, 1/8, -1/16 x 4``, with the wing points
that fall off the mesh reflected across their boundary edge (``a + c - b``, which keeps
linear functions exact); an edge with one interior extraordinary end takes that vertex's
``k``-point stencil (``3/4`` at the vertex; ``k = 3``: ``5/12, -1/12, -1/12``; ``k = 4``:
``3/8, 0, -1/8, 0``; ``k >= 5``: ``(1/4 + cos(2 pi j/k) + cos(4 pi j/k)/2) / k``), with two
the mean of both; a boundary edge takes the four-point rule ``-1/16, 9/16, 9/16, -1/16``
along the boundary. ``loop`` (approximating; Loop 1987): edges ``3/8, 3/8, 1/8, 1/8``, boundary
edges their midpoint, vertices Loop's ``beta`` weights, boundary vertices ``3/4, 1/8, 1/8``
(the boundary is a cubic B-spline curve); after the last level every vertex is moved to its
limit position (interior ``chi = 1 / (k + 3 / (8 beta))``, boundary ``1/6, 2/3, 1/6``).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from trispline.fit.targets import area_weighted_normals
from trispline.spline.index import lattice, lattice_triangles

SCHEMES = ("butterfly", "loop")


@dataclass(frozen=True)
class Refined:
    """A subdivided mesh; see the module docstring."""

    V: np.ndarray
    carry: np.ndarray
    lattice: np.ndarray
    normals: np.ndarray
    faces: np.ndarray


@dataclass(frozen=True)
class _HalfEdges:
    """Half-edge ``3 f + k`` runs ``F[f, k] -> F[f, k+1]``, opposite ``F[f, k+2]``; ``twin`` is -1 on the boundary."""

    src: np.ndarray
    dst: np.ndarray
    opp: np.ndarray
    twin: np.ndarray
    nv: int

    @classmethod
    def of(cls, F: np.ndarray, nv: int) -> "_HalfEdges":
        src, dst, opp = F.ravel(), F[:, [1, 2, 0]].ravel(), F[:, [2, 0, 1]].ravel()
        key, rev = src * nv + dst, dst * nv + src
        order = np.argsort(key)
        pos = np.searchsorted(key[order], rev)
        pos = np.minimum(pos, len(key) - 1)
        twin = np.where(key[order][pos] == rev, order[pos], -1)
        return cls(src, dst, opp, twin, nv)

    def nxt(self, h: np.ndarray) -> np.ndarray:
        return h - h % 3 + (h + 1) % 3

    def prv(self, h: np.ndarray) -> np.ndarray:
        return h - h % 3 + (h + 2) % 3

    @property
    def boundary_vertex(self) -> np.ndarray:
        out = np.zeros(self.nv, bool)
        out[self.src[self.twin < 0]] = True
        return out

    def valence(self) -> np.ndarray:
        """Neighbour count of every vertex (a boundary vertex has one more neighbour than half-edges out)."""
        return np.bincount(self.src, minlength=self.nv) + self.boundary_vertex

    def boundary_next(self) -> np.ndarray:
        """``(nv,)`` the next vertex along the boundary (-1 inside): the end of the boundary half-edge leaving it."""
        out = np.full(self.nv, -1)
        b = np.flatnonzero(self.twin < 0)
        out[self.src[b]] = self.dst[b]
        return out

    def edges(self) -> np.ndarray:
        """One half-edge per undirected edge: ``src < dst``, or the boundary one."""
        return np.flatnonzero((self.twin < 0) | (self.src < self.dst))


def _wing(he: _HalfEdges, V: np.ndarray, side: np.ndarray, apex: np.ndarray) -> np.ndarray:
    """The vertex across half-edge ``side``; off the mesh, ``apex`` reflected across it (``src + dst - apex``)."""
    t = he.twin[side]
    ghost = V[he.src[side]] + V[he.dst[side]] - V[apex]
    return np.where((t >= 0)[:, None], V[he.opp[np.maximum(t, 0)]], ghost)


def _ten_point(he: _HalfEdges, V: np.ndarray, h: np.ndarray) -> np.ndarray:
    """Butterfly's ten-point rule at interior half-edges ``h``; missing wings reflected."""
    t = he.twin[h]
    a, b, c, d = he.src[h], he.dst[h], he.opp[h], he.opp[t]
    wings = (_wing(he, V, he.prv(h), b) + _wing(he, V, he.nxt(h), a)
             + _wing(he, V, he.prv(t), a) + _wing(he, V, he.nxt(t), b))
    return 0.5 * (V[a] + V[b]) + 0.125 * (V[c] + V[d]) - wings / 16


def _stencil_weights(k: np.ndarray, kmax: int) -> np.ndarray:
    """``(n, kmax)`` Butterfly weights of an extraordinary vertex's neighbours ``s_0 .. s_{k-1}`` (0 beyond ``k``)."""
    j = np.arange(kmax)[None, :]
    kk = k[:, None].astype(float)
    w = (0.25 + np.cos(2 * np.pi * j / kk) + 0.5 * np.cos(4 * np.pi * j / kk)) / kk
    w = np.where(k[:, None] == 3, np.select([j == 0, j < 3], [5 / 12, -1 / 12], 0.0), w)
    w = np.where(k[:, None] == 4, np.select([j == 0, j == 2], [3 / 8, -1 / 8], 0.0), w)
    return np.where(j < k[:, None], w, 0.0)


def _extraordinary(he: _HalfEdges, V: np.ndarray, h: np.ndarray, k: np.ndarray) -> np.ndarray:
    """The ``k``-point rule of the (interior) source vertex of each half-edge ``h``, ``s_0`` its end."""
    kmax = int(k.max())
    W = _stencil_weights(k, kmax)
    out = 0.75 * V[he.src[h]]
    cur = h.copy()
    for j in range(kmax):
        out += W[:, j:j + 1] * V[he.dst[cur]]
        cur = he.twin[he.prv(cur)]  # the next half-edge out of the vertex, counter-clockwise
        cur = np.maximum(cur, 0)  # past the vertex's valence: weight 0
    return out


def _butterfly_edges(he: _HalfEdges, V: np.ndarray, h: np.ndarray) -> np.ndarray:
    """New points ``(len(h), 3)`` of the modified Butterfly scheme on the edges of half-edges ``h``."""
    bnd, val = he.boundary_vertex, he.valence()
    out = np.empty((len(h), 3))
    onb = he.twin[h] < 0
    hb = h[onb]
    nb = he.boundary_next()
    prev_of = np.full(he.nv, -1)
    prev_of[nb[nb >= 0]] = np.flatnonzero(nb >= 0)
    a, b = he.src[hb], he.dst[hb]
    out[onb] = (9 * (V[a] + V[b]) - V[prev_of[a]] - V[nb[b]]) / 16
    hi = h[~onb]
    a, b = he.src[hi], he.dst[hi]
    xa = ~bnd[a] & (val[a] != 6)
    xb = ~bnd[b] & (val[b] != 6)
    res = _ten_point(he, V, hi)
    one_a, one_b, both = xa & ~xb, xb & ~xa, xa & xb
    if one_a.any():
        res[one_a] = _extraordinary(he, V, hi[one_a], val[a[one_a]])
    if one_b.any():
        res[one_b] = _extraordinary(he, V, he.twin[hi[one_b]], val[b[one_b]])
    if both.any():
        hh = hi[both]
        res[both] = 0.5 * (_extraordinary(he, V, hh, val[a[both]]) + _extraordinary(he, V, he.twin[hh], val[b[both]]))
    out[~onb] = res
    return out


def _neighbour_sums(he: _HalfEdges, V: np.ndarray) -> np.ndarray:
    """``(nv, 3)`` sum of every vertex's neighbours (each undirected edge counted once per end)."""
    e = he.edges()
    out = np.zeros_like(V)
    for d in range(3):
        out[:, d] = (np.bincount(he.src[e], V[he.dst[e], d], minlength=he.nv)
                     + np.bincount(he.dst[e], V[he.src[e], d], minlength=he.nv))
    return out


def _loop_beta(k: np.ndarray) -> np.ndarray:
    return (0.625 - (0.375 + 0.25 * np.cos(2 * np.pi / k)) ** 2) / k


def _loop_vertices(he: _HalfEdges, V: np.ndarray, limit: bool) -> np.ndarray:
    """Loop's even-vertex rule (``limit``: the limit-position masks instead)."""
    bnd, k = he.boundary_vertex, he.valence().astype(float)
    nb = he.boundary_next()
    prev_of = np.full(he.nv, -1)
    prev_of[nb[nb >= 0]] = np.flatnonzero(nb >= 0)
    beta = _loop_beta(np.maximum(k, 3))
    w = 1.0 / (k + 3.0 / (8.0 * beta)) if limit else beta
    out = (1 - k * w)[:, None] * V + w[:, None] * _neighbour_sums(he, V)
    b = np.flatnonzero(bnd)
    side = 1 / 6 if limit else 1 / 8
    out[b] = (1 - 2 * side) * V[b] + side * (V[prev_of[b]] + V[nb[b]])
    return out


def _loop_edges(he: _HalfEdges, V: np.ndarray, h: np.ndarray) -> np.ndarray:
    """Loop's odd (edge) points: ``3/8, 3/8, 1/8, 1/8``; boundary edges their midpoint."""
    a, b = he.src[h], he.dst[h]
    out = 0.5 * (V[a] + V[b])
    t = he.twin[h]
    i = t >= 0
    out[i] = 0.375 * (V[a[i]] + V[b[i]]) + 0.125 * (V[he.opp[h[i]]] + V[he.opp[t[i]]])
    return out


def _split_table(R: int) -> tuple[np.ndarray, np.ndarray]:
    """For lattice(2R): ``(n, 2)`` the two lattice(R) points each point is the midpoint of (equal for old points)."""
    pos = {tuple(int(x) for x in e): n for n, e in enumerate(lattice(R))}
    out = []
    for e in lattice(2 * R):
        odd = np.flatnonzero(e % 2)
        if odd.size == 0:
            q = pos[tuple(int(x) for x in e // 2)]
            out.append((q, q))
            continue
        p, q = odd
        A, B = e.copy(), e.copy()
        A[p] += 1
        A[q] -= 1
        B[p] -= 1
        B[q] += 1
        out.append((pos[tuple(int(x) for x in A // 2)], pos[tuple(int(x) for x in B // 2)]))
    return np.array(out)


def _refine_once(V: np.ndarray, carry: np.ndarray, lat: np.ndarray, R: int, scheme: str
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One 1-to-4 split of the mesh whose faces are the lattice(R) triangles of ``lat``."""
    nv = len(V)
    F = lat[:, lattice_triangles(R)].reshape(-1, 3)
    he = _HalfEdges.of(F, nv)
    h = he.edges()
    pts = _butterfly_edges(he, V, h) if scheme == "butterfly" else _loop_edges(he, V, h)
    old = V if scheme == "butterfly" else _loop_vertices(he, V, limit=False)
    a, b = he.src[h], he.dst[h]
    key = np.minimum(a, b) * nv + np.maximum(a, b)
    order = np.argsort(key)
    table = _split_table(R)
    ia, ib = lat[:, table[:, 0]], lat[:, table[:, 1]]
    mid = ia != ib
    k2 = np.minimum(ia, ib) * nv + np.maximum(ia, ib)
    pos = np.minimum(np.searchsorted(key[order], k2), len(key) - 1)
    new = np.where(mid, nv + order[pos], ia)
    carry2 = np.concatenate([carry, 0.5 * (carry[a] + carry[b])])
    return np.concatenate([old, pts]), carry2, new


def subdivide(V: np.ndarray, F: np.ndarray, levels: int, scheme: str, carry: np.ndarray) -> Refined:
    """``levels`` steps of ``scheme`` (:data:`SCHEMES`) on the mesh ``V (nv, 3)``, ``F (nf, 3)``;
    see the module docstring."""
    if scheme not in SCHEMES:
        raise ValueError(f"unknown scheme {scheme!r}; choose one of {', '.join(SCHEMES)}")
    lat, R = np.asarray(F, np.int64), 1
    V, carry = np.asarray(V, np.float64), np.asarray(carry, np.float64)
    for _ in range(levels):
        V, carry, lat = _refine_once(V, carry, lat, R, scheme)
        R *= 2
    faces = lat[:, lattice_triangles(R)].reshape(-1, 3)
    if scheme == "loop":
        V = _loop_vertices(_HalfEdges.of(faces, len(V)), V, limit=True)
    return Refined(V=V, carry=carry, lattice=lat, normals=area_weighted_normals(V, faces), faces=faces)
