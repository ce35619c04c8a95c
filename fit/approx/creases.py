"""Creases of a clean scan and the thin strips of coarse patches that carry them.

    strips = crease_strips(V, F, uv, analysis, sizing, lam, tree, on_boundary)   # Strips
    strips.vertices, strips.segments     # (p,) scan ids beside the creases, (s, 2) scan ids: the strips' sides

A C1 spline rounds a crease over about the width of the patches across it (a blend of
width ``h`` stands off a crease of turn ``theta`` by about ``h theta / 8``); an isotropic
coarse domain's patches are as wide as they are long. Along every crease of the scan
(a chain of scan edges whose dihedral angle exceeds :data:`CREASE_ANGLE`, at least
:data:`MIN_CHAIN_SPACINGS` target spacings long) the domain gets, one target spacing
apart, a pair of scan vertices, one on each side of the crease about
:data:`STRIP_OFFSET` target spacings (at least :data:`MIN_OFFSET_SCAN` scan
spacings) off it; each side's consecutive vertices are joined by a constrained segment
(:func:`~.cdt.constrained`), so the coarse triangulation keeps a thin strip of patches
along the crease that holds the bend, without lowering the angle bound elsewhere. Only
on clean data: where the scan's residuals are noise (:attr:`~.analysis.ScanAnalysis.noise_share`
above :data:`MAX_NOISE_SHARE`) a large dihedral angle is noise, and there are no strips.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import scipy.sparse as sp
from scipy.spatial import cKDTree

from trispline.spline.topology import undirected_edges

if TYPE_CHECKING:  # the analysis holds the crease edges (:func:`clean_crease_edges`)
    from .analysis import ScanAnalysis

__all__ = ["Strips", "crease_edges", "crease_chains", "crease_strips", "clean_crease_edges", "near_creases", "CREASE_ANGLE", "STRIP_OFFSET",
           "MIN_OFFSET_SCAN", "MIN_CHAIN_SPACINGS", "MAX_NOISE_SHARE", "STATION_STEP"]

#: A scan edge whose two faces' normals differ by more than this (degrees) is a crease edge.
CREASE_ANGLE = 30.0
#: A crease chain shorter than this many target spacings (3D) gets no strip.
MIN_CHAIN_SPACINGS = 2.0
#: The strip's half width: this fraction of the target spacing ...
STRIP_OFFSET = 0.15
#: ... and at least this many of the scan's own spacings (a side vertex is a scan vertex off the crease).
MIN_OFFSET_SCAN = 1.0
#: Stations along a chain this many target spacings apart.
STATION_STEP = 1.0
#: No strip where the scan's noise share exceeds this (its large dihedral angles are noise).
MAX_NOISE_SHARE = 0.25
#: A station keeps this many target spacings from the chain's ends and from the scan's outline.
END_MARGIN = 0.5
#: Scan vertices considered for a side vertex.
SIDE_CANDIDATES = 16


@dataclass(frozen=True)
class Strips:
    """The strips' vertices ``(p,)`` (scan ids) and their sides' segments ``(s, 2)`` (scan ids)."""

    vertices: np.ndarray
    segments: np.ndarray

    @staticmethod
    def empty() -> "Strips":
        return Strips(np.empty(0, np.int64), np.empty((0, 2), np.int64))


def crease_edges(V: np.ndarray, F: np.ndarray, angle: float = CREASE_ANGLE) -> np.ndarray:
    """``(e, 2)`` the scan's interior edges (sorted vertex pairs) whose faces' normals differ by more than
    ``angle`` degrees; ``V (n, 3)``, ``F (m, 3)``."""
    fn = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])
    fn /= np.maximum(np.linalg.norm(fn, axis=1, keepdims=True), 1e-300)
    _, edges, he_edge, count = undirected_edges(F, V.shape[0])
    order = np.argsort(he_edge, kind="stable")  # each edge's half-edges together; row 3 f + k is face f's
    first = np.searchsorted(he_edge[order], np.arange(edges.shape[0]))
    inner = np.flatnonzero(count == 2)
    f1, f2 = order[first[inner]] // 3, order[first[inner] + 1] // 3
    cos = np.einsum("ed,ed->e", fn[f1], fn[f2])
    return edges[inner][cos < np.cos(np.radians(angle))]


def clean_crease_edges(V: np.ndarray, F: np.ndarray, noise_share: float, angle: float = CREASE_ANGLE) -> np.ndarray:
    """``(e, 2)`` :func:`crease_edges` of a clean scan; none where its ``noise_share``
    (:attr:`~.analysis.ScanAnalysis.noise_share`) exceeds :data:`MAX_NOISE_SHARE`: there large dihedral angles
    are noise (a bumps scan at noise 3e-3 of its diagonal: 99.8% of its vertices beside one)."""
    if noise_share > MAX_NOISE_SHARE:
        return np.empty((0, 2), np.int64)
    return crease_edges(V, F, angle)


def near_creases(F: np.ndarray, analysis: ScanAnalysis) -> np.ndarray:
    """``(n,)`` bool: the scan vertices on a crease of a clean scan (``analysis.crease``) or on a face with one:
    where a C1 surface has to round the scan off, over at least the width of the patches beside the crease."""
    on = analysis.crease
    near = np.zeros(on.size, bool)
    near[F[on[F].any(axis=1)].ravel()] = True
    return near


def crease_chains(edges: np.ndarray, n: int) -> list[np.ndarray]:
    """The crease edges ``(e, 2)`` cut into simple chains ``(L_i,)`` of scan ids: maximal paths between
    vertices of another degree than two (ends and junctions); a closed loop starts and ends at its smallest
    id. A walk over the crease edges alone (a small share of the scan's)."""
    if edges.shape[0] == 0:
        return []
    A = sp.csr_matrix((np.ones(2 * edges.shape[0]), (edges.ravel(), edges[:, ::-1].ravel())), shape=(n, n))
    deg = np.diff(A.indptr)
    ids = np.arange(1, edges.shape[0] + 1)
    edge_id = sp.csr_matrix((np.r_[ids, ids], (np.r_[edges[:, 0], edges[:, 1]], np.r_[edges[:, 1], edges[:, 0]])),
                            shape=(n, n))
    seen = np.zeros(edges.shape[0], bool)

    def walk(s: int, t: int) -> np.ndarray:
        path, prev, cur = [s], s, t
        seen[edge_id[s, t] - 1] = True
        while True:
            path.append(cur)
            if deg[cur] != 2 or cur == s:
                return np.array(path, np.int64)
            a, b = A.indices[A.indptr[cur]:A.indptr[cur + 1]]
            nxt = int(b) if int(a) == prev else int(a)
            k = edge_id[cur, nxt] - 1
            if seen[k]:
                return np.array(path, np.int64)
            seen[k] = True
            prev, cur = cur, nxt

    chains = []
    for s in np.flatnonzero((deg > 0) & (deg != 2)):  # from every end or junction along each of its edges
        for t in A.indices[A.indptr[s]:A.indptr[s + 1]]:
            if not seen[edge_id[s, t] - 1]:
                chains.append(walk(int(s), int(t)))
    while not seen.all():  # closed loops of degree-two vertices
        s, t = edges[np.flatnonzero(~seen)[0]]
        chains.append(walk(int(s), int(t)))
    return chains


def _stations(s: np.ndarray, h: float, closed: bool) -> np.ndarray:
    """Arc lengths ``(m,)`` of a chain's stations, :data:`STATION_STEP` ``h`` apart (``s (L,)`` the chain's
    cumulative length): :data:`END_MARGIN` ``h`` inside an open chain's ends, around a closed one."""
    total = float(s[-1])
    if closed:
        m = int(total // (STATION_STEP * h))
        return np.arange(m) * total / max(m, 1)
    margin = END_MARGIN * h
    m = int((total - 2.0 * margin) // (STATION_STEP * h)) + 1
    return np.linspace(margin, total - margin, m) if m >= 2 else np.empty(0)


def _side(uv: np.ndarray, tree: cKDTree, centre: np.ndarray, normal: np.ndarray, w: np.ndarray,
          allowed: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(ids (m,), found (m,))``: per station the scan vertex nearest ``centre + w normal`` (uv, ``(m, 2)``)
    that is ``allowed`` and at least half ``w`` off the crease on that side."""
    k = min(SIDE_CANDIDATES, uv.shape[0])
    _, cand = tree.query(centre + w[:, None] * normal, k=k)
    cand = cand.reshape(-1, k)
    off = np.einsum("mkd,md->mk", uv[cand] - centre[:, None, :], normal)
    good = (off >= 0.5 * w[:, None]) & allowed[cand]
    j = np.argmax(good, axis=1)
    return cand[np.arange(cand.shape[0]), j], good.any(1)


def crease_strips(V: np.ndarray, F: np.ndarray, uv: np.ndarray, analysis: ScanAnalysis, sizing, lam: float,
                  tree: cKDTree, on_boundary: np.ndarray) -> Strips:
    """The strips along the scan's creases; see the module docstring.

    V : (n, 3), F : (m, 3) the scan; uv : (n, 2) its map; sizing, lam : the coarse domain's sizing field
    (``spacing3d``, ``spacing`` in uv, ``local`` for the scan's own uv spacing) and density; tree : a
    KD-tree over ``uv``; on_boundary : (n,) bool, the scan's boundary vertices (never a side vertex)
    """
    if analysis.noise_share > MAX_NOISE_SHARE:
        return Strips.empty()
    edges = analysis.crease_edges
    on_crease = np.zeros(V.shape[0], bool)
    on_crease[edges.ravel()] = True
    allowed = ~on_crease & ~on_boundary & ~analysis.spike
    outline = cKDTree(uv[on_boundary]) if on_boundary.any() else None
    segments = []
    for chain in crease_chains(edges, V.shape[0]):  # a loop over the chains (a few dozen), not points
        s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(V[chain], axis=0), axis=1))])
        h = float(np.median(sizing.spacing3d(lam, uv[chain])))
        closed = bool(chain[0] == chain[-1])
        if s[-1] < MIN_CHAIN_SPACINGS * h:
            continue
        at = _stations(s, h, closed)
        if at.size < 2:
            continue
        pos = lambda x: np.clip(np.searchsorted(s, x), 0, chain.size - 1)  # noqa: E731
        centre = uv[chain[pos(at)]]
        t = uv[chain[pos(np.minimum(at + 0.5 * h, s[-1]))]] - uv[chain[pos(np.maximum(at - 0.5 * h, 0.0))]]
        t /= np.maximum(np.linalg.norm(t, axis=1, keepdims=True), 1e-300)
        normal = np.column_stack([-t[:, 1], t[:, 0]])
        h_uv = sizing.spacing(lam, centre)
        w = np.maximum(STRIP_OFFSET * h_uv, MIN_OFFSET_SCAN * sizing.local(centre)[1])
        ok = np.ones(at.size, bool) if outline is None else outline.query(centre)[0] > END_MARGIN * h_uv
        left, has_l = _side(uv, tree, centre, normal, w, allowed)
        right, has_r = _side(uv, tree, centre, -normal, w, allowed)
        ok &= has_l & has_r
        nxt = np.r_[np.arange(1, at.size), 0 if closed else -1]
        link = ok & (nxt >= 0) & ok[nxt]
        for side in (left, right):
            seg = np.column_stack([side[link], side[nxt[link]]])
            segments.append(seg[seg[:, 0] != seg[:, 1]])
    seg = np.unique(np.sort(np.concatenate(segments), axis=1), axis=0) if segments else np.empty((0, 2), np.int64)
    return Strips(np.unique(seg), seg.reshape(-1, 2).astype(np.int64))
