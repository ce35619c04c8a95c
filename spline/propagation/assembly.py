"""Stage 4 of the build: ``M`` written straight into CSR arrays, class by class.

Every point's row length is known before any value is written: 1 for free
points, 3 for stars (affine in their vertex's frame), 5 for middle points of the
fast path (two inner points and a star), the reduced row for points of an
eliminated vertex system, and ``1 + len(mid_r) + len(mid_s)`` for computed flips.
Rows are written in the propagation order (stars, middle points, flips), so a
row that copies earlier rows (a middle point's star, a flip's middle points)
finds them complete. No COO sort, no sparse products. Every range of edges
writes its own entries: the result does not depend on the thread count.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import partial
from typing import NamedTuple

import numpy as np
import scipy.sparse as sp

from ..net import NetLayout
from ..topology import Triangulation
from ..util import gather as _gather, memory as _memory, parallel as _parallel, sparse as _sparse
from ..util.progress import Report, counting
from .diamonds import diamond_ids, flip_pair, star_weights
from .elimination import Eliminated


class _ReducedRows(NamedTuple):
    """The eliminated systems' rows, concatenated (row ``i`` owns ``cols[ptr[i]:ptr[i+1]]``)."""

    dep: np.ndarray  # (n,) point ids
    n_a: np.ndarray  # (n,) free-point entries per row
    vertex: np.ndarray  # (n,) the vertex whose frame the row's stars expand into
    cols: np.ndarray  # (sum n_a,) free ids
    vals: np.ndarray  # (sum n_a,)
    frame: np.ndarray  # (n, 3) weights of z_s and the two frame points
    ptr: np.ndarray  # (n + 1,) int64


@dataclass(frozen=True, eq=False)
class _Rows:
    """M's CSR arrays while they are written, and what the writers read."""

    tri: Triangulation
    lay: NetLayout
    c2: np.ndarray  # (E_int, 4) diamond coefficients of (q, p, r, s)
    bad_v: np.ndarray  # (V,) bool, vertices whose systems were eliminated
    free_of_point: np.ndarray  # (n_points,) free id of each point, -1 where dependent
    length: np.ndarray  # (n_points,) row lengths
    indptr: np.ndarray
    indices: np.ndarray
    data: np.ndarray


def assemble(work: _parallel.Workers, tri: Triangulation, lay: NetLayout, c2: np.ndarray, bad_v: np.ndarray,
             frame_scale: np.ndarray, free_pts: np.ndarray, free_of_point: np.ndarray, n_free: int,
             length: np.ndarray, elim: Eliminated, report: Report | None = None) -> tuple[sp.csr_array, float]:
    """``M: (n_points, n_free)`` CSR and the largest propagation coefficient written.

    ``free_pts``: sorted ids of the free points besides corners and frames;
    ``length: (n_points,) int32`` with the fast-path middle rows already set to 5;
    ``report``: progress after each of the :data:`ASSEMBLY_STEPS` steps.
    """
    step = counting(report, ASSEMBLY_STEPS)
    nv, npts, ne_int = tri.n_vertices, lay.n_points, tri.interior_edges.size
    reduced = _reduced_rows(elim, free_of_point)
    length[reduced.dep] = reduced.n_a + 3
    length[:nv] = 1
    length[free_pts] = 1
    length[lay.star0 : lay.mid0] = 3
    work.map(partial(_flip_lengths, tri, lay, c2, length), ne_int)
    step()
    nnz = int(length.sum(dtype=np.int64))
    idx_t = _memory.index_dtype(nnz, n_free, npts)
    indptr = _memory.full(npts + 1, 0, idx_t)
    np.cumsum(length, dtype=idx_t, out=indptr[1:])
    data = _memory.empty(nnz)
    rows = _Rows(tri, lay, c2, bad_v, free_of_point, length, indptr, indices=_memory.empty(nnz, idx_t), data=data)
    # corners and stars occupy the first ids with fixed lengths 1 and 3: one contiguous block
    rows.data[:nv] = 1.0
    rows.indices[:nv] = np.arange(nv)
    step()
    work.map(partial(_star_rows, rows, frame_scale), tri.n_edges)
    rest = free_pts[free_pts >= lay.mid0]
    work.map(partial(_free_rows, rows, rest), rest.size)
    step()
    max_coef = max(work.map(partial(_fast_rows, rows), ne_int), default=0.0)
    step()
    work.map(partial(_eliminated_rows, rows, reduced), reduced.dep.size)
    max_coef = max([max_coef] + work.map(partial(_flip_rows, rows), ne_int))
    step()
    M = sp.csr_array((rows.data, rows.indices, indptr), shape=(npts, n_free))
    _sparse.sort_indices(M, work)
    M.eliminate_zeros()
    step()
    return M, max_coef


#: The steps :func:`assemble` reports (lengths, allocation, stars and free rows, fast rows, the rest, sorting).
ASSEMBLY_STEPS = 6


def _reduced_rows(elim: Eliminated, free_of_point: np.ndarray) -> _ReducedRows:
    """The eliminated systems' batches concatenated, their free points as free ids."""
    dep, n_a, vertex = (_parallel.concat(x) for x in (elim.dep, elim.n_a, elim.vertex))
    cols = free_of_point[_parallel.concat(elim.a_cols)]
    if (cols < 0).any():  # pragma: no cover - internal consistency
        raise AssertionError("an eliminated point references a dependent point")
    ptr = np.zeros(dep.size + 1, np.int64)
    np.cumsum(n_a, out=ptr[1:])
    frame = np.concatenate(elim.frame) if elim.frame else np.zeros((0, 3))
    return _ReducedRows(dep, n_a, vertex, cols, _parallel.concat(elim.a_vals, np.float64), frame, ptr)


def _flip_ids(tri: Triangulation, lay: NetLayout, c2: np.ndarray, lo: int, hi: int) -> tuple[np.ndarray, ...]:
    """Interior edges ``lo:hi``: the edges, their computed and free flips, which side is computed, the diamonds."""
    e = tri.interior_edges[lo:hi]
    _, _, f0, f1, k0, k1 = diamond_ids(tri, e)
    c = c2[lo:hi]
    return (e, *flip_pair(lay, f0, k0, f1, k1, c), c)


def _flip_lengths(tri: Triangulation, lay: NetLayout, c2: np.ndarray, length: np.ndarray, lo: int, hi: int) -> None:
    """A computed flip's row: the other flip and both middle rows of its edge."""
    e, dep, _, _, _ = _flip_ids(tri, lay, c2, lo, hi)
    length[dep] = 1 + length[lay.mid(e, 0)] + length[lay.mid(e, 1)]


def _copy_scaled(rows: _Rows, src: np.ndarray, dst: np.ndarray, w: np.ndarray, n: int) -> None:
    """Entries ``src + j`` times ``w`` to ``dst + j``, ``j < n`` (one earlier row into a later one)."""
    for j in range(n):
        rows.data[dst + j] = w * rows.data[src + j]
        rows.indices[dst + j] = rows.indices[src + j]


def _star_rows(rows: _Rows, frame_scale: np.ndarray, lo: int, hi: int) -> None:
    """Rows of the stars of edges lo:hi (star 2 e + end at s = edges[e, end]): z_s and its frame."""
    nv = rows.tri.n_vertices
    ab = rows.tri.edges[lo:hi]
    rows.data[nv + 6 * lo : nv + 6 * hi].reshape(-1, 2, 3)[:] = star_weights(rows.tri.uv, frame_scale, ab, ab[:, ::-1])
    cols = rows.indices[nv + 6 * lo : nv + 6 * hi].reshape(-1, 2, 3)
    cols[..., 0] = ab
    np.multiply(ab, 2, out=cols[..., 1], casting="same_kind")
    cols[..., 1] += nv
    np.add(cols[..., 1], 1, out=cols[..., 2])


def _free_rows(rows: _Rows, rest: np.ndarray, lo: int, hi: int) -> None:
    """Rows of the free points ``rest[lo:hi]`` (middle, inner, flip): the point itself."""
    start = rows.indptr[rest[lo:hi]]
    rows.data[start] = 1.0
    rows.indices[start] = rows.free_of_point[rest[lo:hi]]


def _fast_rows(rows: _Rows, lo: int, hi: int) -> float:
    """Middle point = w_q inner_q + w_p inner_p + w_s star, at both ends of interior edges lo:hi.

    Returns the largest weight written.
    """
    e = rows.tri.interior_edges[lo:hi]
    a, b, f0, f1, k0, k1 = diamond_ids(rows.tri, e)
    c = rows.c2[lo:hi]
    big = 0.0
    # end 0 (s = a): mid coefficient c[:, 3], star c[:, 2]; end 1 (s = b): the other way
    for end, s, mid_col, star_col, kp, kq in ((0, a, 3, 2, (k0 + 1) % 3, (k1 + 2) % 3),
                                               (1, b, 2, 3, (k0 + 2) % 3, (k1 + 1) % 3)):
        ok = np.flatnonzero(~rows.bad_v[s])
        if ok.size == 0:
            continue
        co = _gather.rows(c, ok)
        neg = -co[:, mid_col]
        w = [co[:, 0] / neg, co[:, 1] / neg, co[:, star_col] / neg]  # (inner_q, inner_p, star)
        big = max(big, *(float(np.abs(x).max()) for x in w))
        eo = e[ok]
        start = rows.indptr[rows.lay.mid(eo, end)]
        rows.data[start] = w[0]
        rows.indices[start] = rows.free_of_point[rows.lay.inner(f1[ok], kq[ok])]
        rows.data[start + 1] = w[1]
        rows.indices[start + 1] = rows.free_of_point[rows.lay.inner(f0[ok], kp[ok])]
        star_at = rows.tri.n_vertices + 3 * (2 * eo + end)  # the star's row in the stars block
        _copy_scaled(rows, star_at, start + 2, w[2], 3)
    return big


def _eliminated_rows(rows: _Rows, reduced: _ReducedRows, lo: int, hi: int) -> None:
    """Rows ``lo:hi`` of the eliminated systems: their free points, then ``z_s`` and its frame."""
    nv = rows.tri.n_vertices
    start = rows.indptr[reduced.dep[lo:hi]]
    a0, a1 = reduced.ptr[lo], reduced.ptr[hi]
    n_a = reduced.n_a[lo:hi]
    pos, _ = _gather.segments(start, n_a)
    rows.data[pos] = reduced.vals[a0:a1]
    rows.indices[pos] = reduced.cols[a0:a1]
    at, v = start + n_a, reduced.vertex[lo:hi]
    for j, col in enumerate((v, nv + 2 * v, nv + 2 * v + 1)):
        rows.data[at + j] = reduced.frame[lo:hi, j]
        rows.indices[at + j] = col


def _flip_rows(rows: _Rows, lo: int, hi: int) -> float:
    """Computed flip = w_o other + w_r row(mid_r) + w_s row(mid_s) for interior edges lo:hi.

    Middle rows are copied grouped by their length (1 free, 5 fast path, a few others).
    Returns the largest weight.
    """
    lay, length = rows.lay, rows.length
    e, dep, other, q_dep, c = _flip_ids(rows.tri, lay, rows.c2, lo, hi)
    c_dep = np.where(q_dep, c[:, 0], c[:, 1])
    c_oth = np.where(q_dep, c[:, 1], c[:, 0])
    w = [-c_oth / c_dep, -c[:, 2] / c_dep, -c[:, 3] / c_dep]
    start = rows.indptr[dep]
    rows.data[start] = w[0]
    rows.indices[start] = rows.free_of_point[other]
    offset = start + 1
    for mid, wk in ((lay.mid(e, 0), w[1]), (lay.mid(e, 1), w[2])):
        mlen = length[mid]
        for L in np.flatnonzero(np.bincount(mlen)):
            sel = np.flatnonzero(mlen == L)
            _copy_scaled(rows, rows.indptr[mid[sel]], offset[sel], wk[sel], int(L))
        offset += mlen
    return max(float(np.abs(x).max(initial=0.0)) for x in w)
