"""Incremental local editing of a C1 spline surface (the paper's section 5.3).

    editor = SplineEditor(space, free)            # or .from_fit(result) / .from_surface(surface)
    res = editor.move(editor.inner_point(f, 0), xyz)
    res.points, res.faces, res.ctrl               # what changed, which patches, their new nets

How an edit realises the paper's order
--------------------------------------
The propagation map ``M`` (:mod:`.propagation`) is written row by row in the paper's
order, each row already in terms of free points: a star point's row from its vertex's
corner point and two frame points (the corner region), a middle edge point's row (or an
inner point's, where the pivoting switched direction at a degenerate vertex) from the
free inner and middle points of its vertex system and the star rows it needs (the
edges), a computed flip point's row from the other flip and the two middle rows of its
edge (the flips). Every row of ``M`` is therefore the fully propagated affine
combination of free points, and the nonzero rows of column ``j`` are *exactly* the
control points that moving free point ``j`` changes. An edit reads the column's rows
(CSC structure) and recomputes those rows from the current free vector,
``P[rows] = M[rows] @ free`` (raw CSR arrays, no scipy slicing). Because rows are
recomputed from scratch, never updated by differences, any sequence of edits
equals a full rebuild ``M @ free`` (up to the summation order, which is the same as
scipy's, so in practice bit for bit), and an edit costs ``O(nnz of the column's rows)``
-- bounded by the valences, independent of the mesh size.

Which patches an edit touches (from the structure, docs/design.md §3 'Local control'):

========================  ==============================================================
free point                patches that change
========================  ==============================================================
corner / frame of ``v``   the faces around ``v`` (its star points, the middle points at
                          ``v``'s end of its edges, their dependent flips -- all in the ring)
inner point of ``f``      ``f`` and the faces across ``f``'s two edges at that corner
at corner ``s``           (its two middle points and their edges' flips); where the
                          vertex system of ``s`` switched direction (degenerate frames),
                          at most the faces around ``s``
flip point of edge ``e``  the two faces of ``e`` (only the other flip changes)
boundary middle / flip    its own face only
========================  ==============================================================
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from .checks import as_array, check_ids, check_magnitude, real_number, whole_number
from .errors import DependentPointError, InputError, NotC1Error, first_few
from .propagation import KIND_FRAME, KIND_NAMES, SplineSpace
from .tolerances import FROM_SURFACE_RTOL
from .util import gather as _gather

__all__ = ["SplineEditor", "EditResult", "DependentPointError", "NotC1Error"]


@dataclass(frozen=True)
class EditResult:
    """What one edit (or one batch) changed.

    Attributes
    ----------
    free_ids : (k,) int64, the free points moved (in call order)
    old_free : (k, d) their previous positions (``editor.move(free_ids, old_free)`` undoes)
    points : (m,) int64, sorted global control point ids recomputed
    faces : (n,) int64, sorted patches containing any of them
    ctrl : (n, 21, d) the new control points of those patches
    """

    free_ids: np.ndarray
    old_free: np.ndarray
    points: np.ndarray
    faces: np.ndarray
    ctrl: np.ndarray


def _ranges(ptr: np.ndarray, rows: np.ndarray, local: bool = False) -> tuple[np.ndarray, np.ndarray | None]:
    """Concatenated index ranges ``ptr[r]:ptr[r+1]`` of ``rows`` (``(n,)``), and with
    ``local`` the position in ``rows`` each entry belongs to (``(n,)``)."""
    starts = ptr[rows]
    return _gather.segments(starts, ptr[rows + 1] - starts, owner=local)


class SplineEditor:
    """Mutable editing state over an immutable :class:`SplineSpace`.

    Parameters
    ----------
    space : SplineSpace
    free : (n_free, d) float, the free points (copied)

    Attributes
    ----------
    space : SplineSpace
    free : (n_free, d) current free points (read-only view)
    points : (n_points, d) current control points (read-only view); always equal to
        ``space.M @ free``
    """

    def __init__(self, space: SplineSpace, free: np.ndarray) -> None:
        free = np.array(as_array(free, "free", (space.n_free, "d"), finite=True))  # a copy: the editor's own
        self.space = space
        self._free = free
        M = sp.csr_array(space.M)
        M.sort_indices()
        # index arrays keep scipy's dtype (int32 up to 2^31 nonzeros): half the memory at 1M faces
        self._indptr = M.indptr
        self._indices = M.indices
        self._data = M.data
        C = sp.csc_array(M)
        C.sort_indices()
        self._cptr = C.indptr
        self._crows = C.indices
        self._points = M @ free
        # point -> faces incidence (CSR): faces containing each global point
        pid = space.point_index.ravel()
        order = np.argsort(pid, kind="stable")
        self._pf_face = (order // space.point_index.shape[1]).astype(np.int64)
        self._pf_ptr = np.concatenate([[0], np.cumsum(np.bincount(pid, minlength=space.n_points))]).astype(np.int64)
        # global point -> free id (-1 for dependent points and for frames, which are no control points)
        self._point_free = np.full(space.n_points, -1, np.int64)
        is_pt = space.free_point >= 0
        self._point_free[space.free_point[is_pt]] = np.flatnonzero(is_pt)

    # --------------------------------------------------------------- factories
    @classmethod
    def from_fit(cls, result) -> "SplineEditor":
        """Editor on a :class:`trispline.fit.FitResult` (uses its ``space`` and ``free``)."""
        return cls(result.space, result.free)

    @classmethod
    def from_surface(cls, surface, space: SplineSpace | None = None, *, rtol: float = FROM_SURFACE_RTOL
                     ) -> "SplineEditor":
        """Editor on a :class:`SplineSurface` whose net is C1 (e.g. a loaded fit).

        The free points are read off the net (:meth:`SplineSpace.free_from_points`);
        the net must be reproduced from them to ``rtol`` of its size, else
        :class:`NotC1Error` (a C0-only or foreign net cannot be edited locally).
        """
        from .propagation import build_space
        from .surface import SplineSurface

        if not isinstance(surface, SplineSurface):
            raise InputError(f"surface must be a SplineSurface, got {type(surface).__name__}")
        rtol = real_number(rtol, "rtol", positive=True)
        if space is None:
            space = build_space(surface.uv, surface.faces)
        ctrl = as_array(surface.ctrl, "surface ctrl", space.point_index.shape + ("d",))
        pts = np.zeros((space.n_points, ctrl.shape[-1]))
        pts[space.point_index.reshape(-1)] = ctrl.reshape(-1, ctrl.shape[-1])
        free = space.free_from_points(pts)
        err = np.abs(space.control_points(free) - ctrl).max(axis=(1, 2))
        scale = float(np.ptp(ctrl.reshape(-1, ctrl.shape[-1]), axis=0).max()) or 1.0
        bad = np.flatnonzero(err > rtol * scale)
        if bad.size:
            raise NotC1Error(
                f"the surface's control net is not in the C1 spline space of its domain: patches "
                f"{first_few(bad)} differ from the propagated net by up to {err.max():.3g} "
                f"(size {scale:.3g}, tolerance {rtol:g} relative)"
            )
        return cls(space, free)

    # ------------------------------------------------------------------ state
    @property
    def free(self) -> np.ndarray:
        v = self._free.view()
        v.setflags(write=False)
        return v

    @property
    def points(self) -> np.ndarray:
        v = self._points.view()
        v.setflags(write=False)
        return v

    @property
    def ctrl(self) -> np.ndarray:
        """``(F, 21, d)`` per-patch control points (a gather, ``O(F)``)."""
        return self.space.patch_points(self._points)

    def patch_ctrl(self, faces: np.ndarray) -> np.ndarray:
        """``(n, 21, d)`` control points of the patches ``faces``."""
        faces = check_ids(as_array(np.atleast_1d(faces), "faces", (None,), integer=True, whole_floats=False), "faces",
                          self.space.tri.n_faces)
        return self._points[self.space.point_index[faces]]

    def to_surface(self, **extras):
        """An immutable :class:`SplineSurface` of the current state (``free`` in its extras)."""
        from .surface import SplineSurface

        t = self.space.tri
        return SplineSurface(t.uv, t.faces, self.ctrl, extras=dict(free=self._free, **extras))

    def rebuild_error(self) -> float:
        """``max |points - M @ free|`` (0 up to rounding; a self-check)."""
        return float(np.abs(self._points - self.space.M @ self._free).max(initial=0.0))

    # ------------------------------------------------------ addressing by meaning
    def corner_point(self, v: int) -> int:
        """Free id of the corner point ``z_v`` (the interpolated data vertex ``v``)."""
        return int(self.space.corner_free[self.vertex_id(v)])

    def frame_points(self, v: int) -> np.ndarray:
        """``(2,)`` free ids of the frame points ``h_v(v + d_v e_x / 5)``, ``h_v(v + d_v e_y / 5)``."""
        return self.space.frame_free[self.vertex_id(v)].copy()

    def inner_point(self, face: int, local_vertex: int) -> int:
        """Free id of the near-corner inner point of ``face`` at its corner ``local_vertex``."""
        f, k = self._face_local(face, local_vertex)
        return self.point_free_id(int(self.space.layout.inner(f, k)), strict=True)

    def flip_point(self, face: int, local_edge: int) -> int:
        """Free id of ``face``'s flip point on the edge opposite its corner ``local_edge``."""
        f, k = self._face_local(face, local_edge)
        return self.point_free_id(int(self.space.layout.flip(f, k)), strict=True)

    def mid_point(self, edge: int, end: int) -> int:
        """Free id of edge ``edge``'s middle point nearer its end ``end`` (0: smaller vertex)."""
        edge = whole_number(edge, "edge", least=0, most=self.space.tri.n_edges - 1)
        end = whole_number(end, "end", least=0, most=1)
        return self.point_free_id(int(self.space.layout.mid(edge, end)), strict=True)

    def point_free_id(self, point: int, *, strict: bool = False) -> int:
        """Free id of global control point ``point``; ``-1`` if it is dependent
        (``strict=True``: raise :class:`DependentPointError` naming its controllers)."""
        point = whole_number(point, "control point id", least=0, most=self.space.n_points - 1)
        j = int(self._point_free[point])
        if j < 0 and strict:
            raise self._dependent_error(point)
        return j

    def controllers(self, points) -> np.ndarray:
        """Sorted free ids whose positions determine control point(s) ``points`` (int or
        ``(k,)``): the nonzero columns of those rows of M."""
        pts = check_ids(as_array(np.atleast_1d(points), "control point ids", (None,), integer=True),
                        "control point ids", self.space.n_points)
        idx, _ = _ranges(self._indptr, pts)
        return np.unique(self._indices[idx][self._data[idx] != 0]).astype(np.int64)

    def vertex_faces(self, vertices) -> np.ndarray:
        """Sorted patches containing any of ``vertices`` (int or ``(k,)``), in ``O(k)``."""
        v = check_ids(as_array(np.atleast_1d(vertices), "vertex ids", (None,), integer=True),
                      "vertex ids", self.space.tri.n_vertices)
        return self._faces_of(v)  # corner point id == vertex id

    def supports(self, free_ids) -> tuple[np.ndarray, np.ndarray]:
        """Patches each free point controls, without moving anything.

        Returns
        -------
        owner : (n,) int64, position in ``free_ids``
        face : (n,) int64, a patch that changes when ``free_ids[owner]`` moves (pairs may repeat)
        """
        ids = self._free_ids(free_ids)
        cidx, cown = _ranges(self._cptr, ids, local=True)
        rows = self._crows[cidx]
        fidx, fown = _ranges(self._pf_ptr, rows, local=True)
        return cown[fown], self._pf_face[fidx]

    def patch_matrix(self, faces: np.ndarray, free_ids: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The patches' control points as an affine function of some free points.

        ``ctrl[faces] = A @ free[free_ids] + c`` with the other free points at their
        current positions. ``free_ids`` must be sorted.

        Returns
        -------
        A : (21 n, k) scipy.sparse.csr_array, rows in patch-major storage order
        c : (21 n, d)
        """
        faces = np.asarray(faces, np.int64)
        ids = np.asarray(free_ids, np.int64)
        rows = self.space.point_index[faces].ravel()
        idx, loc = _ranges(self._indptr, rows, local=True)
        col = self._indices[idx]
        pos = np.searchsorted(ids, col)
        pos_c = np.minimum(pos, max(ids.size - 1, 0))
        inside = (pos < ids.size) & (ids[pos_c] == col) if ids.size else np.zeros(col.size, bool)
        A = sp.csr_array((self._data[idx[inside]], (loc[inside], pos[inside])), shape=(rows.size, ids.size))
        out = ~inside
        vals = self._data[idx[out], None] * self._free[col[out]]
        c = np.stack([np.bincount(loc[out], vals[:, k], minlength=rows.size) for k in range(vals.shape[1])], 1)
        return A, c

    def describe_point(self, point: int) -> str:
        """Human-readable name of global control point ``point``."""
        lay, t = self.space.layout, self.space.tri
        p = whole_number(point, "control point id", least=0, most=self.space.n_points - 1)
        if p < lay.star0:
            return f"corner point of vertex {p}"
        if p < lay.mid0:
            e, end = divmod(p - lay.star0, 2)
            a, b = t.edges[e, end], t.edges[e, 1 - end]
            return f"star point of vertex {a} toward {b} (edge {e})"
        if p < lay.inner0:
            e, end = divmod(p - lay.mid0, 2)
            a, b = t.edges[e, end], t.edges[e, 1 - end]
            return f"middle point of edge {e} ({a}, {b}) nearer vertex {a}"
        if p < lay.flip0:
            f, k = divmod(p - lay.inner0, 3)
            return f"near-corner inner point of face {f} at vertex {t.faces[f, k]}"
        f, k = divmod(p - lay.flip0, 3)
        a, b = t.faces[f, (k + 1) % 3], t.faces[f, (k + 2) % 3]
        return f"flip point of face {f} on edge ({a}, {b})"

    def describe_free(self, j: int) -> str:
        """Human-readable name of free variable ``j``."""
        j = self._free_ids(j)[0]
        kind = int(self.space.free_kind[j])
        if kind == KIND_FRAME:
            v, which = divmod(int(j - self.space.frame_free[0, 0]), 2)
            return f"free {j} (frame): frame point {'xy'[which]} of vertex {v}"
        return f"free {j} ({KIND_NAMES[kind]}): {self.describe_point(int(self.space.free_point[j]))}"

    # ------------------------------------------------------------------ edits
    def move(self, free_ids, positions) -> EditResult:
        """Move free points to new positions; recompute only what depends on them.

        Parameters
        ----------
        free_ids : int or (k,) int, distinct free ids
        positions : (d,) or (k, d) float

        Returns
        -------
        EditResult
        """
        ids = self._free_ids(free_ids)
        # one position (d,) reads as (1, d)
        pos = check_magnitude(as_array(np.atleast_2d(positions), "positions", (ids.size, self._free.shape[1]),
                                       finite=True), "positions")
        old = self._free[ids]
        self._free[ids] = pos
        rows = self._column_rows(ids)
        self._recompute(rows)
        faces = self._faces_of(rows)
        return EditResult(ids, old, rows, faces, self._points[self.space.point_index[faces]])

    def translate(self, free_ids, delta) -> EditResult:
        """Move free points by ``delta`` ((d,) or (k, d))."""
        ids = self._free_ids(free_ids)
        d = self._free.shape[1]
        delta = _real(delta, "delta")
        if delta.shape not in ((d,), (ids.size, d)):
            raise InputError(f"delta must have shape ({d},) or ({ids.size}, {d}), got {delta.shape}")
        return self.move(ids, self._free[ids] + delta)

    def move_point(self, point_ids, positions) -> EditResult:
        """Move global control points that are free (corner, inner, flip, boundary points).

        A dependent point raises :class:`DependentPointError` naming the free points that
        control it. Frame points are no control points: move them with :meth:`move`
        and :meth:`frame_points`.
        """
        pids = np.atleast_1d(np.asarray(point_ids))
        ids = np.array([self.point_free_id(p, strict=True) for p in pids.ravel()], np.int64)
        return self.move(ids if np.ndim(point_ids) else ids[0], positions)

    def move_vertex(self, v: int, xyz, *, carry_frame: bool = True) -> EditResult:
        """Re-interpolate a changed data vertex: move the corner point ``z_v`` to ``xyz``.

        With ``carry_frame`` (default) the two frame points move by the same offset, so
        the corner region (the tangent plane at ``v``) is translated, not tilted.
        """
        v = self.vertex_id(v)
        xyz = as_array(_real(xyz, "xyz"), "xyz", (self._free.shape[1],), finite=True)
        if not carry_frame:
            return self.move(self.space.corner_free[v], xyz)
        ids = np.array([self.space.corner_free[v], *self.space.frame_free[v]], np.int64)
        pos = self._free[ids] + (xyz - self._free[ids[0]])
        pos[0] = xyz  # exactly the new data vertex
        return self.move(ids, pos)

    def vertex_id(self, v) -> int:
        """``v`` as a vertex index, checked: an integer in ``[0, V)`` (else :class:`InputError`)."""
        return whole_number(v, "vertex", least=0, most=self.space.tri.n_vertices - 1)

    # --------------------------------------------------------------- internals
    def _face_local(self, face, k) -> tuple[int, int]:
        return (whole_number(face, "face", least=0, most=self.space.tri.n_faces - 1),
                whole_number(k, "local index", least=0, most=2))

    def _free_ids(self, free_ids) -> np.ndarray:
        ids = as_array(np.atleast_1d(free_ids), "free ids", (None,), integer=True, whole_floats=False)
        check_ids(ids, "free ids", self.space.n_free)
        if ids.size > 1 and np.unique(ids).size != ids.size:
            s = np.sort(ids)
            raise InputError(f"free ids repeat in one edit: {first_few(np.unique(s[1:][s[1:] == s[:-1]]))}")
        return ids

    def _column_rows(self, ids: np.ndarray) -> np.ndarray:
        if ids.size == 1:
            j = ids[0]
            return self._crows[self._cptr[j] : self._cptr[j + 1]].astype(np.int64)
        idx, _ = _ranges(self._cptr, ids)
        return np.unique(self._crows[idx]).astype(np.int64, copy=False)

    def _recompute(self, rows: np.ndarray) -> None:
        """``P[rows] = M[rows] @ free`` from the raw CSR arrays (rows of M are never empty)."""
        if rows.size == 0:
            return
        idx, local = _ranges(self._indptr, rows, local=True)
        vals = self._data[idx, None] * self._free[self._indices[idx]]
        # bincount accumulates in entry order, like scipy's CSR product: bit-identical rows
        m = rows.size
        for c in range(vals.shape[1]):
            self._points[rows, c] = np.bincount(local, vals[:, c], minlength=m)

    def _faces_of(self, rows: np.ndarray) -> np.ndarray:
        if rows.size == 0:
            return np.zeros(0, np.int64)
        idx, _ = _ranges(self._pf_ptr, rows)
        return np.unique(self._pf_face[idx])

    def _dependent_error(self, point: int) -> DependentPointError:
        ctl = self.controllers(point)
        names = "; ".join(self.describe_free(j) for j in ctl[:8])
        more = f"; ... ({ctl.size} in all)" if ctl.size > 8 else ""
        return DependentPointError(
            f"control point {point} ({self.describe_point(point)}) is not free: the C1 propagation "
            f"computes it from {ctl.size} free points: {names}{more}. Move one of those instead.",
            point, ctl,
        )


def _real(values, name: str) -> np.ndarray:
    """``values`` as a float array, or InputError naming ``name`` (strings, objects)."""
    try:
        return np.asarray(values, np.float64)
    except (TypeError, ValueError):
        raise InputError(f"{name} must be real numbers, got {values!r}") from None
