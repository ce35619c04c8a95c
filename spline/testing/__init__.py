"""Generators for tests, examples and benchmarks: planar triangulations, random polynomials, C1 surfaces.

    from trispline.spline.testing import domains, random_polynomial
    uv, faces = domains.random_delaunay(500, holes=2)

Not part of the spline API proper: these make inputs, they do not compute splines.
"""
from ..polynomial import random_polynomial
from . import domains
from .surfaces import random_c1_surface

__all__ = ["domains", "random_polynomial", "random_c1_surface"]
