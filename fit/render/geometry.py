"""Differential geometry of the analytic surface: unit normals, mean and Gaussian curvature.

    n = unit_normals(du, dv)                        # (n, 3)
    H, K = curvatures(du, dv, uu, uv, vv)           # (n,), (n,)
    H, K = surface_curvatures(surface, face_idx, bary)

Any regular parameterization of the surface gives the same values, so the
pictures may use each patch's own barycentric parameters.
"""
from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:  # pragma: no cover
    from trispline.spline.surface import SplineSurface

__all__ = ["CURVATURES", "unit_normals", "curvatures", "surface_curvatures"]

#: What the curvature pictures can show.
CURVATURES = ("mean", "gaussian")


def unit_normals(du: np.ndarray, dv: np.ndarray) -> np.ndarray:
    """Unit normals ``(n, 3)`` = normalised ``du x dv`` (NaN where the tangents are parallel)."""
    c = np.cross(du, dv)
    nrm = np.linalg.norm(c, axis=-1, keepdims=True)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(nrm > 0, c / np.where(nrm > 0, nrm, 1.0), np.nan)


def curvatures(du: np.ndarray, dv: np.ndarray, uu: np.ndarray, uv: np.ndarray, vv: np.ndarray
               ) -> tuple[np.ndarray, np.ndarray]:
    """Mean and Gaussian curvature ``(n,)`` from first and second derivatives ``(n, 3)``.

    First fundamental form ``E, F, G`` and second ``L, M, N`` (against the unit normal
    ``du x dv / |du x dv|``): ``K = (L N - M^2) / (E G - F^2)``,
    ``H = (E N - 2 F M + G L) / (2 (E G - F^2))``. NaN where the surface is singular
    (``E G - F^2 = 0``).
    """
    n = unit_normals(du, dv)
    E = np.einsum("nd,nd->n", du, du)
    F = np.einsum("nd,nd->n", du, dv)
    G = np.einsum("nd,nd->n", dv, dv)
    L = np.einsum("nd,nd->n", uu, n)
    M = np.einsum("nd,nd->n", uv, n)
    N = np.einsum("nd,nd->n", vv, n)
    det = E * G - F * F
    with np.errstate(invalid="ignore", divide="ignore"):
        inv = np.where(det > 0, 1.0 / np.where(det > 0, det, 1.0), np.nan)
    return 0.5 * (E * N - 2 * F * M + G * L) * inv, (L * N - M * M) * inv


def surface_curvatures(surface: "SplineSurface", face_idx: np.ndarray, bary: np.ndarray
                       ) -> tuple[np.ndarray, np.ndarray]:
    """Mean and Gaussian curvature ``(n,)`` at ``face_idx (n,)``, ``bary (n, 3)`` (uv derivatives)."""
    d = surface.evaluate_derivatives(face_idx, bary, second=True)
    return curvatures(d.du, d.dv, d.uu, d.uv, d.vv)
