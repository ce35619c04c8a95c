"""Nearly singular patches, judged against the scan's own map.

    rel = relative_regularity(surface, scan_uv, element)   # (f,) about 1 unless the surface pinches

A patch of the coarse spline is a map from its uv triangle to space; its area element
``|F_u x F_v|`` collapses toward 0 where the surface pinches to a point with no tangent plane, and
its curvature blows up there (:func:`~trispline.spline.patches.regularity`: the smallest area element
over the largest, on a lattice). But the spline's uv is the scan's: where the scan's own map squeezes
its shape (LSCM's area ratio reaches 3.7e4 on camelhead.off), a faithful surface's area element
varies as much within one patch, and the plain ratio reads that as a pinch (camelhead at 1e-3 of its
diagonal: 51 patches below :data:`~.fit.PINCHED`, the smallest 0.027). So on the same lattice the
surface's area element is divided by the scan's own there (``element`` of the nearest scan vertex in
uv: the 3D area of its faces over their uv area): about constant over a patch whose surface follows
the scan, near 0 where it pinches and the scan does not. A patch's relative regularity is the smallest
of those ratios over their median, at most 1 (camelhead 0.21, and a thin boundary patch of beetle.off
with two scan vertices in it, whose area element falls to 0.04 of its median along its outline edge: 0.06).
"""
from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from trispline.spline.index import lattice
from trispline.spline.patches import area_elements
from trispline.spline.surface import SplineSurface

__all__ = ["RESOLUTION", "area_ratios", "relative_regularity"]

#: Steps per patch edge of the lattice sampled (:func:`~trispline.spline.patches.area_elements`, as
#: :func:`~trispline.spline.patches.regularity` samples it).
RESOLUTION = 8


def area_ratios(surface: SplineSurface, scan_uv: np.ndarray, element: np.ndarray,
                resolution: int = RESOLUTION) -> np.ndarray:
    """``(f, m)`` the surface's area element on the lattice of ``resolution`` steps per patch edge over the
    scan's own (``element (n,)``) at the scan vertex nearest in uv (``scan_uv (n, 2)``)."""
    area = area_elements(surface.uv, surface.faces, np.asarray(surface.ctrl), resolution)  # (f, m)
    at = np.einsum("mk,fkd->fmd", lattice(resolution) / resolution, surface.uv[surface.faces])
    _, near = cKDTree(scan_uv).query(at.reshape(-1, 2))
    return area / np.maximum(element[near].reshape(area.shape), np.finfo(float).tiny)


def relative_regularity(surface: SplineSurface, scan_uv: np.ndarray, element: np.ndarray,
                        resolution: int = RESOLUTION) -> np.ndarray:
    """``(f,)`` per patch the smallest of its :func:`area_ratios` over their median, at most 1."""
    ratio = area_ratios(surface, scan_uv, element, resolution)
    mid = np.median(ratio, axis=1)
    return np.where(mid > 0, np.minimum(1.0, ratio.min(1) / np.where(mid > 0, mid, 1.0)), 0.0)
