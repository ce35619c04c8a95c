"""The normalisation of a planar map, and the domain in the user's own coordinates.

:func:`~trispline.param.parameterize` normalises every map (bounding-box centre at 0,
farthest vertex at distance 1, ``u`` mirrored if it came out clockwise), and the fit works
in that frame. A quintic patch depends on its domain triangle only through barycentric
coordinates, so the spline is the same under any affine map of its domain:
:func:`user_domain` moves a fitted control net back onto the user's own ``uv`` (the mesh's
texture coordinates, a height field's ``(x, y)``), where evaluating at the user's points
gives the surface there, and :meth:`UVTransform.as_extras` stores the normalisation itself.

    uv, faces, ctrl = user_domain(p, ctrl)        # p: the Parameterization the fit used
    SplineSurface(uv, faces, ctrl, extras=p.transform.as_extras())
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Mapping

import numpy as np

from trispline.spline.index import EXPONENTS, index_of

from .errors import MeshError

if TYPE_CHECKING:
    from .parameterize import Parameterization

__all__ = ["UVTransform", "normalise", "reverse_faces", "user_domain", "REVERSED_ORDER"]

#: ``ctrl[:, REVERSED_ORDER]`` is a patch's control net for the face listed backwards:
#: ``b_ijk`` of ``(a, b, c)`` is ``b_ikj`` of ``(a, c, b)`` (the permutation is its own inverse).
REVERSED_ORDER = np.array([index_of(int(i), int(k), int(j)) for i, j, k in EXPONENTS])


@dataclass(frozen=True)
class UVTransform:
    """``raw = uv * scale + centre``: from normalised uv back to the method's raw map.

    ``mirrored`` says the raw map was the method's output with ``u`` negated
    (it came out clockwise); :meth:`to_output` undoes that too.
    """

    centre: np.ndarray
    scale: float
    mirrored: bool = False

    def to_raw(self, uv: np.ndarray) -> np.ndarray:
        """``(n, 2)`` normalised -> raw."""
        return np.asarray(uv) * self.scale + self.centre

    def from_raw(self, raw: np.ndarray) -> np.ndarray:
        """``(n, 2)`` raw -> normalised."""
        return (np.asarray(raw) - self.centre) / self.scale

    def to_output(self, uv: np.ndarray) -> np.ndarray:
        """``(n, 2)`` normalised -> the method's own output (raw, with a mirroring undone)."""
        raw = self.to_raw(uv)
        return raw * np.array([-1.0, 1.0]) if self.mirrored else raw

    def as_extras(self) -> dict[str, np.ndarray]:
        """Optional surface-file keys ``uv_centre (2,)``, ``uv_scale ()``, ``uv_mirrored ()``."""
        return dict(uv_centre=np.asarray(self.centre, np.float64), uv_scale=np.asarray(float(self.scale)),
                    uv_mirrored=np.asarray(bool(self.mirrored)))

    @classmethod
    def from_extras(cls, extras: Mapping[str, Any]) -> "UVTransform | None":
        """The transform stored by :meth:`as_extras`, or None when the keys are absent."""
        if not {"uv_centre", "uv_scale", "uv_mirrored"} <= set(extras):
            return None
        return cls(centre=np.asarray(extras["uv_centre"], np.float64).reshape(2),
                   scale=float(np.asarray(extras["uv_scale"])), mirrored=bool(np.asarray(extras["uv_mirrored"])))


def normalise(raw: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """``(uv (n, 2), centre (2,), scale)``: bounding-box centre to 0, farthest vertex to distance 1."""
    centre = 0.5 * (raw.min(0) + raw.max(0))
    scale = float(np.sqrt(((raw - centre) ** 2).sum(1).max()))
    if not np.isfinite(scale) or scale <= 0:
        raise MeshError("the parameterization collapsed to a point (zero extent)", ["degenerate_map"])
    return (raw - centre) / scale, centre, scale


def reverse_faces(faces: np.ndarray, ctrl: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(faces (nf, 3), ctrl (nf, 21, 3))`` of the same patches with every face listed backwards."""
    return faces[:, [0, 2, 1]], ctrl[:, REVERSED_ORDER]


def user_domain(p: "Parameterization", ctrl: np.ndarray, uv: np.ndarray | None = None
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The fitted net ``ctrl (nf, 21, 3)`` over the normalised domain moved onto the user's domain.

    ``uv (nv, 2)`` is the normalised domain the fit actually used (``space.tri.uv``: the spline
    core may have snapped nearly singular vertices onto exact line crossings); None means
    ``p.uv``. For ``method="uv"`` (unless a fold repair replaced the map) the result is exactly
    the ``uv`` the caller gave (``V[:, :2]`` for a height field) at every vertex the fit did not
    move, and the moved vertices' positions mapped back to the caller's frame; faces are listed
    backwards where that domain is clockwise. For the other methods, which have no user frame,
    it is the normalised domain itself. Returns ``(uv (nv, 2), faces (nf, 3), ctrl (nf, 21, 3))``,
    the same surface: the patch at barycentric coordinates ``b`` is unchanged.
    """
    used = p.uv if uv is None else np.asarray(uv, np.float64)
    if p.method != "uv" or p.repaired is not None or p.source_uv is None:
        return used, p.faces, ctrl
    out = np.array(p.source_uv, np.float64)
    moved = np.flatnonzero((used != p.uv).any(axis=1))
    out[moved] = p.transform.to_output(used[moved])
    faces = p.faces
    if p.transform.mirrored:
        faces, ctrl = reverse_faces(p.faces, ctrl)
    return out, faces, ctrl
