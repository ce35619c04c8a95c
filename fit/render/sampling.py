"""The surface sampled for pictures: per-patch lattice grids and the patch-boundary curves.

    s = sample_surface(surface, 4)                  # SurfaceSample: points, normals, curvature, triangles
    ref = reference_sample(surface)                 # the fixed sample behind resolution-free numbers
    points, segments = patch_curves(surface, 4)     # the images of the domain edges as polylines

Each patch keeps its own samples on :func:`trispline.spline.index.lattice` (``r``
steps per edge), so a jump across a patch boundary stays a jump in the picture.
What must not change with the render resolution (the default view, the curvature
colour range) is computed on :func:`reference_sample`: :data:`REFERENCE_RESOLUTION`
steps per edge on at most :data:`REFERENCE_PATCHES` evenly spread patches.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache
from typing import TYPE_CHECKING

import numpy as np

from trispline.spline.bernstein import basis, basis_gradient_bary, basis_hessian_bary
from trispline.spline.util.memory import require_memory
from trispline.spline.index import NCTRL, lattice, lattice_triangles
from trispline.spline.patches import edge_samples

from ..errors import RenderError
from .geometry import curvatures, unit_normals

if TYPE_CHECKING:  # pragma: no cover
    from trispline.spline.surface import SplineSurface

__all__ = [
    "SurfaceSample", "sample_surface", "reference_sample", "auto_resolution", "patch_curves", "TARGET_TRIANGLES",
    "REFERENCE_RESOLUTION", "REFERENCE_PATCHES",
]

#: Triangles aimed at by the automatic resolution (per backend), and its upper bound.
TARGET_TRIANGLES = {"pyvista": 1_700_000, "matplotlib": 120_000}
MAX_AUTO_RESOLUTION = 8
#: Faces evaluated per block (bounds the memory of the derivative arrays).
BLOCK_FACES = 20_000
#: The reference sample (:func:`reference_sample`): steps per patch edge, and the most
#: patches it visits (evenly spread; 50k patches of 15 points take about 0.3 s with curvature).
REFERENCE_RESOLUTION = 4
REFERENCE_PATCHES = 50_000


@lru_cache(maxsize=16)
def _lattice_basis(r: int) -> np.ndarray:
    """``(6 n, 21)``: value, d/ds, d/dt, d2/ds2, d2/dsdt, d2/dt2 of the Bernstein basis on
    ``lattice(r) / r``, in the local parameters ``(s, t) = (l_b, l_c)``, ``l_a = 1 - s - t``."""
    bary = lattice(r) / r
    B = basis(bary)
    dB = basis_gradient_bary(bary)  # (3, n, 21)
    H = basis_hessian_bary(bary)  # (3, 3, n, 21)
    stack = np.concatenate([
        B, dB[1] - dB[0], dB[2] - dB[0],
        H[1, 1] - 2 * H[0, 1] + H[0, 0],
        H[1, 2] - H[0, 1] - H[0, 2] + H[0, 0],
        H[2, 2] - 2 * H[0, 2] + H[0, 0],
    ])
    stack.setflags(write=False)
    return stack


@dataclass(frozen=True)
class SurfaceSample:
    """The surface sampled per patch on the lattice (``n = F (r+1)(r+2)/2`` points).

    points, normals : (n, 3); normals analytic and unit (NaN where singular)
    triangles : (F r^2, 3) int64, counter-clockwise like the faces
    face_idx : (n,) patch of each point; bary : (n, 3) its barycentric coordinates
    (``F``: the patches sampled, every one unless ``faces`` was given)
    mean_curvature, gaussian_curvature : (n,) or None (``curvature=False``)
    resolution : r
    """

    points: np.ndarray
    normals: np.ndarray
    triangles: np.ndarray
    face_idx: np.ndarray
    bary: np.ndarray
    mean_curvature: np.ndarray | None
    gaussian_curvature: np.ndarray | None
    resolution: int


def sample_surface(surface: "SplineSurface", resolution: int = 4, *, curvature: bool = True,
                   faces: np.ndarray | None = None) -> SurfaceSample:
    """Sample every patch (or the patches ``faces (F,)``) with ``resolution`` steps per edge.

    See :class:`SurfaceSample`. Values, analytic normals and (with ``curvature``)
    mean and Gaussian curvature come from one ``(6 n, 21) @ (21, 3 F)`` product per
    block of faces.
    """
    r = int(resolution)
    if r < 1 or r != resolution:
        raise RenderError(f"resolution must be an integer >= 1, got {resolution}")
    ctrl = np.asarray(surface.ctrl, np.float64)
    ids = np.arange(ctrl.shape[0]) if faces is None else np.asarray(faces, np.int64)
    if faces is not None:
        ctrl = ctrl[ids]
    nf = ctrl.shape[0]
    n = (r + 1) * (r + 2) // 2
    require_memory(nf * n * (8 if curvature else 6) * 8 + nf * r * r * 24,
                   f"sampling {nf} patches at resolution {r} ({nf * n} points)", "use a lower --resolution")
    bary = lattice(r) / r
    n = bary.shape[0]
    stack = _lattice_basis(r) if curvature else _lattice_basis(r)[: 3 * n]
    q = stack.shape[0] // n
    points, normals = np.empty((nf, n, 3)), np.empty((nf, n, 3))
    H, K = (np.empty((nf, n)), np.empty((nf, n))) if curvature else (None, None)
    for lo in range(0, nf, BLOCK_FACES):
        hi = min(lo + BLOCK_FACES, nf)
        flat = ctrl[lo:hi].transpose(1, 0, 2).reshape(NCTRL, -1)
        out = (stack @ flat).reshape(q, n, hi - lo, 3).transpose(0, 2, 1, 3)  # (q, f, n, 3)
        points[lo:hi] = out[0]
        ds, dt = out[1].reshape(-1, 3), out[2].reshape(-1, 3)
        normals[lo:hi] = unit_normals(ds, dt).reshape(hi - lo, n, 3)
        if curvature:
            h, k = curvatures(ds, dt, out[3].reshape(-1, 3), out[4].reshape(-1, 3), out[5].reshape(-1, 3))
            H[lo:hi] = h.reshape(hi - lo, n)
            K[lo:hi] = k.reshape(hi - lo, n)
    triangles = (lattice_triangles(r)[None, :, :] + (n * np.arange(nf))[:, None, None]).reshape(-1, 3)
    return SurfaceSample(
        points=points.reshape(-1, 3), normals=normals.reshape(-1, 3), triangles=triangles,
        face_idx=np.repeat(ids, n), bary=np.tile(bary, (nf, 1)),
        mean_curvature=None if H is None else H.ravel(), gaussian_curvature=None if K is None else K.ravel(),
        resolution=r,
    )


def reference_sample(surface: "SplineSurface", *, curvature: bool = True) -> SurfaceSample:
    """The fixed sample of ``surface``: :data:`REFERENCE_RESOLUTION` steps per edge on at most
    :data:`REFERENCE_PATCHES` evenly spread patches, whatever a picture's resolution."""
    nf = surface.n_faces
    faces = None if nf <= REFERENCE_PATCHES else np.linspace(0, nf - 1, REFERENCE_PATCHES).round().astype(np.int64)
    return sample_surface(surface, REFERENCE_RESOLUTION, curvature=curvature, faces=faces)


def auto_resolution(n_faces: int, backend: str) -> int:
    """Samples per patch edge that give about :data:`TARGET_TRIANGLES` triangles (1..8)."""
    from ..io.sizes import resolution_for

    return resolution_for(n_faces, TARGET_TRIANGLES.get(backend, TARGET_TRIANGLES["pyvista"]), MAX_AUTO_RESOLUTION)


def patch_curves(surface: "SplineSurface", steps: int) -> tuple[np.ndarray, np.ndarray]:
    """The images of the domain edges as polylines of ``steps`` segments each.

    Returns
    -------
    points : (E (steps + 1), 3), edge by edge
    segments : (E steps, 2) int64 into ``points``
    """
    tri = surface.triangulation
    m = steps + 1
    face, bary = edge_samples(tri, np.arange(tri.n_edges), np.linspace(0.0, 1.0, m))
    pts = surface.evaluate(np.repeat(face, m), bary.reshape(-1, 3))
    base = (np.arange(tri.n_edges) * m)[:, None] + np.arange(steps)[None, :]
    return pts, np.stack([base, base + 1], axis=-1).reshape(-1, 2)
