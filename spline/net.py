"""The global control net: ``V + 4E + 6F`` shared points and their gather per patch.

Global point ids (``E`` edges with ``edges[e] = (a, b)``, ``a < b``):

=========================  ===================================  =====================
class                      polar label                          id
=========================  ===================================  =====================
corner of vertex ``v``     ``f(v^5)``                           ``v``
star point                 ``f(a^4 b)`` / ``f(b^4 a)``          ``V + 2e + 0 / 1``
middle edge point          ``f(a^3 b^2)`` / ``f(a^2 b^3)``      ``V + 2E + 2e + 0 / 1``
near-corner inner point    ``f(v_k^3 ...)`` of face ``f``       ``V + 4E + 3f + k``
flip point                 edge opposite local ``k`` of ``f``   ``V + 4E + 3F + 3f + k``
=========================  ===================================  =====================

"End" ``0`` of an edge is its smaller vertex ``a``, end ``1`` is ``b``.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .util import memory as _memory
from .index import CORNER, FLIP, INNER, MID, NCTRL, STAR
from .topology import Triangulation


@dataclass(frozen=True)
class NetLayout:
    """Offsets of the point classes in the global net."""

    n_vertices: int
    n_edges: int
    n_faces: int

    @property
    def star0(self) -> int:
        return self.n_vertices

    @property
    def mid0(self) -> int:
        return self.n_vertices + 2 * self.n_edges

    @property
    def inner0(self) -> int:
        return self.n_vertices + 4 * self.n_edges

    @property
    def flip0(self) -> int:
        return self.n_vertices + 4 * self.n_edges + 3 * self.n_faces

    @property
    def n_points(self) -> int:
        return self.n_vertices + 4 * self.n_edges + 6 * self.n_faces

    def star(self, e: np.ndarray, end: np.ndarray) -> np.ndarray:
        return self.star0 + 2 * e + end

    def mid(self, e: np.ndarray, end: np.ndarray) -> np.ndarray:
        """Middle point of edge ``e`` nearer its end ``end`` (``f(end^3 other^2)``)."""
        return self.mid0 + 2 * e + end

    def inner(self, f: np.ndarray, k: np.ndarray) -> np.ndarray:
        return self.inner0 + 3 * f + k

    def flip(self, f: np.ndarray, k: np.ndarray) -> np.ndarray:
        return self.flip0 + 3 * f + k


def layout_of(tri: Triangulation) -> NetLayout:
    return NetLayout(tri.n_vertices, tri.n_edges, tri.n_faces)


def point_index(tri: Triangulation) -> np.ndarray:
    """Global point id of each patch control point: ``(F, 21)``, storage order.

    int32 while the net has fewer than 2**31 points (halves its memory at 1M faces), else int64.
    """
    lay = layout_of(tri)
    F = tri.faces
    nf = tri.n_faces
    fe = tri.face_edges
    f = np.arange(nf)
    out = np.empty((nf, NCTRL), _memory.index_dtype(lay.n_points))
    for k in range(3):
        out[:, CORNER[k]] = F[:, k]
        out[:, INNER[k]] = lay.inner(f, k)
        out[:, FLIP[k]] = lay.flip(f, k)
        for m in range(3):
            if m == k:
                continue
            e = fe[:, 3 - k - m]  # edge opposite the third vertex joins k and m
            end = (F[:, k] > F[:, m]).astype(np.int64)  # end index of vertex k on that edge
            out[:, STAR[k, m]] = lay.star(e, end)
            out[:, MID[k, m]] = lay.mid(e, end)
    return out
