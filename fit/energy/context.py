"""What the energy terms are built from: some patches, the frames of some vertices, and the data's local fits.

The global fit covers every patch and vertex; the local re-fair a few patches, the frames
they contain, and the local fits of a halo around them. Vertices are renumbered to the
halo in increasing order, so the neighbour order of the local fits, their truncation and
hence their values are the global ones wherever a vertex's ``fit_rings``-ring lies in
the halo.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from trispline.spline.propagation import SplineSpace

from .. import boundary, targets
from ..progress import Report, silent, span
from ..targets import LocalRBFFit, local_rbf_fit
from ..weights import FitWeights
from .data import DataPoints

__all__ = ["TermContext", "term_context", "frame_ids", "vertex_areas"]


@dataclass(frozen=True)
class TermContext:
    """The inputs of every term's ``setup`` (vertex ids in halo numbering, ``h`` halo vertices).

    Attributes
    ----------
    weights : FitWeights
    areas : (n,) uv areas of the patches, bary_gradients : (n, 3, 2) their barycentric gradients
    faces : (n, 3) the patches' vertices
    uv : (h, 2), V : (h, 3) the halo vertices' domain points and data
    halo_faces : (nh, 3) the halo's faces
    fit : LocalRBFFit of the halo's data
    frame_vertices : (m,) vertices whose frames the terms see
    frame_scale : (m,) their frame scales ``d_v``; vertex_area : (m,) a third of their incident uv areas
    data_points : DataPoints on the patches (face ids into the n patches), or None
    sample_weight : ``n_vertices / domain area`` of the whole triangulation (``1 / h^2`` of the data term)
    report : progress of the terms' setup (:mod:`trispline.fit.progress`; the local targets use it)
    target_shift : (n, 21, 2) uv shifts of the patches' target points (the outline faired as a curve,
        :func:`~trispline.fit.boundary.outline_warp` of the whole mesh), or None
    memo : values the terms derive from this context once and share (:func:`~trispline.fit.agreement.local_trust`,
        the local term's targets blended with the bend's reference); each context has its own,
        ``dataclasses.replace`` included
    """

    weights: FitWeights
    areas: np.ndarray
    bary_gradients: np.ndarray
    faces: np.ndarray
    uv: np.ndarray
    V: np.ndarray
    halo_faces: np.ndarray
    fit: LocalRBFFit
    frame_vertices: np.ndarray
    frame_scale: np.ndarray
    vertex_area: np.ndarray
    data_points: DataPoints | None
    sample_weight: float
    report: Report = silent
    target_shift: np.ndarray | None = None
    memo: dict = field(default_factory=dict, init=False, repr=False, compare=False)


def vertex_areas(faces: np.ndarray, areas: np.ndarray, n_vertices: int) -> np.ndarray:
    """``(n_vertices,)``: a third of the uv area of each vertex's incident faces ``faces (nf, 3)``."""
    return np.bincount(faces.ravel(), np.repeat(areas / 3.0, 3), minlength=n_vertices)


def frame_ids(space: SplineSpace, vertices: np.ndarray) -> np.ndarray:
    """``(2 m,)`` free ids of the frame points of ``vertices (m,)``: all ``u`` frames, then all ``v`` frames."""
    return np.concatenate([space.frame_free[vertices, 0], space.frame_free[vertices, 1]])


def term_context(space: SplineSpace, V: np.ndarray, weights: FitWeights, *, faces: np.ndarray | None = None,
                 frame_vertices: np.ndarray | None = None, halo: np.ndarray | None = None,
                 data_points: DataPoints | None = None, report: Report | None = None,
                 curved_outline: bool = False, smooth_map: bool | None = None) -> TermContext:
    """The context of patches ``faces`` and the frames of ``frame_vertices`` (default: all).

    Parameters
    ----------
    space : SplineSpace, V : (nv, 3) data vertices
    faces : (n,) patches; frame_vertices : (m,) vertices (sorted)
    halo : (nh,) faces whose data the local fits see; it must hold every face around the
        frame vertices and the patches' vertices (default: all faces)
    report : progress of the local fits (its first 60%) and of the terms' setup (the rest)
    curved_outline : the boundary patches' targets follow the outline faired as a curve
        (:func:`~trispline.fit.boundary.outline_warp`, computed on the whole mesh, so that a halo's
        patches get exactly the whole fit's targets); where it is False (the uv were given) the
        outline vertices' local fits take a ring more (:data:`~trispline.fit.targets.OUTLINE_RING`); the
        outline vertices and the next ring take second, wider fits either way
        (:func:`~trispline.fit.targets.outline_fit_kernels`)
    smooth_map : the map is smooth up to its outline (given uv, or a polynomial map:
        :mod:`trispline.param.polymap`): the outline fits are those of given uv (a ring more, the wider
        second fits of degree 4-6) even where the outline is curved; default ``not curved_outline``. The
        rough-data guard of the second fits (:data:`~trispline.fit.targets.OWN_MAP_OUTLINE_LOO`) stays with
        ``curved_outline``: it is about the scan, not the map
    """
    tri = space.tri
    if halo is None:
        hv, hfaces, renumber = np.arange(tri.n_vertices), tri.faces, (lambda a: a)
    else:
        hv = np.unique(tri.faces[halo])
        hfaces = np.searchsorted(hv, tri.faces[halo])
        renumber = lambda a: np.searchsorted(hv, a)  # noqa: E731
    faces = np.arange(tri.n_faces) if faces is None else np.asarray(faces, np.int64)
    fv = np.arange(tri.n_vertices) if frame_vertices is None else np.asarray(frame_vertices, np.int64)
    harea = tri.areas if halo is None else tri.areas[halo]
    w = weights
    rough = curved_outline if smooth_map is None else not smooth_map  # the fit's own map, least accurate at its outline
    second = targets.outline_fit_kernels(rough)
    return TermContext(
        weights=w, areas=tri.areas[faces], bary_gradients=tri.bary_gradients[faces],
        faces=renumber(tri.faces[faces]), uv=tri.uv[hv], V=V[hv], halo_faces=hfaces,
        fit=local_rbf_fit(tri.uv[hv], V[hv], hfaces, max_degree=w.fit_degree, rings=w.fit_rings,
                          outline_ring=targets.OUTLINE_RING and not rough, outline_fits=bool(second),
                          outline_kernels=second or None,
                          outline_loo=targets.OWN_MAP_OUTLINE_LOO if curved_outline else None,
                          report=span(report, 0.0, 0.6)),
        frame_vertices=renumber(fv), frame_scale=space.frame_scale[fv],
        vertex_area=vertex_areas(hfaces, harea, hv.size)[renumber(fv)], data_points=data_points,
        sample_weight=tri.n_vertices / float(tri.areas.sum()), report=span(report, 0.6, 1.0),
        target_shift=boundary.outline_warp(V, tri.uv, tri.faces)[faces] if curved_outline and boundary.CURVE_WARP
        else None)
