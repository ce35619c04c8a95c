"""``SplineSpace``: the C1 quintic spline space of a triangulation as ``P = M @ free``."""
from __future__ import annotations

from dataclasses import dataclass, field
from functools import partial

import numpy as np
import scipy.sparse as sp

from ..index import CORNER, FLIP, INNER, NCTRL
from ..net import NetLayout
from ..topology import Triangulation
from ..util import gather as _gather, parallel as _parallel, sparse as _sparse

#: What a free variable is (``SplineSpace.free_kind``), and the names of the kinds.
KIND_CORNER, KIND_FRAME, KIND_INNER, KIND_MID, KIND_FLIP = 0, 1, 2, 3, 4
KIND_NAMES = ("corner", "frame", "inner", "mid", "flip")

#: Faces per range of the threaded gathers in ``SplineSpace.patch_points`` / ``control_points``.
PATCH_CHUNK = 1 << 14


def working_origin(points: np.ndarray) -> np.ndarray | None:
    """The centre ``(d,)`` of the bounding box of ``points: (n, d)`` when it lies further from the
    origin than the box is wide (a UTM tile, a scan offset by 1e6), else ``None``: the ``about``
    of ``SplineSpace.control_points`` for nets fitted to such data."""
    lo, hi = points.min(0), points.max(0)
    centre = 0.5 * (lo + hi)
    return centre if np.abs(centre).max() > (hi - lo).max() else None


@dataclass(frozen=True, eq=False)
class SplineSpace:
    """The C1 quintic spline space over a triangulation, as ``P = M @ free``.

    Attributes
    ----------
    tri : Triangulation
        The triangulation actually used: the input, or a copy whose nearly singular
        vertices were moved onto the crossing of their two lines (``stats``).
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
    stats : dict
        ``max_coefficient`` (largest ``|M|`` entry); ``max_elimination_coefficient``
        (largest weight of one propagation step: fast-path and flip weights, and the
        eliminated rows' weights of free points and frame variables, star points collapsed
        into the frame); ``nnz``; ``eliminated_vertices`` (vertex systems reduced by
        pivoting) and ``exact_vertices`` (of these, eliminated again in double-double);
        ``snapped_vertices``, ``max_move`` (uv units) and ``max_relative_move`` (over the
        moved vertex's mean edge length); ``timings`` (seconds per build stage).
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
        return _sparse.matmul(self.M, _rows_of(free, self.n_free, "free", np.float64))

    def control_points(self, free: np.ndarray, about: np.ndarray | None = None) -> np.ndarray:
        """Per-patch control points ``(F, 21, d)`` from ``free: (n_free, d)``.

        ``about: (d,)``: compute the net of ``free - about`` and move it back, the corner points
        set to their free values exactly. ``M``'s rows are affine, so this is the same net, but
        for data far from the origin (UTM tiles, offsets of 1e6: see ``working_origin``) the C1
        combinations of large coordinates lose the digits of a small tile; about its centre the
        net is C1 up to the rounding of its stored coordinates.

        Equal to ``patch_points(points(free))``, without the whole net in between: the
        shared points (corners, stars, middle points: ``inner0`` rows) are computed
        first, a face's own inner and flip points straight into its patch, range by
        range (at 1M faces the net in between would be 300 MB of fresh memory; this
        keeps 156 MB).
        """
        free = _rows_of(free, self.n_free, "free", np.float64)
        if about is not None:
            ctrl = self.control_points(free - about) + about
            ctrl[:, CORNER] = free[self.corner_free[self.tri.faces]]
            return ctrl
        if free.ndim != 2 or not _sparse.kernel_ok(self.M, free):
            return self.patch_points(self.points(free))
        nf, d = self.point_index.shape[0], free.shape[1]
        shared = _sparse.matmul(self.M, free, rows=(0, self.layout.inner0))
        out = np.empty((nf, NCTRL, d))
        faces = partial(_own_points_into, self.M, self.layout, self.point_index,
                        np.ascontiguousarray(free).reshape(-1), shared, out)
        try:
            faces(0, min(1, nf))  # a kernel that refuses the call fails here, alone
        except (TypeError, ValueError, AttributeError):  # pragma: no cover - scipy changed its private API
            return self.patch_points(self.points(free))
        with _parallel.Workers(nf) as work:
            work.map(faces, nf, chunk=PATCH_CHUNK)
        return out

    def patch_points(self, points: np.ndarray) -> np.ndarray:
        """Gather a net ``points: (n_points, d)`` into per-patch ``(F, 21, d)``."""
        points = _rows_of(points, self.n_points, "points")
        pidx = self.point_index
        out = np.empty(pidx.shape + points.shape[1:], points.dtype)
        with _parallel.Workers(pidx.shape[0]) as work:
            work.map(partial(_gather_into, points, pidx, out), pidx.shape[0], chunk=PATCH_CHUNK)
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
        v = np.concatenate([t.edges[:, 0], t.edges[:, 1]])
        w = np.concatenate([t.edges[:, 1], t.edges[:, 0]])
        pt = np.concatenate([lay.star(e, 0), lay.star(e, 1)])
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


def _rows_of(a: np.ndarray, n: int, name: str, dtype=None) -> np.ndarray:
    """``a`` as an array with ``n`` rows (any trailing shape), else ``ValueError``."""
    a = np.asarray(a, dtype=dtype)
    if a.ndim == 0 or a.shape[0] != n:
        raise ValueError(f"{name} must have {n} rows, got shape {a.shape}")
    return a


def _gather_into(points: np.ndarray, pidx: np.ndarray, out: np.ndarray, lo: int, hi: int) -> None:
    """``out[lo:hi] = points[pidx[lo:hi]]`` for faces ``lo:hi``.

    np.take along axis 0 copies whole rows: ~3x faster than fancy indexing; each range
    also first-touches its own part of the output.
    """
    np.take(points, pidx[lo:hi].reshape(-1), axis=0, mode="clip", out=out[lo:hi].reshape((-1,) + points.shape[1:]))


def _own_points_into(M: sp.csr_array, lay: NetLayout, pidx: np.ndarray, xs: np.ndarray, shared: np.ndarray,
                     out: np.ndarray, lo: int, hi: int) -> None:
    """Patches ``lo:hi`` of ``out: (F, 21, d)``: shared points gathered, own points computed.

    ``shared: (inner0, d)`` holds the corner, star and middle points; ``xs`` is ``free``
    raveled. A face's inner and flip points are rows ``first + 3 f + k`` of ``M``.
    """
    d = out.shape[2]
    # own points' ids are >= inner0: clipped to the last shared point, then overwritten
    np.take(shared, pidx[lo:hi].reshape(-1), axis=0, mode="clip", out=out[lo:hi].reshape(-1, d))
    own = np.empty((hi - lo, 3, d))
    for slots, first in ((INNER, lay.inner0), (FLIP, lay.flip0)):
        _sparse.rows_into(M, xs, first + 3 * lo, first + 3 * hi, own.reshape(-1, d))
        for k, slot in enumerate(slots):  # basic indexing: a strided copy, no fancy-index loop
            out[lo:hi, slot] = own[:, k]
