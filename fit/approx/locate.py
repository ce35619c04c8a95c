"""Point location in a planar domain that clamps points outside it to the nearest boundary edge.

    loc = ClampedLocator(uv, faces)                 # (k, 2), (f, 3) counter-clockwise
    hit = loc(points)                               # Located: face (n,), bary (n, 3), edge (n,), t (n,)
    edge, t, foot = loc.project(points)             # nearest boundary edge, parameter on it, foot (n, 2)

A coarse domain whose boundary runs along chords between kept scan vertices leaves
the scan's points between a chord and the true outline outside it; the fit still
needs a patch parameter for them. Those points are clamped to the nearest point of
the domain's boundary (the foot on the nearest boundary edge) and flagged, so a
caller can count them and use the patch there as an extrapolation of the surface.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from trispline.spline.checks import as_array
from trispline.spline.locate import Locator
from trispline.spline.topology import Triangulation
from trispline.spline.util import gather

__all__ = ["ClampedLocator", "Located", "segment_foot"]

#: Boundary edges whose midpoints are nearest to a point, checked first for its nearest edge.
NEAREST_EDGES = 16


@dataclass(frozen=True)
class Located:
    """Where points lie in the domain.

    face : (n,) int64 face containing the point (for a clamped point: the face of its edge)
    bary : (n, 3) barycentric coordinates in ``face`` (of the clamped foot for a clamped point)
    edge : (n,) int64 boundary edge (a :class:`Triangulation` edge id) of a clamped point, else -1
    t : (n,) the clamped foot's parameter along ``edge`` (see :meth:`ClampedLocator.project`), else NaN
    """

    face: np.ndarray
    bary: np.ndarray
    edge: np.ndarray
    t: np.ndarray

    @property
    def clamped(self) -> np.ndarray:
        """(n,) bool: the point was outside the domain and moved onto its boundary."""
        return self.edge >= 0


def segment_foot(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Parameter ``t (...,)`` in ``[0, 1]`` and foot ``(..., d)`` of the nearest point of segments ``a b`` to ``p``."""
    e = b - a
    den = np.maximum(np.einsum("...d,...d->...", e, e), 1e-300)
    t = np.clip(np.einsum("...d,...d->...", p - a, e) / den, 0.0, 1.0)
    return t, a + t[..., None] * e


class ClampedLocator:
    """Locate uv points in ``(uv, faces)``; points outside go to the nearest boundary point.

    Parameters
    ----------
    uv : (k, 2) float64, faces : (f, 3) int64 counter-clockwise
    triangulation : optional prebuilt :class:`Triangulation` of ``(uv, faces)``
    """

    def __init__(self, uv: np.ndarray, faces: np.ndarray, *, triangulation: Triangulation | None = None) -> None:
        self.tri = triangulation if triangulation is not None else Triangulation(uv, faces)
        self.locator = Locator(self.tri.uv, self.tri.faces)
        self.boundary_edges = self.tri.boundary_edges  # (nb,) edge ids
        ends = self.tri.edges[self.boundary_edges]  # (nb, 2)
        self._a = gather.rows(self.tri.uv, ends[:, 0])
        self._b = gather.rows(self.tri.uv, ends[:, 1])
        self._tree = cKDTree(0.5 * (self._a + self._b))
        # points along the boundary edges, at most a median edge apart: the nearest edge is among those
        # of the nearest points unless a point is within half that spacing of a farther one (with the
        # midpoints alone the longest edge set that margin: most interior points of a refined domain,
        # whose outline keeps a few long chords, were checked against every edge)
        length = np.linalg.norm(self._b - self._a, axis=1)
        pieces = np.maximum(np.ceil(length / max(float(np.median(length)), 1e-300)), 1).astype(np.int64)
        self._piece_edge = np.repeat(np.arange(length.size), pieces)
        j = np.arange(self._piece_edge.size) - np.repeat(np.cumsum(pieces) - pieces, pieces)
        frac = ((j + 0.5) / pieces[self._piece_edge])[:, None]
        self._pieces = cKDTree(self._a[self._piece_edge] + frac * (self._b - self._a)[self._piece_edge])
        self._half = 0.5 * float((length / pieces).max())
        ef = self.tri.edge_faces[self.boundary_edges]
        self._face = np.where(ef[:, 0] >= 0, ef[:, 0], ef[:, 1])
        # the two boundary edges at each boundary vertex (a manifold boundary has exactly two)
        flat = ends.reshape(-1)
        order = np.argsort(flat, kind="stable")
        self._vertex_edges = np.full((self.tri.n_vertices, 2), -1, np.int64)
        self._vertex_edges[flat[order[::2]]] = self.boundary_edges[order.reshape(-1, 2) // 2]

    def project(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Nearest boundary point of each uv point (exact).

        Returns ``edge (n,)`` (Triangulation edge ids), ``t (n,)`` in ``[0, 1]`` from
        ``edges[edge, 0]`` to ``edges[edge, 1]`` and the foot ``(n, 2)``. The edges with the
        :data:`NEAREST_EDGES` nearest of points spaced along the edges (at most a median edge length apart)
        are tried first; a point for which they do not prove the answer (a farther edge could still be
        nearer) is checked against every edge.
        """
        p = as_array(points, "points", (None, 2), finite=True)
        ns = self._piece_edge.size
        k = min(NEAREST_EDGES, ns)
        dmid, near = self._pieces.query(p, k=k)
        cand, dmid = self._piece_edge[near.reshape(p.shape[0], k)], dmid.reshape(p.shape[0], k)
        t, foot = segment_foot(p[:, None, :], self._a[cand], self._b[cand])
        d = np.linalg.norm(foot - p[:, None, :], axis=2)
        j = d.argmin(1)
        rows = np.arange(p.shape[0])
        best, t, foot, cand = d[rows, j], t[rows, j], foot[rows, j], cand[rows, j]
        # an edge not tried has all its points beyond the k-th nearest: nearer only if that is within best + half
        open_ = np.flatnonzero((k < ns) & (dmid[:, -1] <= best + self._half))
        for s in range(0, open_.size, 1024):
            q = open_[s : s + 1024]
            tq, fq = segment_foot(p[q, None, :], self._a[None], self._b[None])
            jq = np.linalg.norm(fq - p[q, None, :], axis=2).argmin(1)
            t[q], foot[q], cand[q] = tq[np.arange(q.size), jq], fq[np.arange(q.size), jq], jq
        return self.boundary_edges[cand], t, foot

    def extension(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``face (n,)``, ``bary (n, 3)``: for uv points outside the domain, the boundary face whose patch
        extends to each with the least extrapolation (the largest smallest barycentric coordinate of the
        point's own uv), among the faces of the :data:`NEAREST_EDGES` boundary edges of nearest midpoints.

        Not the nearest edge's face: a point in the wedge beyond a boundary vertex is equally near both
        edges there (a tie), and their faces may reach it only far out (barycentric -0.95 on the
        rectangle-with-hole at 30 vertices) where a third edge's face, a little farther, covers it
        nearly (-0.09).
        """
        p = as_array(points, "points", (None, 2), finite=True)
        k = min(NEAREST_EDGES, self._a.shape[0])
        cand = self._tree.query(p, k=k)[1].reshape(p.shape[0], k)
        faces = self._face[cand]  # (n, k)
        bary = self.locator.bary_in(faces.ravel(), np.repeat(p, k, axis=0)).reshape(p.shape[0], k, 3)
        j = bary.min(2).argmax(1)
        rows = np.arange(p.shape[0])
        return faces[rows, j], bary[rows, j]

    def turn(self, edge: np.ndarray, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """At an end (``t`` 0 or 1) of boundary ``edge (n,)``: the other boundary edge there and its ``t`` at that vertex."""
        ends = self.tri.edges[edge]
        v = np.where(np.asarray(t) >= 0.5, ends[:, 1], ends[:, 0])
        pair = self._vertex_edges[v]
        other = np.where(pair[:, 0] == edge, pair[:, 1], pair[:, 0])
        return other, np.where(self.tri.edges[other, 0] == v, 0.0, 1.0)

    def beside(self, edge: np.ndarray) -> np.ndarray:
        """``(n, 3)`` each boundary edge of ``edge (n,)`` and the boundary edges beside it along the boundary, at
        its two ends (itself again where a loop has no other)."""
        edge = np.asarray(edge, np.int64)
        at_ends = self._vertex_edges[self.tri.edges[edge]]  # (n, 2 ends, 2 edges)
        other = np.where(at_ends[..., 0] == edge[:, None], at_ends[..., 1], at_ends[..., 0])
        return np.column_stack([edge, np.where(other >= 0, other, edge[:, None])])

    def on_edge(self, edge: np.ndarray, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Face ``(n,)``, barycentric coordinates ``(n, 3)`` and uv ``(n, 2)`` of the points at ``t (n,)``
        along boundary edges ``edge (n,)`` (from ``edges[edge, 0]`` to ``edges[edge, 1]``)."""
        j = np.searchsorted(self.boundary_edges, edge)
        uv = self._a[j] + np.asarray(t)[:, None] * (self._b[j] - self._a[j])
        face = self._face[j]
        bary = np.clip(self.locator.bary_in(face, uv), 0.0, 1.0)
        return face, bary / bary.sum(1, keepdims=True), uv

    def __call__(self, points: np.ndarray, hint: np.ndarray | None = None) -> Located:
        """Face and barycentric coordinates of ``points (n, 2)``, clamping the ones outside; see :class:`Located`.

        ``hint (n,)``: a face to try first for each point (a point inside it, edges included,
        keeps it; the others go through the bucket grid).
        """
        p = as_array(points, "points", (None, 2), finite=True)
        if hint is None:
            face, bary = self.locator(p)
        else:
            face = np.array(hint, np.int64)
            bary = self.locator.bary_in(face, p)
            miss = np.flatnonzero(bary.min(1) < 0.0)
            if miss.size:
                face[miss], bary[miss] = self.locator(p[miss])
        edge = np.full(p.shape[0], -1, np.int64)
        t = np.full(p.shape[0], np.nan)
        out = np.flatnonzero(face < 0)
        if out.size:
            edge[out], t[out], _ = self.project(p[out])
            face[out], bary[out], _ = self.on_edge(edge[out], t[out])
        return Located(face=face, bary=bary, edge=edge, t=t)
