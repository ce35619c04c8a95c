"""The fairness energy: one module per term, one definition per term.

Terms (weights in :class:`trispline.fit.weights.FitWeights`):

``bend`` (:mod:`.bend`)
    Thin-plate energy over the uv domain, exact per patch.
``tilt`` (:mod:`.tilt`)
    Each corner frame toward the local fit's tangent frame.
``local`` (:mod:`.local`)
    Every other non-corner control point toward the blended local fits of its patch's vertices.
``data`` (:mod:`.data`)
    Extra sample points ``(face, bary) -> xyz``.
``angle`` (:mod:`.angle`, nonlinear)
    The frame's unit normal toward the data normal.

Each term builds its arrays once (:func:`setup_terms` over a :class:`TermContext`); from
them come its residual (numpy or JAX: the global fit's optimistix residual
:func:`residuals`, the host energies :func:`term_energies`) and, for the linear terms,
its part of the normal equations (:func:`normal_parts`, :func:`normal_equations`), which
serve the global fit's factor and the local re-fair alike. :mod:`.terms` says how to add one.
"""
from .bend import bend_weights, gram, thin_plate_gram
from .context import TermContext, frame_ids, term_context, vertex_areas
from .data import DataPoints, as_data_points
from .local import blended_targets
from .normal import NormalParts, normal_equations
from .problem import (Problem, control_points, energies, energy_units, normalised_energies, residuals,
                      setup_problem)
from .terms import MODULES, TERMS, is_nonlinear, normal_parts, setup_terms, term_energies, term_residuals

__all__ = [
    "TERMS", "MODULES", "TermContext", "term_context", "frame_ids", "vertex_areas", "setup_terms",
    "term_residuals", "term_energies", "normal_parts", "is_nonlinear", "NormalParts",
    "normal_equations", "Problem", "setup_problem", "control_points", "residuals", "energies", "energy_units",
    "normalised_energies",
    "DataPoints", "as_data_points", "bend_weights", "gram", "thin_plate_gram", "blended_targets",
]
