"""Every exception type of the spline layer; all errors a user can cause derive from :class:`InputError`.

The CLI maps :class:`InputError` to exit code 2 with a one-line message and
everything else to exit code 1. ``trispline.param.errors`` and
``trispline.fit.errors`` add the other layers' types on top of these.
"""
from __future__ import annotations

import numpy as np


class InputError(ValueError):
    """Bad input that the user can fix (mesh, domain, file, option, array shape)."""


class TriangulationError(InputError):
    """The planar domain triangulation is not usable for a spline."""


class OutsideDomainError(InputError):
    """Query points lie outside the uv domain."""


class SurfaceFileError(InputError):
    """A surface file that cannot be read: wrong file, version, keys, shapes or values."""


class OutputError(InputError):
    """An output path that cannot be written (missing folder, a folder, no permission)."""


class ResourceError(InputError):
    """A request whose result would not fit in memory, refused before the work starts."""


class DependentPointError(InputError):
    """The control point is computed by the propagation, not free; see ``controllers``."""

    def __init__(self, message: str, point: int, controllers: np.ndarray) -> None:
        super().__init__(message)
        self.point = point
        self.controllers = controllers


class NotC1Error(InputError):
    """A surface's control net is not in the C1 spline space of its triangulation."""


def first_few(indices: np.ndarray, n: int = 5) -> str:
    """``"3 (first: 1, 7, 9)"`` style summary of offending indices."""
    idx = np.asarray(indices).ravel()
    head = ", ".join(str(int(i)) for i in idx[:n])
    more = ", ..." if idx.size > n else ""
    return f"{idx.size} (first: {head}{more})"
