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
points whose whole support (the patches they control, DESIGN.md §3 'Local control')
lies in the region, so *nothing outside the region changes*. The energy is
restricted to the patches those points control (all other terms are constant), and
its targets (the local polynomial fits of the data, which move with the data) are
recomputed only on a halo of ``fit_rings`` more rings, where they equal the global
fit's targets exactly. Cost: ``O(k^2)`` patches, independent of the mesh size.

Terms not supported locally: the nonlinear ``angle`` term and extra ``data`` points
(the fit result does not keep the samples); :class:`LocalRefairer` refuses weights
that use them.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from trispline.spline.index import CORNER, NCTRL, STAR
from trispline.spline.edit import EditResult, SplineEditor
from trispline.spline.errors import InputError
from trispline.spline.propagation import KIND_CORNER, KIND_FRAME, SplineSpace

from . import energy as en
from .pipeline import FitWeights
from .energy.gram import thin_plate_gram
from .targets import local_rbf_fit

__all__ = ["LocalRefairer", "RefairResult", "fairness_energy"]

def _local_mask() -> np.ndarray:
    """(21,) patch points carrying the ``local`` term: all but corners and stars."""
    mask = np.ones(NCTRL, bool)
    mask[CORNER] = False
    mask[STAR[STAR >= 0]] = False
    return mask


@dataclass
class _Terms:
    """Energy data of some patches and frames (data units)."""

    gram: np.ndarray  # (n, 21, 21) bend weight included
    point_weight: np.ndarray  # (n, 21) local-term weights
    target: np.ndarray  # (n, 21, 3)
    frame_ids: np.ndarray  # (m,) free ids of frame points
    tilt_target: np.ndarray  # (m, 3)
    tilt_weight: np.ndarray  # (m,) squared scales


def _terms(space: SplineSpace, V: np.ndarray, w: FitWeights, faces: np.ndarray, frame_vertices: np.ndarray,
           halo_faces: np.ndarray) -> _Terms:
    """Targets and weights of the patches ``faces`` and of the frames of ``frame_vertices``.

    The local polynomial fits are computed on ``halo_faces`` only; they equal the global
    fits at every vertex whose ``fit_rings``-ring lies in the halo (vertices are renumbered
    in increasing order, so the neighbour order, and the truncation, are the global ones).
    """
    tri = space.tri
    hv = np.unique(tri.faces[halo_faces])

    def loc(a):
        return np.searchsorted(hv, a)

    hfaces = loc(tri.faces[halo_faces])
    fit = local_rbf_fit(tri.uv[hv], V[hv], hfaces, max_degree=w.fit_degree, rings=w.fit_rings)
    target = en.blended_targets(tri.uv[hv], loc(tri.faces[faces]), fit.evaluate, power=w.blend_power)
    areas = tri.areas
    gram = thin_plate_gram(tri.bary_gradients[faces], areas[faces]) * w.bend
    pw = np.where(_local_mask()[None, :], (w.local / areas[faces])[:, None], 0.0)
    # tilt: frame points toward the fitted tangent frame
    lv = loc(frame_vertices)
    vert_area = np.bincount(hfaces.ravel(), np.repeat(areas[halo_faces] / 3.0, 3), minlength=hv.size)[lv]
    d = space.frame_scale[frame_vertices]
    Vf = V[frame_vertices]
    grad = fit.grad[lv]  # (m, 3, 2)
    tilt_target = np.concatenate([Vf + grad[:, :, 0] * (d / 5.0)[:, None], Vf + grad[:, :, 1] * (d / 5.0)[:, None]])
    tilt_weight = np.tile(w.tilt * vert_area * 25.0 / d**4, 2)
    frame_ids = np.concatenate([space.frame_free[frame_vertices, 0], space.frame_free[frame_vertices, 1]])
    return _Terms(gram, pw, target, frame_ids, tilt_target, tilt_weight)


def _energy(ctrl: np.ndarray, frames: np.ndarray, t: _Terms) -> dict[str, float]:
    """``bend``, ``tilt``, ``local`` and ``total`` of patches ``ctrl (n, 21, 3)`` and frame points ``(m, 3)``."""
    bend = float(np.einsum("fic,fij,fjc->", ctrl, t.gram, ctrl))
    local = float((t.point_weight[..., None] * (ctrl - t.target) ** 2).sum())
    tilt = float((t.tilt_weight[:, None] * (frames - t.tilt_target) ** 2).sum())
    return dict(bend=bend, tilt=tilt, local=local, total=bend + tilt + local)


def fairness_energy(space: SplineSpace, free: np.ndarray, V: np.ndarray, weights: FitWeights = FitWeights()
                    ) -> dict[str, float]:
    """The quadratic fairness energy of :func:`fit_surface` (bend, tilt, local; data units).

    Parameters
    ----------
    space : SplineSpace, free : (n_free, 3), V : (nv, 3) data vertices

    Returns
    -------
    dict with ``bend``, ``tilt``, ``local``, ``total``
    """
    allf = np.arange(space.tri.n_faces)
    t = _terms(space, np.asarray(V, float), weights, allf, np.arange(space.tri.n_vertices), allf)
    free = np.asarray(free, float)
    return _energy(space.control_points(free), free[t.frame_ids], t)


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
    """

    def __init__(self, editor: SplineEditor, V: np.ndarray, weights: FitWeights = FitWeights(), *,
                 rings: int = 2) -> None:
        if not isinstance(weights, FitWeights):
            raise InputError(f"weights must be a FitWeights, got {type(weights).__name__}")
        if weights.angle > 0:
            raise InputError(f"local re-fairing supports the quadratic terms only; weights.angle is "
                             f"{weights.angle}, set it to 0")
        nv = editor.space.tri.n_vertices
        V = np.array(V, dtype=np.float64)
        if V.shape != (nv, 3):
            raise InputError(f"V must have shape ({nv}, 3), got {V.shape}")
        if not np.isfinite(V).all():
            raise InputError("V has non-finite coordinates")
        self.editor = editor
        self.V = V
        self.weights = weights
        self.rings = self._check_rings(rings)

    @classmethod
    def from_fit(cls, result, *, rings: int = 2) -> "LocalRefairer":
        """From a :class:`FitResult` (its space, free points, data vertices and weights)."""
        if float(result.energies.get("data", 0.0)) > 0:
            raise InputError("the fit used extra data points, which local re-fairing does not see; "
                             "refit globally instead")
        ed = SplineEditor.from_fit(result)
        return cls(ed, result.free[result.space.corner_free], result.weights, rings=rings)

    @staticmethod
    def _check_rings(rings) -> int:
        if not (np.ndim(rings) == 0 and float(rings) == int(rings) and int(rings) >= 1):
            raise InputError(f"rings must be an integer >= 1, got {rings!r}")
        return int(rings)

    def energy(self) -> dict[str, float]:
        """The global fairness energy of the current surface (``O(n)``; for checks)."""
        return fairness_energy(self.editor.space, self.editor.free, self.V, self.weights)

    def region(self, vertex: int, rings: int | None = None) -> tuple[np.ndarray, np.ndarray]:
        """``(faces, vertices)``: the patches within ``rings`` of ``vertex`` and their vertices."""
        rings = self.rings if rings is None else self._check_rings(rings)
        ed = self.editor
        verts = np.array([ed._vertex(vertex)], np.int64)
        faces = ed.vertex_faces(verts)
        for _ in range(rings - 1):
            verts = np.unique(ed.space.tri.faces[faces])
            faces = ed.vertex_faces(verts)
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
        v = self.editor._vertex(vertex)
        xyz = np.asarray(xyz, np.float64)
        if xyz.shape != (3,) or not np.isfinite(xyz).all():
            raise InputError(f"xyz must be 3 finite numbers, got {xyz!r}")
        self.V[v] = xyz
        self.editor.move_vertex(v, xyz, carry_frame=True)
        return self.refair(v, rings)

    def refair(self, vertex: int, rings: int | None = None) -> RefairResult:
        """Re-optimise the free points around ``vertex`` with everything else fixed."""
        clock = [time.perf_counter()]
        timings: dict[str, float] = {}

        def stage(name):
            now = time.perf_counter()
            timings[name] = now - clock[0]
            clock[0] = now

        rings = self.rings if rings is None else self._check_rings(rings)
        ed, space, w = self.editor, self.editor.space, self.weights
        v = ed._vertex(vertex)
        ids, region = self.region_free(v, rings)
        owner, face = ed.supports(ids)
        faces = np.unique(face)  # patches the re-optimised points control
        frame_vertices = np.unique((ids[space.free_kind[ids] == KIND_FRAME] - space.tri.n_vertices) // 2)
        # halo: vertices within fit_rings - 1 of the patches' vertices, and their faces
        hverts = np.unique(space.tri.faces[faces])
        halo = ed.vertex_faces(hverts)
        for _ in range(w.fit_rings - 1):
            halo = ed.vertex_faces(np.unique(space.tri.faces[halo]))
        stage("region")
        t = _terms(space, self.V, w, faces, frame_vertices, halo)
        stage("targets")
        A, c = ed.patch_matrix(faces, ids)  # ctrl = A x + c
        n, k = faces.size, ids.size
        fpos = np.searchsorted(ids, t.frame_ids)  # both frames of a vertex share their support
        if not np.array_equal(ids[np.minimum(fpos, k - 1)], t.frame_ids):
            raise AssertionError("a frame point of the region is missing from the re-optimised set")
        blk = t.gram.copy()
        di = np.arange(NCTRL)
        blk[:, di, di] += t.point_weight
        # block-diagonal patch matrix (21n, 21n), CSR built directly
        indptr = np.arange(0, n * NCTRL * NCTRL + 1, NCTRL)
        indices = np.repeat((np.arange(n) * NCTRL)[:, None] + di[None, :], NCTRL, axis=0).ravel()
        B = sp.csr_array((blk.ravel(), indices, indptr), shape=(n * NCTRL, n * NCTRL))
        H = (A.T @ (B @ A)).tocsc()
        H = H + sp.csc_array((t.tilt_weight, (fpos, fpos)), shape=(k, k))
        rhs = A.T @ ((t.point_weight[..., None] * t.target).reshape(-1, 3) - B @ c)
        np.add.at(rhs, fpos, t.tilt_weight[:, None] * t.tilt_target)
        stage("assemble")
        if k == 0:
            x = np.zeros((0, 3))
        else:
            try:
                x = spla.splu(H).solve(np.ascontiguousarray(rhs))
            except RuntimeError as exc:  # exactly singular: weights that leave points undetermined
                raise InputError(f"the local fairing problem around vertex {v} is singular ({exc}); "
                                 f"use positive local and tilt weights") from None
        stage("solve")
        x_old = ed.free[ids]
        before = _energy((A @ x_old + c).reshape(n, NCTRL, 3), ed.free[t.frame_ids], t)
        res = ed.move(ids, x)
        after = _energy(ed.patch_ctrl(faces), ed.free[t.frame_ids], t)
        stage("apply")
        return RefairResult(vertex=v, rings=rings, free_ids=ids, region=region, faces=res.faces,
                            energy_before=before, energy_after=after, edit=res, timings=timings)
