"""The output formats trispline writes, chosen by file suffix, and the check of an output name.

    check_export_path("scan.ply")                    # ".ply"
    check_export_path("x.jpg", IMAGE_FORMATS)         # ExportFormatError: use one of .png

Kept apart from :mod:`.export` so that :mod:`trispline.fit.render`, which export
draws its pictures with, can check its PNG names without importing export.
"""
from __future__ import annotations

import os
import warnings
from pathlib import Path

import numpy as np

from ..errors import ExportFormatError, LossyExportWarning

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
#: A 32-bit format's rounding (half a unit in the last place of the largest coordinate) above this share of the
#: points' extent is warned about: a 1 km tile at UTM offsets (5e6 m) rounds by up to 0.25 m, 2.5e-4 of it, while a
#: mesh around the origin rounds by about 3e-8 of its extent.
FLOAT32_ROUNDING_WARN = 1e-5


def check_export_path(path: str | os.PathLike, formats: tuple[str, ...] = EXPORT_FORMATS) -> str:
    """Return the lower-case suffix of ``path`` if it is one of ``formats``; else raise."""
    suffix = Path(path).suffix.lower()
    if suffix not in formats:
        raise ExportFormatError(
            f"cannot write {path}: unknown output format {suffix or '(no extension)'!r}; "
            f"use one of {', '.join(formats)}"
        )
    return suffix


def check_coordinate_range(path: str | os.PathLike, points: np.ndarray) -> None:
    """Refuse to write ``points (..., 3)`` to ``path`` where its format cannot hold their magnitude
    (:data:`FLOAT32_FORMATS`), and warn (:class:`LossyExportWarning`) where it would round them by more than
    :data:`FLOAT32_ROUNDING_WARN` of their extent (coordinates far from the origin: map coordinates)."""
    suffix = Path(path).suffix.lower()
    P = np.asarray(points, float).reshape(-1, 3)
    if suffix not in FLOAT32_FORMATS or not P.size:
        return
    largest = float(np.abs(P).max())
    if not largest <= FLOAT32_MAX:
        raise ExportFormatError(
            f"cannot write {path}: {suffix[1:].upper()} stores 32-bit floats (at most {FLOAT32_MAX:.3g}) and the "
            f"coordinates reach {largest:.3g}; use .ply, .obj or .off")
    extent = float(np.ptp(P, axis=0).max())
    rounding = float(np.spacing(np.float32(largest))) / 2  # the largest rounding: half the spacing up there
    if extent > 0 and rounding > FLOAT32_ROUNDING_WARN * extent:
        warnings.warn(
            f"{Path(path).name}: {suffix[1:].upper()} stores 32-bit floats, which round coordinates as large as "
            f"{largest:.3g} by up to {rounding:.2g}, {rounding / extent:.1g} of the extent {extent:.3g}; .ply, .obj "
            "or .off keep them to 64 bits (or subtract an offset)", LossyExportWarning, stacklevel=3)
