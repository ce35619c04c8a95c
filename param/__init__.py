"""trispline.param — mesh repair, validation and planar parameterization (libigl).

    from trispline.param import repair_mesh, validate_mesh, parameterize, inspect_mesh
    r = repair_mesh(V, F)                          # bowties, fins, duplicates, slivers, components
    vm = validate_mesh(r.V, r.F)                   # raises MeshError naming each problem
    p = parameterize(vm.V, vm.F)                   # DEFAULT_METHOD "spectral", or "lscm", "harmonic", "slim", "uv", "auto"
    p.uv, p.faces, p.distortion, p.repaired, p.reason
    uv, faces, ctrl = user_domain(p, ctrl)         # a fitted net onto the user's own uv
    inspect_mesh(V, F)                             # topology counts of any mesh, and the verdict

Modules: ``validate`` (the checks), ``tables`` (edge, component, fan and loop tables),
``inspect`` (the report), ``repair_mesh`` (mesh repair), ``methods`` (the maps),
``parameterize`` (checks, repair and choice of a map), ``repair`` (fold repair),
``distortion`` (measures, folds, the score), ``domain`` (normalisation, the user's frame);
libigl is imported by ``_igl`` only. ``trispline.param.testing`` generates meshes for tests,
examples and benchmarks.
"""
from ._igl import closest_points
from .distortion import (
    distortion_report, face_distortion, face_jacobians, fold_mask, outline_crossings, segment_crossings, summarize,
)
from .domain import UVTransform, normalise, reverse_faces, user_domain
from .errors import CoordinatePrecisionWarning, MeshError, MeshWarning, UnreferencedVerticesWarning
from .hull import hull_sliver_faces
from .inspect import inspect_mesh
from .methods import harmonic_uv, slim_uv
from .parameterize import DEFAULT_METHOD, METHODS, Parameterization, parameterize
from .repair import fill_holes, polygon_area, repair_folds, tutte
from .repair_mesh import RepairedMesh, repair_mesh
from .tables import loop_successors
from .validate import ValidatedMesh, face_areas_3d, face_aspects, refuse_slivers, sliver_message, validate_mesh

__all__ = [
    "CoordinatePrecisionWarning", "MeshError", "MeshWarning", "UnreferencedVerticesWarning",
    "ValidatedMesh", "face_areas_3d", "face_aspects", "hull_sliver_faces", "refuse_slivers", "sliver_message", "validate_mesh", "inspect_mesh", "RepairedMesh", "repair_mesh",
    "DEFAULT_METHOD", "METHODS", "Parameterization", "UVTransform", "parameterize", "harmonic_uv", "slim_uv",
    "user_domain", "reverse_faces", "fill_holes", "fold_mask", "normalise", "repair_folds", "tutte",
    "distortion_report", "face_distortion", "face_jacobians", "summarize", "closest_points",
    "outline_crossings", "segment_crossings", "loop_successors", "polygon_area",
]
