"""``variation``: the curvature-variation energy ``int |D^3 F|^2`` over the uv domain, exact per patch.

``|D^3 F|^2 = F_uuu^2 + 3 F_uuv^2 + 3 F_uvv^2 + F_vvv^2``, weighted on each patch by its own
uv area (``h_f^2 ~ area``), so that against a data term measured per ``h^4`` the balance sets a
smoothing length proportional to the patch size. Its null space is the quadratic functions:
a fit that uses it instead of the thin-plate energy reproduces a quadric exactly (the
approximation's default, :data:`trispline.fit.approx.fit.APPROX_WEIGHTS`), and it does not
flatten curvature the way the thin-plate energy does. Third derivatives of a quintic have
degree 2, so the 16-point rule of :mod:`.quadrature` integrates the square exactly.

Residual ``sqrt(weight) area_f sqrt(w_q) [F_uuu, sqrt3 F_uuv, sqrt3 F_uvv, F_vvv]`` at the
quadrature points; the Gram matrix comes from the same coefficients (:func:`variation_weights`).
"""
from __future__ import annotations

from functools import lru_cache
from itertools import permutations
from typing import TYPE_CHECKING

import numpy as np

from trispline.spline.bernstein import basis
from trispline.spline.index import NCTRL

from .arrays import Array, array_module
from .quadrature import triangle_quadrature

if TYPE_CHECKING:
    from .context import TermContext
    from .normal import NormalParts

__all__ = ["TRIPLES", "triple_derivatives", "variation_weights"]

NAME = "variation"
LINEAR = True
#: The energy scales like (data size)**2.
SCALE_EXPONENT = 2

#: The ten barycentric third-derivative triples ``a <= b <= c``.
TRIPLES = np.array([(a, b, c) for a in range(3) for b in range(a, 3) for c in range(b, 3)])
#: The uv third derivatives ``F_uuu, F_uuv, F_uvv, F_vvv`` as derivative directions, and their multiplicities.
_DIRECTIONS = ((0, 0, 0), (0, 0, 1), (0, 1, 1), (1, 1, 1))
_MULTIPLICITY = np.array([1.0, 3.0, 3.0, 1.0])


@lru_cache(maxsize=None)
def triple_derivatives() -> tuple[np.ndarray, np.ndarray]:
    """``D (Q, 10, 21)``: the third barycentric partials ``D_T B_i`` at the quadrature points, and ``sqw (Q,)``."""
    bary, w = triangle_quadrature(4)
    D = np.stack([basis(bary, tuple(int(np.count_nonzero(t == k)) for k in range(3))) for t in TRIPLES], axis=1)
    sqw = np.sqrt(w)
    D.setflags(write=False)
    sqw.setflags(write=False)
    return D, sqw


@lru_cache(maxsize=None)
def _moments() -> np.ndarray:
    """``(10, 10, 21, 21)`` triangle means of ``D_T B_i D_S B_j``."""
    D, _ = triple_derivatives()
    out = np.einsum("q,qti,qsj->tsij", triangle_quadrature(4)[1], D, D)
    out.setflags(write=False)
    return out


def variation_weights(bary_grad: np.ndarray, areas: np.ndarray, weight: float) -> np.ndarray:
    """``(F, 10, 4)`` coefficients turning triple partials ``D_T F`` into the scaled uv third derivatives.

    A uv third derivative along directions ``(d1, d2, d3)`` is ``sum_{a,b,c} g_a[d1] g_b[d2]
    g_c[d3] D_abc F`` over ordered triples; each multiset ``T`` collects its orderings. Scaled by
    ``sqrt(multiplicity)``, ``area_f`` (the patch-size weighting) and ``sqrt(weight area_f)``
    (the integral). ``bary_grad (F, 3, 2)``, ``areas (F,)``.
    """
    g = np.asarray(bary_grad, float)
    areas = np.asarray(areas, float)
    W = np.zeros((g.shape[0], len(TRIPLES), 4))
    for t, T in enumerate(TRIPLES):
        for a, b, c in set(permutations(T)):
            for k, (d1, d2, d3) in enumerate(_DIRECTIONS):
                W[:, t, k] += g[:, a, d1] * g[:, b, d2] * g[:, c, d3]
    W *= np.sqrt(_MULTIPLICITY)[None, None, :]
    return W * (areas * np.sqrt(weight * areas))[:, None, None]


def setup(ctx: TermContext) -> dict[str, np.ndarray]:
    """``D (Q, 10, 21)``, ``sqw (Q,)`` and ``W (n, 10, 4)`` of the patches (weight ``ctx.weights.variation``)."""
    D, sqw = triple_derivatives()
    weight = float(getattr(ctx.weights, NAME, 0.0))
    return dict(D=D, sqw=sqw, W=variation_weights(ctx.bary_gradients, ctx.areas, weight))


def residual(ctrl: Array, frames: Array, a: dict) -> Array:
    """``(n, Q, 4, d)``: the scaled uv third derivatives of patches ``ctrl (n, 21, d)``."""
    xp = array_module(ctrl)
    d3 = xp.einsum("qti,fic->fqtc", a["D"], ctrl)
    return xp.einsum("fqtc,ftk,q->fqkc", d3, a["W"], a["sqw"])


def add_normal(parts: NormalParts, a: dict) -> None:
    """Adds each patch's Gram matrix ``ctrl^T G ctrl = |residual|^2`` to its block."""
    C = np.einsum("ftk,fsk->fts", a["W"], a["W"])  # (F, 10, 10)
    nt = len(TRIPLES)
    parts.blocks += (C.reshape(-1, nt * nt) @ _moments().reshape(nt * nt, NCTRL * NCTRL)).reshape(-1, NCTRL, NCTRL)
