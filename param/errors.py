"""Errors and warnings of mesh loading, validation and parameterization."""
from __future__ import annotations

from trispline.spline.errors import InputError


class MeshError(InputError):
    """The input mesh cannot be used (unreadable, invalid, or its domain folds).

    ``kinds`` names the problems found (``"non_finite"``, ``"bowtie_vertices"``,
    ``"components"``, ...), so callers and tests can tell them apart without
    parsing the message.
    """

    def __init__(self, message: str, kinds: tuple[str, ...] | list[str] = ()) -> None:
        super().__init__(message)
        self.kinds = tuple(kinds)


class MeshWarning(UserWarning):
    """Something about the mesh was changed on the way in (the message says what)."""


class UnreferencedVerticesWarning(MeshWarning):
    """Vertices used by no face were dropped (the others keep their order)."""


class CoordinatePrecisionWarning(MeshWarning):
    """The file's coordinates are rounded by a noticeable share of the mesh's edges (single precision far from
    the origin): folds and roughness at that scale are the rounding's."""
