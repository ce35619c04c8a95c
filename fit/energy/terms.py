"""The registry of energy terms and what every consumer derives from it.

A term is one module with ``NAME`` (its weight in :class:`~trispline.fit.weights.FitWeights`),
``LINEAR``, ``SCALE_EXPONENT`` (its energy scales like the data's size to this power),
``setup(ctx) -> dict`` (its arrays, once: targets, scales, indices), ``residual(ctrl, frames,
a)`` (numpy or JAX alike) and, when linear, ``add_normal(parts, a)``. Adding a term means
writing such a module and listing it in :data:`MODULES`.
"""
from __future__ import annotations

from types import ModuleType

import numpy as np

from . import angle, bend, data, local, robust, tilt
from .context import TermContext
from .normal import NormalParts

__all__ = ["MODULES", "TERMS", "DATA_LOSSES", "setup_terms", "term_residuals", "term_energies", "normal_parts",
           "is_nonlinear"]

#: The term modules, in report order.
MODULES: tuple[ModuleType, ...] = (bend, tilt, local, data, angle)
#: Their names.
TERMS: tuple[str, ...] = tuple(m.NAME for m in MODULES)
#: The data term's module per loss (the approximation's choice; ``fit_surface`` uses plain ``data``).
DATA_LOSSES: dict[str, ModuleType] = {"l2": data, **{loss: robust for loss in robust.LOSSES}}


def setup_terms(ctx: TermContext) -> dict[str, dict[str, np.ndarray]]:
    """Every term's arrays for the context: ``{name: {array name: array}}``."""
    return {m.NAME: m.setup(ctx) for m in MODULES}


def term_residuals(ctrl, frames, terms: dict) -> dict:
    """Residuals of every term for patch points ``ctrl (n, 21, d)`` and frame points ``frames (2m, d)``."""
    return {m.NAME: m.residual(ctrl, frames, terms[m.NAME]) for m in MODULES}


def term_energies(ctrl: np.ndarray, frames: np.ndarray, terms: dict) -> dict[str, float]:
    """Energy (sum of squared residuals, weights included) of every term, on the host."""
    return {k: float(np.sum(r * r)) for k, r in term_residuals(ctrl, frames, terms).items()}


def normal_parts(terms: dict, n_patches: int, n_frames: int) -> NormalParts:
    """The linear terms' normal-equation pieces (nonlinear terms left out)."""
    parts = NormalParts.zeros(n_patches, n_frames)
    for m in MODULES:
        if m.LINEAR:
            m.add_normal(parts, terms[m.NAME])
    return parts


def is_nonlinear(terms: dict) -> bool:
    """True when a nonlinear term has rows (then Gauss--Newton must iterate)."""
    return any(a.size for m in MODULES if not m.LINEAR for a in terms[m.NAME].values())
