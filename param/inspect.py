"""Topology report of any triangle mesh, valid or not, and whether :func:`validate_mesh` accepts it.

    rep = inspect_mesh(V, F)
    rep["components"], rep["boundary_loops"], rep["manifold"], rep["validation"]["accepted"]

Unlike :func:`validate_mesh`, which stops at the first stage that fails, this counts what
it can on a broken mesh (several components, non-manifold edges, bowties, NaN
coordinates), from the same tables (:mod:`trispline.param.tables`). With ``repair=True``
the verdict is that on :func:`~trispline.param.repair_mesh`'s result, and with ``param``
the verdict includes the distortion of that parameterization (``rep["distortion"]``).
"""
from __future__ import annotations

from typing import Any

import numpy as np

from trispline.spline.checks import check_ids

from .errors import MeshError
from .hull import edge_lengths, hull_sliver_faces
from .parameterize import parameterize
from .repair_mesh import repair_mesh
from .tables import boundary_loop_count, fan_counts, small_holes, undirected_edges, vertex_components
from .validate import (ValidatedMesh, as_mesh_arrays, folded_edges, repeated_vertex_faces, scale_problem, validate_mesh,
                       zero_area_faces)


def inspect_mesh(V: np.ndarray, F: np.ndarray, *, keep_largest: bool = False, repair: bool = False,
                 param: str | None = None, uv: np.ndarray | None = None,
                 vertex_ids: np.ndarray | None = None) -> dict[str, Any]:
    """Counts and checks of a mesh, and the verdict of ``validate_mesh(V, F, keep_largest=...)``.

    Parameters
    ----------
    V : (nv, 3) float64 (a (nv, 2) array is lifted to z = 0); NaN and inf are counted, not refused
    F : (nf, 3) int, ids in ``[0, nv)``
    keep_largest : bool
        Judge as ``validate_mesh(..., keep_largest=True)`` would.
    repair : bool
        Judge the mesh :func:`~trispline.param.repair_mesh` makes of it (``validation`` then
        also holds ``mesh_repair``: its ``changes`` and ``messages``).
    param : str, optional
        A :func:`~trispline.param.parameterize` method: when the mesh is accepted, its map's
        distortion goes into ``rep["distortion"]`` (``method``, the percentiles, ``score``,
        ``flipped_before_repair``, ``degenerate_before_repair``, ``repaired``, ``warning``,
        ``reason``); a map that cannot be made fold-free rejects the mesh.
    vertex_ids : (nv,) int, optional
        Each vertex's number in the user's file, for the messages (as :func:`validate_mesh`).
    uv : (nv, 2) float64, optional
        The mesh's own coordinates for ``param="uv"`` (e.g. OBJ texture coordinates), one
        row per input vertex; without them ``"uv"`` maps ``V[:, :2]``.

    Returns
    -------
    dict
        ``vertices``, ``faces``, ``non_finite_vertices``, ``bounds`` (of the finite vertices),
        ``degenerate_faces`` (``repeated_vertex``, ``zero_area``), ``edges``, ``boundary_edges``,
        ``non_manifold_edges``, ``components``, ``euler_characteristic``, ``bowtie_vertices``
        (when no face repeats a vertex), ``manifold``, ``folded_edges`` and ``worst_fold_degrees``
        (:func:`fold_report`; 0 and None with non-finite vertices), ``hull_slivers`` and ``longest_outline_edge``
        (:func:`hull_report`; likewise); for a manifold mesh ``boundary_loops`` and
        ``closed``, and with one component ``holes`` and ``genus``; last ``validation``:
        ``accepted``, ``problems`` (the :class:`MeshError` kinds), ``message`` (the error's
        text, empty when accepted) and ``repairs`` (what validation changed); after it
        ``distortion`` when ``param`` is given and the mesh is accepted.

    Raises
    ------
    MeshError
        Arrays of the wrong shape or dtype; InputError for face ids outside ``[0, nv)``.
    """
    V, F = as_mesh_arrays(V, F)
    nv, nf = V.shape[0], F.shape[0]
    check_ids(F, "F", nv)
    finite = np.isfinite(V).all(1)
    rep: dict[str, Any] = dict(vertices=nv, faces=nf, non_finite_vertices=int((~finite).sum()))
    if finite.any():
        rep["bounds"] = [V[finite].min(0), V[finite].max(0)]
    measurable = finite.all() and scale_problem(V) is None  # else the geometric reports overflow: validation says why
    repeated = repeated_vertex_faces(F)
    zero = zero_area_faces(V, F) if measurable else np.zeros(nf, bool)
    rep["degenerate_faces"] = dict(repeated_vertex=int(repeated.sum()), zero_area=int((zero & ~repeated).sum()))
    _, edges, he_edge, edge_count = undirected_edges(F, nv)
    proper = edges[:, 0] != edges[:, 1]  # a face with a repeated vertex has an edge (a, a)
    edges, count = edges[proper], edge_count[proper]
    rep.update(edges=int(edges.shape[0]), boundary_edges=int((count == 1).sum()),
               non_manifold_edges=int((count > 2).sum()))
    used = np.zeros(nv, bool)
    used[F.ravel()] = True
    _, labels = vertex_components(F, nv)
    rep["components"] = int(np.unique(labels[used]).size)
    rep["euler_characteristic"] = int(used.sum() - edges.shape[0] + nf)
    bow = 0
    if not repeated.any():
        bow = int((fan_counts(F, he_edge, nv) > 1).sum())
        rep["bowtie_vertices"] = bow
    rep["manifold"] = bool(rep["non_manifold_edges"] == 0 and bow == 0 and not repeated.any())
    rep.update(fold_report(V, F) if measurable else dict(folded_edges=0, worst_fold_degrees=None))
    rep.update(hull_report(V, F) if measurable and not repeated.any()
               else dict(hull_slivers=0, longest_outline_edge=None))
    if rep["manifold"]:
        _loop_counts(rep, edges, count, nv)
    rep["validation"] = _validation(V, F, keep_largest, repair, (param, uv), rep, vertex_ids)
    return rep


#: Folds whose normals are at most this far apart (degrees) read as sharp creases (a cliff, a bevel), not as
#: folded-back flaps: ``fit --repair`` cuts them all the same, so it is advised only past this. Measured
#: worst folds: beetle 103.5 and mountain 95.8 (scanned creases), a height field with a one-cell cliff 90.1;
#: the pelvis registration's flaps reach 180 (938 edges past 120).
FLAP_DEGREES = 120.0


def fold_report(V: np.ndarray, F: np.ndarray) -> dict[str, Any]:
    """``folded_edges``: the edges whose two faces' normals point apart (dihedral above 90 degrees,
    :func:`~trispline.param.validate.folded_edges`), and ``worst_fold_degrees``: the largest angle
    between such normals (None without folds), and ``flaps``: whether that exceeds :data:`FLAP_DEGREES` (a
    folded-back flap, not a sharp crease). An interpolating surface spikes at a fold;
    :func:`~trispline.param.repair_mesh` cuts the folded flaps off."""
    _, cos = folded_edges(V, F)
    worst = float(np.degrees(np.arccos(np.clip(cos.min(), -1.0, 1.0)))) if cos.size else None
    return dict(folded_edges=int(cos.size), worst_fold_degrees=worst, flaps=worst is not None and worst > FLAP_DEGREES)


def hull_report(V: np.ndarray, F: np.ndarray) -> dict[str, Any]:
    """``hull_slivers``: the faces :func:`~trispline.param.hull.hull_sliver_faces` would peel off the
    outline (the hull of a triangulation of scattered points), and ``longest_outline_edge``: the longest
    outline edge over the median edge of the mesh (None without an outline)."""
    tables = edge_lengths(V, F)
    _, he_edge, count, length = tables
    rim = count[he_edge] == 1
    median = float(np.median(length)) if length.size else 0.0
    longest = float(length[rim].max() / median) if rim.any() and median > 0 else None
    return dict(hull_slivers=int(hull_sliver_faces(V, F, tables=tables).sum()), longest_outline_edge=longest)


def _loop_counts(rep: dict[str, Any], edges: np.ndarray, count: np.ndarray, nv: int) -> None:
    """``boundary_loops``, ``closed`` and, with one component, ``holes`` and ``genus`` of a manifold mesh."""
    loops = boundary_loop_count(edges, count, nv)
    rep["boundary_loops"] = loops
    rep["closed"] = loops == 0
    if rep["components"] == 1:
        rep["holes"] = max(loops - 1, 0)
        twice = 2 - rep["euler_characteristic"] - loops  # odd only for a non-orientable or broken mesh
        rep["genus"] = twice // 2 if twice % 2 == 0 else twice / 2


def _validation(V: np.ndarray, F: np.ndarray, keep_largest: bool, repair: bool,
                param: tuple[str | None, np.ndarray | None], rep: dict[str, Any],
                vertex_ids: np.ndarray | None = None) -> dict[str, Any]:
    """The verdict of :func:`validate_mesh` (after :func:`repair_mesh` with ``repair``); on success
    without repair its loop, hole and genus counts go into ``rep``, and with ``param = (method, uv)``
    the distortion."""
    fixed = None
    method, uv = param
    try:
        if repair:
            fixed = repair_mesh(V, F)
            V, F = fixed.V, fixed.F
            uv = None if uv is None else np.asarray(uv)[fixed.source_vertex_index]
            vertex_ids = None if vertex_ids is None else np.asarray(vertex_ids)[fixed.source_vertex_index]
        vm = validate_mesh(V, F, keep_largest=keep_largest, vertex_ids=vertex_ids)
        if method is not None:
            uv = None if uv is None or vm.kept is None else np.asarray(uv)[vm.kept]
            rep["distortion"] = _distortion(vm, method, uv if method == "uv" else None)
    except MeshError as exc:
        out = dict(accepted=False, problems=list(exc.kinds), message=str(exc), repairs=[])
    else:
        if not repair:
            rep.update({k: v for k, v in vm.report.items() if k in ("boundary_loops", "holes", "genus")})
            rep["small_holes"] = len(small_holes(vm.boundary_loops))
        out = dict(accepted=True, problems=[], message="", repairs=list(vm.messages))
    if fixed is not None:
        out["mesh_repair"] = dict(changes=fixed.changes, messages=fixed.messages)
    return out


def _distortion(vm: ValidatedMesh, method: str, uv: np.ndarray | None) -> dict[str, Any]:
    """The distortion of ``method``'s map of the validated mesh ``vm`` (MeshError if it cannot be made)."""
    p = parameterize(vm.V, vm.F, method, uv=uv)
    return dict(method=p.method, **p.distortion, repaired=p.repaired, warning=p.warning, reason=p.reason)
