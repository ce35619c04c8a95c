"""trispline.param — mesh validation and planar parameterization (libigl).

    from trispline.param import validate_mesh, parameterize
    vm = validate_mesh(V, F)                       # raises MeshError naming each problem
    p = parameterize(vm.V, vm.F, method="harmonic")
    p.uv, p.faces, p.distortion, p.repaired
"""
from ._igl import closest_points
from .distortion import face_distortion, face_jacobians, summarize
from .errors import MeshError, MeshWarning, UnreferencedVerticesWarning
from .parameterize import (
    METHODS, Parameterization, UVTransform, fill_holes, fold_mask, normalise, parameterize, tutte,
)
from .validate import ValidatedMesh, face_areas_3d, validate_mesh

__all__ = [
    "MeshError", "MeshWarning", "UnreferencedVerticesWarning",
    "ValidatedMesh", "face_areas_3d", "validate_mesh",
    "METHODS", "Parameterization", "UVTransform", "parameterize",
    "fill_holes", "fold_mask", "normalise", "tutte",
    "face_distortion", "face_jacobians", "summarize", "closest_points",
]
