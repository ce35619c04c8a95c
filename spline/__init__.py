"""trispline.spline — C1 quintic triangular splines over planar triangulations.

Pure math (numpy/scipy only): index tables, the Bernstein basis, the domain
triangulation, the free-to-control propagation map, continuity checks,
evaluation, tessellation and the surface file format.
"""
from ._index import CORNER, DEGREE, EXPONENTS, FLIP, INNER, MID, NCTRL, STAR, index_of
from .bernstein import bary_grid, basis, basis_gradient_bary, basis_hessian_bary

__all__ = [
    "CORNER", "DEGREE", "EXPONENTS", "FLIP", "INNER", "MID", "NCTRL", "STAR", "index_of",
    "bary_grid", "basis", "basis_gradient_bary", "basis_hessian_bary",
]
