"""Signed distance from the surface to its data mesh (surface -> data).

    d = deviation(points, V, F)          # (n,) + on the side the data face's normal points to
    V, F = as_mesh("scan.ply")           # a data mesh from a pair, a trimesh or a file
    stored_data_mesh(surface)            # the fit's own data vertices with the surface's faces, or None

Distances are exact point-to-triangle distances through
:func:`trispline.param.closest_points` (libigl's AABB tree). Data -> surface would
be zero at every data vertex of an interpolating fit and show nothing.
"""
from __future__ import annotations

import os
from typing import TYPE_CHECKING, Any

import numpy as np

from ..errors import RenderError

if TYPE_CHECKING:  # pragma: no cover
    from trispline.spline.surface import SplineSurface

__all__ = ["as_mesh", "deviation", "stored_data_mesh"]


def _check_mesh(V: np.ndarray, F: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``V (nv, 3)`` float64 and ``F (nf, 3)`` int64 indexing finite vertices; else a RenderError."""
    if V.ndim != 2 or V.shape[1] != 3 or F.ndim != 2 or F.shape[1] != 3 or F.shape[0] == 0:
        raise RenderError(f"a data mesh needs V (nv, 3) and F (nf >= 1, 3), got {V.shape} and {F.shape}")
    if not np.issubdtype(F.dtype, np.integer):
        raise RenderError(f"data mesh faces must be integers, got {F.dtype}")
    F = F.astype(np.int64)
    bad = np.flatnonzero((F < 0).any(1) | (F >= V.shape[0]).any(1))
    if bad.size:
        raise RenderError(f"data mesh: {bad.size} faces index missing vertices (of {V.shape[0]}); "
                          f"first: {bad[:5].tolist()}")
    bad = np.flatnonzero(~np.isfinite(V).all(1))
    if bad.size:
        raise RenderError(f"data mesh: {bad.size} vertices are not finite; first: {bad[:5].tolist()}")
    return V, F


def as_mesh(mesh: Any) -> tuple[np.ndarray, np.ndarray]:
    """``V (nv, 3)``, ``F (nf, 3)`` from a pair, a trimesh-like object, or a mesh file path."""
    if isinstance(mesh, (str, os.PathLike)):
        from ..io.mesh import read_mesh  # trimesh: imported only for a mesh file

        md = read_mesh(mesh)
        return np.asarray(md.V, np.float64), np.asarray(md.F, np.int64)
    if hasattr(mesh, "vertices") and hasattr(mesh, "faces"):
        mesh = (mesh.vertices, mesh.faces)
    try:
        V, F = mesh
        V = np.asarray(V, np.float64)
        F = np.asarray(F)
    except (TypeError, ValueError):
        raise RenderError("a data mesh must be (V, F) arrays, a trimesh or a mesh file path") from None
    return _check_mesh(V, F)


def deviation(points: np.ndarray, V: np.ndarray, F: np.ndarray) -> np.ndarray:
    """Signed distance ``(n,)`` from ``points (n, 3)`` to the triangle mesh ``V (nv, 3)``, ``F (nf, 3)``.

    The sign is that of ``(P - C) . n_f`` with ``C`` the closest point and ``n_f`` the
    normal of its face (``+`` on the side the face normal points to); NaN where a
    point is not finite.
    """
    from trispline.param import closest_points  # libigl AABB tree: about 2 s per million points

    P = np.ascontiguousarray(points, np.float64)
    V, F = as_mesh((V, F))
    d = np.full(P.shape[0], np.nan)
    ok = np.isfinite(P).all(1)
    if not ok.any():
        return d
    sq, idx, C = closest_points(P[ok], V, F)
    T = V[F[idx]]
    fn = np.cross(T[:, 1] - T[:, 0], T[:, 2] - T[:, 0])
    side = np.einsum("nd,nd->n", P[ok] - C, fn)
    d[ok] = np.sqrt(np.maximum(sq, 0.0)) * np.where(side < 0, -1.0, 1.0)
    return d


def stored_data_mesh(surface: "SplineSurface") -> tuple[np.ndarray, np.ndarray] | None:
    """The fitted data mesh stored with a fit (``data_vertices`` + the surface's faces), if any.

    An approximation (``approx_scan_vertices`` in the file) has none: its corners' data vertices with
    the coarse faces are not the scan it approximates (render it with ``--mesh`` the scan); nor has a file
    whose ``data_vertices`` are malformed (not one finite row per vertex).
    """
    D = surface.extras.get("data_vertices")
    if D is None or "approx_scan_vertices" in surface.extras:  # an approximation: its data is the scan
        return None
    try:
        D = np.asarray(D, np.float64)
    except (ValueError, TypeError):  # a malformed optional key (another writer's, an edited file): no data mesh
        return None
    if D.shape != (surface.n_vertices, 3) or not np.isfinite(D).all():
        return None
    return D, np.asarray(surface.faces, np.int64)
