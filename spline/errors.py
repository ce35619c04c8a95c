"""Exception types. Every error a user can cause derives from :class:`InputError`.

The CLI maps :class:`InputError` to exit code 2 with a one-line message and
everything else to exit code 1.
"""
from __future__ import annotations

import numpy as np


class InputError(ValueError):
    """Bad input that the user can fix (mesh, domain, file, option)."""


class TriangulationError(InputError):
    """The planar domain triangulation is not usable for a spline."""


def first_few(indices: np.ndarray, n: int = 5) -> str:
    """``"3 (first: 1, 7, 9)"`` style summary of offending indices."""
    idx = np.asarray(indices).ravel()
    head = ", ".join(str(int(i)) for i in idx[:n])
    more = ", ..." if idx.size > n else ""
    return f"{idx.size} (first: {head}{more})"
