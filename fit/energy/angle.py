"""``angle`` (nonlinear): each corner frame's unit normal pulled toward the data normal.

Residual ``sqrt(weight A_v) (slope_v / d_v) (unit(t_u x t_v) - n_v)`` for the frame vectors
``t_u, t_v`` (frame points minus the corner point) and the local fit's normal ``n_v``
(area-weighted mesh normals where the fit's tangents degenerate); ``slope_v`` (the fit's RMS
gradient) and ``d_v`` make it comparable with ``tilt``. It leaves the frame's length alone.
Not quadratic: Gauss--Newton iterates, with the linear terms' factor as preconditioner.
"""
from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from trispline.spline.tolerances import TINY

from ..targets import area_weighted_normals, fitted_normals
from .arrays import Array, array_module

if TYPE_CHECKING:
    from .context import TermContext

NAME = "angle"
LINEAR = False
#: Unit normals: the energy does not scale with the data.
SCALE_EXPONENT = 0


def setup(ctx: TermContext) -> dict[str, np.ndarray]:
    """``pair (m, 2)`` rows of the frames array, corner ``z (m, 3)``, ``normal (m, 3)``, ``scale (m,)``."""
    w = ctx.weights
    if w.angle <= 0:
        return dict(pair=np.zeros((0, 2), np.int64), z=np.zeros((0, 3)), normal=np.zeros((0, 3)), scale=np.zeros(0))
    fv = ctx.frame_vertices
    m = fv.size
    normal = fitted_normals(ctx.fit, reference=area_weighted_normals(ctx.V, ctx.halo_faces))[fv]
    slope = np.linalg.norm(ctx.fit.grad[fv], axis=(1, 2)) / np.sqrt(2.0)
    scale = np.sqrt(w.angle * ctx.vertex_area) * slope / ctx.frame_scale
    pair = np.column_stack([np.arange(m), m + np.arange(m)])  # frames: u frames, then v frames
    return dict(pair=pair, z=ctx.V[fv], normal=normal, scale=scale)


def residual(ctrl: Array, frames: Array, a: dict) -> Array:
    """``(m, 3)`` scaled differences between the frames' unit normals and the target normals."""
    xp = array_module(frames)
    tu = frames[a["pair"][:, 0]] - a["z"]
    tv = frames[a["pair"][:, 1]] - a["z"]
    n = xp.cross(tu, tv)
    length = xp.sqrt(xp.sum(n * n, axis=1, keepdims=True) + TINY)
    return a["scale"][:, None] * (n / length - a["normal"])
