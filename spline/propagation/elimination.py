"""Stage 2 of the build: the ``i = 1`` vertex systems, reduced by weighted complete pivoting.

The ``i = 1`` conditions of the interior edges at a vertex ``s`` couple the middle
edge points ``f(r^2 s^3)`` and the near-corner inner points at ``s``. Instead of
always solving for the middle points (the paper's choice, which divides by a
coefficient that vanishes when two edges through ``s`` are collinear, paper 7.2.2),
each vertex system with a weak equation is reduced by Gauss--Jordan elimination
with complete, weighted pivoting: middle points are preferred, an inner point is
computed instead when the middle point's coefficient is small. Only the weak
equations need the pivot search: every other equation pivots on its own middle
point, which no other equation holds.

A singular vertex (four edges on two lines: :mod:`.snap` puts the nearly singular
ones exactly there) makes its system lose rank by one; its elimination stops one
pivot early and leaves one more unknown free, which is exactly the extra dimension
of the spline space there. Near such a configuration (but not on it) the last
pivot is O(eps) and the rows it produces cancel O(1) terms to O(eps): in double
they are off by ``1e-16 / eps``. Systems whose smallest pivot is below
:data:`~trispline.spline.tolerances.EXACT_PIVOT_TOL` are therefore eliminated again in
double-double arithmetic (:mod:`~trispline.spline.util.ddouble`), from the uv
coordinates up -- diamond coefficients, elimination, star weights -- and only the
final rows (O(1) coefficients of free points and frame variables) are rounded to
double. Every other system keeps its double rows, bit for bit.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

from ..net import NetLayout
from ..tolerances import EXACT_PIVOT_TOL, EXACT_SINGULAR_TOL
from ..topology import Triangulation
from ..util import ddouble, gather as _gather, memory as _memory, parallel as _parallel
from ..util.ddouble import DD
from .diamonds import diamond_ids, edge_coefficients, star_weights, weak

#: Vertex systems of one shape eliminated together (bounds the batch's temporaries).
SYSTEM_BATCH = 2048


class _Batch(NamedTuple):
    """The reduced rows of one batch of vertex systems (see :class:`Eliminated`)."""

    singular: np.ndarray
    free: np.ndarray
    dep: np.ndarray
    n_a: np.ndarray
    a_cols: np.ndarray
    a_vals: np.ndarray
    frame: np.ndarray
    vertex: np.ndarray
    max_coef: float
    n_exact: int


@dataclass
class Eliminated:
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
    n_exact: int = 0  # systems eliminated again in double-double

    def add(self, batches: list[_Batch]) -> None:
        """Append one batch's rows (batches come in group and position order)."""
        for batch in batches:
            if batch.singular.size:
                self.singular.append(batch.singular)
            for name in ("free", "dep", "n_a", "a_cols", "a_vals", "frame", "vertex"):
                getattr(self, name).append(getattr(batch, name))
            self.max_coef = max(self.max_coef, batch.max_coef)
            self.n_exact += batch.n_exact


def eliminate(A: np.ndarray | DD, K: np.ndarray | DD, weight: np.ndarray, tol: float, search: np.ndarray,
              drop: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Batched Gauss--Jordan with weighted complete pivoting over the ``search`` rows, in place.

    Rows outside ``search`` pivot on their own middle point, column ``c - m + row``: a
    middle point lives in its own equation only, so those pivots never change another
    row and need no elimination step; the search rows (the equations whose middle-point
    coefficient is weak) are reduced among themselves, and their pivot columns are
    eliminated from every row. The result is the reduced row echelon form for that
    pivot set. ``A`` and ``K`` are float64 or double-double (:class:`DD`) arrays.

    Parameters
    ----------
    A : (B, m, c) coefficients of the unknowns; K : (B, m, m) of the known points.
    weight : (c,) pivot preference per column.
    tol : pivots (magnitudes) at or below this count as zero.
    search : (B, m) bool, the rows whose pivot is searched; every system has the same
        number of them.
    drop : (B,) int, pivots each system leaves out (1 at a singular vertex: its last,
        smallest pivot is zero up to rounding), or None.

    Returns
    -------
    piv_col : (B, m) pivot column of each row, -1 for search rows left without a pivot
        (linearly dependent on the others, or dropped).
    min_pivot : (B,) smallest pivot magnitude taken in the search (0 where a row found
        no pivot above ``tol``, inf where the search took none).
    """
    nb, m, c = A.shape
    piv_col = np.full((nb, m), -1, np.int64)
    min_pivot = np.full(nb, np.inf)
    row_done = ~search
    active = np.ones(nb, bool)
    bidx = np.arange(nb)
    n_search = int(search.sum(1).max(initial=0))
    for step in range(n_search):
        # available entries: search rows not yet pivoted. A pivot's column is exactly zero in
        # every other row after its elimination step, so used columns need no mask of their own.
        mag = ddouble.magnitude(A)
        mag[row_done] = 0.0
        found = mag.reshape(nb, -1).max(axis=1) > tol
        if drop is not None:
            active &= step < n_search - drop
        min_pivot[active & ~found] = 0.0  # a search row left without pivot: dependent up to tol
        active &= found
        if not active.any():
            break
        mag *= weight
        r, col = np.divmod(np.argmax(mag.reshape(nb, -1), axis=1), c)
        b = bidx[active]
        r, col = r[active], col[active]
        min_pivot[b] = np.minimum(min_pivot[b], ddouble.magnitude(A[b, r, col]))  # b: distinct systems
        _pivot(A, K, b, r, col)
        row_done[b, r] = True
        piv_col[b, r] = col
    # the other rows: their own middle point (its coefficient passed the pivot test)
    rows = np.arange(m)
    own = ddouble.where(search, 1.0, A[:, rows, c - m + rows])  # (B, m): dividing by 1 changes nothing
    A /= own[:, :, None]
    K /= own[:, :, None]
    np.copyto(piv_col, c - m + rows, where=~search)
    return piv_col, min_pivot


def _pivot(A: np.ndarray | DD, K: np.ndarray | DD, b: np.ndarray, r: np.ndarray, col: np.ndarray) -> None:
    """One Gauss--Jordan step in systems ``b``: row ``r`` scaled to 1 at ``col``, ``col`` cleared elsewhere."""
    piv = A[b, r, col]
    A[b, r, :] /= piv[:, None]
    K[b, r, :] /= piv[:, None]
    f = A[b, :, col].copy()  # (nb_active, m) multipliers
    f[np.arange(b.size), r] = 0.0
    if b.size == A.shape[0]:  # all systems still active: update in place (no gather/scatter copies)
        A -= f[:, :, None] * A[b, r, None, :]
        K -= f[:, :, None] * K[b, r, None, :]
    else:
        A[b] -= f[:, :, None] * A[b, r, None, :]
        K[b] -= f[:, :, None] * K[b, r, None, :]
    A[b, :, col] = 0.0
    A[b, r, col] = 1.0


class _System(NamedTuple):
    """A batch of ``nb`` vertex systems with ``nc`` corners and ``m`` equations each."""

    A: np.ndarray | DD  # (nb, m, nc + m) coefficients of the unknowns: inner points, then middle points
    K: np.ndarray | DD  # (nb, m, m) coefficients of the known star points
    weak: np.ndarray  # (nb, m) bool, the equations whose pivot is searched
    col_pid: np.ndarray  # (nb, nc + m) global point id of every unknown
    far: np.ndarray  # (nb, m) far end of each equation's edge (its star points toward it)

    def subset(self, keep: np.ndarray) -> "_System":
        """The systems ``keep: (nb,) bool``."""
        return _System(*(x[keep] for x in self))


@dataclass(frozen=True)
class _Systems:
    """The flagged vertices' ``i = 1`` systems, read off the vertex fans, eliminated in batches.

    The system of vertex ``s`` has one unknown inner point per corner of its fan (in
    counter-clockwise order) and one equation per interior edge at ``s``: the edge
    between fan corners ``j`` and ``j + 1`` couples their two inner points with its
    middle point and its star. ``verts``: flagged vertices grouped by shape (corner
    count, equation count, weak equation count), increasing inside a group;
    ``singular``: the vertices that lose one pivot (on the crossing of their two lines).
    """

    tri: Triangulation
    lay: NetLayout
    c2: np.ndarray  # (n_ie, 4) diamond coefficients of (q, p, r, s), by position in ie
    ie_pos: np.ndarray  # (E,) position of an interior edge in ie
    frame_scale: np.ndarray
    verts: np.ndarray  # (n,) flagged vertices
    n_c: np.ndarray  # (V,) corners per vertex
    n_e: np.ndarray  # (V,) interior edges (= equations) per vertex
    singular: np.ndarray  # (V,) bool
    singular_tol: float
    inner_weight: float
    exact_tol: float

    def batch(self, p0: int, p1: int) -> list[_Batch]:
        """Eliminate the systems of the vertices ``verts[p0:p1]`` (all of one shape).

        In double first; the systems whose smallest pivot is below ``exact_tol`` (and that
        are not singular) again in double-double, from the coordinates up.
        """
        verts = self.verts[p0:p1]
        system = self._gather(verts)
        nc = system.col_pid.shape[1] - system.far.shape[1]
        weight = np.concatenate([np.full(nc, self.inner_weight), np.ones(system.far.shape[1])])
        drop = self.singular[verts].astype(np.int64)
        piv, min_pivot = eliminate(system.A, system.K, weight, self.singular_tol, system.weak, drop)
        redo = (min_pivot < self.exact_tol) & (drop == 0)
        if not redo.any():
            return [self._rows(verts, system, piv)]
        exact = self._gather(verts[redo], exact=True)._replace(weak=system.weak[redo])
        piv_x, _ = eliminate(exact.A, exact.K, weight, EXACT_SINGULAR_TOL, exact.weak)
        keep = ~redo
        rows = [self._rows(verts[redo], exact, piv_x)]
        return rows if not keep.any() else [self._rows(verts[keep], system.subset(keep), piv[keep])] + rows

    def _gather(self, verts: np.ndarray, exact: bool = False) -> _System:
        """The systems of ``verts: (nb,)``, read off their fans; with ``exact`` in double-double,
        the diamond coefficients computed again from the coordinates (``weak`` is then None)."""
        tri, lay = self.tri, self.lay
        nc, m, nb = int(self.n_c[verts[0]]), int(self.n_e[verts[0]]), verts.size
        corners = tri.fan_corners[tri.fan_ptr[verts][:, None] + np.arange(nc)]  # (nb, nc)
        f, k = np.divmod(corners[:, :m], 3)
        e = _gather.at(tri.face_edges, f, (k + 1) % 3)  # (nb, m): the edge from s shared by corners j and j+1
        ab = _gather.rows(tri.edges, e)  # (nb, m, 2)
        end = (ab[..., 1] == verts[:, None]).astype(np.int64)  # s = b: end 1
        if exact:  # (nb, m, 4): (q, p, r, s)
            c = edge_coefficients(tri, diamond_ids(tri, e.reshape(-1)), DD(tri.uv)).reshape(e.shape + (4,))
        else:
            c = _gather.rows(self.c2, self.ie_pos[e])
        # at end 1 (s = b) the middle point is the r column and the star the s column; at end 0
        # the other way. Corner j's face is the diamond's p side (f0) or its q side (f1).
        on_p = _gather.at(tri.edge_faces, e, 0) == f
        j = np.arange(m)
        j1 = (j + 1) % nc
        col_p = np.where(on_p, j, j1)
        col_q = np.where(on_p, j1, j)
        c_mid = ddouble.where(end == 1, c[..., 2], c[..., 3])
        c_star = ddouble.where(end == 1, c[..., 3], c[..., 2])
        # as in the diamonds stage (the double-double pass keeps the double pass's search rows)
        weak_rows = None if exact else weak(c_mid, c[..., 0], c[..., 1], self.inner_weight, self.singular_tol)
        # global ids of the unknowns: inner points (by fan position) then middle points (by row)
        col_pid = np.empty((nb, nc + m), np.int64)
        col_pid[:, :nc] = lay.inner0 + corners
        col_pid[:, nc:] = lay.mid(e, end)
        zeros = DD.zeros if exact else np.zeros
        A = zeros((nb, m, nc + m))
        K = zeros((nb, m, m))
        bi = np.arange(nb)[:, None]
        A[bi, j, col_q] = c[..., 0]  # the two inner points are different corners: set once each
        A[bi, j, col_p] = c[..., 1]
        A[bi, j, nc + j] = c_mid
        K[:, j, j] = c_star
        return _System(A, K, weak_rows, col_pid, np.where(end == 1, ab[..., 0], ab[..., 1]))

    def _rows(self, verts: np.ndarray, system: _System, piv: np.ndarray) -> _Batch:
        """The dependent rows of reduced systems: ``unknown[piv] = -sum_j A[r, j] u_j - sum_k K[r, k] star_k``.

        ``j`` runs over the free columns; every star of the vertex is affine in its frame,
        so the star part collapses to 3 weights (in the systems' precision; the rows are
        rounded to double after the collapse). ``max_coef``: the largest of these
        coefficients, the ones ``M`` holds.
        """
        A, K, col_pid = system.A, system.K, system.col_pid
        m = K.shape[1]
        lost = (piv < 0).sum(1)  # singular vertices: rows without pivot
        singular = np.repeat(verts[lost > 0], lost[lost > 0])
        is_piv_col = np.zeros(col_pid.shape, bool)
        pb, pr = np.nonzero(piv >= 0)
        is_piv_col[pb, piv[pb, pr]] = True
        dep = col_pid[pb, piv[pb, pr]]
        Ar = A[pb, pr]  # (npiv, c)
        Ar[is_piv_col[pb]] = 0.0
        ja, ca = np.nonzero(ddouble.magnitude(Ar))
        exact = isinstance(A, DD)
        sv = star_weights(DD(self.tri.uv) if exact else self.tri.uv, self.frame_scale,
                          np.broadcast_to(verts[:, None], system.far.shape), system.far)
        frame = -K[:, :, 0, None] * sv[:, None, 0]  # (nb, m, 3)
        for i in range(1, m):  # a fixed summation order: batching cannot change a bit
            frame -= K[:, :, i, None] * sv[:, None, i]
        a_vals, frame = ddouble.to_double(-Ar[ja, ca]), ddouble.to_double(frame[pb, pr])
        big = max(float(np.abs(a_vals).max(initial=0.0)), float(np.abs(frame).max(initial=0.0)))
        return _Batch(singular, col_pid[~is_piv_col], dep, np.bincount(ja, minlength=pb.size),
                      col_pid[pb[ja], ca], a_vals, frame, verts[pb], big, verts.size if exact else 0)


def vertex_systems(work: _parallel.Workers, tri: Triangulation, lay: NetLayout, c2: np.ndarray,
                   frame_scale: np.ndarray, n_weak: np.ndarray, singular: np.ndarray, singular_tol: float,
                   inner_weight: float, exact_tol: float = EXACT_PIVOT_TOL) -> Eliminated:
    """Reduce the ``i = 1`` systems of the vertices with weak equations (``n_weak: (V,)`` > 0).

    ``singular: (V,) bool`` marks the vertices whose system loses one pivot: interior
    vertices with four equations, all weak, on the crossing of their two lines.

    Systems of one shape (corner count, equation count, weak equation count) are
    eliminated together, in batches of at most ``SYSTEM_BATCH`` vertices (small
    temporaries; batches run in threads). Each system is gathered from its vertex's
    fan: no global sort of equations or corners.
    """
    verts = np.flatnonzero(n_weak)
    out = Eliminated(n_systems=int(verts.size))
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
    ie_pos = np.cumsum(~tri.boundary_edge_mask, dtype=_memory.index_dtype(tri.interior_edges.size)) - 1
    singular = singular & (n_weak == n_e) & (n_e == 4) & ~tri.boundary_vertex_mask
    systems = _Systems(tri=tri, lay=lay, c2=c2, ie_pos=ie_pos, frame_scale=frame_scale, verts=verts, n_c=n_c,
                       n_e=n_e, singular=singular, singular_tol=singular_tol, inner_weight=inner_weight,
                       exact_tol=exact_tol)
    futures = [work.submit(systems.batch, int(g0 + lo), int(g0 + hi))
               for g0, gn in zip(g_first, g_count) for lo, hi in _parallel.ranges(int(gn), SYSTEM_BATCH)]
    for fut in futures:  # in group and position order: the output does not depend on the batching
        out.add(fut.result())
    return out
