"""Every exception and warning type of the fit layer (on top of :mod:`trispline.spline.errors`)."""
from __future__ import annotations

import numpy as np

from trispline.spline.errors import InputError, OutputError


class FitError(RuntimeError):
    """The solver did not converge (raised by :func:`fit_surface` unless ``throw=False``): it stopped after
    ``steps`` of at most ``max_steps`` Gauss-Newton steps."""

    def __init__(self, message: str, *, steps: int = 0, max_steps: int = 0) -> None:
        super().__init__(message)
        self.steps = steps
        self.max_steps = max_steps


class FactorMemoryError(InputError):
    """The fit's sparse factorisation would need more memory than is available (refused before it starts)."""

    def __init__(self, message: str, *, estimate: int, available: int) -> None:
        super().__init__(message)
        self.estimate = estimate  # bytes
        self.available = available  # bytes


class NotPositiveDefinite(InputError, np.linalg.LinAlgError):
    """The fit's normal matrix cannot be factored in float64: triangles too thin for the spline's C1
    conditions (a bad input: :func:`~trispline.fit.pipeline.fit_surface` names them)."""


class X64Error(RuntimeError):
    """JAX is not running in float64."""


class ExportFormatError(OutputError):
    """An output file name whose suffix names no format we can write."""


class LargeExportWarning(UserWarning):
    """A mesh export is estimated (before it is written) above
    :data:`~trispline.fit.io.export.LARGE_EXPORT_BYTES`."""


class LossyExportWarning(UserWarning):
    """A mesh format that stores 32-bit floats (STL, GLB) would round the coordinates by a noticeable share of
    the surface's extent: a tile at map (UTM) coordinates (see :func:`trispline.fit.io.formats.check_coordinate_range`)."""


class RenderError(InputError):
    """A bad render request (unknown mode or view, bad size, deviation without a data mesh)."""


class RenderFallbackWarning(UserWarning):
    """PyVista/VTK was not usable; the picture was drawn with matplotlib instead."""


class UsageError(InputError):
    """A bad command line (unknown option, missing argument, invalid value)."""


class CommandFailed(RuntimeError):
    """The command could not finish for a reason that is not a bug (exit 1, one line)."""


class ResultRejected(RuntimeError):
    """The command finished its work but the result misses what was asked (a fit that did not converge within
    its steps): exit 3, one line, nothing written."""
