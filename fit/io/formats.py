"""The output formats trispline writes, chosen by file suffix, and the check of an output name.

    check_export_path("scan.ply")                    # ".ply"
    check_export_path("x.jpg", IMAGE_FORMATS)         # ExportFormatError: use one of .png

Kept apart from :mod:`.export` so that :mod:`trispline.fit.render`, which export
draws its pictures with, can check its PNG names without importing export.
"""
from __future__ import annotations

import os
from pathlib import Path

from ..errors import ExportFormatError

__all__ = ["MESH_FORMATS", "SURFACE_FORMATS", "IMAGE_FORMATS", "CAD_FORMATS", "EXPORT_FORMATS", "FLOAT32_FORMATS",
           "check_export_path", "check_coordinate_range"]

#: Tessellated-mesh formats (through trimesh).
MESH_FORMATS = (".obj", ".ply", ".stl", ".glb", ".off")
#: Surface file formats (docs/design.md §6).
SURFACE_FORMATS = (".npz", ".json")
#: Pictures (:mod:`trispline.fit.render`).
IMAGE_FORMATS = (".png",)
#: Exact CAD formats (:mod:`.cad`: STEP and IGES through Open CASCADE, 3dm through rhino3dm).
CAD_FORMATS = (".step", ".stp", ".iges", ".igs", ".3dm")
EXPORT_FORMATS = MESH_FORMATS + SURFACE_FORMATS + IMAGE_FORMATS + CAD_FORMATS
#: Mesh formats that store 32-bit floats (trimesh writes STL and glTF binary so): coordinates beyond
#: :data:`FLOAT32_MAX` would be written as infinities.
FLOAT32_FORMATS = (".stl", ".glb")
FLOAT32_MAX = 3.4028234663852886e38


def check_export_path(path: str | os.PathLike, formats: tuple[str, ...] = EXPORT_FORMATS) -> str:
    """Return the lower-case suffix of ``path`` if it is one of ``formats``; else raise."""
    suffix = Path(path).suffix.lower()
    if suffix not in formats:
        raise ExportFormatError(
            f"cannot write {path}: unknown output format {suffix or '(no extension)'!r}; "
            f"use one of {', '.join(formats)}"
        )
    return suffix


def check_coordinate_range(path: str | os.PathLike, largest: float) -> None:
    """Refuse to write coordinates of magnitude ``largest`` to ``path`` where its format cannot hold them
    (:data:`FLOAT32_FORMATS`)."""
    suffix = Path(path).suffix.lower()
    if suffix in FLOAT32_FORMATS and not largest <= FLOAT32_MAX:
        raise ExportFormatError(
            f"cannot write {path}: {suffix[1:].upper()} stores 32-bit floats (at most {FLOAT32_MAX:.3g}) and the "
            f"coordinates reach {largest:.3g}; use .ply, .obj or .off")
