"""The weights of the fairness energy: one frozen object shared by the fit, the energy terms and the re-fair."""
from __future__ import annotations

from dataclasses import dataclass

from trispline.spline.checks import real_number, whole_number
from trispline.spline.errors import InputError

__all__ = ["FitWeights", "MAX_BLEND_POWER", "TERM_WEIGHTS"]

#: The energy terms' weights, in the order of :data:`trispline.fit.energy.TERMS`.
TERM_WEIGHTS = ("bend", "tilt", "local", "data", "angle")
#: Largest term weight: only the weights' ratios matter, and the terms' sums overflow near 1e300.
MAX_WEIGHT = 1e100
#: Largest ``blend_power``: the blend's weights ``5^p`` overflow near p = 441, and far below that the blend
#: is already a step at every corner.
MAX_BLEND_POWER = 16.0


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
            v = real_number(getattr(self, name), f"weight {name}", least=0.0)
            object.__setattr__(self, name, v)
            if v > MAX_WEIGHT:
                raise InputError(f"weight {name} is {v:g}, above {MAX_WEIGHT:g}: only the weights' ratios matter, "
                                 "so scale them all down")
        if self.bend <= 0 and self.local <= 0:
            raise InputError("at least one of the bend and local weights must be positive")
        object.__setattr__(self, "fit_degree", whole_number(self.fit_degree, "fit_degree", least=2, most=3))
        object.__setattr__(self, "fit_rings", whole_number(self.fit_rings, "fit_rings", least=1))
        object.__setattr__(self, "blend_power", real_number(self.blend_power, "blend_power", least=0.0))
        if self.blend_power > MAX_BLEND_POWER:
            raise InputError(f"blend_power must be in [0, {MAX_BLEND_POWER:g}], got {self.blend_power:g}")
