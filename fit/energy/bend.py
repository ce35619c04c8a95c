"""``bend``: the thin-plate energy ``int |F_uu|^2 + 2|F_uv|^2 + |F_vv|^2`` over the uv domain, exact per patch.

Residual form: ``r = sqrt(w_q) [F_uu, sqrt(2) F_uv, F_vv] * sqrt(weight area)`` at the
quadrature points (:mod:`.quadrature`; the 16-point rule compressed to the 10 rows the
cubic second derivatives need), so ``|r|^2`` is the weighted energy exactly. The
per-patch coefficients ``W (F, 6, 3)`` (:func:`bend_weights`) turn the pair partials into
the scaled uv second derivatives; the Gram matrix ``r^T r = ctrl^T G ctrl`` comes from the
same ``W``, so the residual and the normal matrix cannot disagree.
"""
from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from trispline.spline.index import NCTRL
from trispline.spline.util.parallel import Workers

from .. import boundary
from ..agreement import sliver_bend
from .arrays import Array, array_module
from .local import shared_targets
from .quadrature import PAIRS, pair_hessian_rows, pair_moments

if TYPE_CHECKING:
    from .context import TermContext
    from .normal import NormalParts

NAME = "bend"
LINEAR = True
#: The energy scales like (data size)**2.
SCALE_EXPONENT = 2


def bend_weights(bary_grad: np.ndarray, areas: np.ndarray, weight: float) -> np.ndarray:
    """``(F, 6, 3)`` coefficients turning pair derivatives ``D_P F`` into sqrt-weighted
    ``F_uu, sqrt(2) F_uv, F_vv`` (multiplied by ``sqrt(weight * area)``).

    Parameters
    ----------
    bary_grad : (F, 3, 2) barycentric gradients, areas : (F,) uv areas
    """
    g = np.asarray(bary_grad, float)
    a, b = PAIRS[:, 0], PAIRS[:, 1]
    mult = np.where(a == b, 1.0, 2.0)  # an off-diagonal pair stands for D_ab and D_ba
    uu = g[:, a, 0] * g[:, b, 0]
    uv = 0.5 * (g[:, a, 0] * g[:, b, 1] + g[:, b, 0] * g[:, a, 1]) * np.sqrt(2.0)
    vv = g[:, a, 1] * g[:, b, 1]
    W = np.stack([uu, uv, vv], axis=-1) * mult[None, :, None]
    return W * np.sqrt(weight * np.asarray(areas, float))[:, None, None]


def gram(W: np.ndarray) -> np.ndarray:
    """``(F, 21, 21)`` Gram matrices ``G`` with ``|residual|^2 = ctrl^T G ctrl`` for ``W (F, 6, 3)``."""
    C = np.einsum("fps,frs->fpr", W, W)  # (F, 6, 6)
    return (C.reshape(-1, 36) @ pair_moments().reshape(36, NCTRL * NCTRL)).reshape(-1, NCTRL, NCTRL)


def thin_plate_gram(bary_grad: np.ndarray, areas: np.ndarray) -> np.ndarray:
    """Exact thin-plate Gram matrix ``(F, 21, 21)`` of every patch (unit weight).

    Symmetric positive semidefinite with the linear functions (and nothing else) as null
    space: ``ctrl_f^T G_f ctrl_f`` is the patch's thin-plate energy.
    """
    return gram(bend_weights(bary_grad, areas, 1.0))


def setup(ctx: TermContext) -> dict[str, np.ndarray]:
    """``D (Q, 6, 21)``, ``sqw (Q,)`` (the 10-row quadrature tables), ``W (n, 6, 3)`` of the patches and
    ``target``, the nets the thin plate is measured from (:func:`trispline.fit.boundary.bend_reference`)."""
    D, sqw = pair_hessian_rows()
    return dict(D=D, sqw=sqw, W=bend_weights(ctx.bary_gradients, ctx.areas, ctx.weights.bend)
                * sliver_bend(ctx)[:, None, None],  # fit.agreement: a sliver's thin plate counts more
                target=boundary.bend_reference(ctx, shared_targets(ctx)))


def residual(ctrl: Array, frames: Array, a: dict) -> Array:
    """``(n, d, Q, 3)``: the scaled ``F_uu, sqrt2 F_uv, F_vv`` of patches ``ctrl (n, 21, d)`` at the Q rows.

    Two matrix products in the arrays' own layouts: the pair derivatives of every patch
    and coordinate, ``(n d, 21) @ (21, 6 Q)``, then per patch ``(d Q, 6) @ W (6, 3)``
    (XLA then moves no large intermediate between layouts).
    """
    xp = array_module(ctrl)
    if "target" in a:  # measured from the reference nets (trispline.fit.boundary)
        ctrl = ctrl - a["target"]
    n, _, d = ctrl.shape
    D = a["D"] * a["sqw"][:, None, None]
    Q = D.shape[0]
    d2 = xp.swapaxes(ctrl, 1, 2).reshape(n * d, NCTRL) @ D.reshape(Q * 6, NCTRL).T  # (n d, Q 6)
    return xp.matmul(d2.reshape(n, d * Q, 6), a["W"]).reshape(n, d, Q, 3)


#: Patches per chunk of :func:`add_normal` (a temporary of chunk * 441 floats, 14 MB).
GRAM_CHUNK = 4096


def add_normal(parts: NormalParts, a: dict) -> None:
    """Adds the Gram matrices to the patch blocks (no target: nothing on the right-hand side).

    In chunks of patches on a thread per core: no temporary of the blocks' full size.
    """
    W, T = a["W"], a.get("target", np.zeros(1))

    def add(lo: int, hi: int) -> None:
        G = gram(W[lo:hi])
        parts.blocks[lo:hi] += G
        if T.size > 1:  # measured from the reference nets: G T on the right-hand side
            parts.patch_rhs[lo:hi] += np.matmul(G, T[lo:hi])

    with Workers(W.shape[0], parallel_min=2 * GRAM_CHUNK, serial_blas=True) as work:
        work.map(add, W.shape[0], GRAM_CHUNK)
