"""trispline.param — mesh validation and planar parameterization (libigl)."""
from .errors import MeshError, MeshWarning, UnreferencedVerticesWarning
from .validate import ValidatedMesh, face_areas_3d, validate_mesh

__all__ = [
    "MeshError", "MeshWarning", "UnreferencedVerticesWarning",
    "ValidatedMesh", "face_areas_3d", "validate_mesh",
]
