"""The weights of the fairness energy: one frozen object shared by the fit, the energy terms and the re-fair."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from trispline.spline.errors import InputError

__all__ = ["FitWeights", "TERM_WEIGHTS"]

#: The energy terms' weights, in the order of :data:`trispline.fit.energy.TERMS`.
TERM_WEIGHTS = ("bend", "tilt", "local", "data", "angle")
#: Largest term weight: only the weights' ratios matter, and the terms' sums overflow near 1e300.
MAX_WEIGHT = 1e100


@dataclass(frozen=True)
class FitWeights:
    """Weights of the fairness energy terms (all dimensionless, see docs/fit.md).

    Attributes
    ----------
    bend : thin-plate bending over the uv domain
    tilt : corner frames toward the local fit's tangent frame
    local : other control points toward the blended local fits
    data : extra sample points (``data_points`` of :func:`~trispline.fit.pipeline.fit_surface`)
    angle : nonlinear: the frame's unit normal toward the data normal
    fit_degree : highest polynomial degree of the local fits: 2 (kernels r^3, r^5) or 3 (also r^7);
        the local fits are polyharmonic interpolants of each vertex's ``fit_rings``-ring, kernel
        chosen per vertex by leave-one-out error (:func:`trispline.fit.targets.local_rbf_fit`)
    fit_rings : neighbourhood (edge rings) of the local fits
    blend_power : exponent of the corner blend of the local targets
    """

    bend: float = 1.0
    tilt: float = 30.0
    local: float = 3.0
    data: float = 1.0
    angle: float = 0.0
    fit_degree: int = 3
    fit_rings: int = 3
    blend_power: float = 2.0

    def __post_init__(self) -> None:
        for name in TERM_WEIGHTS:
            v = getattr(self, name)
            if not (np.isfinite(v) and v >= 0):
                raise InputError(f"weight {name} must be finite and >= 0, got {v}")
            if v > MAX_WEIGHT:
                raise InputError(f"weight {name} is {v:g}, above {MAX_WEIGHT:g}: only the weights' ratios matter, "
                                 "so scale them all down")
        if self.bend <= 0 and self.local <= 0:
            raise InputError("at least one of the bend and local weights must be positive")
        if self.fit_degree not in (2, 3):
            raise InputError(f"fit_degree must be 2 or 3, got {self.fit_degree}")
        if self.fit_rings < 1:
            raise InputError(f"fit_rings must be >= 1, got {self.fit_rings}")
