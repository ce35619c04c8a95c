"""trispline.param — mesh validation and planar parameterization (libigl)."""
from .errors import MeshError, MeshWarning, UnreferencedVerticesWarning

__all__ = ["MeshError", "MeshWarning", "UnreferencedVerticesWarning"]
