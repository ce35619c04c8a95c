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
computed instead when the middle point's coefficient is small. A singular
vertex (four edges on two lines) makes its system lose rank by one; the
elimination then leaves one more unknown free, which is exactly the extra
dimension of the spline space there. Every surface ``M @ free`` is exactly C1.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp

from . import _memory
from .net import NetLayout, layout_of, point_index
from .topology import Triangulation

#: Pivots below this (equations are normalised to O(1) coefficients) count as zero.
#: Measured on perturbed alternating and criss-cross grids: with 1e-13 the C1
#: residual stays below 2e-14 (relative) for every perturbation size, while the
#: composed map M stays bounded (the 1/pivot growth cancels in M).
SINGULAR_TOL = 1e-13
#: Pivot preference of inner points relative to middle edge points.
INNER_PIVOT_WEIGHT = 0.2

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
    point_index : (F, 21) int64
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
        return self.M @ free

    def control_points(self, free: np.ndarray) -> np.ndarray:
        """Per-patch control points ``(F, 21, d)`` from ``free: (n_free, d)``."""
        return self.patch_points(self.points(free))

    def patch_points(self, points: np.ndarray) -> np.ndarray:
        """Gather a net ``points: (n_points, d)`` into per-patch ``(F, 21, d)``."""
        points = np.asarray(points)
        if points.shape[0] != self.n_points:
            raise ValueError(f"points must have {self.n_points} rows, got {points.shape[0]}")
        # np.take along axis 0 copies whole rows: ~3x faster than points[point_index]
        out = _memory.empty(self.point_index.shape + points.shape[1:], points.dtype)
        np.take(points, self.point_index.reshape(-1), axis=0, out=out.reshape((-1,) + points.shape[1:]), mode="clip")
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
        d = (t.uv[w] - t.uv[v]) / self.frame_scale[v, None]  # (2E, 2) = (alpha, beta)
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


def _cat(parts: list[np.ndarray], dtype=None) -> np.ndarray:
    return np.concatenate(parts) if parts else np.zeros(0, dtype or np.float64)


def _ragged_gather(indptr: np.ndarray, rows: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Positions of all entries of CSR ``rows`` and the index of the row each came from."""
    start = indptr[rows]
    length = indptr[rows + 1] - start
    owner = np.repeat(np.arange(rows.size), length)
    offs = np.arange(owner.size) - np.repeat(np.cumsum(length) - length, length)
    return start[owner] + offs, owner


def _compose(lay: NetLayout, nv: int, edges: np.ndarray, UV: np.ndarray, frame_scale: np.ndarray,
             free_of_point: np.ndarray, n_free: int, fast: dict, slow: tuple, flips: dict) -> sp.csr_array:
    """Write ``M`` straight into CSR arrays, class by class.

    Every point's row length is known before any value is written: 1 for free
    points, 3 for stars (affine in their vertex's frame), 5 for middle points of
    the fast path (two inner points and a star), the reduced row for points of an
    eliminated vertex system, and ``1 + len(mid_r) + len(mid_s)`` for computed
    flips. Flips have the highest ids and depend only on earlier rows, so they
    are gathered from the rows already written. No COO sort, no sparse products.
    """
    npts = lay.n_points
    # star 2e + end sits at vertex s = edges[e, end] towards w = edges[e, 1 - end]
    star_s, star_w = edges.reshape(-1), edges[:, ::-1].reshape(-1)
    star_vals = np.empty((star_s.size, 3))
    np.subtract(UV[star_w], UV[star_s], out=star_vals[:, 1:])
    star_vals[:, 1:] /= frame_scale[star_s, None]
    np.subtract(1.0, star_vals[:, 1], out=star_vals[:, 0])
    star_vals[:, 0] -= star_vals[:, 2]
    col_t = free_of_point.dtype
    star_cols = np.empty((star_s.size, 3), col_t)
    star_cols[:, 0] = star_s
    np.multiply(star_s, 2, out=star_cols[:, 1], casting="same_kind")
    star_cols[:, 1] += nv
    np.add(star_cols[:, 1], 1, out=star_cols[:, 2])
    del star_w

    # points of eliminated vertex systems: expand star references into frames
    rows, cols, vals = (_cat(x, np.int64 if k < 2 else None) for k, x in enumerate(slow))
    is_star = (cols >= lay.star0) & (cols < lay.mid0)
    k = cols[is_star] - lay.star0
    s_rows = np.concatenate([rows[~is_star], np.repeat(rows[is_star], 3)])
    s_cols = np.concatenate([free_of_point[cols[~is_star]], star_cols[k].ravel()])
    s_vals = np.concatenate([vals[~is_star], (vals[is_star, None] * star_vals[k]).ravel()])
    if (s_cols < 0).any():  # pragma: no cover - internal consistency
        raise AssertionError("an eliminated point references a dependent point")
    s_ids, s_local = np.unique(s_rows, return_inverse=True)
    S = sp.csr_array((s_vals, (s_local, s_cols)), shape=(s_ids.size, n_free))
    S.sum_duplicates()

    length = np.zeros(npts, np.int32)  # a row holds at most 1 + 2 * (longest middle row) entries
    free_pts = np.flatnonzero(free_of_point >= 0)
    length[free_pts] = 1
    length[lay.star0 : lay.mid0] = 3
    length[fast["rows"]] = 5
    length[s_ids] = np.diff(S.indptr)
    length[flips["rows"]] = 1 + length[flips["mid_r"]] + length[flips["mid_s"]]
    nnz = int(length.sum(dtype=np.int64))
    idx_t = _memory.index_dtype(nnz, n_free, npts)
    indptr = np.zeros(npts + 1, idx_t)
    np.cumsum(length, dtype=idx_t, out=indptr[1:])
    data = _memory.empty(nnz)
    indices = _memory.empty(nnz, idx_t)

    def put_columns(row_ids, cols, vals):
        """Rows of fixed width, one scatter per column (no (n, width) temporaries)."""
        start = indptr[row_ids]
        for j, (c, v) in enumerate(zip(cols, vals)):
            data[start + j] = v
            indices[start + j] = c

    # corners and stars occupy the first ids with fixed lengths 1 and 3: one contiguous block
    head = indptr[lay.mid0]
    data[:nv] = 1.0
    indices[:nv] = np.arange(nv)
    data[nv:head] = star_vals.ravel()
    indices[nv:head] = star_cols.ravel()
    rest = free_pts[free_pts >= lay.mid0]
    put_columns(rest, [free_of_point[rest]], [1.0])
    ks = fast["star"] - lay.star0
    w = fast["w"]
    put_columns(
        fast["rows"],
        [free_of_point[fast["inner_q"]], free_of_point[fast["inner_p"]]] + [star_cols[ks, j] for j in range(3)],
        [w[:, 0], w[:, 1]] + [w[:, 2] * star_vals[ks, j] for j in range(3)],
    )
    pos, owner = _ragged_gather(S.indptr, np.arange(s_ids.size))
    dest = indptr[s_ids][owner] + (pos - S.indptr[owner])
    data[dest] = S.data[pos]
    indices[dest] = S.indices[pos]
    # flips: w_other * other + w_r * row(mid_r) + w_s * row(mid_s); the middle rows are
    # copied grouped by their length (1 free, 5 fast path, a few others), column by column
    fr, fw = flips["rows"], flips["w"]
    put_columns(fr, [free_of_point[flips["other"]]], [fw[:, 0]])
    offset = indptr[fr] + 1
    for mid, wk in ((flips["mid_r"], fw[:, 1]), (flips["mid_s"], fw[:, 2])):
        mlen = length[mid]
        for L in np.unique(mlen):
            sel = np.flatnonzero(mlen == L)
            src, dst, wsel = indptr[mid[sel]], offset[sel], wk[sel]
            for j in range(int(L)):
                data[dst + j] = wsel * data[src + j]
                indices[dst + j] = indices[src + j]
        offset += mlen
    M = sp.csr_array((data, indices, indptr), shape=(npts, n_free))
    M.sort_indices()
    M.eliminate_zeros()
    return M


def _rank_within(keys: np.ndarray, n_groups: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Stable order by ``keys``, each element's rank inside its group, and group counts."""
    order = np.argsort(keys, kind="stable")
    counts = np.bincount(keys, minlength=n_groups)
    starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
    rank = np.empty(keys.size, np.int64)
    rank[order] = np.arange(keys.size) - starts[keys[order]]
    return order, rank, counts


def _eliminate(A: np.ndarray, K: np.ndarray, weight: np.ndarray, tol: float):
    """Batched Gauss--Jordan with weighted complete pivoting, in place.

    Parameters
    ----------
    A : (B, m, c) coefficients of the unknowns; K : (B, m, m) of the known points.
    weight : (c,) pivot preference per column.

    Returns
    -------
    piv_col : (B, m) pivot column of each row, -1 for rows left without a pivot
        (linearly dependent on the others).
    """
    nb, m, c = A.shape
    piv_col = np.full((nb, m), -1, np.int64)
    row_done = np.zeros((nb, m), bool)
    col_done = np.zeros((nb, c), bool)
    active = np.ones(nb, bool)
    bidx = np.arange(nb)
    for _ in range(m):
        avail = ~row_done[:, :, None] & ~col_done[:, None, :]
        mag = np.where(avail, np.abs(A), 0.0)
        raw_max = mag.reshape(nb, -1).max(axis=1)
        active &= raw_max > tol
        if not active.any():
            break
        flat = np.argmax((mag * weight).reshape(nb, -1), axis=1)
        r, col = np.divmod(flat, c)
        b = bidx[active]
        r, col = r[active], col[active]
        piv = A[b, r, col]
        A[b, r, :] /= piv[:, None]
        K[b, r, :] /= piv[:, None]
        f = A[b, :, col].copy()  # (nb_active, m) multipliers
        f[np.arange(b.size), r] = 0.0
        A[b] -= f[:, :, None] * A[b, r, None, :]
        K[b] -= f[:, :, None] * K[b, r, None, :]
        A[b, :, col] = 0.0
        A[b, r, col] = 1.0
        row_done[b, r] = True
        col_done[b, col] = True
        piv_col[b, r] = col
    return piv_col


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
    """
    clock = [time.perf_counter()]
    timings: dict[str, float] = {}

    def tick(name: str) -> None:
        now = time.perf_counter()
        timings[name] = timings.get(name, 0.0) + now - clock[0]
        clock[0] = now

    tri = uv if isinstance(uv, Triangulation) else Triangulation(uv, faces)
    _ = tri.edges, tri.edge_faces
    tick("triangulation")
    lay = layout_of(tri)
    F, UV = tri.faces, tri.uv
    nv = tri.n_vertices
    npts = lay.n_points
    edges = tri.edges

    # ---- frame scale: mean incident edge length
    elen = np.linalg.norm(UV[edges[:, 0]] - UV[edges[:, 1]], axis=1)
    frame_scale = np.bincount(edges.ravel(), weights=np.repeat(elen, 2), minlength=nv) / np.bincount(
        edges.ravel(), minlength=nv
    )

    # ---- the i = 1 equations, one per interior edge end
    ie = tri.interior_edges
    a, b = edges[ie, 0], edges[ie, 1]
    f0, f1 = tri.edge_faces[ie, 0], tri.edge_faces[ie, 1]
    k0, k1 = tri.edge_opposite[ie, 0], tri.edge_opposite[ie, 1]
    p, q = F[f0, k0], F[f1, k1]
    # in f0: a = local k0+1, b = local k0+2; in f1: b = local k1+1, a = local k1+2
    eq_s = np.concatenate([a, b])
    eq_e = np.concatenate([ie, ie])
    eq_end = np.concatenate([np.zeros_like(ie), np.ones_like(ie)])
    eq_fp = np.concatenate([f0, f0])
    eq_kp = np.concatenate([(k0 + 1) % 3, (k0 + 2) % 3])
    eq_fq = np.concatenate([f1, f1])
    eq_kq = np.concatenate([(k1 + 2) % 3, (k1 + 1) % 3])
    # one diamond per interior edge: with r = a, s = b it is the equation at end 1 and
    # the flips' i = 2 condition; at end 0 (r = b, s = a) the r and s coefficients swap
    # (the signed areas change sign exactly, so this is bit-identical to recomputing)
    c2 = diamond_coefficients(UV[p], UV[q], UV[a], UV[b])  # (q, p, r, s)
    coef = np.concatenate([c2[:, [0, 1, 3, 2]], c2])

    tick("diamonds")
    # ---- local numbering: corners and equations per vertex
    corner_v = F.ravel()
    _, corner_rank, n_c = _rank_within(corner_v, nv)
    _, eq_rank, n_e = _rank_within(eq_s, nv)
    col_p = corner_rank[3 * eq_fp + eq_kp]
    col_q = corner_rank[3 * eq_fq + eq_kq]

    D_rows, D_cols, D_vals = [], [], []  # point <- point
    free_pts = []  # global ids of free control points (besides corners)

    max_coef = 0.0
    # ---- per-vertex systems. Fast path: where every equation's middle-point
    # coefficient passes the pivot preference, weighted complete pivoting would pick
    # all middle points (a middle column lives in one row only), so no elimination.
    good_eq = np.abs(coef[:, 2]) >= inner_weight * np.maximum(np.abs(coef[:, 0]), np.abs(coef[:, 1]))
    good_eq &= np.abs(coef[:, 2]) > singular_tol
    bad_v = np.zeros(nv, bool)
    bad_v[eq_s[~good_eq]] = True
    fast = ~bad_v[eq_s]
    i = np.flatnonzero(fast)
    cr = coef[i, 2]
    fast_rec = dict(
        rows=lay.mid(eq_e[i], eq_end[i]),
        inner_q=lay.inner(eq_fq[i], eq_kq[i]),
        inner_p=lay.inner(eq_fp[i], eq_kp[i]),
        star=lay.star(eq_e[i], eq_end[i]),
        w=coef[i][:, [0, 1, 3]],  # weights of (inner_q, inner_p, star), scaled below
    )
    fast_rec["w"] /= -cr[:, None]
    if i.size:
        max_coef = max(max_coef, float(np.abs(fast_rec["w"]).max()))
    # all inner points at fast-path vertices are free
    corner_fast = ~bad_v[corner_v]
    free_pts.append(lay.inner0 + np.flatnonzero(corner_fast))

    tick("fast_path")
    # slow path: batched elimination, grouped by system shape
    singular = []
    shape_key = np.where(bad_v, n_c * (n_e.max(initial=0) + 1) + n_e, -1)
    eq_group_key = shape_key[eq_s]
    for key in np.unique(shape_key[bad_v]):
        verts = np.flatnonzero(shape_key == key)
        nc, m = int(n_c[verts[0]]), int(n_e[verts[0]])
        nb = verts.size
        slot = np.full(nv, -1, np.int64)
        slot[verts] = np.arange(nb)
        # global ids of the unknowns: inner points (by corner rank) then mids (by eq rank)
        col_pid = np.empty((nb, nc + m), np.int64)
        cidx = np.flatnonzero(shape_key[corner_v] == key)
        col_pid[slot[corner_v[cidx]], corner_rank[cidx]] = lay.inner0 + cidx  # inner id = inner0 + 3f + k
        eqi = np.flatnonzero(eq_group_key == key)
        bi, ri = slot[eq_s[eqi]], eq_rank[eqi]
        col_pid[bi, nc + ri] = lay.mid(eq_e[eqi], eq_end[eqi])
        star_pid = np.empty((nb, m), np.int64)
        star_pid[bi, ri] = lay.star(eq_e[eqi], eq_end[eqi])
        A = np.zeros((nb, m, nc + m))
        K = np.zeros((nb, m, m))
        np.add.at(A, (bi, ri, col_q[eqi]), coef[eqi, 0])
        np.add.at(A, (bi, ri, col_p[eqi]), coef[eqi, 1])
        A[bi, ri, nc + ri] = coef[eqi, 2]
        K[bi, ri, ri] = coef[eqi, 3]
        weight = np.concatenate([np.full(nc, inner_weight), np.ones(m)])
        piv = _eliminate(A, K, weight, singular_tol)
        # singular vertices: rows without pivot
        lost = (piv < 0).sum(1)
        if lost.any():
            singular.append(np.repeat(verts[lost > 0], lost[lost > 0]))
        is_piv_col = np.zeros((nb, nc + m), bool)
        pb, pr = np.nonzero(piv >= 0)
        is_piv_col[pb, piv[pb, pr]] = True
        free_pts.append(col_pid[~is_piv_col])
        # dependent rows: unknown[piv] = -sum_j A[r, j] u_j - sum_k K[r, k] star_k (j free columns)
        dep = col_pid[pb, piv[pb, pr]]
        Ar = A[pb, pr]  # (npiv, c)
        Ar[is_piv_col[pb]] = 0.0
        jj, cc = np.nonzero(Ar)
        D_rows.append(dep[jj])
        D_cols.append(col_pid[pb[jj], cc])
        D_vals.append(-Ar[jj, cc])
        Kr = K[pb, pr]
        jj, cc = np.nonzero(Kr)
        D_rows.append(dep[jj])
        D_cols.append(star_pid[pb[jj], cc])
        D_vals.append(-Kr[jj, cc])
        if Ar.size:
            max_coef = max(max_coef, float(np.abs(Ar).max()), float(np.abs(Kr).max()))
    n_vertex_systems = int(bad_v.sum())
    tick("elimination")

    # ---- boundary edges: both middle points and the face's flip are free
    be = tri.boundary_edges
    bf = np.where(tri.edge_faces[be, 0] >= 0, tri.edge_faces[be, 0], tri.edge_faces[be, 1])
    bk = np.where(tri.edge_faces[be, 0] >= 0, tri.edge_opposite[be, 0], tri.edge_opposite[be, 1])
    free_pts += [lay.mid(be, 0), lay.mid(be, 1), lay.flip(bf, bk)]

    # ---- flips of interior edges: i = 2, r = a, s = b; the flip with the larger coefficient is computed
    flip_p, flip_q = lay.flip(f0, k0), lay.flip(f1, k1)
    mid_r, mid_s = lay.mid(ie, 0), lay.mid(ie, 1)
    q_dep = np.abs(c2[:, 0]) >= np.abs(c2[:, 1])
    dep = np.where(q_dep, flip_q, flip_p)
    other = np.where(q_dep, flip_p, flip_q)
    c_dep = np.where(q_dep, c2[:, 0], c2[:, 1])
    c_oth = np.where(q_dep, c2[:, 1], c2[:, 0])
    free_pts.append(other)
    flip_rec = dict(rows=dep, other=other, mid_r=mid_r, mid_s=mid_s,
                    w=np.column_stack([-c_oth / c_dep, -c2[:, 2] / c_dep, -c2[:, 3] / c_dep]))
    if ie.size:
        max_coef = max(max_coef, float(np.abs(flip_rec["w"]).max()))
    tick("flips")
    # ---- free variables. The per-equation tables are no longer needed: release them
    # before the CSR assembly, whose arrays set the peak memory.
    del eq_s, eq_e, eq_end, eq_fp, eq_kp, eq_fq, eq_kq, coef, col_p, col_q
    del ie, a, b, f0, f1, k0, k1, p, q, flip_p, flip_q
    del corner_v, corner_rank, eq_rank, good_eq, fast, i, cr, c2, q_dep, dep, other, c_dep, c_oth
    free_pts = np.sort(np.concatenate(free_pts)) if free_pts else np.zeros(0, np.int64)
    n_free = 3 * nv + free_pts.size
    free_of_point = np.full(npts, -1, _memory.index_dtype(npts, n_free))
    free_of_point[:nv] = np.arange(nv)
    free_of_point[free_pts] = np.arange(3 * nv, n_free)
    M = _compose(lay, nv, edges, UV, frame_scale, free_of_point, n_free, fast_rec, (D_rows, D_cols, D_vals), flip_rec)

    tick("compose")
    free_kind = np.empty(n_free, np.int8)
    free_kind[:nv] = KIND_CORNER
    free_kind[nv : 3 * nv] = KIND_FRAME
    kinds = np.full(npts, -1, np.int8)
    kinds[lay.mid0 : lay.inner0] = KIND_MID
    kinds[lay.inner0 : lay.flip0] = KIND_INNER
    kinds[lay.flip0 :] = KIND_FLIP
    free_kind[3 * nv :] = kinds[free_pts]
    free_point = np.concatenate([np.arange(nv), np.full(2 * nv, -1, np.int64), free_pts])
    frame_free = nv + 2 * np.arange(nv)[:, None] + np.arange(2)[None, :]
    sing = np.sort(np.concatenate(singular)) if singular else np.zeros(0, np.int64)
    pidx = point_index(tri)
    tick("point_index")
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
                   nnz=int(M.nnz), eliminated_vertices=n_vertex_systems, timings=timings),
    )
