"""``data`` with a robust loss (nonlinear): sample points ``F(face, bary) ~ xyz`` that outliers cannot pull.

The plain data term (:mod:`.data`) has the residual ``e = s (F(face, bary) - xyz)`` per
sample. This term keeps its arrays and its weight (``FitWeights.data``) and transforms
each residual vector so that the sum of squares is a robust loss of its length:

    psi(e) = e g(q),    |psi(e)|^2 = tau^2 rho(q),    q = |e|^2 / tau^2,

with ``tau = s c`` the loss scale ``c`` (model units, from the noise estimate) in residual
units and

    huber:  rho = q (q <= 1), 2 sqrt(q) - 1 (q > 1)      g = 1, sqrt(2 t - 1) / t   (t = sqrt q)
    cauchy: rho = log(1 + q)                             g = sqrt(log(1 + q) / q)

Both equal the plain term for small residuals (``psi(e) = e + O(|e|^3)``), so the plain
term's normal matrix is the exact Gauss--Newton matrix of the inliers and preconditions
the rest (:class:`~trispline.fit.solve.FactorSolver` ``mode="pcg"``). ``psi`` is C1 in ``e``
(Huber: ``g`` and its slope are continuous at ``t = 1``), so optimistix's Gauss--Newton
takes real steps on it: a least-squares problem whose minimum is the robust M-estimate.
Huber's influence stays bounded (a far point still pulls, with constant force); Cauchy's
falls off like ``1 / t`` (a far point is ignored).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from trispline.spline.tolerances import TINY

from . import data
from .arrays import Array, array_module
from .data import DataPoints

if TYPE_CHECKING:
    from .context import TermContext

__all__ = ["LOSSES", "TUNING", "RobustPoints", "gain", "inlier_weight"]

#: The robust data term replaces the plain one: same weight.
NAME = data.NAME
LINEAR = False
#: The energy scales like (data size)**2.
SCALE_EXPONENT = 2

#: The robust losses.
LOSSES = ("huber", "cauchy")
#: Loss scale ``c`` in noise standard deviations: 95% efficiency under Gaussian noise.
TUNING = {"huber": 1.345, "cauchy": 2.385}
#: Below this ``q`` the Cauchy gain uses its series (``log(1 + q) / q = 1 - q / 2 + ...``).
_SERIES_Q = 1e-8


@dataclass(frozen=True)
class RobustPoints(DataPoints):
    """Samples for the robust data term: :class:`~.data.DataPoints` with a loss and its scale.

    Attributes
    ----------
    face : (n,) int64, bary : (n, 3), xyz : (n, 3)
    loss : one of :data:`LOSSES`
    scale : the loss scale ``c`` (data units, > 0), one for all samples or ``(n,)`` one each:
        residuals below it count as plain least squares
    """

    loss: str = "huber"
    scale: float | np.ndarray = 1.0

    def __post_init__(self) -> None:
        if self.loss not in LOSSES:
            raise ValueError(f"loss must be one of {', '.join(LOSSES)}, got {self.loss!r}")
        c = np.asarray(self.scale, float)
        if c.ndim > 1 or (c.ndim == 1 and c.size != self.face.size) or not (np.isfinite(c) & (c > 0)).all():
            raise ValueError(f"the loss scale must be finite and > 0, one or one per sample ({self.face.size})")


def setup(ctx: TermContext) -> dict[str, np.ndarray]:
    """The plain term's arrays plus ``tau (s,)`` (scale in residual units) and ``cauchy ()`` (1.0 or 0.0)."""
    dp = ctx.data_points
    if not isinstance(dp, RobustPoints):
        raise TypeError(f"the robust data term needs RobustPoints, got {type(dp).__name__}")
    a = data.setup(ctx)
    return dict(a, tau=a["scale"] * np.asarray(dp.scale, float), cauchy=np.asarray(float(dp.loss == "cauchy")))


def gain(q: Array, cauchy: Array) -> Array:
    """``g (s,)`` of the module docstring for ``q = |e|^2 / tau^2 (s,)``, Huber or (``cauchy`` = 1) Cauchy."""
    xp = array_module(q, cauchy)
    big = q > 1.0
    t = xp.sqrt(xp.where(big, q, 1.0))
    huber = xp.where(big, xp.sqrt(2.0 * t - 1.0) / t, 1.0)
    small = q < _SERIES_Q
    qs = xp.where(small, 1.0, q)
    ratio = xp.where(small, 1.0 - 0.5 * q, xp.log1p(qs) / qs)
    return xp.where(cauchy > 0.5, xp.sqrt(ratio), huber)


def residual(ctrl: Array, frames: Array, a: dict) -> Array:
    """``(s, d)`` robust residuals ``psi(e)`` of the surface of ``ctrl (n, 21, d)`` at the samples."""
    xp = array_module(ctrl)
    e = data.residual(ctrl, frames, a)
    q = xp.sum(e * e, axis=1) / xp.maximum(a["tau"] * a["tau"], TINY)  # tau 0: a data weight of 0, e 0 too
    return e * gain(q, a["cauchy"])[:, None]


def inlier_weight(distance: np.ndarray, scale: float | np.ndarray, loss: str) -> np.ndarray:
    """``(n,)`` the loss's IRLS weight ``rho'(q)`` of residual lengths ``distance (n,)`` at loss scales
    ``scale`` (one, or ``(n,)``); 1 is plain least squares.

    Huber ``min(1, c / d)``, Cauchy ``1 / (1 + (d / c)^2)``: how much a point at distance
    ``d`` still pulls, relative to an inlier.
    """
    t = np.asarray(distance, float) / scale
    if loss == "cauchy":
        return 1.0 / (1.0 + t * t)
    return np.minimum(1.0, 1.0 / np.maximum(t, 1e-300))
