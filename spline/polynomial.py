"""Exact control nets of global polynomials (a test oracle and a reproduction tool).

A bivariate polynomial of total degree ``<= 5`` restricted to any triangle is a
quintic Bézier patch, so it has an exact control net. It is found per patch by
collocation: evaluate the polynomial at the patch's 21 domain points
``(i a + j b + k c) / 5`` and solve the ``21 x 21`` Bernstein collocation system
``basis(bary_grid(5)) @ ctrl = values``, one LU factorisation for all faces and
coordinates.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache
from typing import Callable

import numpy as np
import scipy.linalg

from .bernstein import bary_grid, basis
from .checks import as_array, check_ids
from .errors import InputError
from .index import DEGREE
from .util import gather as _gather

__all__ = ["Polynomial", "polynomial_control_net", "random_polynomial"]


@lru_cache(maxsize=1)
def _collocation_lu() -> tuple[np.ndarray, np.ndarray]:
    """LU factors of the (21, 21) Bernstein collocation matrix at ``bary_grid(5)``."""
    return scipy.linalg.lu_factor(basis(bary_grid(DEGREE)))


def polynomial_control_net(
    uv: np.ndarray, faces: np.ndarray, func: Callable[[np.ndarray], np.ndarray]
) -> np.ndarray:
    """Exact per-patch control net of a global polynomial of degree ``<= 5``.

    Parameters
    ----------
    uv : (V, 2) float
    faces : (F, 3) int
    func : callable mapping ``(n, 2)`` uv points to ``(n, d)`` (or ``(n,)``) values.
        Must be a polynomial of total degree ``<= 5`` for the net to be exact;
        otherwise the result is the patchwise quintic interpolant at the domain points.

    Returns
    -------
    ctrl : (F, 21, d) float64 (``d = 1`` for a scalar ``func``)
    """
    uv = as_array(uv, "uv", ("V", 2))
    faces = check_ids(as_array(faces, "faces", ("F", 3), integer=True), "faces", uv.shape[0])
    nf = faces.shape[0]
    grid = bary_grid(DEGREE)  # (21, 3)
    pts = np.einsum("gk,fkc->fgc", grid, _gather.rows(uv, faces))  # (F, 21, 2)
    vals = np.asarray(func(pts.reshape(-1, 2)), dtype=np.float64)
    if vals.ndim == 1:
        vals = vals[:, None]
    if vals.ndim != 2 or vals.shape[0] != nf * grid.shape[0]:
        raise InputError(
            f"func must map (n, 2) points to (n, d) values; got shape {vals.shape} for n = {nf * 21}"
        )
    d = vals.shape[1]
    rhs = vals.reshape(nf, 21, d).transpose(1, 0, 2).reshape(21, nf * d)
    sol = scipy.linalg.lu_solve(_collocation_lu(), rhs)  # (21, F*d)
    return np.ascontiguousarray(sol.reshape(21, nf, d).transpose(1, 0, 2))


@dataclass(frozen=True)
class Polynomial:
    """A vector-valued bivariate polynomial ``sum_(p+q<=deg) c_pq u^p v^q``.

    Parameters
    ----------
    powers : (m, 2) int
        Exponents ``(p, q)`` of the monomials.
    coeffs : (m, d) float
        One coefficient row per monomial.
    centre : (2,) float
        Monomials are in ``(u, v) - centre`` (keeps values well scaled).
    """

    powers: np.ndarray
    coeffs: np.ndarray
    centre: np.ndarray

    @property
    def degree(self) -> int:
        return int(self.powers.sum(1).max())

    def _monomials(self, points: np.ndarray, du: int = 0, dv: int = 0) -> np.ndarray:
        x = np.asarray(points, dtype=np.float64) - self.centre
        p, q = self.powers[:, 0], self.powers[:, 1]
        cu = np.ones(p.shape)
        cv = np.ones(q.shape)
        for t in range(du):
            cu = cu * (p - t)
        for t in range(dv):
            cv = cv * (q - t)
        pu = np.clip(p - du, 0, None)
        pv = np.clip(q - dv, 0, None)
        return (cu * cv)[None, :] * x[:, :1] ** pu[None, :] * x[:, 1:2] ** pv[None, :]

    def __call__(self, points: np.ndarray) -> np.ndarray:
        """Values ``(n, d)`` at ``points: (n, 2)``."""
        return self._monomials(points) @ self.coeffs

    def derivative(self, points: np.ndarray, du: int, dv: int) -> np.ndarray:
        """Partial derivative ``d^(du+dv) / du^du dv^dv``, shape ``(n, d)``."""
        return self._monomials(points, du, dv) @ self.coeffs

    def gradient(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(d/du, d/dv)``, each ``(n, d)``."""
        return self.derivative(points, 1, 0), self.derivative(points, 0, 1)


def random_polynomial(
    degree: int = DEGREE, d: int = 3, seed: int = 0, *, centre: tuple[float, float] = (0.5, 0.5)
) -> Polynomial:
    """A polynomial with standard normal coefficients for every monomial of degree ``<= degree``.

    Returns a callable :class:`Polynomial` mapping ``(n, 2) -> (n, d)``; it also
    has ``.derivative`` and ``.gradient`` for derivative tests.
    """
    if degree < 0:
        raise InputError(f"degree must be >= 0, got {degree}")
    rng = np.random.default_rng(seed)
    powers = np.array([(p, t - p) for t in range(degree + 1) for p in range(t, -1, -1)], dtype=np.int64)
    coeffs = rng.standard_normal((powers.shape[0], d))
    return Polynomial(powers=powers, coeffs=coeffs, centre=np.asarray(centre, dtype=np.float64))
