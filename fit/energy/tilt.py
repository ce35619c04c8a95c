"""``tilt``: each corner frame pulled toward the local fit's tangent frame (paper 7.2.3).

The two frame points of vertex ``v`` are ``h_v(uv_v + (d_v / 5) e_k)``, ``k = u, v``; their
targets put the local fit's gradient there: ``V_v + grad_k (d_v / 5)``. Residual
``sqrt(weight A_v) (5 / d_v^2) (frame - target)``, with ``A_v`` a third of the incident uv
area: like a first derivative error squared, integrated over the vertex's share of the domain.
"""
from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ..agreement import frame_trust
from ..boundary import corner_gradients
from .arrays import Array

if TYPE_CHECKING:
    from .context import TermContext
    from .normal import NormalParts

NAME = "tilt"
LINEAR = True
#: The energy scales like (data size)**2.
SCALE_EXPONENT = 2


def setup(ctx: TermContext) -> dict[str, np.ndarray]:
    """``target (2m, 3)`` and ``scale (2m,)`` of the frame points (``u`` frames, then ``v`` frames)."""
    d = ctx.frame_scale
    Vf = ctx.V[ctx.frame_vertices]
    grad = corner_gradients(ctx)  # (m, 3, 2) the local fits' own, but at a lone corner of an ear (fit.boundary)
    step = (d / 5.0)[:, None]
    target = np.concatenate([Vf + grad[:, :, 0] * step, Vf + grad[:, :, 1] * step])
    scale = np.tile(np.sqrt(ctx.weights.tilt * ctx.vertex_area) * 5.0 / d**2 * frame_trust(ctx), 2)  # fit.agreement
    return dict(target=target, scale=scale)


def residual(ctrl: Array, frames: Array, a: dict) -> Array:
    """``(2m, d)`` scaled frame errors of ``frames (2m, d)``."""
    return a["scale"][:, None] * (frames - a["target"])


def add_normal(parts: NormalParts, a: dict) -> None:
    """Adds ``scale^2`` to the frame diagonals, ``scale^2 target`` to their right-hand sides."""
    w = a["scale"] ** 2
    parts.frame_weight += w
    parts.frame_rhs += w[:, None] * a["target"]
