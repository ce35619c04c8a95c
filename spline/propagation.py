"""The propagation scheme as a sparse linear map ``P = M @ free`` (DESIGN.md §3).

Free variables (``nfree`` of them, each a point in R^3):

* per vertex ``v``: the corner point ``z_v`` and two *frame points*
  ``h_v(v + d_v e_x / 5)``, ``h_v(v + d_v e_y / 5)`` of the corner region's affine
  map ``h_v`` (``d_v`` = mean length of the edges at ``v``, so frames are
  well-conditioned); every star point ``f(v^4 w) = h_v(v + (w - v)/5)`` is an
  affine combination of these three;
* the near-corner inner points and middle edge points that the per-vertex
  ``i = 1`` systems leave free (normally all inner points);
* one flip point per interior edge, both middle points and the flip point of
  each boundary edge.

Propagation order: corner regions, then edges, then flips. The ``i = 1``
conditions of the interior edges at a vertex ``s`` couple the middle edge
points ``f(r^2 s^3)`` and the near-corner inner points at ``s``. Instead of
always solving for the middle points (the paper's choice, which divides by a
coefficient that vanishes when two edges through ``s`` are collinear, paper
7.2.2), each vertex system is reduced by Gauss--Jordan elimination with
complete, weighted pivoting: middle points are preferred, an inner point is
computed instead when the middle point's coefficient is small. Only the
equations with such a weak middle-point coefficient need the pivot search:
every other equation pivots on its own middle point, which no other equation
holds (vertices without weak equations take that fast path entirely). A
singular vertex (four edges on two lines) makes its system lose rank by one;
the elimination then leaves one more unknown free, which is exactly the extra
dimension of the spline space there. Every surface ``M @ free`` is exactly C1.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp

from .util import gather as _gather, memory as _memory, parallel as _parallel, sparse as _sparse
from .index import FLIP, INNER, NCTRL
from .net import NetLayout, layout_of, point_index
from .topology import Triangulation

#: Pivots below this (equations are normalised to O(1) coefficients) count as zero.
#: Measured on perturbed alternating and criss-cross grids: with 1e-13 the C1
#: residual stays below 2e-14 (relative) for every perturbation size, while the
#: composed map M stays bounded (the 1/pivot growth cancels in M).
SINGULAR_TOL = 1e-13
#: Pivot preference of inner points relative to middle edge points.
INNER_PIVOT_WEIGHT = 0.2

#: Vertex systems of one shape eliminated together (bounds the batch's temporaries).
SYSTEM_BATCH = 2048
#: Faces per range of the threaded gather in ``SplineSpace.patch_points``.
PATCH_CHUNK = 1 << 14

KIND_CORNER, KIND_FRAME, KIND_INNER, KIND_MID, KIND_FLIP = 0, 1, 2, 3, 4
KIND_NAMES = ("corner", "frame", "inner", "mid", "flip")


def _area(x: np.ndarray, y: np.ndarray, z: np.ndarray) -> np.ndarray:
    """Signed areas of triangles ``(x, y, z)``, each ``(n, 2)``."""
    return 0.5 * ((y[:, 0] - x[:, 0]) * (z[:, 1] - x[:, 1]) - (y[:, 1] - x[:, 1]) * (z[:, 0] - x[:, 0]))


def diamond_coefficients(p: np.ndarray, q: np.ndarray, r: np.ndarray, s: np.ndarray) -> np.ndarray:
    """Normalised coefficients of the C1 relation of a diamond.

    With ``q = λ p + μ r + ν s`` the condition ``X_q - λ X_p - μ X_r - ν X_s = 0``
    is scaled by ``|area(p, r, s)| / (|area(p, r, s)| + |area(q, s, r)|)`` so that
    all coefficients are dimensionless and O(1).

    Returns
    -------
    (n, 4) coefficients of ``(X_q, X_p, X_r, X_s)``; they sum to zero.
    """
    T = _area(p, r, s)
    lam = _area(q, r, s) / T
    mu = _area(p, q, s) / T
    nu = _area(p, r, q) / T
    scale = np.abs(T) / (np.abs(T) + np.abs(_area(q, s, r)))
    return np.column_stack([np.ones_like(lam), -lam, -mu, -nu]) * scale[:, None]


@dataclass(frozen=True, eq=False)
class SplineSpace:
    """The C1 quintic spline space over a triangulation, as ``P = M @ free``.

    Attributes
    ----------
    tri : Triangulation
    layout : NetLayout
    M : scipy.sparse.csr_array (n_points, n_free)
        Rows sum to one (affine combinations).
    point_index : (F, 21) int32 (int64 beyond 2**31 points)
        Global point id of every patch control point.
    corner_free : (V,) int64
        Free index of corner point ``z_v`` (equal to ``v``).
    frame_free : (V, 2) int64
        Free indices of the frame points of vertex ``v``.
    frame_scale : (V,) float64
        ``d_v``: the frame points sit over ``v + d_v e_x / 5`` and ``v + d_v e_y / 5``.
    free_kind : (n_free,) int8
        ``KIND_CORNER``, ``KIND_FRAME``, ``KIND_INNER``, ``KIND_MID`` or ``KIND_FLIP``.
    free_point : (n_free,) int64
        Global point id a free variable *is* (``-1`` for frame points).
    singular_vertices : (σ,) int64
        Vertices whose ``i = 1`` system lost rank (one extra free point each).
    """

    tri: Triangulation
    layout: NetLayout
    M: sp.csr_array
    point_index: np.ndarray
    corner_free: np.ndarray
    frame_free: np.ndarray
    frame_scale: np.ndarray
    free_kind: np.ndarray
    free_point: np.ndarray
    singular_vertices: np.ndarray
    stats: dict = field(default_factory=dict)

    @property
    def n_free(self) -> int:
        return int(self.M.shape[1])

    @property
    def n_points(self) -> int:
        return int(self.M.shape[0])

    @property
    def n_singular(self) -> int:
        return int(self.singular_vertices.size)

    def expected_dimension(self) -> int:
        """``21 F - 11 E_int + 3 V_int + σ``: dimension of the C1 quintic spline space."""
        t = self.tri
        v_int = int((~t.boundary_vertex_mask).sum())
        return 21 * t.n_faces - 11 * int(t.interior_edges.size) + 3 * v_int + self.n_singular

    def points(self, free: np.ndarray) -> np.ndarray:
        """All control points ``(n_points, d)`` from ``free: (n_free, d)``."""
        free = np.asarray(free, dtype=np.float64)
        if free.shape[0] != self.n_free:
            raise ValueError(f"free must have {self.n_free} rows, got {free.shape[0]}")
        return _sparse.matmul(self.M, free)

    def control_points(self, free: np.ndarray) -> np.ndarray:
        """Per-patch control points ``(F, 21, d)`` from ``free: (n_free, d)``.

        Equal to ``patch_points(points(free))``, without the whole net in between: the
        shared points (corners, stars, middle points: ``inner0`` rows) are computed
        first, a face's own inner and flip points straight into its patch, range by
        range (at 1M faces the net in between would be 300 MB of fresh memory; this
        keeps 156 MB).
        """
        free = np.asarray(free, dtype=np.float64)
        if free.shape[0] != self.n_free:
            raise ValueError(f"free must have {self.n_free} rows, got {free.shape[0]}")
        if free.ndim != 2 or not _sparse.kernel_ok(self.M, free):
            return self.patch_points(self.points(free))
        lay, pidx, d = self.layout, self.point_index, free.shape[1]
        shared = _sparse.matmul(self.M, free, rows=(0, lay.inner0))
        xs = np.ascontiguousarray(free).reshape(-1)
        out = np.empty((pidx.shape[0], NCTRL, d))

        def faces(lo: int, hi: int) -> None:
            # own points' ids are >= inner0: clipped to the last shared point, then overwritten
            np.take(shared, pidx[lo:hi].reshape(-1), axis=0, mode="clip", out=out[lo:hi].reshape(-1, d))
            own = np.empty((hi - lo, 3, d))
            for slots, first in ((INNER, lay.inner0), (FLIP, lay.flip0)):
                _sparse.rows_into(self.M, xs, first + 3 * lo, first + 3 * hi, own.reshape(-1, d))
                for k, slot in enumerate(slots):  # basic indexing: a strided copy, no fancy-index loop
                    out[lo:hi, slot] = own[:, k]

        try:
            faces(0, min(1, pidx.shape[0]))  # a kernel that refuses the call fails here, alone
        except (TypeError, ValueError, AttributeError):  # pragma: no cover - scipy changed its private API
            return self.patch_points(self.points(free))
        with _parallel.Workers(pidx.shape[0]) as work:
            work.map(faces, pidx.shape[0], chunk=PATCH_CHUNK)
        return out

    def patch_points(self, points: np.ndarray) -> np.ndarray:
        """Gather a net ``points: (n_points, d)`` into per-patch ``(F, 21, d)``."""
        points = np.asarray(points)
        if points.shape[0] != self.n_points:
            raise ValueError(f"points must have {self.n_points} rows, got {points.shape[0]}")
        pidx = self.point_index
        out = np.empty(pidx.shape + points.shape[1:], points.dtype)

        def gather(lo: int, hi: int) -> None:
            # np.take along axis 0 copies whole rows: ~3x faster than points[point_index];
            # each range also first-touches its own part of the output
            np.take(points, pidx[lo:hi].reshape(-1), axis=0, mode="clip",
                    out=out[lo:hi].reshape((-1,) + points.shape[1:]))

        with _parallel.Workers(pidx.shape[0]) as work:
            work.map(gather, pidx.shape[0], chunk=PATCH_CHUNK)
        return out

    def free_from_points(self, points: np.ndarray) -> np.ndarray:
        """Read the free variables off a full C1 net ``(n_points, d)``.

        Free control points are read directly; frame points are recovered from
        the star points (least squares over each vertex's stars, exact for a C1 net).
        """
        points = np.asarray(points, dtype=np.float64)
        out = np.zeros((self.n_free,) + points.shape[1:])
        is_pt = self.free_point >= 0
        out[is_pt] = points[self.free_point[is_pt]]
        # frames: solve star = (1-a-b) z + a p1 + b p2 for p1, p2 per vertex (least squares)
        t, lay = self.tri, self.layout
        e = np.arange(t.n_edges)
        rows_v, rows_w, rows_pt = [], [], []
        for end in (0, 1):
            rows_v.append(t.edges[:, end])
            rows_w.append(t.edges[:, 1 - end])
            rows_pt.append(lay.star(e, end))
        v = np.concatenate(rows_v)
        w = np.concatenate(rows_w)
        pt = np.concatenate(rows_pt)
        d = (_gather.rows(t.uv, w) - _gather.rows(t.uv, v)) / self.frame_scale[v, None]  # (2E, 2): (alpha, beta)
        rhs = points[pt] - points[v]  # = alpha (p1 - z) + beta (p2 - z)
        nv = t.n_vertices
        G = np.zeros((nv, 2, 2))
        np.add.at(G, v, d[:, :, None] * d[:, None, :])
        B = np.zeros((nv, 2) + points.shape[1:])
        np.add.at(B, v, d.reshape(d.shape + (1,) * (points.ndim - 1)) * rhs[:, None])
        sol = np.linalg.solve(G, B.reshape(nv, 2, -1)).reshape(B.shape)
        out[self.frame_free[:, 0]] = points[:nv] + sol[:, 0]
        out[self.frame_free[:, 1]] = points[:nv] + sol[:, 1]
        return out


def _diamond_ids(tri: Triangulation, e: np.ndarray) -> tuple[np.ndarray, ...]:
    """For interior edges ``e = (a, b)``: ``a, b, f0, f1, k0, k1``.

    ``f0`` is the face left of ``a -> b`` with ``a, b`` at its local corners
    ``k0 + 1, k0 + 2``; in ``f1`` they sit at ``k1 + 2, k1 + 1``. The diamond's
    outer vertices are ``p = F[f0, k0]`` and ``q = F[f1, k1]``.
    """
    ab, ef, eo = (_gather.rows(table, e) for table in (tri.edges, tri.edge_faces, tri.edge_opposite))
    return ab[:, 0], ab[:, 1], ef[:, 0], ef[:, 1], eo[:, 0], eo[:, 1]


def _weak(c_mid: np.ndarray, c_q: np.ndarray, c_p: np.ndarray, inner_weight: float, tol: float) -> np.ndarray:
    """Equations whose middle point is no good pivot: its coefficient ``c_mid`` is below
    ``inner_weight`` times the larger inner-point coefficient, or below ``tol``."""
    cm = np.abs(c_mid)
    return ~((cm >= inner_weight * np.maximum(np.abs(c_q), np.abs(c_p))) & (cm > tol))


def _flip_pair(lay: NetLayout, f0: np.ndarray, k0: np.ndarray, f1: np.ndarray, k1: np.ndarray,
               c: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The two flips of interior edges: ``(computed, free, q_side_computed)``.

    Of the flips ``f(p ...)`` (face ``f0``) and ``f(q ...)`` (face ``f1``) of a diamond with
    coefficients ``c: (n, 4)`` of ``(q, p, r, s)``, the one with the larger coefficient is
    computed (no division by a small number); the other is free.
    """
    q_dep = np.abs(c[:, 0]) >= np.abs(c[:, 1])
    flip_p, flip_q = lay.flip(f0, k0), lay.flip(f1, k1)
    return np.where(q_dep, flip_q, flip_p), np.where(q_dep, flip_p, flip_q), q_dep


def _star_weights(uv: np.ndarray, frame_scale: np.ndarray, s: np.ndarray, w: np.ndarray) -> np.ndarray:
    """Weights of ``(z_s, frame_s,x, frame_s,y)`` in the star points ``f(s^4 w)``, ``(..., 3)``.

    A star is affine in its vertex's frame: ``f(s^4 w) = (1 - x - y) z_s + x frame_s,x
    + y frame_s,y`` with ``(x, y) = (w - s) / d_s``; ``s, w`` are vertex ids of one shape.
    """
    out = np.empty(s.shape + (3,))
    np.subtract(_gather.rows(uv, w), _gather.rows(uv, s), out=out[..., 1:])
    out[..., 1:] /= frame_scale[s][..., None]
    np.subtract(1.0, out[..., 1], out=out[..., 0])
    out[..., 0] -= out[..., 2]
    return out


@dataclass
class _Eliminated:
    """What the eliminated vertex systems contribute, one list entry per batch.

    A dependent point's row is ``sum a_vals * (free point a_cols) + frame @ (z_s, frame_s)``:
    its free inner/middle points, then its star points already expanded into the
    three free frame variables of its vertex ``s`` (so a row has no duplicate columns).
    """

    dep: list = field(default_factory=list)  # (n,) dependent point ids
    n_a: list = field(default_factory=list)  # (n,) free-point entries per row
    a_cols: list = field(default_factory=list)  # (sum n_a,) point ids of free points, row after row
    a_vals: list = field(default_factory=list)
    frame: list = field(default_factory=list)  # (n, 3) weights of z_s and the two frame points
    vertex: list = field(default_factory=list)  # (n,) the vertex s of each row
    free: list = field(default_factory=list)  # point ids left free
    singular: list = field(default_factory=list)
    max_coef: float = 0.0
    n_systems: int = 0
def _eliminate(A: np.ndarray, K: np.ndarray, weight: np.ndarray, tol: float, search: np.ndarray) -> np.ndarray:
    """Batched Gauss--Jordan with weighted complete pivoting over the ``search`` rows, in place.

    Rows outside ``search`` pivot on their own middle point, column ``c - m + row``: a
    middle point lives in its own equation only, so those pivots never change another
    row and need no elimination step; the search rows (the equations whose middle-point
    coefficient is weak) are reduced among themselves, and their pivot columns are
    eliminated from every row. The result is the reduced row echelon form for that
    pivot set.

    Parameters
    ----------
    A : (B, m, c) coefficients of the unknowns; K : (B, m, m) of the known points.
    weight : (c,) pivot preference per column.
    search : (B, m) bool, the rows whose pivot is searched; every system has the same
        number of them.

    Returns
    -------
    piv_col : (B, m) pivot column of each row, -1 for search rows left without a pivot
        (linearly dependent on the others).
    """
    nb, m, c = A.shape
    piv_col = np.full((nb, m), -1, np.int64)
    row_done = ~search
    active = np.ones(nb, bool)
    bidx = np.arange(nb)
    n_search = int(search.sum(1).max(initial=0))
    for _ in range(n_search):
        # available entries: search rows not yet pivoted. A pivot's column is exactly zero in
        # every other row after its elimination step, so used columns need no mask of their own.
        mag = np.abs(A)
        mag[row_done] = 0.0
        raw_max = mag.reshape(nb, -1).max(axis=1)
        active &= raw_max > tol
        if not active.any():
            break
        mag *= weight
        flat = np.argmax(mag.reshape(nb, -1), axis=1)
        r, col = np.divmod(flat, c)
        b = bidx[active]
        r, col = r[active], col[active]
        piv = A[b, r, col]
        A[b, r, :] /= piv[:, None]
        K[b, r, :] /= piv[:, None]
        f = A[b, :, col].copy()  # (nb_active, m) multipliers
        f[np.arange(b.size), r] = 0.0
        if b.size == nb:  # all systems still active: update in place (no gather/scatter copies)
            A -= f[:, :, None] * A[b, r, None, :]
            K -= f[:, :, None] * K[b, r, None, :]
        else:
            A[b] -= f[:, :, None] * A[b, r, None, :]
            K[b] -= f[:, :, None] * K[b, r, None, :]
        A[b, :, col] = 0.0
        A[b, r, col] = 1.0
        row_done[b, r] = True
        piv_col[b, r] = col
    # the other rows: their own middle point (its coefficient passed the pivot test)
    rows = np.arange(m)
    own = np.where(search, 1.0, A[:, rows, c - m + rows])  # (B, m): dividing by 1 changes nothing
    A /= own[:, :, None]
    K /= own[:, :, None]
    np.copyto(piv_col, c - m + rows, where=~search)
    return piv_col


@dataclass(frozen=True)
class _Systems:
    """The flagged vertices' ``i = 1`` systems, read off the vertex fans, eliminated in batches.

    The system of vertex ``s`` has one unknown inner point per corner of its fan (in
    counter-clockwise order) and one equation per interior edge at ``s``: the edge
    between fan corners ``j`` and ``j + 1`` couples their two inner points with its
    middle point and its star. ``verts``: flagged vertices grouped by shape (corner
    count, equation count, weak equation count), increasing inside a group.
    """

    tri: Triangulation
    lay: NetLayout
    c2: np.ndarray  # (n_ie, 4) diamond coefficients of (q, p, r, s), by position in ie
    ie_pos: np.ndarray  # (E,) position of an interior edge in ie
    frame_scale: np.ndarray
    verts: np.ndarray  # (n,) flagged vertices
    n_c: np.ndarray  # (V,) corners per vertex
    n_e: np.ndarray  # (V,) interior edges (= equations) per vertex
    singular_tol: float
    inner_weight: float

    def batch(self, p0: int, p1: int) -> tuple:
        """Eliminate the systems of the vertices ``verts[p0:p1]`` (all of one shape)."""
        tri, lay = self.tri, self.lay
        verts = self.verts[p0:p1]
        nc, m, nb = int(self.n_c[verts[0]]), int(self.n_e[verts[0]]), verts.size
        corners = tri.fan_corners[tri.fan_ptr[verts][:, None] + np.arange(nc)]  # (nb, nc)
        f, k = np.divmod(corners[:, :m], 3)
        e = _gather.at(tri.face_edges, f, (k + 1) % 3)  # (nb, m): the edge from s shared by corners j and j+1
        ab = _gather.rows(tri.edges, e)  # (nb, m, 2)
        end = (ab[..., 1] == verts[:, None]).astype(np.int64)  # s = b: end 1
        c = _gather.rows(self.c2, self.ie_pos[e])  # (nb, m, 4): (q, p, r, s)
        # at end 1 (s = b) the middle point is the r column and the star the s column; at end 0
        # the other way. Corner j's face is the diamond's p side (f0) or its q side (f1).
        on_p = _gather.at(tri.edge_faces, e, 0) == f
        j = np.arange(m)
        j1 = (j + 1) % nc
        col_p = np.where(on_p, j, j1)
        col_q = np.where(on_p, j1, j)
        c_mid = np.where(end == 1, c[..., 2], c[..., 3])
        c_star = np.where(end == 1, c[..., 3], c[..., 2])
        weak = _weak(c_mid, c[..., 0], c[..., 1], self.inner_weight, self.singular_tol)  # as in the diamonds stage
        # global ids of the unknowns: inner points (by fan position) then middle points (by row)
        col_pid = np.empty((nb, nc + m), np.int64)
        col_pid[:, :nc] = lay.inner0 + corners
        col_pid[:, nc:] = lay.mid(e, end)
        A = np.zeros((nb, m, nc + m))
        K = np.zeros((nb, m, m))
        bi = np.arange(nb)[:, None]
        A[bi, j, col_q] = c[..., 0]  # the two inner points are different corners: set once each
        A[bi, j, col_p] = c[..., 1]
        A[bi, j, nc + j] = c_mid
        K[:, j, j] = c_star
        weight = np.concatenate([np.full(nc, self.inner_weight), np.ones(m)])
        piv = _eliminate(A, K, weight, self.singular_tol, weak)
        lost = (piv < 0).sum(1)  # singular vertices: rows without pivot
        singular = np.repeat(verts[lost > 0], lost[lost > 0])
        is_piv_col = np.zeros((nb, nc + m), bool)
        pb, pr = np.nonzero(piv >= 0)
        is_piv_col[pb, piv[pb, pr]] = True
        # dependent rows: unknown[piv] = -sum_j A[r, j] u_j - sum_k K[r, k] star_k (j free columns);
        # every star of the vertex is affine in its frame, so the star part collapses to 3 weights
        dep = col_pid[pb, piv[pb, pr]]
        Ar = A[pb, pr]  # (npiv, c)
        Ar[is_piv_col[pb]] = 0.0
        ja, ca = np.nonzero(Ar)
        w = np.where(end == 1, ab[..., 0], ab[..., 1])  # (nb, m) far ends of the edges
        sv = _star_weights(tri.uv, self.frame_scale, np.broadcast_to(verts[:, None], w.shape), w)
        frame = -K[:, :, 0, None] * sv[:, None, 0]  # (nb, m, 3)
        for i in range(1, m):  # a fixed summation order: batching cannot change a bit
            frame -= K[:, :, i, None] * sv[:, None, i]
        Kr = K if pb.size == K.shape[0] * m else K[pb, pr]  # the rows with a pivot
        big = max(float(np.abs(Ar).max()), float(np.abs(Kr).max())) if Ar.size else 0.0
        return (singular, col_pid[~is_piv_col], dep, np.bincount(ja, minlength=pb.size),
                col_pid[pb[ja], ca], -Ar[ja, ca], frame[pb, pr], verts[pb], big)


def _vertex_systems(work: _parallel.Workers, tri: Triangulation, lay: NetLayout, ie: np.ndarray, c2: np.ndarray,
                    frame_scale: np.ndarray, n_weak: np.ndarray, singular_tol: float,
                    inner_weight: float) -> _Eliminated:
    """Reduce the ``i = 1`` systems of the vertices with weak equations (``n_weak: (V,)`` > 0).

    Systems of one shape (corner count, equation count, weak equation count) are
    eliminated together, in batches of at most ``SYSTEM_BATCH`` vertices (small
    temporaries; batches run in threads). Each system is gathered from its vertex's
    fan: no global sort of equations or corners.
    """
    verts = np.flatnonzero(n_weak)
    out = _Eliminated(n_systems=int(verts.size))
    if out.n_systems == 0:
        return out
    n_c = np.diff(tri.fan_ptr)
    n_e = n_c - tri.boundary_vertex_mask
    # flagged vertices grouped by system shape, increasing inside a group
    big = int(n_c.max(initial=0)) + 1
    shape_key = (n_c[verts] * big + n_e[verts]) * big + n_weak[verts]
    order = np.argsort(shape_key, kind="stable")
    verts = verts[order]
    _, g_first, g_count = np.unique(shape_key[order], return_index=True, return_counts=True)
    ie_pos = np.cumsum(~tri.boundary_edge_mask, dtype=_memory.index_dtype(ie.size)) - 1
    systems = _Systems(tri=tri, lay=lay, c2=c2, ie_pos=ie_pos, frame_scale=frame_scale, verts=verts, n_c=n_c, n_e=n_e,
                       singular_tol=singular_tol, inner_weight=inner_weight)
    futures = [work.submit(systems.batch, int(g0 + lo), int(g0 + hi))
               for g0, gn in zip(g_first, g_count) for lo, hi in _parallel.ranges(int(gn), SYSTEM_BATCH)]
    for fut in futures:  # in group and position order: the output does not depend on the batching
        singular, free, dep, n_a, a_cols, a_vals, frame, vertex, big_coef = fut.result()
        if singular.size:
            out.singular.append(singular)
        out.free.append(free)
        out.dep.append(dep)
        out.n_a.append(n_a)
        out.a_cols.append(a_cols)
        out.a_vals.append(a_vals)
        out.frame.append(frame)
        out.vertex.append(vertex)
        out.max_coef = max(out.max_coef, big_coef)
    return out


def build_space(
    uv: np.ndarray | Triangulation,
    faces: np.ndarray | None = None,
    *,
    singular_tol: float = SINGULAR_TOL,
    inner_weight: float = INNER_PIVOT_WEIGHT,
) -> SplineSpace:
    """Build the free-to-control map of the C1 quintic spline space.

    Parameters
    ----------
    uv : (V, 2) float or a :class:`Triangulation`
    faces : (F, 3) int, counter-clockwise in uv (omit when passing a Triangulation)

    Returns
    -------
    SplineSpace

    Notes
    -----
    The per-edge stages (diamonds, fast-path rows, flips) and the writing of
    ``M`` run on ranges of edges in a thread per core; every range writes its
    own entries, so the result does not depend on the thread count.
    """
    clock = [time.perf_counter()]
    timings: dict[str, float] = {}

    def tick(name: str) -> None:
        now = time.perf_counter()
        timings[name] = timings.get(name, 0.0) + now - clock[0]
        clock[0] = now

    tri = uv if isinstance(uv, Triangulation) else Triangulation(uv, faces)
    _ = tri.edges, tri.edge_faces, tri.face_edges
    tick("triangulation")
    lay = layout_of(tri)
    F, UV = tri.faces, tri.uv
    nv, npts = tri.n_vertices, lay.n_points
    edges = tri.edges
    ie = tri.interior_edges
    n_ie = ie.size

    with _parallel.Workers(max(n_ie, tri.n_faces)) as work:
        pidx_job = work.submit(point_index, tri)  # independent of everything below

        # ---- frame scale: mean incident edge length
        elen = np.linalg.norm(_gather.rows(UV, edges[:, 0]) - _gather.rows(UV, edges[:, 1]), axis=1)
        frame_scale = np.bincount(edges.ravel(), weights=np.repeat(elen, 2), minlength=nv) / np.bincount(
            edges.ravel(), minlength=nv
        )
        del elen

        # ---- one diamond per interior edge (p, q, r = a, s = b): the i = 1 equation at end 1
        # and the flips' i = 2 condition; the equation at end 0 (r = b, s = a) has the r and s
        # coefficients swapped (the signed areas change sign exactly: bit-identical).
        # Columns of c2: (q, p, r, s). A vertex needs elimination when one of its equations'
        # middle-point coefficient fails the pivot preference; elsewhere weighted complete
        # pivoting would pick every middle point (a middle column lives in one row only).
        c2 = _memory.empty((n_ie, 4))

        def diamonds(lo: int, hi: int) -> np.ndarray:
            a, b, f0, f1, k0, k1 = _diamond_ids(tri, ie[lo:hi])
            p, q = _gather.at(F, f0, k0), _gather.at(F, f1, k1)
            c = diamond_coefficients(*(_gather.rows(UV, v) for v in (p, q, a, b)))
            c2[lo:hi] = c
            return np.concatenate([s[_weak(c[:, mid_col], c[:, 0], c[:, 1], inner_weight, singular_tol)]
                                   for s, mid_col in ((a, 3), (b, 2))])

        n_weak = np.bincount(_parallel.concat(work.map(diamonds, n_ie)), minlength=nv)  # weak equations per vertex
        bad_v = n_weak > 0
        tick("diamonds")

        # ---- which points are free, and the row length of every point in M
        is_free = _memory.full(npts, False, bool)  # besides the corners (free ids 0..V-1)
        length = _memory.full(npts, 0, np.int32)  # a row holds at most 1 + 2 * (longest middle row) entries

        def classify(lo: int, hi: int) -> None:
            e = ie[lo:hi]
            a, b, f0, f1, k0, k1 = _diamond_ids(tri, e)
            fast_a, fast_b = ~bad_v[a], ~bad_v[b]
            length[lay.mid(e[fast_a], 0)] = 5  # two inner points and the star
            length[lay.mid(e[fast_b], 1)] = 5
            is_free[_flip_pair(lay, f0, k0, f1, k1, c2[lo:hi])[1]] = True

        work.map(classify, n_ie)
        tick("classify")
        elim = _vertex_systems(work, tri, lay, ie, c2, frame_scale, n_weak, singular_tol, inner_weight)
        tick("elimination")
        is_free[lay.inner0 : lay.flip0] = ~bad_v[F.ravel()]  # all inner points at fast-path vertices
        for pts in elim.free:
            is_free[pts] = True
        # boundary edges: both middle points and the face's flip are free
        be = tri.boundary_edges
        side = (tri.edge_faces[be, 0] < 0).astype(np.int64)
        bf, bk = tri.edge_faces[be, side], tri.edge_opposite[be, side]
        is_free[lay.mid(be, 0)] = True
        is_free[lay.mid(be, 1)] = True
        is_free[lay.flip(bf, bk)] = True
        free_pts = np.flatnonzero(is_free)
        n_free = 3 * nv + free_pts.size
        free_of_point = _memory.full(npts, -1, _memory.index_dtype(npts, n_free))
        free_of_point[:nv] = np.arange(nv)
        free_of_point[free_pts] = np.arange(3 * nv, n_free)
        tick("free_points")

        M, max_coef = _assemble(work, tri, lay, ie, c2, bad_v, frame_scale, free_pts, free_of_point,
                                n_free, length, elim)
        max_coef = max(max_coef, elim.max_coef)
        tick("write_M")
        pidx = pidx_job.result()
    free_kind = np.empty(n_free, np.int8)
    free_kind[:nv] = KIND_CORNER
    free_kind[nv : 3 * nv] = KIND_FRAME
    free_kind[3 * nv :] = np.array([KIND_MID, KIND_INNER, KIND_FLIP], np.int8)[
        np.searchsorted([lay.inner0, lay.flip0], free_pts, side="right")]
    free_point = np.concatenate([np.arange(nv), np.full(2 * nv, -1, np.int64), free_pts])
    frame_free = nv + 2 * np.arange(nv)[:, None] + np.arange(2)[None, :]
    sing = np.sort(np.concatenate(elim.singular)) if elim.singular else np.zeros(0, np.int64)
    tick("finish")
    return SplineSpace(
        tri=tri,
        layout=lay,
        M=M,
        point_index=pidx,
        corner_free=np.arange(nv),
        frame_free=frame_free,
        frame_scale=frame_scale,
        free_kind=free_kind,
        free_point=free_point,
        singular_vertices=sing,
        stats=dict(max_coefficient=max(float(M.data.max(initial=0.0)), -float(M.data.min(initial=0.0))),
                   max_elimination_coefficient=max_coef,
                   nnz=int(M.nnz), eliminated_vertices=elim.n_systems, timings=timings),
    )


def _assemble(work: _parallel.Workers, tri: Triangulation, lay: NetLayout, ie: np.ndarray, c2: np.ndarray,
              bad_v: np.ndarray, frame_scale: np.ndarray, free_pts: np.ndarray, free_of_point: np.ndarray,
              n_free: int, length: np.ndarray, elim: _Eliminated) -> tuple[sp.csr_array, float]:
    """Write ``M`` straight into CSR arrays, class by class; also the largest coefficient.

    Every point's row length is known before any value is written: 1 for free
    points, 3 for stars (affine in their vertex's frame), 5 for middle points of
    the fast path (two inner points and a star), the reduced row for points of an
    eliminated vertex system, and ``1 + len(mid_r) + len(mid_s)`` for computed
    flips. Flips depend only on middle rows, so they are copied from the rows
    already written. No COO sort, no sparse products.
    ``length``: (n_points,) int32 with the fast-path middle rows already set to 5.
    """
    nv, npts, edges, UV = tri.n_vertices, lay.n_points, tri.edges, tri.uv

    # rows of eliminated vertex systems: free inner/middle points, then z_s and the frame
    s_dep, s_na, s_vertex = (_parallel.concat(x) for x in (elim.dep, elim.n_a, elim.vertex))
    s_cols = free_of_point[_parallel.concat(elim.a_cols)]
    s_vals = _parallel.concat(elim.a_vals, np.float64)
    s_frame = np.concatenate(elim.frame) if elim.frame else np.zeros((0, 3))
    if (s_cols < 0).any():  # pragma: no cover - internal consistency
        raise AssertionError("an eliminated point references a dependent point")
    s_ptr = np.zeros(s_dep.size + 1, np.int64)
    np.cumsum(s_na, out=s_ptr[1:])
    length[s_dep] = s_na + 3

    length[:nv] = 1
    length[free_pts] = 1
    length[lay.star0 : lay.mid0] = 3

    def flip_ids(lo: int, hi: int) -> tuple[np.ndarray, ...]:
        """Edges lo:hi, their computed and free flips, which side is computed, the diamonds."""
        e = ie[lo:hi]
        _, _, f0, f1, k0, k1 = _diamond_ids(tri, e)
        c = c2[lo:hi]
        return (e, *_flip_pair(lay, f0, k0, f1, k1, c), c)

    def flip_lengths(lo: int, hi: int) -> None:
        e, dep, _, _, _ = flip_ids(lo, hi)
        length[dep] = 1 + length[lay.mid(e, 0)] + length[lay.mid(e, 1)]

    work.map(flip_lengths, ie.size)
    nnz = int(length.sum(dtype=np.int64))
    idx_t = _memory.index_dtype(nnz, n_free, npts)
    indptr = _memory.full(npts + 1, 0, idx_t)
    np.cumsum(length, dtype=idx_t, out=indptr[1:])
    data = _memory.empty(nnz)
    indices = _memory.empty(nnz, idx_t)

    # corners and stars occupy the first ids with fixed lengths 1 and 3: one contiguous block
    data[:nv] = 1.0
    indices[:nv] = np.arange(nv)

    def stars(lo: int, hi: int) -> None:
        """Rows of the stars of edges lo:hi (star 2 e + end at s = edges[e, end]): z_s and its frame."""
        ab = edges[lo:hi]
        data[nv + 6 * lo : nv + 6 * hi].reshape(-1, 2, 3)[:] = _star_weights(UV, frame_scale, ab, ab[:, ::-1])
        cols = indices[nv + 6 * lo : nv + 6 * hi].reshape(-1, 2, 3)
        cols[..., 0] = ab
        np.multiply(ab, 2, out=cols[..., 1], casting="same_kind")
        cols[..., 1] += nv
        np.add(cols[..., 1], 1, out=cols[..., 2])

    rest = free_pts[free_pts >= lay.mid0]

    def free_rows(lo: int, hi: int) -> None:
        start = indptr[rest[lo:hi]]
        data[start] = 1.0
        indices[start] = free_of_point[rest[lo:hi]]

    work.map(stars, tri.n_edges)
    work.map(free_rows, rest.size)

    def fast_rows(lo: int, hi: int) -> float:
        """Middle point = w_q inner_q + w_p inner_p + w_s star, at both ends of edges lo:hi."""
        e = ie[lo:hi]
        a, b, f0, f1, k0, k1 = _diamond_ids(tri, e)
        c = c2[lo:hi]
        big = 0.0
        # end 0 (s = a): mid coefficient c[:, 3], star c[:, 2]; end 1 (s = b): the other way
        for end, s, mid_col, star_col, kp, kq in ((0, a, 3, 2, (k0 + 1) % 3, (k1 + 2) % 3),
                                                   (1, b, 2, 3, (k0 + 2) % 3, (k1 + 1) % 3)):
            ok = np.flatnonzero(~bad_v[s])
            if ok.size == 0:
                continue
            co = _gather.rows(c, ok)
            neg = -co[:, mid_col]
            w = [co[:, 0] / neg, co[:, 1] / neg, co[:, star_col] / neg]  # (inner_q, inner_p, star)
            big = max(big, *(float(np.abs(x).max()) for x in w))
            eo = e[ok]
            start = indptr[lay.mid(eo, end)]
            star_at = nv + 3 * (2 * eo + end)  # the star's row in the stars block
            data[start] = w[0]
            indices[start] = free_of_point[lay.inner(f1[ok], kq[ok])]
            data[start + 1] = w[1]
            indices[start + 1] = free_of_point[lay.inner(f0[ok], kp[ok])]
            for j in range(3):
                data[start + 2 + j] = w[2] * data[star_at + j]
                indices[start + 2 + j] = indices[star_at + j]
        return big

    max_coef = max(work.map(fast_rows, ie.size), default=0.0)

    def eliminated_rows(lo: int, hi: int) -> None:
        start = indptr[s_dep[lo:hi]]
        a0, a1 = s_ptr[lo], s_ptr[hi]
        n_a = s_na[lo:hi]
        owner = np.repeat(np.arange(hi - lo), n_a)
        pos = start[owner] + (np.arange(a0, a1) - s_ptr[lo:hi][owner])
        data[pos] = s_vals[a0:a1]
        indices[pos] = s_cols[a0:a1]
        at, v = start + n_a, s_vertex[lo:hi]
        for j, col in enumerate((v, nv + 2 * v, nv + 2 * v + 1)):
            data[at + j] = s_frame[lo:hi, j]
            indices[at + j] = col

    work.map(eliminated_rows, s_dep.size)

    def flip_rows(lo: int, hi: int) -> float:
        """Computed flip = w_o other + w_r row(mid_r) + w_s row(mid_s); middle rows are
        copied grouped by their length (1 free, 5 fast path, a few others)."""
        e, dep, other, q_dep, c = flip_ids(lo, hi)
        c_dep = np.where(q_dep, c[:, 0], c[:, 1])
        c_oth = np.where(q_dep, c[:, 1], c[:, 0])
        w = [-c_oth / c_dep, -c[:, 2] / c_dep, -c[:, 3] / c_dep]
        start = indptr[dep]
        data[start] = w[0]
        indices[start] = free_of_point[other]
        offset = start + 1
        for mid, wk in ((lay.mid(e, 0), w[1]), (lay.mid(e, 1), w[2])):
            mlen = length[mid]
            for L in np.flatnonzero(np.bincount(mlen)):
                sel = np.flatnonzero(mlen == L)
                src, dst, wsel = indptr[mid[sel]], offset[sel], wk[sel]
                for j in range(int(L)):
                    data[dst + j] = wsel * data[src + j]
                    indices[dst + j] = indices[src + j]
            offset += mlen
        return max(float(np.abs(x).max(initial=0.0)) for x in w)

    max_coef = max([max_coef] + work.map(flip_rows, ie.size))
    M = sp.csr_array((data, indices, indptr), shape=(npts, n_free))
    _sparse.sort_indices(M, work)
    M.eliminate_zeros()
    return M, max_coef
