"""How big an output will be, known before it is written: steps per patch edge for a triangle
budget, and the bytes of each mesh format.

    resolution_for(63_000, 1_500_000)               # 4: steps per patch edge for about 1.5M triangles
    export_resolution(surface.n_faces)              # the default steps per edge of a mesh export
    estimate_export_bytes(surface, "scan.obj", 5)   # the file's size in bytes (None for surface files, pictures)
    estimate_export_bytes(surface, "scan.step")     # exact CAD: bytes per patch as the writers write them

The counts come from :func:`trispline.spline.tessellate.tessellation_counts`
(``V + (r-1) E + (r-1)(r-2)/2 F`` vertices, ``r^2 F`` triangles); the bytes per vertex
and triangle were measured on the writers of :mod:`.export`, the bytes per patch of exact CAD on
those of :mod:`.cad`. Pictures
(:mod:`trispline.fit.render`) use the same budget rule for their automatic resolution.
"""
from __future__ import annotations

import os
from typing import TYPE_CHECKING

import numpy as np

from .formats import CAD_FORMATS, MESH_FORMATS, check_export_path

if TYPE_CHECKING:  # pragma: no cover
    from trispline.spline.surface import SplineSurface

__all__ = ["CAD_BYTES", "EXPORT_MEMORY_FACTOR", "EXPORT_TRIANGLES", "MAX_EXPORT_RESOLUTION", "MESH_BYTES",
           "resolution_for", "export_resolution", "estimate_export_bytes", "require_export_memory"]

#: A mesh export's default resolution aims at about this many triangles ...
EXPORT_TRIANGLES = 1_500_000
#: ... with at most this many steps per patch edge (the old fixed default).
MAX_EXPORT_RESOLUTION = 8
#: Bytes per vertex, per triangle and once per file of the binary mesh formats as trispline
#: writes them (vertex normals included): PLY in float64, GLB in float32 with uint32 indices,
#: STL 50 bytes per triangle. OBJ and OFF are text: see :func:`_obj_bytes`, :func:`_off_bytes`.
MESH_BYTES = {".ply": (48, 13, 300), ".glb": (24, 12, 1100), ".stl": (0, 50, 84)}
#: Bytes per patch of exact CAD (three B-spline faces per patch; two with ``merge``), measured on
#: 979 patches (camelhead's 22,704 patches as STEP: 4% more, its entity numbers being longer).
_STEP, _IGES = (21_200, 18_700), (20_400, 17_700)
CAD_BYTES = {".step": _STEP, ".stp": _STEP, ".iges": _IGES, ".igs": _IGES, ".3dm": (3_850, 3_320)}


#: Peak memory of writing a mesh format, over the tessellation's own arrays
#: (:func:`~trispline.spline.tessellate.require_tessellation_memory`): trimesh's text writers build strings.
#: Measured on 152 patches at resolutions 200 and 400 (peak RSS less the start): PLY 2.5x, GLB 2.8x, STL 7.1x,
#: OFF 7.5x, OBJ 11.6x (a resolution of 1000 asked for 76M points: the OBJ writer would need ~80 GB).
EXPORT_MEMORY_FACTOR = {".ply": 3.0, ".glb": 3.0, ".stl": 8.0, ".off": 8.0, ".obj": 12.0}


def require_export_memory(n_vertices: int, n_edges: int, n_faces: int, resolution: int, path: str | os.PathLike
                          ) -> None:
    """Refuse (``ResourceError``), before any work, a mesh export whose writing would not fit in memory."""
    from trispline.spline.tessellate import tessellation_bytes, tessellation_counts
    from trispline.spline.util.memory import require_memory

    suffix = check_export_path(path, MESH_FORMATS)
    m, nt = tessellation_counts(n_vertices, n_edges, n_faces, resolution)
    require_memory(EXPORT_MEMORY_FACTOR[suffix] * tessellation_bytes(m, nt),
                   f"writing {os.fspath(path)} ({n_faces} patches at resolution {resolution}: {m:,} points, "
                   f"{nt:,} triangles)", "use a lower --resolution")


def resolution_for(n_faces: int, triangles: int, most: int = MAX_EXPORT_RESOLUTION) -> int:
    """Steps per patch edge (1..``most``) that give about ``triangles`` triangles over ``n_faces`` patches
    (``r^2`` triangles per patch)."""
    return int(np.clip(np.floor(np.sqrt(triangles / max(int(n_faces), 1))), 1, most))


def export_resolution(n_faces: int) -> int:
    """The default steps per patch edge of a mesh export: about :data:`EXPORT_TRIANGLES` triangles.

    8 (every patch finely) up to about 23k patches, 4 at 63k, 1 from 1.5M patches.
    """
    return resolution_for(n_faces, EXPORT_TRIANGLES)


def _digits(n: int) -> float:
    """Mean number of decimal digits of the integers 1..n."""
    total, k = 0, 1
    while 10 ** (k - 1) <= n:
        total += k * (min(n, 10**k - 1) - 10 ** (k - 1) + 1)
        k += 1
    return total / max(n, 1)


def _number_chars(size: float) -> float:
    """Mean characters of a coordinate written with 15 decimals (``size``: the largest absolute coordinate):
    a sign half the time, the integer digits, the point and the decimals."""
    return 17.5 + max(0.0, np.floor(np.log10(max(size, 1.0))))


def _obj_bytes(n_vertices: int, n_triangles: int, size: float) -> float:
    """OBJ text as written here: ``v`` and ``vn`` lines of three numbers with 15 decimals
    (``size``: the largest absolute coordinate) and ``f a//a b//b c//c`` lines."""
    vertex = (2 + 3 * _number_chars(size) + 1) + (3 + 3 * 17.5 + 1)
    triangle = 2 + 3 * (2 * _digits(n_vertices) + 3)
    return n_vertices * vertex + n_triangles * triangle + 40


def _off_bytes(n_vertices: int, n_triangles: int, size: float) -> float:
    """OFF text as written here: a header, lines of three numbers with 15 decimals (``size``: the largest
    absolute coordinate) and ``3 a b c`` lines."""
    return n_vertices * (3 * _number_chars(size) + 3) + n_triangles * (2 + 3 * (_digits(n_vertices) + 1)) + 25


def estimate_export_bytes(surface: "SplineSurface", path: str | os.PathLike, resolution: int | None = None,
                          *, merge: bool = False) -> int | None:
    """The size in bytes of the file ``path`` before anything is drawn or written.

    A mesh (OBJ, PLY, STL, GLB, OFF) at ``resolution`` (None: :func:`export_resolution`), from the
    tessellation's counts, within about 5% of the file written; exact CAD (STEP, IGES, 3dm, ``merge``
    as in :func:`.cad.export_cad`) from :data:`CAD_BYTES`, within about 10%. None for surface files
    and pictures."""
    from trispline.spline.tessellate import tessellation_counts

    suffix = check_export_path(path)
    if suffix in CAD_FORMATS:
        return int(surface.n_faces * CAD_BYTES[suffix][int(bool(merge))])
    if suffix not in MESH_FORMATS:
        return None
    tri = surface.triangulation
    r = export_resolution(tri.n_faces) if resolution is None else int(resolution)
    nv, nt = tessellation_counts(tri.n_vertices, tri.n_edges, tri.n_faces, r)
    if suffix in (".obj", ".off"):
        size = float(np.abs(np.asarray(surface.ctrl)).max()) if tri.n_faces else 1.0
        return int((_obj_bytes if suffix == ".obj" else _off_bytes)(nv, nt, size))
    per_vertex, per_triangle, header = MESH_BYTES[suffix]
    return int(nv * per_vertex + nt * per_triangle + header)
