"""``build_space``: the propagation map ``M`` as a short sequence of stages (docs/design.md §3).

    snap          nearly singular vertices moved onto the crossing of their two lines
    diamonds      coefficients of every interior edge's C1 relation; weak equations per vertex
    classify      which flips are free; the fast-path middle rows (two inner points and a star)
    elimination   the vertex systems with weak equations, reduced by weighted complete pivoting
                  (the nearly singular ones again in double-double)
    free_points   every free point gets its free id (corners, frames, then the others by point id)
    write_M       the CSR arrays, class by class
    finish        the free variables' kinds and the SplineSpace

Each stage's wall time is in ``space.stats["timings"]`` under its name (and
``triangulation`` for the domain tables).
"""
from __future__ import annotations

from functools import partial

import numpy as np

from ..net import NetLayout, layout_of, point_index
from ..tolerances import EXACT_PIVOT_TOL, INNER_PIVOT_WEIGHT, SINGULAR_TOL, SNAP_TOL
from ..topology import Triangulation
from ..util import memory as _memory, parallel as _parallel
from ..util.progress import Report, silent, span
from ..util.timer import StageTimer
from .assembly import assemble
from .diamonds import diamond_ids, diamonds, flip_pair, frame_scales
from .elimination import Eliminated, vertex_systems
from .snap import Snap, snap
from .space import KIND_CORNER, KIND_FLIP, KIND_FRAME, KIND_INNER, KIND_MID, SplineSpace


def build_space(
    uv: np.ndarray | Triangulation,
    faces: np.ndarray | None = None,
    *,
    singular_tol: float = SINGULAR_TOL,
    inner_weight: float = INNER_PIVOT_WEIGHT,
    snap_tol: float = SNAP_TOL,
    exact_tol: float = EXACT_PIVOT_TOL,
    report: Report | None = None,
) -> SplineSpace:
    """Build the free-to-control map of the C1 quintic spline space.

    Parameters
    ----------
    uv : (V, 2) float or a :class:`Triangulation`
    faces : (F, 3) int, counter-clockwise in uv (omit when passing a Triangulation)
    singular_tol : pivots of the double elimination below this count as zero
        (:data:`~trispline.spline.tolerances.SINGULAR_TOL`)
    inner_weight : pivot preference of inner points relative to middle points
    snap_tol : interior valence-4 vertices within this times their mean edge length of the
        crossing of their two lines are moved onto it and are singular
        (:data:`~trispline.spline.tolerances.SNAP_TOL`; 0 moves none)
    exact_tol : vertex systems with a smaller pivot are eliminated again in double-double
        (:data:`~trispline.spline.tolerances.EXACT_PIVOT_TOL`)
    report : ``report(fraction)`` as the steps end (:data:`BUILD_SHARES`; writing ``M``, ~3/4 of the
        time, step by step)

    Returns
    -------
    SplineSpace
        Its ``tri`` is the triangulation actually used: the input, or a copy with the
        snapped vertices moved (``stats["snapped_vertices"]``, ``stats["max_move"]``).

    Notes
    -----
    The per-edge stages (diamonds, fast-path rows, flips) and the writing of
    ``M`` run on ranges of edges in a thread per core; every range writes its
    own entries, so the result does not depend on the thread count.
    """
    report = report or silent
    clock = StageTimer(lambda name, _seconds: report(BUILD_SHARES[name]))
    tri = uv if isinstance(uv, Triangulation) else Triangulation(uv, faces)
    _ = tri.edges, tri.edge_faces, tri.face_edges
    clock("triangulation")
    lay = layout_of(tri)
    with _parallel.Workers(max(tri.interior_edges.size, tri.n_faces)) as work:
        pidx_job = work.submit(point_index, tri)  # topology only (the snapped copy has the same): runs alongside
        tri, frame_scale, snapped = _snapped(tri, snap_tol)
        clock("snap")
        c2, n_weak = diamonds(work, tri, inner_weight, singular_tol)
        bad_v = n_weak > 0
        clock("diamonds")
        is_free, length = _classify(work, tri, lay, c2, bad_v)
        clock("classify")
        elim = vertex_systems(work, tri, lay, c2, frame_scale, n_weak, snapped.singular, singular_tol, inner_weight,
                              exact_tol)
        clock("elimination")
        free_pts, free_of_point = _free_points(tri, lay, bad_v, is_free, elim)
        n_free = 3 * tri.n_vertices + free_pts.size
        clock("free_points")
        M, max_coef = assemble(work, tri, lay, c2, bad_v, frame_scale, free_pts, free_of_point, n_free, length, elim,
                               span(report, BUILD_SHARES["free_points"], BUILD_SHARES["write_M"]))
        clock("write_M")
        pidx = pidx_job.result()
    space = _space(tri, lay, M, pidx, frame_scale, free_pts, elim, snapped, max(max_coef, elim.max_coef),
                   clock.timings)
    clock("finish")
    return space


#: :func:`build_space`'s progress at the end of each step: their shares of the time at 200k faces (writing
#: ``M`` 0.45 of 0.6 s).
BUILD_SHARES = {"triangulation": 0.02, "snap": 0.06, "diamonds": 0.16, "classify": 0.18, "elimination": 0.24,
                "free_points": 0.26, "write_M": 0.97, "finish": 1.0}


def _snapped(tri: Triangulation, snap_tol: float) -> tuple[Triangulation, np.ndarray, Snap]:
    """The triangulation to use (``tri`` or its snapped copy), its frame scales ``(V,)`` and the :class:`Snap`."""
    frame_scale = frame_scales(tri)
    snapped = snap(tri, frame_scale, snap_tol)
    if not snapped.moved.size:
        return tri, frame_scale, snapped
    tri = snapped.tri
    _ = tri.edges, tri.edge_faces, tri.face_edges
    return tri, frame_scales(tri), snapped


def _classify(work: _parallel.Workers, tri: Triangulation, lay: NetLayout, c2: np.ndarray, bad_v: np.ndarray
              ) -> tuple[np.ndarray, np.ndarray]:
    """``is_free: (n_points,) bool`` with the free flips set, ``length: (n_points,) int32`` with the
    fast-path middle rows set to 5 (a row holds at most 1 + 2 * (longest middle row) entries)."""
    is_free = _memory.full(lay.n_points, False, bool)  # besides the corners (free ids 0..V-1)
    length = _memory.full(lay.n_points, 0, np.int32)
    work.map(partial(_classify_range, tri, lay, c2, bad_v, is_free, length), tri.interior_edges.size)
    return is_free, length


def _classify_range(tri: Triangulation, lay: NetLayout, c2: np.ndarray, bad_v: np.ndarray, is_free: np.ndarray,
                    length: np.ndarray, lo: int, hi: int) -> None:
    """:func:`_classify` for interior edges ``lo:hi``."""
    e = tri.interior_edges[lo:hi]
    a, b, f0, f1, k0, k1 = diamond_ids(tri, e)
    fast_a, fast_b = ~bad_v[a], ~bad_v[b]
    length[lay.mid(e[fast_a], 0)] = 5  # two inner points and the star
    length[lay.mid(e[fast_b], 1)] = 5
    is_free[flip_pair(lay, f0, k0, f1, k1, c2[lo:hi])[1]] = True


def _free_points(tri: Triangulation, lay: NetLayout, bad_v: np.ndarray, is_free: np.ndarray, elim: Eliminated
                 ) -> tuple[np.ndarray, np.ndarray]:
    """Every free point besides the corners, and the free id of every point.

    Free: all inner points at fast-path vertices, what the eliminated systems left free, the
    free flips (``is_free`` on entry), and on boundary edges both middle points and the
    face's flip. Free ids: corners ``0..V-1``, frames ``V..3V-1``, then the others by point id.

    Returns
    -------
    free_pts : (n,) int64 sorted point ids
    free_of_point : (n_points,) free id of each point, -1 where dependent
    """
    nv, npts = tri.n_vertices, lay.n_points
    is_free[lay.inner0 : lay.flip0] = ~bad_v[tri.faces.ravel()]
    for pts in elim.free:
        is_free[pts] = True
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
    return free_pts, free_of_point


def _space(tri: Triangulation, lay: NetLayout, M, pidx: np.ndarray, frame_scale: np.ndarray, free_pts: np.ndarray,
           elim: Eliminated, snapped: Snap, max_coef: float, timings: dict[str, float]) -> SplineSpace:
    """The :class:`SplineSpace`: what each free variable is, the singular vertices, the statistics."""
    nv, n_free = tri.n_vertices, int(M.shape[1])
    free_kind = np.empty(n_free, np.int8)
    free_kind[:nv] = KIND_CORNER
    free_kind[nv : 3 * nv] = KIND_FRAME
    free_kind[3 * nv :] = np.array([KIND_MID, KIND_INNER, KIND_FLIP], np.int8)[
        np.searchsorted([lay.inner0, lay.flip0], free_pts, side="right")]
    free_point = np.concatenate([np.arange(nv), np.full(2 * nv, -1, np.int64), free_pts])
    frame_free = nv + 2 * np.arange(nv)[:, None] + np.arange(2)[None, :]
    sing = np.sort(np.concatenate(elim.singular)) if elim.singular else np.zeros(0, np.int64)
    stats = dict(max_coefficient=max(float(M.data.max(initial=0.0)), -float(M.data.min(initial=0.0))),
                 max_elimination_coefficient=max_coef, nnz=int(M.nnz), eliminated_vertices=elim.n_systems,
                 exact_vertices=elim.n_exact, snapped_vertices=int(snapped.moved.size), max_move=snapped.max_move,
                 max_relative_move=snapped.max_relative_move, timings=timings)
    return SplineSpace(tri=tri, layout=lay, M=M, point_index=pidx, corner_free=np.arange(nv), frame_free=frame_free,
                       frame_scale=frame_scale, free_kind=free_kind, free_point=free_point,
                       singular_vertices=sing, stats=stats)
