"""Fits shared by the fit tests: each problem is set up and solved once per session.

Fitting a small problem costs about a second, nearly all of it compiling the Gauss--Newton
loop for the problem's shapes; :mod:`trispline.fit.solve` keeps that compile for every later
problem of the same shapes, and these fixtures keep the fits themselves.
"""
from __future__ import annotations

from types import ModuleType

import jax
import numpy as np
import pytest
from bench_modules import bench_module
from scipy.spatial import Delaunay

jax.config.update("jax_enable_x64", True)

from trispline.fit.datasets.franke import exponential, sample_points  # noqa: E402
from trispline.fit.pipeline import fit_surface  # noqa: E402
from trispline.spline.testing.domains import orient_ccw  # noqa: E402

def franke_mesh(n: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """``V (n, 3)``, ``F``: Franke's exponential over ``n`` points of the unit square, Delaunay triangulated."""
    p = sample_points(n, seed=seed)
    F = orient_ccw(p, Delaunay(p).simplices)
    return np.column_stack([p, exponential(p[:, 0], p[:, 1])]), F


@pytest.fixture(scope="session")
def franke_fit():
    """``(V, F, FitResult)``: the default fit of a 150-point height field with ``uv = (x, y)``."""
    V, F = franke_mesh(150, seed=4)
    return V, F, fit_surface(V, F, uv=V[:, :2])


@pytest.fixture(scope="session")
def accuracy_bench() -> ModuleType:
    """``benchmarks/bench_accuracy.py`` as a module (its ``run_case`` serves the accuracy tests)."""
    return bench_module("bench_accuracy")


@pytest.fixture(scope="session")
def real_mesh() -> tuple[np.ndarray, np.ndarray]:
    """``(V, F)``: the generated real-world-like scan (:func:`~trispline.fit.datasets.face.face_scan`,
    about 4000 triangles: ragged outline, one hole, irregular sampling, noise), in every clone."""
    from trispline.fit.datasets.face import face_scan

    return face_scan(4000, seed=0)
