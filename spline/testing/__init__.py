"""Generators for tests, examples and benchmarks: planar triangulations and random polynomials.

    from trispline.spline.testing import domains, random_polynomial
    uv, faces = domains.random_delaunay(500, holes=2)

Not part of the spline API proper: these make inputs, they do not compute splines.
"""
from ..polynomial import random_polynomial
from . import domains

__all__ = ["domains", "random_polynomial"]
