"""trispline.param — mesh validation and planar parameterization (libigl).

    from trispline.param import validate_mesh, parameterize, inspect_mesh
    vm = validate_mesh(V, F)                       # raises MeshError naming each problem
    p = parameterize(vm.V, vm.F)                   # DEFAULT_METHOD "lscm", or "harmonic", "uv"
    p.uv, p.faces, p.distortion, p.repaired
    inspect_mesh(V, F)                             # topology counts of any mesh, and the verdict

Modules: ``validate`` (the checks), ``tables`` (edge, component, fan and loop tables),
``inspect`` (the report), ``parameterize`` (the methods), ``repair`` (fold repair),
``distortion``; libigl is imported by ``_igl`` only. ``trispline.param.testing`` generates
meshes for tests, examples and benchmarks.
"""
from ._igl import closest_points
from .distortion import face_distortion, face_jacobians, summarize
from .errors import MeshError, MeshWarning, UnreferencedVerticesWarning
from .inspect import inspect_mesh
from .parameterize import (
    DEFAULT_METHOD, METHODS, Parameterization, UVTransform, harmonic_uv, normalise, parameterize,
)
from .repair import fill_holes, fold_mask, repair_folds, tutte
from .validate import ValidatedMesh, face_areas_3d, validate_mesh

__all__ = [
    "MeshError", "MeshWarning", "UnreferencedVerticesWarning",
    "ValidatedMesh", "face_areas_3d", "validate_mesh", "inspect_mesh",
    "DEFAULT_METHOD", "METHODS", "Parameterization", "UVTransform", "parameterize", "harmonic_uv",
    "fill_holes", "fold_mask", "normalise", "repair_folds", "tutte",
    "face_distortion", "face_jacobians", "summarize", "closest_points",
]
