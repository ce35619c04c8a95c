"""How far a fitted surface strays outside its data's bounding box: the guard against a wild solution.

A surface that leaves the box of the data it was fitted to by a sizeable share of the box's diagonal is
not a fit of that data: the interpolating fit of a nearly indefinite normal matrix that happened to factor
(:data:`~trispline.fit.pipeline.WILD_NET`), or an approximation whose data weight let a patch overshoot
between the scan's points (:data:`~trispline.fit.approx.fit.WILD_REACH`). The control net is not the
measure: the net of a hull sliver reaches far beyond its tame patch; a patch lies in its net's convex
hull, so the net only says which patches to sample.
"""
from __future__ import annotations

import numpy as np

from trispline.spline.bernstein import bary_grid
from trispline.spline.patches import evaluate_grid

#: Lattice steps per edge on which a patch whose net reaches past the limit is sampled.
REACH_STEPS = 16


def box_reach(points: np.ndarray, V: np.ndarray) -> np.ndarray:
    """``(...)`` how far each of ``points (..., 3)`` lies outside the bounding box of ``V (n, 3)``, in
    bounding-box diagonals (0 inside)."""
    lo, hi = V.min(0), V.max(0)
    out = np.maximum(np.maximum(lo - points, points - hi), 0.0)
    return np.sqrt((out * out).sum(-1)) / max(float(np.linalg.norm(hi - lo)), np.finfo(float).tiny)


def surface_reach(ctrl: np.ndarray, V: np.ndarray, beyond: float) -> float:
    """How far the surface of ``ctrl (F, 21, 3)`` reaches outside the bounding box of ``V (n, 3)``, in
    bounding-box diagonals. Only the patches whose net reaches past ``beyond`` are sampled (on a lattice of
    :data:`REACH_STEPS`); where none does, the net's reach (at most ``beyond``) is returned."""
    net = box_reach(ctrl, V).max(1)  # (F,)
    wild = np.flatnonzero(net > beyond)
    if wild.size == 0:
        return float(net.max(initial=0.0))
    return float(box_reach(evaluate_grid(ctrl[wild], bary_grid(REACH_STEPS))[0], V).max())
