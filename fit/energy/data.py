"""``data``: extra sample points ``F(face, bary) ~ xyz`` between the vertices.

Residual ``sqrt(weight) (F(face, bary) - xyz) / h`` with ``h^2 = domain area / n_vertices``
(the mean uv area per vertex), so the term is measured like the others however many samples
there are per vertex.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import scipy.sparse as sp

from trispline.spline.bernstein import PRODUCT_MONOMIALS, basis, gram_from_moments, product_monomials
from trispline.spline.checks import as_array, check_bary, check_ids
from trispline.spline.errors import InputError
from trispline.spline.index import NCTRL

from .arrays import Array, array_module

if TYPE_CHECKING:
    from .context import TermContext
    from .normal import NormalParts

__all__ = ["DataPoints", "as_data_points"]

NAME = "data"
LINEAR = True
#: The energy scales like (data size)**2.
SCALE_EXPONENT = 2
#: Samples per chunk of the normal blocks (memory: chunk * 21 * 21 floats).
_CHUNK = 4096


@dataclass(frozen=True)
class DataPoints:
    """Extra samples for the data term: ``F(face[i], bary[i]) ~ xyz[i]``.

    Attributes
    ----------
    face : (n,) int64 patches, bary : (n, 3) barycentric coordinates, xyz : (n, 3) data
    """

    face: np.ndarray
    bary: np.ndarray
    xyz: np.ndarray


def as_data_points(data_points, n_faces: int) -> DataPoints:
    """Validate ``DataPoints`` or a ``(face, bary, xyz)`` tuple against ``n_faces`` patches."""
    if isinstance(data_points, DataPoints):
        face, bary, xyz = data_points.face, data_points.bary, data_points.xyz
    else:
        try:
            face, bary, xyz = data_points
        except (TypeError, ValueError) as exc:
            raise InputError("data_points must be DataPoints or a (face, bary, xyz) tuple") from exc
    face = as_array(face, "data_points face", (None,), integer=True)
    n = face.shape[0]
    if np.shape(bary) != (n, 3) or np.shape(xyz) != (n, 3):
        raise InputError(f"data_points bary and xyz must have shape ({n}, 3), got {np.shape(bary)} and {np.shape(xyz)}")
    check_ids(face, "data_points face", n_faces)
    return DataPoints(face, check_bary(as_array(bary, "data_points bary", (n, 3), finite=True), "data_points bary"),
                      as_array(xyz, "data_points xyz", (n, 3), finite=True))


def setup(ctx: TermContext) -> dict[str, np.ndarray]:
    """``face (s,)``, ``bary (s, 3)``, ``basis (s, 21)``, ``target (s, 3)`` and ``scale (s,)`` of the samples
    (none: empty)."""
    dp = ctx.data_points
    if dp is None:
        return dict(face=np.zeros(0, np.int64), bary=np.zeros((0, 3)), basis=np.zeros((0, NCTRL)),
                    target=np.zeros((0, 3)), scale=np.zeros(0))
    scale = np.full(dp.face.size, np.sqrt(ctx.weights.data * ctx.sample_weight))
    bary = np.asarray(dp.bary, float)
    return dict(face=dp.face, bary=bary, basis=basis(bary), target=dp.xyz, scale=scale)


def residual(ctrl: Array, frames: Array, a: dict) -> Array:
    """``(s, d)`` scaled errors of the surface of ``ctrl (n, 21, d)`` at the samples."""
    xp = array_module(ctrl)
    if xp is np:  # on the host in chunks: ctrl[face] at once is 0.5 GB of fresh memory at 1M samples
        vals = np.empty(a["target"].shape[:1] + ctrl.shape[2:])
        for lo in range(0, vals.shape[0], _CHUNK):
            sl = slice(lo, lo + _CHUNK)
            vals[sl] = np.matmul(a["basis"][sl, None, :], ctrl[a["face"][sl]])[:, 0]
    else:
        vals = xp.einsum("nk,nkc->nc", a["basis"], ctrl[a["face"]])
    return a["scale"][:, None] * (vals - a["target"])


def add_normal(parts: NormalParts, a: dict) -> None:
    """Adds ``s^2 b b^T`` and ``s^2 b xyz^T`` of every sample ``b = basis`` to its patch (each chunk's sums
    per patch as one sparse patch-by-sample product: ``np.add.at`` over the blocks is ~15x slower). The
    ``b b^T`` sums come from the samples' degree-10 moments (:func:`~trispline.spline.bernstein.gram_from_moments`:
    66 sums a sample instead of 441)."""
    moments = np.zeros((parts.blocks.shape[0], PRODUCT_MONOMIALS))
    for lo in range(0, a["face"].size, _CHUNK):
        sl = slice(lo, lo + _CHUNK)
        s2 = a["scale"][sl] ** 2
        faces, owner = np.unique(a["face"][sl], return_inverse=True)
        S = sp.csr_array((np.ones(owner.size), (owner, np.arange(owner.size))), shape=(faces.size, owner.size))
        moments[faces] += ((product_monomials(a["bary"][sl]) * s2) @ S.T).T
        rhs = a["basis"][sl][:, :, None] * (s2[:, None] * a["target"][sl])[:, None, :]
        parts.patch_rhs[faces] += (S @ rhs.reshape(owner.size, -1)).reshape((faces.size,) + rhs.shape[1:])
    touched = np.flatnonzero(moments.any(axis=1))
    parts.blocks[touched] += gram_from_moments(moments[touched])
