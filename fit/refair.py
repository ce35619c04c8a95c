"""Local re-fairing: the interactive counterpart of the global fit.

    rf = LocalRefairer.from_fit(result, rings=2)     # result = fit_surface(...)
    res = rf.move_vertex(v, xyz)                     # data vertex v moved: re-interpolate + re-fair
    rf.editor.ctrl, res.free_ids, res.faces

After a data vertex ``v`` moves, the corner point ``z_v`` follows it (exact
interpolation) and the free points *around* ``v`` are re-optimised with every other
free point fixed, minimising the same fairness energy as :func:`fit_surface`
(thin-plate ``bend`` + ``tilt`` + ``local``, with the weights of the fit, see
:mod:`trispline.fit.energy`). The result is still exactly C1 (every free vector is).

Which free points move (``rings = k``): the region is the set of patches within
``k`` rings of ``v`` (``k = 1``: the patches around ``v``; ``k = 2``: those around
its 1-ring neighbours, ...). The re-optimised free points are the non-corner free
points whose whole support (the patches they control, docs/design.md §3 'Local control')
lies in the region, so *nothing outside the region changes*. The energy is
restricted to the patches those points control (all other terms are constant), and
its targets (the local fits of the data, which move with the data) are recomputed
only on a halo of ``fit_rings - 1`` more rings of vertices around those patches, where
they equal the global fit's targets exactly (:mod:`trispline.fit.energy.context`). Cost: ``O(k^2)`` patches, independent of the mesh size.

Terms not supported locally: the nonlinear ``angle`` term and extra ``data`` points
(the fit result does not keep the samples); :class:`LocalRefairer` refuses weights
that use them.
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np
import scipy.sparse.linalg as spla

from trispline.spline.checks import as_array, whole_number
from trispline.spline.edit import EditResult, SplineEditor
from trispline.spline.errors import InputError
from trispline.spline.index import NCTRL
from trispline.spline.propagation import KIND_CORNER, SplineSpace
from trispline.spline.util.timer import StageTimer

from . import targets
from .energy import frame_ids, normal_equations, normal_parts, setup_terms, term_context, term_energies
from .weights import FitWeights

__all__ = ["LocalRefairer", "RefairResult", "fairness_energy"]

#: The terms a re-fair sees (the quadratic ones without extra samples).
LOCAL_TERMS = ("bend", "tilt", "local")


def _report(energies: dict[str, float]) -> dict[str, float]:
    """``bend``, ``tilt``, ``local`` and their ``total``."""
    out = {k: energies[k] for k in LOCAL_TERMS}
    out["total"] = sum(out.values())
    return out


def fairness_energy(space: SplineSpace, free: np.ndarray, V: np.ndarray, weights: FitWeights = FitWeights(),
                    *, curved_outline: bool = False, smooth_map: bool | None = None) -> dict[str, float]:
    """The quadratic fairness energy of :func:`fit_surface` (bend, tilt, local; data units).

    Parameters
    ----------
    space : SplineSpace, free : (n_free, 3), V : (nv, 3) data vertices
    curved_outline, smooth_map : the fit's own (:attr:`~trispline.fit.pipeline.FitResult.curved_outline`,
        :attr:`~trispline.fit.pipeline.FitResult.smooth_map`)

    Returns
    -------
    dict with ``bend``, ``tilt``, ``local``, ``total``
    """
    terms = setup_terms(term_context(space, np.asarray(V, float), replace(weights, angle=0.0),
                                     curved_outline=curved_outline, smooth_map=smooth_map))
    free = np.asarray(free, float)
    frames = free[frame_ids(space, np.arange(space.tri.n_vertices))]
    return _report(term_energies(space.control_points(free), frames, terms))


@dataclass(frozen=True)
class RefairResult:
    """Outcome of one local re-fairing.

    Attributes
    ----------
    vertex : the data vertex
    rings : region size
    free_ids : (k,) sorted free ids re-optimised (all inside the region)
    region : (r,) sorted patches of the region (nothing outside changed)
    faces : (n,) sorted patches whose control points changed (subset of ``region``)
    energy_before, energy_after : dict, the region's energy terms before and after
        (after the vertex moved; differences equal differences of the global energy)
    edit : EditResult of the re-optimisation move
    timings : dict stage -> seconds
    """

    vertex: int
    rings: int
    free_ids: np.ndarray
    region: np.ndarray
    faces: np.ndarray
    energy_before: dict
    energy_after: dict
    edit: EditResult
    timings: dict = field(default_factory=dict)


class LocalRefairer:
    """Move data vertices and re-fair around them, on a :class:`SplineEditor`.

    Parameters
    ----------
    editor : SplineEditor (modified in place)
    V : (nv, 3) data vertices (copied; kept in sync by :meth:`move_vertex`)
    weights : FitWeights of the fit (``angle`` must be 0)
    rings : default region size (>= 1)
    curved_outline : the fit's own (:attr:`~trispline.fit.pipeline.FitResult.curved_outline`): the
        halo's boundary patches get the fit's targets
    smooth_map : the fit's own (:attr:`~trispline.fit.pipeline.FitResult.smooth_map`; default ``not
        curved_outline``): the outline's local fits are the fit's
    """

    def __init__(self, editor: SplineEditor, V: np.ndarray, weights: FitWeights = FitWeights(), *,
                 rings: int = 2, curved_outline: bool = False, smooth_map: bool | None = None) -> None:
        if not isinstance(weights, FitWeights):
            raise InputError(f"weights must be a FitWeights, got {type(weights).__name__}")
        if weights.angle > 0:
            raise InputError(f"local re-fairing supports the quadratic terms only; weights.angle is "
                             f"{weights.angle}, set it to 0")
        nv = editor.space.tri.n_vertices
        V = np.array(as_array(V, "V", (nv, 3), finite=True))  # a copy: move_vertex keeps it in sync
        self.editor = editor
        self.V = V
        self.weights = weights
        self.curved_outline = bool(curved_outline)
        self.smooth_map = not self.curved_outline if smooth_map is None else bool(smooth_map)
        self.rings = self._check_rings(rings)

    @classmethod
    def from_fit(cls, result, *, rings: int = 2) -> "LocalRefairer":
        """From a :class:`FitResult` (its space, free points, data vertices and weights)."""
        if float(result.energies.get("data", 0.0)) > 0:
            raise InputError("the fit used extra data points, which local re-fairing does not see; "
                             "refit globally instead")
        ed = SplineEditor.from_fit(result)
        return cls(ed, result.free[result.space.corner_free], result.weights, rings=rings,
                   curved_outline=result.curved_outline, smooth_map=result.smooth_map)

    @staticmethod
    def _check_rings(rings) -> int:
        return whole_number(rings, "rings", least=1)

    def energy(self) -> dict[str, float]:
        """The global fairness energy of the current surface (``O(n)``; for checks)."""
        return fairness_energy(self.editor.space, self.editor.free, self.V, self.weights,
                               curved_outline=self.curved_outline, smooth_map=self.smooth_map)

    def region(self, vertex: int, rings: int | None = None) -> tuple[np.ndarray, np.ndarray]:
        """``(faces, vertices)``: the patches within ``rings`` of ``vertex`` and their vertices."""
        rings = self.rings if rings is None else self._check_rings(rings)
        ed = self.editor
        verts = np.array([ed.vertex_id(vertex)], np.int64)
        faces = ed.vertex_faces(verts)
        for _ in range(rings - 1):
            grown = ed.vertex_faces(np.unique(ed.space.tri.faces[faces]))
            if grown.size == faces.size:  # the region covers its component: more rings add nothing
                break
            faces = grown
        return faces, np.unique(ed.space.tri.faces[faces])

    def region_free(self, vertex: int, rings: int | None = None) -> tuple[np.ndarray, np.ndarray]:
        """``(free_ids, region)``: the non-corner free points whose support lies in the region."""
        ed, space = self.editor, self.editor.space
        region, _ = self.region(vertex, rings)
        cand = ed.controllers(np.unique(space.point_index[region]))
        cand = cand[space.free_kind[cand] != KIND_CORNER]
        owner, face = ed.supports(cand)
        outside = np.unique(owner[~np.isin(face, region)])
        keep = np.ones(cand.size, bool)
        keep[outside] = False
        return cand[keep], region

    def move_vertex(self, vertex: int, xyz, rings: int | None = None) -> RefairResult:
        """Move data vertex ``vertex`` to ``xyz`` (the corner point follows exactly) and re-fair."""
        v = self.editor.vertex_id(vertex)
        rings = self.rings if rings is None else self._check_rings(rings)
        try:
            xyz = np.asarray(xyz, np.float64)
        except (TypeError, ValueError):
            raise InputError(f"xyz must be 3 finite numbers, got {xyz!r}") from None
        if xyz.shape != (3,) or not np.isfinite(xyz).all():
            raise InputError(f"xyz must be 3 finite numbers, got {xyz!r}")
        old = self.V[v].copy()
        edit = self.editor.move_vertex(v, xyz, carry_frame=True)  # refuses a position beyond double precision
        self.V[v] = xyz
        try:
            return self.refair(v, rings)
        except InputError:  # nothing half done: the vertex goes back where it was
            self.V[v] = old
            self.editor.move(edit.free_ids, edit.old_free)
            raise

    def refair(self, vertex: int, rings: int | None = None) -> RefairResult:
        """Re-optimise the free points around ``vertex`` with everything else fixed."""
        clock = StageTimer()
        rings = self.rings if rings is None else self._check_rings(rings)
        ed, space = self.editor, self.editor.space
        v = ed.vertex_id(vertex)
        ids, region = self.region_free(v, rings)
        faces, frame_vertices, halo = self._support(ids)
        clock("region")
        terms = setup_terms(term_context(space, self.V, self.weights, faces=faces, frame_vertices=frame_vertices,
                                         halo=halo, curved_outline=self.curved_outline,
                                         smooth_map=self.smooth_map))
        clock("targets")
        A, c = ed.patch_matrix(faces, ids)  # ctrl = A x + c
        fids = frame_ids(space, frame_vertices)
        fpos = np.searchsorted(ids, fids)
        if not np.array_equal(ids[np.minimum(fpos, max(ids.size - 1, 0))], fids):
            raise AssertionError("a frame point of the region is missing from the re-optimised set")
        H, rhs = normal_equations(A, c, fpos, normal_parts(terms, faces.size, fids.size))
        clock("assemble")
        x = self._solve(H, rhs, v)
        clock("solve")
        n = faces.size
        before = _report(term_energies((A @ ed.free[ids] + c).reshape(n, NCTRL, 3), ed.free[fids], terms))
        res = ed.move(ids, x)
        after = _report(term_energies(ed.patch_ctrl(faces), ed.free[fids], terms))
        clock("apply")
        return RefairResult(vertex=v, rings=rings, free_ids=ids, region=region, faces=res.faces,
                            energy_before=before, energy_after=after, edit=res, timings=clock.timings)

    def _support(self, ids: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(faces, frame_vertices, halo)`` of free points ``ids``: the patches they control, the
        vertices whose frames are among them, and those patches' faces grown by ``fit_rings - 1``
        rings of vertices (where the local fits equal the global ones; near the outline, where the uv
        were given, by the rings of its second fits, :data:`~trispline.fit.targets.OUTLINE_FITS`)."""
        ed, space = self.editor, self.editor.space
        _, face = ed.supports(ids)
        faces = np.unique(face)
        verts = np.unique(space.tri.faces[faces])
        frame_vertices = verts[np.isin(space.frame_free[verts, 0], ids)]
        halo = ed.vertex_faces(verts)
        wider = targets.OUTLINE_RING and self.smooth_map  # an outline vertex's fit: a ring more
        grow = self.weights.fit_rings - 1 + int(wider)
        for _ in range(grow):
            halo = ed.vertex_faces(np.unique(space.tri.faces[halo]))
        if (targets.outline_fit_kernels(not self.smooth_map)
                and space.tri.boundary_vertex_mask[space.tri.faces[halo]].any()):
            for _ in range(max(targets.OUTLINE_FIT_RINGS) - grow):  # the second fits near the outline: their rings
                halo = ed.vertex_faces(np.unique(space.tri.faces[halo]))
        return faces, frame_vertices, halo

    @staticmethod
    def _solve(H, rhs: np.ndarray, vertex: int) -> np.ndarray:
        """``H^{-1} rhs`` by a sparse LU (``(0, 3)`` when nothing is free)."""
        if H.shape[0] == 0:
            return np.zeros((0, 3))
        try:
            return spla.splu(H.tocsc()).solve(np.ascontiguousarray(rhs))
        except RuntimeError as exc:  # exactly singular: weights that leave points undetermined
            raise InputError(f"the local fairing problem around vertex {vertex} is singular ({exc}); "
                             f"use positive local and tilt weights") from None
