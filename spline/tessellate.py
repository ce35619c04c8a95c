"""Watertight tessellation of a quintic triangular spline surface.

Every patch is sampled on the regular barycentric grid with ``r = resolution``
steps per edge, but each surface point is evaluated once and stored once:

* one vertex per domain vertex (the patch corner point, exact),
* ``r - 1`` vertices per domain edge, evaluated on one owner face, in a fixed
  direction along the edge,
* ``(r - 1)(r - 2) / 2`` vertices inside each face.

Neighbouring patches therefore share their boundary vertices and the mesh is
watertight along patch boundaries (``V + (r-1) E + (r-1)(r-2)/2 F`` vertices,
``r^2 F`` triangles). Normals are analytic: the normalised cross product of two
tangent derivatives (at corners, of the two star-point differences).

Vertex numbering: domain vertices first (vertex ``v`` is tessellation vertex
``v``), then edge samples ``V + (s - 1) E + slot(e)`` (edges in an internal
order), then interior samples ``V + (r - 1) E + q F + f`` (``q``: the sample's rank among a
face's interior points of :func:`~trispline.spline.index.lattice`). The triangles of a face
are :func:`~trispline.spline.index.lattice_triangles`. Samples are evaluated by one BLAS
product per range of about ``TASK_PATCHES`` patches (so the temporaries stay in cache), the
ranges run on a thread per core; there is no per-face Python loop.
"""
from __future__ import annotations

from functools import lru_cache, partial
from typing import NamedTuple

import numpy as np

from .bernstein import bary_grid, basis, basis_gradient_bary
from .checks import whole_number
from .index import CORNER, NCTRL, STAR, lattice, lattice_triangles
from .patches import check_ctrl
from .topology import Triangulation
from .util import gather as _gather, memory as _memory, parallel as _parallel

__all__ = ["Tessellation", "patch_points", "require_tessellation_memory", "tessellate", "tessellation_bytes",
           "tessellation_counts"]

#: Meshes with fewer faces are tessellated on the calling thread only.
PARALLEL_FACES = 8192
#: Patches per evaluation task: keeps each task's temporaries in cache.
TASK_PATCHES = 8192


class Tessellation(NamedTuple):
    """A triangle mesh sampled from a spline surface.

    vertices : (m, d) surface points
    triangles : (t, 3) int32 (int64 beyond 2^31 vertices), counter-clockwise in uv; patch ``f``'s are
        rows ``f r^2`` to ``(f + 1) r^2`` (``r`` the resolution)
    normals : (m, 3) unit normals (zero where the surface is singular); only for d == 3
    uv : (m, 2) domain point of each vertex
    """

    vertices: np.ndarray
    triangles: np.ndarray
    normals: np.ndarray
    uv: np.ndarray


def tessellation_counts(n_vertices: int, n_edges: int, n_faces: int, resolution: int) -> tuple[int, int]:
    """``(vertex count, triangle count)`` of :func:`tessellate`."""
    r = int(resolution)
    return n_vertices + (r - 1) * n_edges + (r - 1) * (r - 2) // 2 * n_faces, r * r * n_faces


def tessellation_bytes(n_points: int, n_triangles: int, dim: int = 3) -> int:
    """Bytes of a :class:`Tessellation` of ``n_points`` and ``n_triangles``: points, normals and uv in float64,
    triangles in the narrowest index type."""
    return n_points * (dim + 5) * 8 + n_triangles * 3 * np.dtype(_memory.index_dtype(n_points)).itemsize


def require_tessellation_memory(n_vertices: int, n_edges: int, n_faces: int, resolution: int, dim: int = 3
                                ) -> tuple[int, int]:
    """:func:`tessellation_counts`, after refusing (``ResourceError``) a tessellation whose arrays
    would not fit in the available memory; callers may ask before the surface exists."""
    r = whole_number(resolution, "resolution", least=1)
    m, nt = tessellation_counts(n_vertices, n_edges, n_faces, r)
    _memory.require_memory(tessellation_bytes(m, nt, dim),
                           f"tessellating {n_faces} patches at resolution {r} ({m} points, {nt} triangles)",
                           "use a lower resolution")
    return m, nt


class _Layout(NamedTuple):
    """The sample lattice of one face at resolution ``r``, by what each point shares.

    bary : (n, 3) barycentric coordinates, ``lattice(r) / r``
    corner : (3,) lattice points at the corners; ``corner_local``: their local vertex
    edge : (3 (r - 1),) points inside the edges; ``edge_local``: the local vertex opposite
        the edge, ``edge_step``: the step count ``s`` from local vertex ``(k + 1) % 3``
    inner : ((r - 1)(r - 2) / 2,) interior points, in lattice order
    tris : (r^2, 3) local triangles (indices into the lattice)
    """

    bary: np.ndarray
    corner: np.ndarray
    corner_local: np.ndarray
    edge: np.ndarray
    edge_local: np.ndarray
    edge_step: np.ndarray
    inner: np.ndarray
    tris: np.ndarray


@lru_cache(maxsize=16)
def _local_layout(r: int) -> _Layout:
    """:class:`_Layout` for resolution ``r >= 1``."""
    pts = lattice(r)
    zeros = (pts == 0).sum(1)
    corner, edge, inner = (np.flatnonzero(zeros == z) for z in (2, 1, 0))
    k = np.argmax(pts[edge] == 0, axis=1)  # the zero coordinate: the local vertex opposite the edge
    return _Layout(bary=bary_grid(r), corner=corner, corner_local=np.argmax(pts[corner] == r, axis=1),
                   edge=edge, edge_local=k, edge_step=pts[edge, (k + 2) % 3], inner=inner,
                   tris=lattice_triangles(r))


class _Owners(NamedTuple):
    """Each edge's owner face, which evaluates its ``r - 1`` samples from its local ``k + 1`` to ``k + 2``.

    Edges are stored grouped by that local index ``k``: ``order`` lists them so, ``slot`` is the
    inverse (each edge's position). All ``(E,)``.
    """

    face: np.ndarray
    k: np.ndarray
    order: np.ndarray
    slot: np.ndarray
    start: np.ndarray  # vertex at local k + 1 of the owner
    end: np.ndarray  # vertex at local k + 2


def _edge_owners(tri: Triangulation) -> _Owners:
    ne, F = tri.n_edges, tri.faces
    ef, eo = tri.edge_faces, tri.edge_opposite
    own = np.where(ef[:, 0] >= 0, 0, 1)
    f0 = ef[np.arange(ne), own]
    k0 = eo[np.arange(ne), own]
    order = np.argsort(k0, kind="stable")
    slot = np.empty(ne, np.int64)
    slot[order] = np.arange(ne)
    return _Owners(f0, k0, order, slot, F[f0, (k0 + 1) % 3], F[f0, (k0 + 2) % 3])


def _cross_normalise(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Normalised ``x × y`` for component-major ``(3, ...)`` arrays; zero vectors stay zero."""
    c = np.empty_like(x)
    np.multiply(x[1], y[2], out=c[0])
    c[0] -= x[2] * y[1]
    np.multiply(x[2], y[0], out=c[1])
    c[1] -= x[0] * y[2]
    np.multiply(x[0], y[1], out=c[2])
    c[2] -= x[1] * y[0]
    nrm = np.sqrt(c[0] * c[0] + c[1] * c[1] + c[2] * c[2])
    np.divide(1.0, nrm, out=nrm, where=nrm > 0)
    c *= nrm
    return c


def _basis_rows(bary: np.ndarray, d: int) -> np.ndarray:
    """Rows of the sample products: values and, for ``d == 3``, two tangents.

    Returns ``(k n, 21)`` with k = 3 (value, d/dl_b - d/dl_a, d/dl_c - d/dl_a) for d == 3, else 1.
    """
    rows = basis(bary)
    if d == 3:
        dB = basis_gradient_bary(bary)
        rows = np.concatenate([rows, dB[1] - dB[0], dB[2] - dB[0]])
    return rows


def _write_samples(values: np.ndarray, normals: np.ndarray, rows: np.ndarray, ctrl: np.ndarray) -> None:
    """Evaluate ``ctrl (P, 21, d)`` at the samples of ``rows`` and write them.

    ``values (n, P, d)`` receives the points and ``normals (n, P, 3)`` the unit
    normals. One BLAS product over the P patches, in component-major layout.
    """
    P, _, d = ctrl.shape
    n = values.shape[0]
    cols = np.ascontiguousarray(ctrl.transpose(1, 2, 0)).reshape(NCTRL, d * P)
    prod = (rows @ cols).reshape(-1, n, d, P)
    values[...] = prod[0].transpose(0, 2, 1)
    if prod.shape[0] == 3:
        normals[...] = _cross_normalise(prod[1].transpose(1, 0, 2), prod[2].transpose(1, 0, 2)).transpose(1, 2, 0)


class _Block(NamedTuple):
    """A block of tessellation vertices, sample-major: ``(samples, items, ...)`` views of the outputs."""

    values: np.ndarray
    normals: np.ndarray
    uv: np.ndarray


def _block(mesh: Tessellation, lo: int, n: int, items: int) -> _Block:
    """Vertices ``lo : lo + n items`` of ``mesh`` as ``n`` samples of ``items`` each."""
    hi = lo + n * items
    return _Block(*(a[lo:hi].reshape(n, items, a.shape[1]) for a in (mesh.vertices, mesh.normals, mesh.uv)))


def tessellate(
    uv: np.ndarray,
    faces: np.ndarray,
    ctrl: np.ndarray,
    resolution: int = 8,
    *,
    triangulation: Triangulation | None = None,
) -> Tessellation:
    """Sample the spline surface into a watertight triangle mesh.

    Parameters
    ----------
    uv : (V, 2), faces : (F, 3) counter-clockwise, ctrl : (F, 21, d)
    resolution : steps per patch edge (``>= 1``)
    triangulation : optional prebuilt :class:`Triangulation` of ``(uv, faces)``

    Returns
    -------
    Tessellation(vertices (m, d), triangles (r^2 F, 3), normals (m, 3), uv (m, 2)) with
    ``m = V + (r-1) E + (r-1)(r-2)/2 F``. Normals are ``(m, 0)`` when ``d != 3``.
    """
    r = whole_number(resolution, "resolution", least=1)
    tri = triangulation if triangulation is not None else Triangulation(uv, faces)
    ctrl = check_ctrl(tri.faces, ctrl)
    d, nf = ctrl.shape[2], tri.n_faces
    m, nt = require_tessellation_memory(tri.n_vertices, tri.n_edges, nf, r, d)
    lay, owners = _local_layout(r), _edge_owners(tri)
    mesh = Tessellation(np.empty((m, d)), np.empty((nt, 3), _memory.index_dtype(m)),
                        np.empty((m, 3 if d == 3 else 0)), np.empty((m, 2)))
    with _parallel.Workers(nf, parallel_min=PARALLEL_FACES, serial_blas=True) as work:
        chunk = work.chunk(nf, TASK_PATCHES)
        # the triangles need no surface values: they run in threads while this thread queues the rest
        jobs = work.start(partial(_triangles, tri, r, lay, owners, mesh.triangles), nf, chunk)
        jobs += _interior_jobs(work, tri, r, lay, ctrl, mesh)
        jobs += _edge_jobs(work, tri, r, owners, ctrl, mesh)
        _corners(tri, ctrl, mesh)  # here, while the tasks run
        for job in jobs:
            job.result()
    return mesh


def patch_points(resolution: int, triangle: np.ndarray, weights: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The patch ``(n,)`` and its barycentric coordinates ``(n, 3)`` of points on a tessellation's triangles.

    ``triangle (n,)`` rows of :attr:`Tessellation.triangles` at ``resolution``, ``weights (n, 3)`` the points'
    barycentric coordinates in them (vertex order of the rows): exact, no search in the domain.
    """
    r = int(resolution)
    t = np.asarray(triangle, np.int64)
    face, local = np.divmod(t, r * r)
    corners = bary_grid(r)[lattice_triangles(r)[local]]  # (n, 3 vertices, 3)
    return face, np.einsum("nk,nkc->nc", np.asarray(weights, np.float64), corners)


def _triangles(tri: Triangulation, r: int, lay: _Layout, owners: _Owners, triangles: np.ndarray,
               lo: int, hi: int) -> None:
    """The triangles of faces ``lo:hi``: each face's lattice triangles on global vertex ids."""
    F, nv, ne, nf = tri.faces, tri.n_vertices, tri.n_edges, tri.n_faces
    nt = lay.tris.shape[0]
    gid = np.empty((hi - lo, lay.bary.shape[0]), triangles.dtype)
    gid[:, lay.corner] = F[lo:hi, lay.corner_local]
    if lay.edge.size:
        ke = lay.edge_local
        e = tri.face_edges[lo:hi, ke]  # (chunk, 3 (r - 1))
        forward = F[lo:hi, (ke + 1) % 3] == owners.start[e]
        s = np.where(forward, lay.edge_step[None, :], r - lay.edge_step[None, :])
        gid[:, lay.edge] = nv + (s - 1) * ne + owners.slot[e]
    base = nv + (r - 1) * ne
    gid[:, lay.inner] = base + np.arange(lay.inner.size)[None, :] * nf + np.arange(lo, hi)[:, None]
    # mode="clip": valid ids by construction, and "raise" would buffer the output
    np.take(gid, lay.tris.ravel(), axis=1, out=triangles[lo * nt : hi * nt].reshape(hi - lo, 3 * nt), mode="clip")


def _interior_jobs(work: _parallel.Workers, tri: Triangulation, r: int, lay: _Layout, ctrl: np.ndarray,
                   mesh: Tessellation) -> list:
    """Interior samples: per face range, one BLAS product for points and normals."""
    if lay.inner.size == 0:
        return []
    nf, ne, nv = tri.n_faces, tri.n_edges, tri.n_vertices
    ib = lay.bary[lay.inner]
    out = _block(mesh, nv + (r - 1) * ne, lay.inner.size, nf)
    return work.start(partial(_interior_range, tri, ib, _basis_rows(ib, ctrl.shape[2]), ctrl, out),
                      nf, work.chunk(nf, TASK_PATCHES))


def _interior_range(tri: Triangulation, ib: np.ndarray, rows: np.ndarray, ctrl: np.ndarray, out: _Block,
                    lo: int, hi: int) -> None:
    _write_samples(out.values[:, lo:hi], out.normals[:, lo:hi], rows, ctrl[lo:hi])
    # uv of the samples: a matmul (an einsum here took 15x longer)
    corner_uv = _gather.rows(tri.uv, tri.faces[lo:hi]).transpose(1, 0, 2).reshape(3, -1)
    out.uv[:, lo:hi] = (ib @ corner_uv).reshape(ib.shape[0], hi - lo, 2)


def _edge_jobs(work: _parallel.Workers, tri: Triangulation, r: int, owners: _Owners, ctrl: np.ndarray,
               mesh: Tessellation) -> list:
    """Edges: ``r - 1`` samples on the owner face, one sample set per local index ``k``
    (three relabelled sample sets, not a per-face loop)."""
    if r == 1:
        return []
    nv, ne = tri.n_vertices, tri.n_edges
    t = np.arange(1, r) / r
    out = _block(mesh, nv, r - 1, ne)
    o = owners.order
    edge_range = partial(_edge_range, tri.uv, t, ctrl, owners.face[o], owners.start[o], owners.end[o], out)
    bounds = np.searchsorted(owners.k[o], [0, 1, 2, 3])
    jobs = []
    for k in range(3):
        eb = np.zeros((r - 1, 3))
        eb[:, (k + 1) % 3] = 1.0 - t
        eb[:, (k + 2) % 3] = t
        count = int(bounds[k + 1] - bounds[k])
        jobs += work.start(partial(edge_range, _basis_rows(eb, ctrl.shape[2])), count,
                           work.chunk(count, TASK_PATCHES), offset=int(bounds[k]))
    return jobs


def _edge_range(UV: np.ndarray, t: np.ndarray, ctrl: np.ndarray, face: np.ndarray, start: np.ndarray,
                end: np.ndarray, out: _Block, rows: np.ndarray, lo: int, hi: int) -> None:
    """Samples of the edges ``lo:hi`` (in owner order) on their owner faces."""
    _write_samples(out.values[:, lo:hi], out.normals[:, lo:hi], rows, _gather.rows(ctrl, face[lo:hi]))
    a, b = _gather.rows(UV, start[lo:hi]), _gather.rows(UV, end[lo:hi])
    out.uv[:, lo:hi] = (1.0 - t)[:, None, None] * a[None] + t[:, None, None] * b[None]


def _corners(tri: Triangulation, ctrl: np.ndarray, mesh: Tessellation) -> None:
    """Exact corner points; normals from the star points of each vertex's lowest corner."""
    nv = tri.n_vertices
    cf, ck = np.divmod(tri.vertex_corner, 3)
    mesh.vertices[:nv] = ctrl[cf, CORNER[ck]]
    mesh.uv[:nv] = tri.uv
    if ctrl.shape[2] == 3:
        z = mesh.vertices[:nv].T
        s1 = ctrl[cf, STAR[ck, (ck + 1) % 3]].T - z
        s2 = ctrl[cf, STAR[ck, (ck + 2) % 3]].T - z
        mesh.normals[:nv] = _cross_normalise(s1, s2).T
