"""Files in and out: meshes (OBJ, OFF, PLY, STL, GLB) and exports of fitted surfaces."""
from .export import (
    EXPORT_FORMATS, IMAGE_FORMATS, MESH_FORMATS, SURFACE_FORMATS, ExportFormatError, check_export_path,
    export_control_net, export_mesh, export_surface,
)
from .mesh import SUPPORTED, MeshData, load_mesh, read_mesh

__all__ = [
    "SUPPORTED", "MeshData", "load_mesh", "read_mesh",
    "EXPORT_FORMATS", "IMAGE_FORMATS", "MESH_FORMATS", "SURFACE_FORMATS", "ExportFormatError",
    "check_export_path", "export_control_net", "export_mesh", "export_surface",
]
