"""``SplineSurface``: an immutable quintic triangular spline surface.

    surface = SplineSurface(uv, faces, ctrl)        # (V, 2), (F, 3), (F, 21, 3)
    pts = surface.evaluate(face_idx, bary)          # (n, 3)
    pts = surface.evaluate_uv(points)               # (n, 3), locate + evaluate
    mesh = surface.tessellate(8)                    # watertight, analytic normals
    surface.save("s.npz"); SplineSurface.load("s.npz")
"""
from __future__ import annotations

import os
from collections.abc import Callable
from dataclasses import dataclass, field
from functools import cached_property
from types import MappingProxyType
from typing import Any, Mapping

import numpy as np

from .errors import InputError
from .locate import Locator
from .patches import PatchDerivatives, evaluate, evaluate_derivatives, numeric_continuity
from .serialize import SurfaceFileError, read_surface, validate_surface_arrays, write_surface
from .tessellate import Tessellation, tessellate
from .topology import Triangulation

__all__ = ["SplineSurface"]


def _frozen(a: np.ndarray) -> np.ndarray:
    a = np.array(a, copy=True)
    a.setflags(write=False)
    return a


@dataclass(frozen=True, eq=False, repr=False)
class SplineSurface:
    """A C0/C1 quintic triangular spline surface over a planar triangulation.

    Parameters
    ----------
    uv : (V, 2) float64, domain vertices
    faces : (F, 3) int64, counter-clockwise in uv
    ctrl : (F, 21, 3) float64, control points per patch in storage order
    extras : optional mapping of extra named data (saved as optional file keys)

    The arrays are copied and made read-only; the triangulation is validated.
    """

    uv: np.ndarray
    faces: np.ndarray
    ctrl: np.ndarray
    extras: Mapping[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        uv, faces, ctrl = validate_surface_arrays(self.uv, self.faces, self.ctrl, error=InputError)
        object.__setattr__(self, "uv", _frozen(uv))
        object.__setattr__(self, "faces", _frozen(faces))
        object.__setattr__(self, "ctrl", _frozen(ctrl))
        if not isinstance(self.extras, Mapping):
            raise InputError(f"extras must be a mapping of names to values, got {type(self.extras).__name__}")
        ext = {}
        for k, v in dict(self.extras).items():
            ext[str(k)] = _frozen(v) if isinstance(v, np.ndarray) else v
        object.__setattr__(self, "extras", MappingProxyType(ext))
        _ = self.triangulation  # validate the domain now

    def __repr__(self) -> str:
        lo, hi = self.ctrl.reshape(-1, 3).min(0), self.ctrl.reshape(-1, 3).max(0)
        extra = f", extras={sorted(self.extras)}" if self.extras else ""
        return (f"SplineSurface({self.n_faces} quintic patches over {self.n_vertices} domain vertices, "
                f"bounds {np.round(lo, 4).tolist()}..{np.round(hi, 4).tolist()}{extra})")

    # ------------------------------------------------------------ derived
    @cached_property
    def triangulation(self) -> Triangulation:
        """The validated domain :class:`Triangulation` (cached)."""
        return Triangulation(self.uv, self.faces)

    @cached_property
    def _locator(self) -> Locator:
        return Locator(self.uv, self.faces)

    @property
    def n_faces(self) -> int:
        return int(self.faces.shape[0])

    @property
    def n_vertices(self) -> int:
        return int(self.uv.shape[0])

    # --------------------------------------------------------- evaluation
    def evaluate(self, face_idx: np.ndarray, bary: np.ndarray) -> np.ndarray:
        """Surface points ``(n, 3)`` at ``face_idx (n,)``, ``bary (n, 3)``."""
        return evaluate(self.uv, self.faces, self.ctrl, face_idx, bary)

    def evaluate_derivatives(self, face_idx: np.ndarray, bary: np.ndarray, *, second: bool = False
                             ) -> PatchDerivatives:
        """Values and uv-derivatives ``(n, 3)`` (second derivatives with ``second=True``)."""
        return evaluate_derivatives(self.uv, self.faces, self.ctrl, face_idx, bary, second=second)

    def locate(self, points: np.ndarray, *, strict: bool = True) -> tuple[np.ndarray, np.ndarray]:
        """``face_idx (n,)``, ``bary (n, 3)`` of uv ``points (n, 2)``; see :func:`locate`."""
        return self._locator(points, strict=strict)

    def evaluate_uv(self, points: np.ndarray, *, strict: bool = True) -> np.ndarray:
        """Surface points ``(n, 3)`` at uv ``points (n, 2)``.

        With ``strict=True`` (default) a point outside the domain raises
        :class:`~trispline.spline.locate.OutsideDomainError`; otherwise its row is NaN.
        """
        fi, bary = self._locator(points, strict=strict)
        out = np.full((fi.shape[0], 3), np.nan)
        ok = fi >= 0
        if ok.any():
            out[ok] = evaluate(self.uv, self.faces, self.ctrl, fi[ok], bary[ok])
        return out

    def tessellate(self, resolution: int = 8) -> Tessellation:
        """Watertight triangle mesh with analytic unit normals; see :func:`tessellate`."""
        return tessellate(self.uv, self.faces, self.ctrl, resolution, triangulation=self.triangulation)

    def continuity(self, n_samples: int = 7, report: Callable[[float], None] | None = None) -> dict:
        """Numeric value and gradient jumps across interior edges; see :func:`numeric_continuity`."""
        return numeric_continuity(self.uv, self.faces, self.ctrl, n_samples, report)

    # ------------------------------------------------------------------ I/O
    def save(self, path: str | os.PathLike) -> None:
        """Write the surface file (format v1); ``.npz`` or ``.json`` by the suffix. Atomic."""
        write_surface(path, self.uv, self.faces, self.ctrl, self.extras)

    @classmethod
    def load(cls, path: str | os.PathLike) -> "SplineSurface":
        """Read and validate a surface file (``.npz`` or ``.json``); unknown keys go to ``extras``."""
        uv, faces, ctrl, extras = read_surface(path)
        try:
            return cls(uv, faces, ctrl, extras)
        except InputError as exc:
            raise SurfaceFileError(f"{path}: {exc}") from None
