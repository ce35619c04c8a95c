"""``local``: every control point off the corner regions pulled toward the data's local fits.

The target of control point ``b_ijk`` of a patch is the blend ``sum_k e_k^p N_k / sum_k e_k^p``
of the exact quintic nets ``N_k`` of the three vertices' local fits on the patch (``e`` the
point's exponents, ``p`` the blend power), so points near a corner follow that corner's fit:
second derivatives at the corners and cross-boundary derivatives along the edges come from
the data. Residual ``sqrt(weight / area_f) (P - target)``. Corner and star points are left
out: the interpolation and the ``tilt`` term fix them.
"""
from __future__ import annotations

from typing import TYPE_CHECKING, Callable

import numpy as np

from trispline.spline.bernstein import basis
from trispline.spline.index import CORNER, DEGREE, EXPONENTS, NCTRL, STAR

from ..agreement import local_trust
from ..progress import Report, span
from .arrays import Array

if TYPE_CHECKING:
    from .context import TermContext
    from .normal import NormalParts

NAME = "local"
LINEAR = True
#: The energy scales like (data size)**2.
SCALE_EXPONENT = 2

#: (21,) patch points carrying the term: all but the corners and the stars.
MASK = np.ones(NCTRL, bool)
MASK[CORNER] = False
MASK[STAR[STAR >= 0]] = False
MASK.setflags(write=False)


def blended_targets(uv: np.ndarray, faces: np.ndarray, evaluate_fit: Callable, *,
                    power: float | tuple[float, ...] = 2.0, report: Report | None = None
                    ) -> np.ndarray | tuple[np.ndarray, ...]:
    """Per-patch target nets ``(F, 21, d)`` from the three vertices' local fits.

    ``evaluate_fit(vertex_ids (F,), points (F, 21, 2), report) -> (F, 21, d)`` evaluates the
    local fit of ``vertex_ids[f]`` at the 21 domain points of patch ``f`` (the grouped form of
    :meth:`trispline.fit.targets.LocalRBFFit.evaluate`); ``uv (nv, 2)``, ``faces (F, 3)``;
    ``report``: progress (:mod:`trispline.fit.progress`). A tuple of blend powers gives a tuple
    of nets, one per power, from one evaluation of the fits (the costly part).
    """
    powers = power if isinstance(power, tuple) else (power,)
    faces = np.asarray(faces, np.int64)
    grid = EXPONENTS / DEGREE  # the control points' domain points, barycentric
    pts = np.einsum("gk,fkc->fgc", grid, uv[faces])  # (F, 21, 2)
    Binv = np.linalg.inv(basis(grid))  # (21, 21) values at the domain points -> control points
    betas = []
    for p in powers:
        e = EXPONENTS.astype(float) ** p
        betas.append(e / e.sum(1, keepdims=True))  # (21, 3)
    out: list = [None] * len(powers)
    for k in range(3):
        vals = evaluate_fit(faces[:, k], pts, span(report, k / 3, (k + 1) / 3))
        net = np.matmul(Binv, vals)  # (F, 21, d): 4x faster than the einsum (which made a batched product too)
        for i, beta in enumerate(betas):
            term = beta[None, :, k, None] * net
            if out[i] is None:
                out[i] = term
            else:
                out[i] += term  # in place: the same sums, no fresh (F, 21, d) array
    return tuple(out) if isinstance(power, tuple) else out[0]


def shared_targets(ctx: TermContext) -> Callable:
    """:func:`blended_targets` for ``ctx``'s patches (the bend reference's argument of
    :func:`trispline.fit.boundary.bend_reference`) that also blends the local term's targets from
    the same evaluations of the fits and keeps them for :func:`setup`: the fits are evaluated
    once per context instead of twice (0.6 s of a 50k-face fit)."""
    def targets(uv: np.ndarray, faces: np.ndarray, evaluate_fit: Callable, *, power: float = 2.0,
                report: Report | None = None) -> np.ndarray:
        own = ctx.weights.blend_power
        if power == own or ctx.weights.local <= 0:
            return blended_targets(uv, faces, evaluate_fit, power=power, report=report)
        nets = blended_targets(uv, faces, evaluate_fit, power=(power, own), report=report or ctx.report)
        ctx.memo["local_targets"] = nets[1]  # at the context's own blend power
        return nets[0]
    return targets


def _targets(ctx: TermContext) -> np.ndarray:
    """``(n, 21, d)`` the local term's targets: kept from the bend's reference, or made now."""
    kept = ctx.memo.pop("local_targets", None)  # released once taken
    if kept is not None:
        return kept
    return blended_targets(ctx.uv, ctx.faces, ctx.fit.evaluate, power=ctx.weights.blend_power, report=ctx.report)


def setup(ctx: TermContext) -> dict[str, np.ndarray]:
    """``index (r,)`` into the flattened patch points ``(21 n)``, ``target (r, 3)``, ``scale (r,)``."""
    w = ctx.weights
    n = ctx.faces.shape[0]
    if w.local <= 0:
        return dict(index=np.zeros(0, np.int64), target=np.zeros((0, 3)), scale=np.zeros(0))
    target = _targets(ctx)
    face, slot = np.nonzero(np.broadcast_to(MASK, (n, NCTRL)))
    return dict(index=face * NCTRL + slot, target=target[face, slot],
                scale=np.sqrt(w.local / ctx.areas[face]) * local_trust(ctx)[face])  # fit.agreement


def residual(ctrl: Array, frames: Array, a: dict) -> Array:
    """``(r, d)`` scaled errors of the patch points ``ctrl (n, 21, d)``."""
    return a["scale"][:, None] * (ctrl.reshape(-1, ctrl.shape[-1])[a["index"]] - a["target"])


def add_normal(parts: NormalParts, a: dict) -> None:
    """Adds ``scale^2`` on the blocks' diagonals (every row is one patch point, each once).

    Through flat views of the (contiguous) blocks and right-hand sides: one index array per
    addition instead of three (at 100k faces 0.13 against 0.65 s, the same sums)."""
    w = a["scale"] ** 2
    index = a["index"]
    if not (parts.blocks.flags.c_contiguous and parts.patch_rhs.flags.c_contiguous):  # reshape would copy
        face, slot = np.divmod(index, NCTRL)
        parts.blocks[face, slot, slot] += w
        parts.patch_rhs[face, slot] += w[:, None] * a["target"]
        return
    # patch point index = 21 face + slot, so the diagonal entry (face, slot, slot) is 21 index + slot
    parts.blocks.reshape(-1)[index * NCTRL + index % NCTRL] += w
    parts.patch_rhs.reshape(-1, parts.patch_rhs.shape[-1])[index] += w[:, None] * a["target"]
