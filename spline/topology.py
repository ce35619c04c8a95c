"""The planar domain triangulation: edges, adjacency, vertex fans, boundary loops.

Everything is derived once, vectorised, from ``uv: (nv, 2)`` and
``faces: (nf, 3)``. Faces must be counter-clockwise with positive uv area.

Conventions
-----------
* Edge ``e`` joins ``edges[e] = (a, b)`` with ``a < b``.
* ``face_edges[f, k]`` is the edge opposite local vertex ``k`` of face ``f``,
  i.e. the edge joining local vertices ``(k + 1) % 3`` and ``(k + 2) % 3``.
* ``edge_faces[e] = (f0, f1)``: ``f0`` is the face in which the edge is
  traversed ``a -> b`` (the face on the left of ``a -> b``), ``f1`` the face
  traversing ``b -> a``; ``-1`` where absent (boundary edge).
* ``edge_opposite[e] = (k0, k1)``: local index, in ``f0`` / ``f1``, of the vertex
  opposite the edge.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from .checks import as_array, check_ids
from .errors import TriangulationError, first_few
from .tolerances import MIN_RELATIVE_AREA
from .util import gather as _gather, parallel as _parallel


def halfedges(F: np.ndarray) -> np.ndarray:
    """Directed half-edges ``(3 nf, 2)``: row ``3 f + k`` runs ``F[f, k+1] -> F[f, k+2]``
    (the half-edge opposite local vertex ``k``)."""
    return np.stack([F[:, [1, 2, 0]], F[:, [2, 0, 1]]], axis=-1).reshape(-1, 2)


def mean_edge_lengths(points: np.ndarray, F: np.ndarray) -> np.ndarray:
    """``(nv,)`` the mean length of the face edges at each vertex of ``points (nv, d)`` (an interior
    edge counted once from each of its two faces); 0 at a vertex of no face."""
    e = np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]])
    length = np.linalg.norm(points[e[:, 0]] - points[e[:, 1]], axis=1)
    return np.bincount(e.ravel(), np.repeat(length, 2), minlength=len(points)) / np.maximum(
        np.bincount(e.ravel(), minlength=len(points)), 1)


def undirected_edges(F: np.ndarray, nv: int, *, he: np.ndarray | None = None
                     ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Half-edges and the undirected edges they lie on, for any ``F (nf, 3)`` with ids in ``[0, nv)``.

    Returns ``he (3 nf, 2)`` (:func:`halfedges`, or the one given), ``edges (ne, 2)`` with
    ``a <= b`` in ascending order, ``he_edge (3 nf,)`` the edge of each half-edge and
    ``edge_count (ne,)`` the number of half-edges on each edge (1 on the boundary, 2
    inside, more on a non-manifold edge). A face with a repeated vertex id yields edges ``(a, a)``.
    """
    he = halfedges(F) if he is None else he
    key = np.minimum(he[:, 0], he[:, 1]) * nv + np.maximum(he[:, 0], he[:, 1])
    uniq, inv, cnt = np.unique(key, return_inverse=True, return_counts=True)
    edges = np.column_stack([uniq // nv, uniq % nv])
    return he, edges, inv.ravel(), cnt


def outline_vertex_mask(F: np.ndarray, nv: int, *, tables: tuple | None = None) -> np.ndarray:
    """``(nv,)`` bool: the vertices on a boundary edge (an edge of one face) of ``F (nf, 3)``.

    ``tables``: ``(he, he_edge, edge_count)`` of :func:`undirected_edges` of ``F``, when known.
    """
    if tables is None:
        he, _, he_edge, count = undirected_edges(np.asarray(F, np.int64), nv)
    else:
        he, he_edge, count = tables
    on = np.zeros(nv, bool)
    on[he[count[he_edge] == 1].ravel()] = True
    return on


def triangle_areas(a: np.ndarray, b: np.ndarray, c: np.ndarray) -> np.ndarray:
    """Signed areas ``(n,)`` of the triangles ``(a, b, c)``, each ``(n, 2)``; positive counter-clockwise."""
    return 0.5 * ((b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0]))


def signed_areas(uv: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Signed uv areas ``(nf,)`` of ``faces: (nf, 3)`` over ``uv: (nv, 2)``, positive for counter-clockwise faces."""
    return triangle_areas(*(_gather.rows(uv, faces[:, k]) for k in range(3)))


def face_bary_gradients(uv: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """uv-gradient of each barycentric coordinate of each face, ``(nf, 3, 2)``.

    ``grad l_k = rot90(edge opposite k, traversed counter-clockwise) / (2 area)``; needs no
    topology (:attr:`Triangulation.bary_gradients` caches it for a triangulation).
    """
    uv = np.asarray(uv, dtype=np.float64)
    faces = np.asarray(faces)
    t = _gather.rows(uv, faces)  # (F, 3, 2)
    e = t[:, [2, 0, 1]] - t[:, [1, 2, 0]]  # edge opposite k, traversed CCW
    twice = 2.0 * signed_areas(uv, faces)
    return np.stack([-e[..., 1], e[..., 0]], axis=-1) / twice[:, None, None]


@dataclass(frozen=True, eq=False)
class Triangulation:
    """A validated planar triangulation (immutable; derived tables are cached).

    Parameters
    ----------
    uv : (nv, 2) float64
    faces : (nf, 3) int64, counter-clockwise in uv
    """

    uv: np.ndarray
    faces: np.ndarray

    def __post_init__(self) -> None:
        err = TriangulationError
        uv = np.ascontiguousarray(as_array(self.uv, "uv", ("nv", 2), finite=True, error=err))
        faces = as_array(self.faces, "faces", ("nf", 3), integer=True, whole_floats=False, min_rows=1, error=err)
        faces = np.ascontiguousarray(check_ids(faces, "faces", uv.shape[0], error=err))
        object.__setattr__(self, "uv", uv)
        object.__setattr__(self, "faces", faces)
        uv.setflags(write=False)
        faces.setflags(write=False)
        self._validate()

    # ------------------------------------------------------------------ checks
    def _validate(self) -> None:
        uv, faces = self.uv, self.faces
        nv = uv.shape[0]
        bad = np.flatnonzero(
            (faces[:, 0] == faces[:, 1]) | (faces[:, 1] == faces[:, 2]) | (faces[:, 0] == faces[:, 2])
        )
        if bad.size:
            raise TriangulationError(f"faces with a repeated vertex id: {first_few(bad)}")
        used = np.zeros(nv, bool)
        used[faces.ravel()] = True
        if not used.all():
            raise TriangulationError(
                f"vertices not used by any face: {first_few(np.flatnonzero(~used))}; "
                "drop unreferenced vertices first"
            )
        area = signed_areas(uv, faces)
        scale = np.abs(area).mean()
        bad = np.flatnonzero(area <= MIN_RELATIVE_AREA * max(scale, np.finfo(float).tiny))
        if bad.size:
            neg = np.flatnonzero(area < 0)
            raise TriangulationError(
                f"faces that are not counter-clockwise with positive uv area: {first_few(bad)} "
                f"({neg.size} flipped, {bad.size - neg.size} degenerate); the domain folds"
            )
        # Directed half-edges must be unique (edge-manifold and consistently oriented):
        # an undirected edge traversed twice in the same direction (the edge tables'
        # sort serves this check too; a third face on an edge always repeats a direction)
        he = self._halfedges
        _, face_edges, _, _ = self._edge_tables
        directed = 2 * face_edges.reshape(-1) + (he[:, 0] > he[:, 1])
        uses = np.bincount(directed, minlength=2 * self.n_edges)
        if (uses > 1).any():
            faces_bad = np.unique(np.flatnonzero(uses[directed] > 1) // 3)
            raise TriangulationError(
                "non-manifold or inconsistently oriented edges (a directed edge used twice) "
                f"in faces {first_few(faces_bad)}"
            )
        fan_count = self._fan_counts
        bad = np.flatnonzero(fan_count > 1)
        if bad.size:
            raise TriangulationError(f"non-manifold (bowtie) vertices: {first_few(bad)}")
        # the half-edge and next-corner tables serve only the edge tables, this check and the
        # fans: drop them now (72 MB at 1M faces; recomputed if ever asked for again)
        for name in ("_halfedges", "_corner_next"):
            self.__dict__.pop(name, None)

    # --------------------------------------------------------------- basic sizes
    @property
    def n_vertices(self) -> int:
        return int(self.uv.shape[0])

    @property
    def n_faces(self) -> int:
        return int(self.faces.shape[0])

    @property
    def n_edges(self) -> int:
        return int(self.edges.shape[0])

    # ------------------------------------------------------------------- edges
    @cached_property
    def _halfedges(self) -> np.ndarray:
        """(3 nf, 2) directed half-edges; half-edge ``3 f + k`` is opposite local vertex k."""
        return halfedges(self.faces)

    @cached_property
    def _edge_tables(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        he, edges, inv, _ = undirected_edges(self.faces, self.n_vertices, he=self._halfedges)
        edges = edges.astype(np.int64, copy=False)
        face_edges = inv.reshape(-1, 3).astype(np.int64, copy=False)
        ne = edges.shape[0]
        edge_faces = np.full((ne, 2), -1, np.int64)
        edge_opp = np.full((ne, 2), -1, np.int64)
        # slot (edge, side) of every half-edge; side 0: traversed a->b (a < b). Flat scatters:
        # numpy's two-array fancy assignment is ~2x slower
        slot = 2 * inv + (he[:, 0] > he[:, 1])
        face_of, k_of = np.divmod(np.arange(he.shape[0]), 3)
        edge_faces.reshape(-1)[slot] = face_of
        edge_opp.reshape(-1)[slot] = k_of
        return edges, face_edges, edge_faces, edge_opp

    @property
    def edges(self) -> np.ndarray:
        """(E, 2) int64, ``a < b``."""
        return self._edge_tables[0]

    @property
    def face_edges(self) -> np.ndarray:
        """(F, 3) edge opposite each local vertex."""
        return self._edge_tables[1]

    @property
    def edge_faces(self) -> np.ndarray:
        """(E, 2) faces on the left of ``a->b`` and of ``b->a``; -1 where absent."""
        return self._edge_tables[2]

    @property
    def edge_opposite(self) -> np.ndarray:
        """(E, 2) local index of the vertex opposite the edge in each face; -1 where absent."""
        return self._edge_tables[3]

    @cached_property
    def boundary_edge_mask(self) -> np.ndarray:
        """(E,) bool."""
        return (self.edge_faces < 0).any(1)

    @cached_property
    def interior_edges(self) -> np.ndarray:
        return np.flatnonzero(~self.boundary_edge_mask)

    @cached_property
    def boundary_edges(self) -> np.ndarray:
        return np.flatnonzero(self.boundary_edge_mask)

    @cached_property
    def boundary_vertex_mask(self) -> np.ndarray:
        """(nv,) bool: vertex lies on a boundary edge."""
        m = np.zeros(self.n_vertices, bool)
        m[self.edges[self.boundary_edges].ravel()] = True
        return m

    @cached_property
    def face_adjacency(self) -> np.ndarray:
        """(F, 3) face across the edge opposite each local vertex; -1 on the boundary."""
        fe = self.face_edges
        ef = _gather.rows(self.edge_faces, fe)  # (F, 3, 2)
        me = np.arange(self.n_faces)[:, None]
        return np.where(ef[..., 0] == me, ef[..., 1], ef[..., 0])

    # -------------------------------------------------------------------- fans
    @cached_property
    def _corner_next(self) -> np.ndarray:
        """(3F,) next corner counter-clockwise around the corner's vertex; -1 at a boundary.

        Corner ``3 f + k`` sits at vertex ``faces[f, k]``. Rotating CCW around it the
        next face shares the edge from the vertex to local vertex ``k + 2``.
        """
        F, fe = self.faces, self.face_edges
        ef, eo = self.edge_faces.reshape(-1), self.edge_opposite.reshape(-1)
        nxt = np.empty(3 * self.n_faces, np.int64)

        def faces_range(lo: int, hi: int) -> None:
            e = fe[lo:hi, [1, 2, 0]].reshape(-1)  # corner 3f+k: the edge opposite local k+1
            v = F[lo:hi].reshape(-1)  # joins v = F[f, k] and w = F[f, k+2]; f traverses it w -> v,
            w = F[lo:hi, [2, 0, 1]].reshape(-1)  # so f is on side (w > v) of the edge tables
            other = 2 * e + (w < v)
            g = ef[other]
            # the neighbour traverses v -> w: the half-edge opposite its local j runs j+1 -> j+2
            kg = (eo[other] + 1) % 3
            nxt[3 * lo : 3 * hi] = np.where(g >= 0, 3 * g + kg, -1)

        with _parallel.Workers(self.n_faces) as work:  # ranges of faces, a thread per core
            work.map(faces_range, self.n_faces)
        return nxt

    @cached_property
    def vertex_corner(self) -> np.ndarray:
        """(nv,) each vertex's lowest corner ``3 f + k`` (``3 F`` for a vertex no face uses)."""
        n3 = 3 * self.n_faces
        first = np.full(self.n_vertices, n3, np.int64)  # no sort of all corners
        np.minimum.at(first, self.faces.ravel(), np.arange(n3))
        return first

    @cached_property
    def _fans(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """CSR ordered fans: ``(ptr (nv+1,), corners (3F,), fan_count (nv,))``."""
        nxt = self._corner_next
        n3 = nxt.size
        v_of = self.faces.ravel()
        nv = self.n_vertices
        has_prev = np.zeros(n3, bool)
        has_prev[nxt[nxt >= 0]] = True
        starts = np.flatnonzero(~has_prev)  # boundary fan starts
        # vertices with no start are interior: start at their first corner
        has_start = np.zeros(nv, bool)
        has_start[v_of[starts]] = True
        first = self.vertex_corner
        interior_starts = first[~has_start & (first < n3)]
        all_starts = np.concatenate([starts, interior_starts])
        n_start_per_v = np.bincount(v_of[all_starts], minlength=nv)
        # walk every fan in lockstep, remembering each step's (fan, corner) pairs
        n_fans = all_starts.size
        walked = []
        fan_len = np.ones(n_fans, np.int64)
        cur = all_starts.copy()
        origin = all_starts
        alive = np.arange(n_fans)
        for _ in range(n3):
            c = nxt[cur[alive]]
            ok = (c >= 0) & (c != origin[alive])
            alive = alive[ok]
            if alive.size == 0:
                break
            cur[alive] = c[ok]
            fan_len[alive] += 1
            walked.append((alive, c[ok]))
        # fans ordered by vertex (then fan id), each fan's corners by step: place every
        # corner at its fan's offset plus its step (no sort or concatenation of all 3F corners)
        fan_order = np.argsort(v_of[all_starts], kind="stable")
        fan_offset = np.empty(n_fans, np.int64)
        fan_offset[fan_order] = np.cumsum(fan_len[fan_order]) - fan_len[fan_order]
        corners = np.empty(int(fan_len.sum()), np.int64)
        corners[fan_offset] = all_starts
        for step, (ids, cs) in enumerate(walked, start=1):
            corners[fan_offset[ids] + step] = cs
        fan_count = n_start_per_v.copy()
        # a vertex whose walk does not reach all of its corners has several fans
        reached = np.bincount(v_of[all_starts], weights=fan_len, minlength=nv).astype(np.int64)
        total = np.bincount(v_of, minlength=nv)
        fan_count[reached != total] = np.maximum(fan_count[reached != total], 2)
        ptr = np.zeros(nv + 1, np.int64)
        np.cumsum(reached, out=ptr[1:])
        return ptr, corners, fan_count

    @property
    def _fan_counts(self) -> np.ndarray:
        return self._fans[2]

    def vertex_fan(self, v: int) -> np.ndarray:
        """Faces around vertex ``v`` in counter-clockwise order ``(valence,)``.

        For a boundary vertex (incomplete star) the fan starts at the face on the
        boundary edge leaving ``v`` counter-clockwise-first.
        """
        ptr, corners, _ = self._fans
        return corners[ptr[v] : ptr[v + 1]] // 3

    @cached_property
    def fan_ptr(self) -> np.ndarray:
        """(nv + 1,) CSR pointer into :attr:`fan_corners`."""
        return self._fans[0]

    @cached_property
    def fan_corners(self) -> np.ndarray:
        """(3F,) corners ``3 f + k`` ordered CCW around each vertex (CSR by vertex)."""
        return self._fans[1]

    # ---------------------------------------------------------------- boundary
    @cached_property
    def boundary_loops(self) -> list[np.ndarray]:
        """Boundary loops as vertex arrays, longest (by uv length) first.

        Each loop is ordered with the domain on its left (outer loop CCW, holes CW).
        """
        be = self.boundary_edges
        if be.size == 0:
            return []
        ef = self.edge_faces[be]
        a, b = self.edges[be, 0], self.edges[be, 1]
        # orient so the existing face is on the left: if f0 exists, a->b
        src = np.where(ef[:, 0] >= 0, a, b)
        dst = np.where(ef[:, 0] >= 0, b, a)
        succ = np.full(self.n_vertices, -1, np.int64)
        succ[src] = dst
        visited = np.zeros(self.n_vertices, bool)
        loops = []
        for s in src:
            if visited[s]:
                continue
            loop = []
            v = s
            while not visited[v]:
                visited[v] = True
                loop.append(v)
                v = succ[v]
            loops.append(np.array(loop, np.int64))
        lengths = [np.linalg.norm(self.uv[l] - self.uv[np.roll(l, -1)], axis=1).sum() for l in loops]
        return [loops[i] for i in np.argsort(lengths)[::-1]]

    @property
    def n_holes(self) -> int:
        return max(len(self.boundary_loops) - 1, 0)

    # -------------------------------------------------------------- geometry
    @cached_property
    def areas(self) -> np.ndarray:
        """(F,) positive uv areas."""
        return signed_areas(self.uv, self.faces)

    @cached_property
    def bary_gradients(self) -> np.ndarray:
        """(F, 3, 2): gradient in uv of each barycentric coordinate of each face (:func:`face_bary_gradients`)."""
        return face_bary_gradients(self.uv, self.faces)
