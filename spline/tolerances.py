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
#: An interior valence-4 vertex closer than this times its mean edge length to the crossing
#: of its two diagonals (the lines through opposite neighbours) is moved onto the crossing
#: and counted singular (issue 14). Small enough that the move stays below 1e-12 of the
#: domain on a height field's ``uv = (x, y)`` (2.4e-14 on a 30 x 30 grid); large enough that
#: the dimension of the space is never a coin toss: over 300 random near-degenerate meshes the
#: C1 conditions' smallest kept singular value was >= 1.1e-13, the largest dropped <= 5.4e-15.
SNAP_TOL = 1e-12
#: Vertex systems whose smallest pivot is below this are eliminated again in double-double
#: arithmetic. In double their rows are off by ~1e-16 / pivot: measured on perturbed 30 x 30
#: criss-cross grids, a plane is reproduced to 1.8e-13 with 1e-2 (4e-14 with 3e-2), the floor
#: of meshes with nothing near-singular (1.3e-13 at a perturbation of 0.1). It costs nothing
#: elsewhere: 25 of the 264,400 eliminated systems of a 1M-face random Delaunay mesh, none on
#: perturbed or alternating grids.
EXACT_PIVOT_TOL = 1e-2
#: Diamonds whose coefficients double arithmetic may get wrong by more than this many units in the
#: last place (the signed areas cancel: slivers, nearly collinear edges; bound of
#: :func:`~trispline.spline.propagation.diamonds.area_cancellation`) are computed again in
#: double-double and rounded. Such coefficients made the sampled C1 jump of a 3,000-point random
#: Delaunay mesh (hull slivers of aspect 5.7e4) 3.2e-8 of the gradient; rounded from double-double
#: 5.4e-11. Nice meshes stay bit for bit (their bound is 1-4).
EXACT_DIAMOND_ULPS = 16.0
#: Pivots of the double-double pass at or below this count as zero: far above its rounding
#: (~1e-31 on the O(1) equations), far below any pivot double coordinates can make off a
#: crossing (>= ~1e-18).
EXACT_SINGULAR_TOL = 1e-26
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
#: A parameterization whose worst angle distortion (singular value ratio of a face's map,
#: 1 = similar triangle) exceeds this is reported with a warning, and ``method="auto"``
#: looks beyond LSCM. Measured on fits of the shared meshes: spikes follow single sheared
#: or folded uv triangles (harmonic's squeezed corners on inspired_mesh and beetle, angle
#: max 62 and 481, raise the fit's max |H| 1600x and 130x over LSCM's maps, angle max 1.01
#: and 1.17), while area distortion alone does not (LSCM's area p99 2e4 on the camel head
#: fits as well as maps with 6).
ANGLE_DISTORTION_WARN = 10.0
#: Area distortion (99th percentile of a face's area share in uv over its share in 3D, or
#: the inverse) above this is reported with a warning: the uv resolution of the fit then
#: varies by more than this between regions of the surface.
AREA_DISTORTION_WARN = 1e3
#: SLIM stops when an iteration lowers its energy by less than this fraction (measured:
#: the distortion percentiles then change in their third digit).
SLIM_RTOL = 1e-3
#: uv smoothing (param/smooth.py): a local fit uses the highest degree whose normal matrix
#: (coordinates in edge lengths, so O(1)) has a reciprocal condition number of at least this;
#: lower degrees where a neighbourhood is too small or too flat to support it.
SMOOTH_RCOND = 1e-8
#: uv smoothing: a boundary loop turning by more than this (degrees, between consecutive 3D
#: edges) has a corner there; boundary fits do not reach across it and the corner keeps its uv.
#: Smooth outlines turn by a few degrees per edge at 200 vertices; rectangle corners by 90.
SMOOTH_CORNER_DEGREES = 35.0

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
#: Exact CAD export: the B-rep tolerance of vertices, edges and faces, in the surface's units
#: (Open CASCADE's ``Precision::Confusion``). The geometry is exact; this is what CAD tools
#: read as the model's tolerance.
CAD_TOLERANCE = 1e-7
#: Zebra pictures: normals with |N . W| below this (almost parallel to the light panel) stay grey.
ZEBRA_MIN_COS = 1e-3

#: A domain triangle more elongated than this (longest edge over its height) is refused before
#: the fit: at 1e7 the fit's normal matrix is no longer positive definite in float64 (measured:
#: a sliver of height 1e-6 on a unit base fits with C1 residual 1e-16, one of 1e-7 fails).
MAX_DOMAIN_ASPECT = 1e6
#: Coordinates (of a mesh, a surface's control points or its uv) of larger magnitude are refused, and so is a
#: mesh whose bounding-box diagonal is below :data:`MIN_EXTENT`: lengths are squared twice in areas and
#: normal equations, which overflow (underflow) double precision from about 1e77 (1e-77); measured, a
#: mesh scaled by 1e76 or 1e-76 fits as at unit scale, one at 1e80 or 1e-80 did not.
MAX_MAGNITUDE = 1e60
MIN_EXTENT = 1e-60
#: Data whose float64 coordinates keep less than this fraction of their extent (``eps * max|V| /
#: extent``: 5e-11 for a 20 m tile at UTM's 5e6 m) get a warning: the stored net's continuity is
#: only known to about 100 times that (the check's precision floor).
FAR_PRECISION = 1e-11
#: A residual passes when within the tolerance plus this many times the residual that the
#: rounding of the stored coordinates alone makes (``precision_floor``: one random draw of
#: half-ulp errors, of which the fit's own rounding is one more draw).
PRECISION_MARGIN = 8.0
#: Below this relative precision of the coordinates (``eps * max|ctrl| / extent``) the floor is not
#: measured: it is far below any tolerance worth asking.
FLOOR_NEGLIGIBLE = 1e-14

# ---------------------------------------------------------------------- approximation
#: A tolerance below this many noise standard deviations (the scan analysis' estimate) can only
#: be met by following the noise: the approximation warns.
NOISE_SIGMAS = 4.5
#: ... where the estimate is noise: neighbouring vertices' residuals about uncorrelated (the scan analysis'
#: ``noise_correlation`` at most this; Gaussian noise -0.09, the local quadrics' model error on the shared
#: real scans +0.26 to +0.66). Without this test six of the eight shared scans were warned at a tolerance
#: of 1e-3 of the diagonal, which five of them met with 2-4% of their vertices.
NOISE_CORRELATION_MAX = 0.1
#: Gauss--Newton tolerances of a robust approximation (data normalised to unit size): a
#: step below 1e-8 of the size moves the surface far less than any scan's noise, and the
#: gradient then passes the fit's CONVERGED_GRAD_RTOL test (at 1e-7 it did not, with moving corners).
APPROX_GN_RTOL = 1e-8
APPROX_GN_ATOL = 1e-8
#: ... and its convergence test: the gradient below this times the gradient at zero (the
#: fit's CONVERGED_GRAD_RTOL is 1e-6; Cauchy's Gauss--Newton, linearly convergent on the
#: outliers, stopped by the step test at about 2e-6 on the synthetic scans).
APPROX_CONVERGED_GRAD_RTOL = 1e-5
#: Relative residual of the conjugate-gradient solve in each robust Gauss--Newton step
#: (inexact Gauss--Newton: 1e-2 took as many steps as 1e-8, in half the time).
APPROX_CG_RTOL = 1e-2
