"""Index tables for quintic triangular Bézier patches (docs/design.md §1).

A face ``(a, b, c)`` carries 21 control points ``b_ijk = f(a^i b^j c^k)``,
``i + j + k = 5``, stored with ``i`` descending, then ``j`` descending. Over the domain, point ``b_ijk``
sits at ``(i a + j b + k c) / 5``; the rows below are lines parallel to edge ``bc``::

    row i=5:  0:(5,0,0)
    row i=4:  1:(4,1,0)  2:(4,0,1)
    row i=3:  3:(3,2,0)  4:(3,1,1)  5:(3,0,2)
    row i=2:  6:(2,3,0)  7:(2,2,1)  8:(2,1,2)  9:(2,0,3)
    row i=1: 10:(1,4,0) 11:(1,3,1) 12:(1,2,2) 13:(1,1,3) 14:(1,0,4)
    row i=0: 15:(0,5,0) 16:(0,4,1) 17:(0,3,2) 18:(0,2,3) 19:(0,1,4) 20:(0,0,5)

Everything in the project uses this order; the tables below are the single
source for it.
"""
from __future__ import annotations

from functools import lru_cache

import numpy as np

DEGREE = 5
NCTRL = 21


@lru_cache(maxsize=32)
def lattice(r: int) -> np.ndarray:
    """``(n, 3)`` int64 lattice points ``(i, j, k)``, ``i + j + k = r``, in storage order.

    ``n = (r + 1)(r + 2) / 2``; ``i`` descending, then ``j`` descending. For ``r = 5`` these
    are the control points' exponents (:data:`EXPONENTS`); ``lattice(r) / r`` are the
    barycentric coordinates of the regular sample grid with ``r`` steps per edge.
    """
    r = int(r)
    if r < 1:
        raise ValueError(f"the lattice needs r >= 1, got {r}")
    out = np.array([(i, j, r - i - j) for i in range(r, -1, -1) for j in range(r - i, -1, -1)], np.int64)
    out.setflags(write=False)
    return out


def _lattice_id(i: int, j: int, r: int) -> int:
    """Position of ``(i, j, r - i - j)`` in :func:`lattice`: rows of ``i`` come in blocks."""
    return (r - i) * (r - i + 1) // 2 + (r - i - j)


@lru_cache(maxsize=32)
def lattice_triangles(r: int) -> np.ndarray:
    """``(r^2, 3)`` int64 triangles of the lattice (indices into :func:`lattice`), counter-clockwise.

    Oriented like the face ``(a, b, c)``: the "upward" triangle at ``(i, j, k)`` is
    ``(i, j, k), (i-1, j+1, k), (i-1, j, k+1)``; between two of them sits the "downward"
    ``(i-1, j+1, k), (i-2, j+1, k+1), (i-1, j, k+1)``.
    """
    r = int(r)
    lattice(r)  # validates r
    tris = []
    for i in range(r, 0, -1):
        for j in range(r - i + 1):
            tris.append((_lattice_id(i, j, r), _lattice_id(i - 1, j + 1, r), _lattice_id(i - 1, j, r)))
            if i >= 2:
                tris.append((_lattice_id(i - 1, j + 1, r), _lattice_id(i - 2, j + 1, r), _lattice_id(i - 1, j, r)))
    out = np.array(tris, np.int64)
    out.setflags(write=False)
    return out


@lru_cache(maxsize=32)
def lattice_edges(r: int) -> np.ndarray:
    """``(3 r (r + 1) / 2, 2)`` int64 unique edges of :func:`lattice_triangles`, sorted."""
    t = lattice_triangles(r)
    e = np.sort(np.concatenate([t[:, [0, 1]], t[:, [1, 2]], t[:, [2, 0]]]), axis=1)
    out = np.unique(e, axis=0)
    out.setflags(write=False)
    return out


#: (21, 3) exponents (i, j, k) of the storage order.
EXPONENTS: np.ndarray = lattice(DEGREE)
_LOOKUP = {tuple(int(x) for x in e): n for n, e in enumerate(EXPONENTS)}


def index_of(i: int, j: int, k: int) -> int:
    """Storage index of ``b_ijk`` (``i + j + k = 5``)."""
    return _LOOKUP[(i, j, k)]


def local_index(powers: dict[int, int]) -> int:
    """Storage index of the point whose local-vertex powers are ``powers``.

    ``powers`` maps local vertex ``0, 1, 2`` to its exponent, e.g.
    ``{0: 3, 2: 2}`` is ``f(a^3 c^2)``.
    """
    e = [powers.get(0, 0), powers.get(1, 0), powers.get(2, 0)]
    if sum(e) != DEGREE:
        raise ValueError(f"exponents {e} do not sum to {DEGREE}")
    return _LOOKUP[tuple(e)]


# Per local vertex k = 0, 1, 2 (the corner) -- storage indices.
#: corner point f(v^5) of local vertex k: (3,)
CORNER = np.array([local_index({k: 5}) for k in range(3)])
#: star point f(v_k^4 v_m) for local vertex k toward local vertex m: (3, 3), -1 on diagonal
STAR = np.array([[local_index({k: 4, m: 1}) if m != k else -1 for m in range(3)] for k in range(3)])
#: middle edge point f(v_k^3 v_m^2) (nearer k): (3, 3), -1 on diagonal
MID = np.array([[local_index({k: 3, m: 2}) if m != k else -1 for m in range(3)] for k in range(3)])
#: near-corner inner point f(v_k^3 v_m v_n) of local vertex k: (3,)
INNER = np.array([local_index({k: 3, (k + 1) % 3: 1, (k + 2) % 3: 1}) for k in range(3)])
#: flip point of the edge opposite local vertex k: f(v_m^2 v_n^2 v_k): (3,)
FLIP = np.array([local_index({k: 1, (k + 1) % 3: 2, (k + 2) % 3: 2}) for k in range(3)])
