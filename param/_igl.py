"""The only module that imports libigl: thin wrappers with checked dtypes (libigl 2.6 bindings)."""
from __future__ import annotations

import igl
import numpy as np
import scipy.sparse as sp

from trispline.spline.checks import as_array, check_ids


def circle_boundary(V: np.ndarray, loop: np.ndarray) -> np.ndarray:
    """Positions ``(n, 2)`` of ``loop`` on the unit circle, spaced by 3D arc length."""
    return np.asarray(
        igl.map_vertices_to_circle(np.asfortranarray(V, dtype=np.float64),
                                   np.ascontiguousarray(loop, dtype=np.int32)),
        dtype=np.float64,
    )


def lscm_hessian(V: np.ndarray, F: np.ndarray) -> sp.csr_matrix:
    """libigl's LSCM energy ``Q (2 nv, 2 nv)`` over ``(u, v)`` stacked: ``-[L 0; 0 L] - 2 A``, ``L``
    the cotangent Laplacian (``igl.cotmatrix``), ``A`` the vector area matrix of the boundary edges
    (``igl.vector_area_matrix``: the map's signed area), as ``igl.lscm`` builds it."""
    V = np.ascontiguousarray(V, dtype=np.float64)
    F = np.ascontiguousarray(F, dtype=np.int64)
    L = igl.cotmatrix(V, F)
    return (-sp.block_diag([L, L]) - 2.0 * igl.vector_area_matrix(F)).tocsr()


def harmonic(V: np.ndarray, F: np.ndarray, b: np.ndarray, bc: np.ndarray) -> np.ndarray:
    """Cotangent-harmonic extension ``(nv, 2)`` of boundary values ``bc`` at ``b``."""
    return np.asarray(
        igl.harmonic(np.ascontiguousarray(V, dtype=np.float64), np.ascontiguousarray(F, dtype=np.int64),
                     np.ascontiguousarray(b, dtype=np.int64), np.ascontiguousarray(bc, dtype=np.float64), 1)
    )


def composite_harmonic(UV0: np.ndarray, F: np.ndarray, b: np.ndarray, bc: np.ndarray) -> np.ndarray:
    """``igl.bijective_composite_harmonic_mapping`` from a fold-free planar ``UV0 (nv, 2)``."""
    return np.asarray(
        igl.bijective_composite_harmonic_mapping(
            np.ascontiguousarray(UV0, dtype=np.float64), np.ascontiguousarray(F, dtype=np.int64),
            np.ascontiguousarray(b, dtype=np.int64), np.ascontiguousarray(bc, dtype=np.float64),
        )
    )


def slim_start(V: np.ndarray, F: np.ndarray, uv0: np.ndarray) -> object:
    """SLIM's data for the conformal (MIPS) energy from the fold-free start ``uv0 (nv, 2)``,
    boundary free (``igl.slim_precompute``)."""
    return igl.slim_precompute(
        np.asfortranarray(V, dtype=np.float64), np.asfortranarray(F, dtype=np.int32),
        np.asfortranarray(uv0, dtype=np.float64), igl.MappingEnergyType.CONFORMAL,
        np.zeros(0, np.int32), np.zeros((0, 2), np.float64, order="F"), 0.0,
    )


def slim_iterate(data: object, iterations: int) -> np.ndarray:
    """``iterations`` more SLIM steps on ``data`` (:func:`slim_start`); the map ``(nv, 2)`` reached."""
    return np.array(igl.slim_solve(data, int(iterations)), dtype=np.float64)


def closest_points(P: np.ndarray, V: np.ndarray, F: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Exact closest points to ``P (n, 3)`` on the mesh ``V (nv, 3)``, ``F (nf, 3)`` (libigl's AABB tree).

    Returns ``(squared distance (n,), face index (n,), closest point (n, 3))``.
    """
    P = as_array(P, "P", (None, 3), finite=True)
    V = as_array(V, "V", (None, 3))
    F = check_ids(as_array(F, "F", (None, 3), integer=True, min_rows=1), "F", V.shape[0])
    sq, idx, C = igl.point_mesh_squared_distance(
        np.ascontiguousarray(P), np.ascontiguousarray(V), np.ascontiguousarray(F),
    )
    return np.asarray(sq), np.asarray(idx, dtype=np.int64), np.asarray(C)
