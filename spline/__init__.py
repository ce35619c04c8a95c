"""trispline.spline — C1 quintic triangular splines over planar triangulations.

Pure math (numpy/scipy only): index tables, the Bernstein basis, the domain
triangulation, the free-to-control propagation map, continuity checks,
evaluation, point location, tessellation and the surface file format.
"""
from .index import CORNER, DEGREE, EXPONENTS, FLIP, INNER, MID, NCTRL, STAR, index_of
from .bernstein import bary_grid, basis, basis_gradient_bary, basis_hessian_bary
from .continuity import continuity_report, continuity_residuals
from .errors import InputError, TriangulationError
from .locate import Locator, OutsideDomainError, locate
from .patches import evaluate, evaluate_derivatives, evaluate_grid, numeric_continuity
from .polynomial import polynomial_control_net, random_polynomial
from .propagation import SplineSpace, build_space
from .serialize import SurfaceFileError, read_surface, write_surface
from .surface import SplineSurface
from .tessellate import Tessellation, tessellate
from .topology import Triangulation

__all__ = [
    "CORNER", "DEGREE", "EXPONENTS", "FLIP", "INNER", "MID", "NCTRL", "STAR", "index_of",
    "bary_grid", "basis", "basis_gradient_bary", "basis_hessian_bary",
    "continuity_report", "continuity_residuals", "InputError", "TriangulationError",
    "Locator", "OutsideDomainError", "locate",
    "evaluate", "evaluate_derivatives", "evaluate_grid", "numeric_continuity",
    "polynomial_control_net", "random_polynomial", "SplineSpace", "build_space",
    "SurfaceFileError", "read_surface", "write_surface", "SplineSurface", "Tessellation", "tessellate",
    "Triangulation",
]
