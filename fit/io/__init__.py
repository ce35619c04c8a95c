"""Files in and out: meshes (OBJ, OFF, PLY, STL, GLB) and exports of fitted surfaces.

    from trispline.fit.io import read_mesh, export_surface

:mod:`.mesh` reads meshes, :mod:`.export` writes surfaces, meshes, control nets and
pictures, :mod:`.cad` the exact STEP, IGES and 3dm files, :mod:`.formats` names the output
formats, :mod:`.sizes` says how big a mesh export will be before it is written. The
modules load on first use (trimesh and libigl only when a mesh is read or written, Open
CASCADE only for CAD), so that :mod:`trispline.fit.render` can check its PNG names
through :mod:`.formats` and size its pictures through :mod:`.sizes` cheaply.
"""
from __future__ import annotations

from trispline.spline.util.lazy import lazy_exports

_EXPORTS = {
    "SUPPORTED": "mesh", "MeshData": "mesh", "load_mesh": "mesh", "read_mesh": "mesh",
    "EXPORT_FORMATS": "formats", "IMAGE_FORMATS": "formats", "MESH_FORMATS": "formats",
    "SURFACE_FORMATS": "formats", "CAD_FORMATS": "formats", "check_export_path": "formats",
    "ExportFormatError": "formats", "export_cad": "cad",
    "export_control_net": "export", "export_mesh": "export", "export_surface": "export",
    "export_resolution": "sizes", "estimate_export_bytes": "sizes",
}

__getattr__, __dir__, __all__ = lazy_exports(__name__, _EXPORTS)
