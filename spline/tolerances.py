"""Every named tolerance of trispline, in one place, with what it decides and why this value.

Tiers (STYLE): exact for combinatorics; ~1e-12 relative for algebraic identities;
solver tolerances for fitted outputs. Modules import the name they need from here.
"""
from __future__ import annotations

# --------------------------------------------------------------------------- spline
#: Pivots of the propagation's vertex systems below this (equations are normalised to
#: O(1) coefficients) count as zero. Measured on perturbed alternating and criss-cross
#: grids: with 1e-13 the C1 residual stays below 2e-14 (relative) for every perturbation.
SINGULAR_TOL = 1e-13
#: Pivot preference of inner points relative to middle edge points in the propagation.
INNER_PIVOT_WEIGHT = 0.2
#: uv triangles with area below this times the mean |area| are degenerate.
MIN_RELATIVE_AREA = 1e-14
#: Point location: barycentric coordinates down to ``-BARY_TOL`` count as inside.
BARY_TOL = 1e-10
#: A surface handed to ``SplineEditor.from_surface`` must reproduce from its free points
#: to this relative accuracy (it must lie in the C1 spline space).
FROM_SURFACE_RTOL = 1e-9
#: Floor of norms and denominators that may vanish (keeps 0/0 finite; far below any length).
TINY = 1e-300

# ---------------------------------------------------------------------------- param
#: 3D faces with area below this times the mean face area are zero-area faces.
MIN_RELATIVE_AREA_3D = 1e-12

# ------------------------------------------------------------------------------ fit
#: Gauss--Newton tolerances of the fit (relative and absolute, data normalised to unit size).
GN_RTOL = 1e-9
GN_ATOL = 1e-9
#: A fit counts as converged when its gradient is below this times the gradient at zero.
CONVERGED_GRAD_RTOL = 1e-6
#: Local fits: tangents whose cross product is below this times |grad|^2 are degenerate.
DEGENERATE_TANGENT_RTOL = 1e-12
#: Default relative tolerance of ``trispline check`` (algebraic identities hold to ~1e-14).
CHECK_TOLERANCE = 1e-9
#: Zebra pictures: normals with |N . W| below this (almost parallel to the light panel) stay grey.
ZEBRA_MIN_COS = 1e-3
