"""Exact conversion of quintic triangular patches into bi-quintic tensor-product Bézier patches.

The centroid ``g`` and the edge midpoints ``m_kl`` split a face ``(v_0, v_1, v_2)`` into
three quads; quad ``k`` sits at corner ``v_k`` (local indices mod 3)::

                 v_2                    quad k, parameters (s, t) in [0, 1]^2:
                /   \\
               /  2  \\                  P01 = m(k, k+2) ---- P11 = g
          m_20 -- g -- m_12                    |                   |
            /     |     \\             t ^    |                   |
           /  0   |   1  \\                  P00 = v_k -------- P10 = m(k, k+1)
        v_0 ---- m_01 ---- v_1                         s ->

(neighbouring quads share a spoke ``m -- g``, all three the centroid; ``(s, t)`` turns
counter-clockwise like the face, so the tensor patch's normal ``S_s x S_t`` points like
the triangle patch's ``F_u x F_v``). The bilinear map ``Q_k(s, t) = sum_pq B_p(s) B_q(t) P_pq`` is affine in
``s`` and in ``t``, so the quintic ``f(Q_k(s, t))`` has bidegree (5, 5): it *is* a
tensor-product Bézier patch, with no approximation. Expanding the polar form ``f`` of the
triangle patch multi-affinely and collecting powers of ``s`` and ``t`` gives its 36
control points::

    P_ij = sum_m  5! / (n00! n01! n10! n11!) / (C(5, i) C(5, j))  f(P00^n00 P01^n01 P10^n10 P11^n11)
    with n11 = m, n10 = i - m, n01 = j - m, n00 = 5 - i - j + m.

The weights depend only on the quads' barycentric corners, the same for every face, so
the conversion is one fixed matrix applied to all patches. Its rational entries are
computed exactly (integers, one correctly rounded division each).

Shared points are computed once. Of the 108 slots of a face, 91 are distinct: 3 corner
points ``f(v^5)``, 9 points strictly inside each domain edge (``f(a^(5-p) m^p)``,
``f(m^5)``, ``f(m^p b^(5-p))``) and 61 points of the face itself (the spokes and the
quads' insides). :func:`tensor_net` computes each vertex's, edge's and face's points once
(an edge from one of its faces, in the direction ``a -> b`` of ``Triangulation.edges``)
and gathers them into the patches, so neighbouring quads carry bit-identical boundary rows.
"""
from __future__ import annotations

from dataclasses import dataclass
from fractions import Fraction
from functools import lru_cache
from itertools import product
from math import comb, factorial, prod

import numpy as np

from .checks import as_array
from .index import DEGREE, NCTRL, index_of
from .topology import Triangulation
from .util import gather as _gather, parallel as _parallel

__all__ = ["QUAD_CORNERS", "EDGE_POINTS", "FACE_POINTS", "TensorNet", "quad_bary", "tensor_net"]

#: ``(3, 2, 2, 3)`` barycentric coordinates of corner ``P_pq`` of quad ``k``: ``[k, p, q]``.
QUAD_CORNERS: np.ndarray = np.array(
    [[[np.eye(3)[k], (np.eye(3)[k] + np.eye(3)[(k + 2) % 3]) / 2],
      [(np.eye(3)[k] + np.eye(3)[(k + 1) % 3]) / 2, np.full(3, 1 / 3)]] for k in range(3)]
)
QUAD_CORNERS.setflags(write=False)
#: Points strictly inside a domain edge (positions 1..9 of 11, the midpoint at 5).
EDGE_POINTS = 2 * DEGREE - 1
#: Points of a face that no other face shares (spokes, centroid, quad insides).
FACE_POINTS = 61
#: Faces per range of the threaded transposes and id tables (keeps a range's rows in cache).
FACE_CHUNK = 1 << 13
#: Smallest range of faces a thread takes (below, thread hand-offs cost more than they save).
FACE_CHUNK_MIN = 1 << 10
_CORNER_INDEX = np.array([index_of(*(DEGREE * np.eye(3, dtype=np.int64)[k])) for k in range(3)])
_SIXTHS = 6  # quad corners have barycentric coordinates in {0, 1/3, 1/2, 1}: integers times 1/6


def quad_bary(st: np.ndarray) -> np.ndarray:
    """Barycentric coordinates ``(3, n, 3)`` in the face of the points ``st (n, 2)`` of each quad."""
    st = as_array(st, "st", (None, 2))
    s, t = st[:, :1], st[:, 1:]
    c = QUAD_CORNERS
    return ((1 - s) * (1 - t) * c[:, None, 0, 0] + s * (1 - t) * c[:, None, 1, 0]
            + (1 - s) * t * c[:, None, 0, 1] + s * t * c[:, None, 1, 1])


def _blossom(points: tuple[tuple[int, int, int], ...]) -> list[int]:
    """``6^5`` times the polar form ``f(x_1, ..., x_5)`` as integer weights of the 21 control points.

    ``points`` are the five arguments in sixths of barycentric coordinates. The polar form
    of ``sum b_ijk 5!/(i!j!k!) l^ijk`` is ``sum_sigma prod_m x_m[sigma(m)] b_(counts of sigma)``
    over all maps ``sigma`` of the five arguments to the three corners: the coefficients of
    the product of the linear forms ``x_m . (A, B, C)``.
    """
    poly = {(0, 0, 0): 1}
    for x in points:
        nxt: dict[tuple[int, int, int], int] = {}
        for e, w in poly.items():
            for c in range(3):
                if x[c]:
                    key = tuple(e[d] + (d == c) for d in range(3))
                    nxt[key] = nxt.get(key, 0) + w * x[c]
        poly = nxt
    out = [0] * NCTRL
    for (i, j, k), w in poly.items():
        out[index_of(i, j, k)] = w
    return out


def _quad_row(k: int, i: int, j: int) -> tuple[Fraction, ...]:
    """Exact weights of the 21 control points in ``P_ij`` of quad ``k`` (module docstring formula)."""
    corner = [[tuple(int(round(_SIXTHS * x)) for x in QUAD_CORNERS[k, p, q]) for q in range(2)] for p in range(2)]
    num = [0] * NCTRL
    for m in range(max(0, i + j - DEGREE), min(i, j) + 1):
        n = {(1, 1): m, (1, 0): i - m, (0, 1): j - m, (0, 0): DEGREE - i - j + m}
        args = tuple(corner[p][q] for (p, q), c in sorted(n.items()) for _ in range(c))
        mult = factorial(DEGREE) // prod(factorial(c) for c in n.values())
        for r, w in enumerate(_blossom(args)):
            num[r] += mult * w
    den = comb(DEGREE, i) * comb(DEGREE, j) * _SIXTHS**DEGREE
    return tuple(Fraction(x, den) for x in num)


@dataclass(frozen=True)
class _Tables:
    """The face-independent tables of the conversion (see :func:`_tables`)."""

    face_weights: np.ndarray  # (61, 21) the face's own points from its control points
    edge_weights: np.ndarray  # (9, 6) points inside an edge from its 6 control points, a -> b
    edge_ctrl: np.ndarray  # (3, 6) storage indices of the edge opposite local k, from k+1 to k+2
    slot_kind: np.ndarray  # (3, 6, 6) per quad slot: 0 corner, 1 edge, 2 face point
    slot_local: np.ndarray  # (3, 6, 6) local vertex k / edge k / face point r
    slot_pos: np.ndarray  # (3, 6, 6) position 1..9 along the edge (k+1 -> k+2); 0 otherwise


def _edge_position(row: tuple[Fraction, ...], k: int, edge_ctrl: np.ndarray) -> tuple[int, ...] | None:
    """``row``'s weights on the edge opposite local ``k`` (``None`` if it uses other points)."""
    support = {r for r, w in enumerate(row) if w}
    if not support <= set(edge_ctrl[k].tolist()):
        return None
    return tuple(row[r] for r in edge_ctrl[k])


@lru_cache(maxsize=1)
def _tables() -> _Tables:
    """Classify the 108 slots of a face into corners, edge points and face points; exact weights."""
    edge_ctrl = np.array([[index_of(*[(DEGREE - p) * (d == (k + 1) % 3) + p * (d == (k + 2) % 3)
                                      for d in range(3)]) for p in range(DEGREE + 1)] for k in range(3)])
    # the 9 points inside the edge opposite local 0, from v_1 to v_2: quad 1's row t = 0 (v_1 -> m_12),
    # then quad 2's row s = 0 backwards (m_12 -> v_2)
    along = ([_quad_row(1, i, 0) for i in range(1, DEGREE + 1)]
             + [_quad_row(2, 0, j) for j in range(DEGREE - 1, 0, -1)])
    ref = {_edge_position(r, 0, edge_ctrl): p + 1 for p, r in enumerate(along)}
    kind, local, pos = (np.zeros((3, DEGREE + 1, DEGREE + 1), np.int64) for _ in range(3))
    face_rows: dict[tuple[Fraction, ...], int] = {}
    for k, i, j in product(range(3), range(DEGREE + 1), range(DEGREE + 1)):
        row = _quad_row(k, i, j)
        corner = [c for c in range(3) if row[_CORNER_INDEX[c]] == 1]  # weights are >= 0 and sum to 1
        on_edge = [(e, _edge_position(row, e, edge_ctrl)) for e in range(3)]
        on_edge = [(e, w) for e, w in on_edge if w is not None and w in ref]
        if corner:
            kind[k, i, j], local[k, i, j] = 0, corner[0]
        elif on_edge:
            kind[k, i, j], local[k, i, j], pos[k, i, j] = 1, on_edge[0][0], ref[on_edge[0][1]]
        else:
            kind[k, i, j], local[k, i, j] = 2, face_rows.setdefault(row, len(face_rows))
    if len(face_rows) != FACE_POINTS or len(ref) != EDGE_POINTS:  # pragma: no cover - a broken table
        raise AssertionError(f"expected {FACE_POINTS} face and {EDGE_POINTS} edge points, "
                             f"got {len(face_rows)} and {len(ref)}")
    face_weights = np.array([[float(w) for w in r] for r in face_rows])
    edge_weights = np.array([[float(w) for w in key] for key, _ in sorted(ref.items(), key=lambda kv: kv[1])])
    for a in (face_weights, edge_weights, edge_ctrl, kind, local, pos):
        a.setflags(write=False)
    return _Tables(face_weights, edge_weights, edge_ctrl, kind, local, pos)


@dataclass(frozen=True, eq=False)
class TensorNet:
    """The bi-quintic tensor-product patches of a triangular spline, on one shared point list.

    ``patches[3 f + k, i, j]`` is the id in ``points`` of control point ``P_ij`` (``i`` along
    ``s``, ``j`` along ``t``) of quad ``k`` of face ``f``. Ids come in blocks: vertex ``v``'s
    corner point is ``v``; point ``p`` (1..9) inside edge ``e``, counted from ``edges[e, 0]``,
    is ``V + (p - 1) E + e``; face ``f``'s own point ``r`` is ``V + 9 E + r F + f``. A point
    that several quads share is stored once, so their common boundary rows are identical.

    Attributes
    ----------
    points : (V + 9 E + 61 F, 3) float64
    patches : (3 F, 6, 6) int64
    n_vertices, n_edges, n_faces : int
    """

    points: np.ndarray
    patches: np.ndarray
    n_vertices: int
    n_edges: int
    n_faces: int

    @property
    def n_patches(self) -> int:
        return int(self.patches.shape[0])

    def patch_points(self) -> np.ndarray:
        """Control points ``(3 F, 6, 6, d)`` of every tensor patch (a gather of ``points``)."""
        return _gather.rows(self.points, self.patches)


def _slot_ids(tri: Triangulation, ids: np.ndarray, lo: int, hi: int) -> None:
    """Fill ``ids[lo:hi]`` (faces ``lo..hi`` of ``(F, 108)``) with the point id of every quad slot."""
    tb = _tables()
    nv, ne, nf = tri.n_vertices, tri.n_edges, tri.n_faces
    kind, local, pos = (a.reshape(-1) for a in (tb.slot_kind, tb.slot_local, tb.slot_pos))
    own = np.flatnonzero(kind == 2)
    ids[lo:hi, own] = (nv + EDGE_POINTS * ne) + local[own] * nf + np.arange(lo, hi)[:, None]
    fv, fe = tri.faces[lo:hi], tri.face_edges[lo:hi]
    for k in range(3):
        ids[lo:hi, np.flatnonzero((kind == 0) & (local == k))] = fv[:, k:k + 1]
        on = np.flatnonzero((kind == 1) & (local == k))
        # the face runs the edge opposite local k from local k+1 to local k+2: forward iff that is a -> b
        forward = fv[:, (k + 1) % 3, None] < fv[:, (k + 2) % 3, None]
        ids[lo:hi, on] = nv + fe[:, k:k + 1] + ne * np.where(forward, pos[on] - 1, 2 * DEGREE - 1 - pos[on])


def _edge_sources(tri: Triangulation) -> tuple[np.ndarray, np.ndarray]:
    """Where every edge's 6 control points are read: ``face (E,)`` and storage indices
    ``(E, 6)`` from ``edges[e, 0]`` to ``edges[e, 1]``, in the face ``edge_faces[e, 0]``
    (it runs the edge ``a -> b``) or, on a boundary edge without it, ``edge_faces[e, 1]``."""
    tb = _tables()
    ef, eo = tri.edge_faces, tri.edge_opposite
    first = ef[:, 0] >= 0
    opp = np.where(first, eo[:, 0], eo[:, 1])
    order = np.where(first[:, None], tb.edge_ctrl[opp], tb.edge_ctrl[opp][:, ::-1])
    return np.where(first, ef[:, 0], ef[:, 1]), order


def tensor_net(uv: np.ndarray, faces: np.ndarray, ctrl: np.ndarray, *,
               triangulation: Triangulation | None = None) -> TensorNet:
    """Convert every quintic triangular patch exactly into three bi-quintic tensor patches.

    Parameters
    ----------
    uv : (V, 2), faces : (F, 3), ctrl : (F, 21, d) control points in storage order
    triangulation : the :class:`Triangulation` of ``uv, faces`` if already built

    Returns
    -------
    TensorNet
        ``3 F`` patches of ``6 x 6`` control points; points shared by neighbouring quads
        are computed once (an edge's from one face, see :func:`_edge_sources`; a vertex's
        from its lowest corner), so shared boundary rows are bit-identical.

    Faces and edges are converted in ranges, a thread per core, each range one BLAS
    product (on one BLAS thread) into its columns of the point blocks.
    """
    tri = Triangulation(uv, faces) if triangulation is None else triangulation
    nv, ne, nf = tri.n_vertices, tri.n_edges, tri.n_faces
    ctrl = as_array(ctrl, "ctrl", (nf, NCTRL, None))
    d, tb = ctrl.shape[2], _tables()
    points = np.empty((nv + EDGE_POINTS * ne + FACE_POINTS * nf, d))
    edge_block = points[nv:nv + EDGE_POINTS * ne].reshape(EDGE_POINTS, ne * d)
    face_block = points[nv + EDGE_POINTS * ne:].reshape(FACE_POINTS, nf * d)
    ids = np.empty((nf, 3 * (DEGREE + 1) ** 2), np.int64)
    flat = ctrl.reshape(nf * NCTRL, d)
    src, order = _edge_sources(tri)

    def faces_range(lo: int, hi: int) -> None:
        by_index = ctrl[lo:hi].transpose(1, 0, 2).reshape(NCTRL, -1)  # (21, n d), a copy
        face_block[:, lo * d:hi * d] = tb.face_weights @ by_index
        _slot_ids(tri, ids, lo, hi)

    def edges_range(lo: int, hi: int) -> None:
        edge_ctrl = _gather.rows(flat, NCTRL * src[None, lo:hi] + order[lo:hi].T)  # (6, n, d)
        edge_block[:, lo * d:hi * d] = tb.edge_weights @ edge_ctrl.reshape(DEGREE + 1, -1)

    # BLAS on one thread per call, threads or not: each product is one range's (measured 3x
    # faster inline at 10k faces on a busy 2-core machine than letting BLAS spawn threads)
    chunk = min(FACE_CHUNK, max(FACE_CHUNK_MIN, -(-nf // 4)))  # several ranges a thread from 2 chunks up
    with _parallel.single_threaded_blas(), _parallel.Workers(nf, parallel_min=2 * FACE_CHUNK_MIN) as work:
        pending = work.start(edges_range, ne, chunk)
        work.map(faces_range, nf, chunk)
        for task in pending:
            task.result()
    vc = tri.vertex_corner  # corner 3 f + k: the control point f(v_k^5) of face f
    points[:nv] = _gather.rows(flat, NCTRL * (vc // 3) + _CORNER_INDEX[vc % 3])
    return TensorNet(points, ids.reshape(3 * nf, DEGREE + 1, DEGREE + 1), nv, ne, nf)
