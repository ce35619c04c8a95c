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
order), then interior samples ``V + (r - 1) E + q F + f``. Samples are evaluated by one BLAS
product per range of about ``TASK_PATCHES`` patches (so the temporaries stay in cache), the
ranges run on a thread per core; there is no per-face Python loop.
"""
from __future__ import annotations

import contextlib
import os
import threading
from concurrent.futures import ThreadPoolExecutor

from functools import lru_cache
from typing import NamedTuple

import numpy as np

from .util import gather as _gather, memory as _memory
from .index import CORNER, NCTRL, STAR
from .bernstein import basis, basis_gradient_bary
from .errors import InputError
from .patches import check_ctrl
from .topology import Triangulation

__all__ = ["Tessellation", "tessellate", "tessellation_counts"]


class Tessellation(NamedTuple):
    """A triangle mesh sampled from a spline surface.

    vertices : (m, d) surface points
    triangles : (t, 3) int32 (int64 beyond 2^31 vertices), counter-clockwise in uv
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


@lru_cache(maxsize=16)
def _local_layout(r: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Per-face grid layout for resolution ``r``.

    Returns
    -------
    jk : (n, 2) lattice coordinates (j, k) of the grid points (bary = (r-j-k, j, k) / r)
    kind : (n,) 0 corner, 1 edge, 2 interior
    a, b : (n,) for corners: local vertex; for edges: local vertex opposite the edge and
        the step count ``s`` from local ``(k+1) % 3``; for interior: running index q
    tris : (r^2, 3) local triangles (indices into the grid points)
    """
    # (i, j, k) with i descending, then j descending (the order of bary_grid)
    pts = [(i, j, r - i - j) for i in range(r, -1, -1) for j in range(r - i, -1, -1)]
    index = {p: n for n, p in enumerate(pts)}
    n = len(pts)
    kind = np.empty(n, np.int64)
    a = np.empty(n, np.int64)
    b = np.zeros(n, np.int64)
    q = 0
    for m, p in enumerate(pts):
        zeros = [c for c in range(3) if p[c] == 0]
        if len(zeros) == 2:
            kind[m], a[m] = 0, [c for c in range(3) if p[c] == r][0]
        elif len(zeros) == 1:
            k = zeros[0]
            kind[m], a[m], b[m] = 1, k, p[(k + 2) % 3]
        else:
            kind[m], a[m] = 2, q
            q += 1
    tris = []
    for j in range(r):
        for k in range(r - j):
            tris.append((index[(r - j - k, j, k)], index[(r - j - k - 1, j + 1, k)], index[(r - j - k - 1, j, k + 1)]))
            if j + k <= r - 2:
                tris.append((index[(r - j - k - 1, j + 1, k)], index[(r - j - k - 2, j + 1, k + 1)],
                             index[(r - j - k - 1, j, k + 1)]))
    jk = np.array([(p[1], p[2]) for p in pts], np.int64)
    return jk, kind, a, b, np.array(tris, np.int64)


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


#: Faces per chunk below which tessellation stays on one thread.
CHUNK_FACES = 4096
#: Patches per evaluation task: keeps each task's temporaries in cache.
TASK_PATCHES = 8192

_blas_lock = threading.Lock()
_blas_state: dict = {"controller": None, "limiter": None, "users": 0}


@contextlib.contextmanager
def _single_threaded_blas():
    """Context in which BLAS runs on the calling thread only.

    The evaluation tasks call BLAS from several Python threads at once; a BLAS
    that threads each call as well oversubscribes the cores (measured slower).
    The limit is process-wide; concurrent tessellations share it, the first one
    in sets it and the last one out restores the original thread count.
    """
    try:
        from threadpoolctl import ThreadpoolController
    except ImportError:  # pragma: no cover - threadpoolctl is a dependency
        yield
        return
    with _blas_lock:
        if _blas_state["users"] == 0:
            if _blas_state["controller"] is None:
                _blas_state["controller"] = ThreadpoolController()
            _blas_state["limiter"] = _blas_state["controller"].limit(limits=1, user_api="blas")
        _blas_state["users"] += 1
    try:
        yield
    finally:
        with _blas_lock:
            _blas_state["users"] -= 1
            if _blas_state["users"] == 0:
                _blas_state["limiter"].restore_original_limits()
                _blas_state["limiter"] = None


class _Workers:
    """Run tasks on a thread per core when the mesh is large enough, else inline.

    ``chunks`` splits the faces for per-face tasks; leaving the ``with`` block waits
    for every task and re-raises the first error. While tasks run in threads, BLAS
    is limited to one thread per call.
    """

    def __init__(self, n: int) -> None:
        workers = min(os.cpu_count() or 1, 8, max(1, n // CHUNK_FACES))
        self._pool = ThreadPoolExecutor(workers) if workers > 1 else None
        self._blas = _single_threaded_blas() if workers > 1 else contextlib.nullcontext()
        self.chunks = self.split(n, 2 * workers if workers > 1 else 1)
        self._futures = []

    @staticmethod
    def split(n: int, parts: int) -> list[tuple[int, int]]:
        bounds = np.linspace(0, n, max(1, parts) + 1).astype(int)
        return [(int(a), int(b)) for a, b in zip(bounds[:-1], bounds[1:]) if b > a]

    def task_chunks(self, n: int) -> list[tuple[int, int]]:
        """Ranges of at most about ``TASK_PATCHES``, at least two per worker."""
        parts = max(-(-n // TASK_PATCHES), len(self.chunks) if self._pool is not None else 1)
        return self.split(n, parts)

    def submit(self, fn, *args) -> None:
        if self._pool is None:
            fn(*args)
        else:
            self._futures.append(self._pool.submit(fn, *args))

    def __enter__(self) -> "_Workers":
        self._blas.__enter__()
        return self

    def __exit__(self, *exc) -> None:
        try:
            if self._pool is not None:
                try:
                    for fut in self._futures:
                        fut.result()
                finally:
                    self._pool.shutdown(wait=True)
        finally:
            self._blas.__exit__(None, None, None)


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
    r = int(resolution)
    if r < 1 or r != resolution:
        raise InputError(f"resolution must be an integer >= 1, got {resolution}")
    tri = triangulation if triangulation is not None else Triangulation(uv, faces)
    F = tri.faces
    ctrl = check_ctrl(F, ctrl)
    nv, nf, ne = tri.n_vertices, tri.n_faces, tri.n_edges
    d = ctrl.shape[2]
    UV = tri.uv
    jk, kind, la, lb, ltris = _local_layout(r)
    inner = kind == 2
    n_inner = int(inner.sum())
    m = nv + (r - 1) * ne + n_inner * nf
    vertices = np.empty((m, d))
    normals = np.empty((m, 3 if d == 3 else 0))
    uv_pts = np.empty((m, 2))
    # --- edge ownership: r - 1 samples per edge on an owner face, from its local k+1 to
    # k+2; edges are stored grouped by that local index k (slot order)
    ef, eo = tri.edge_faces, tri.edge_opposite
    own = np.where(ef[:, 0] >= 0, 0, 1)
    f0 = ef[np.arange(ne), own]
    k0 = eo[np.arange(ne), own]
    order = np.argsort(k0, kind="stable")
    slot = np.empty(ne, np.int64)
    slot[order] = np.arange(ne)
    start = F[f0, (k0 + 1) % 3]
    end = F[f0, (k0 + 2) % 3]

    # --- the per-face vertex ids need no surface values: they start at once on face
    # chunks in threads (numpy releases the GIL) while this thread evaluates
    base = nv + (r - 1) * ne
    n = jk.shape[0]
    idx_t = _memory.index_dtype(m)
    nt = ltris.shape[0]
    triangles = np.empty((nf * nt, 3), idx_t)
    cm = np.flatnonzero(kind == 0)
    em = np.flatnonzero(kind == 1)
    im = np.flatnonzero(inner)
    ke, se = la[em], lb[em]

    def ids_chunk(lo: int, hi: int) -> None:
        gid = np.empty((hi - lo, n), idx_t)
        gid[:, cm] = F[lo:hi, la[cm]]
        if em.size:
            e = tri.face_edges[lo:hi, ke]  # (chunk, m)
            forward = F[lo:hi, (ke + 1) % 3] == start[e]
            s = np.where(forward, se[None, :], r - se[None, :])
            gid[:, em] = nv + (s - 1) * ne + slot[e]
        gid[:, im] = base + la[im][None, :] * nf + np.arange(lo, hi)[:, None]
        # mode="clip": valid ids by construction, and "raise" would buffer the output
        np.take(gid, ltris.ravel(), axis=1, out=triangles[lo * nt : hi * nt].reshape(hi - lo, 3 * nt), mode="clip")

    with _Workers(nf) as work:
        for lo, hi in work.chunks:
            work.submit(ids_chunk, lo, hi)

        # --- interior samples: per face range, one BLAS product, points and normals
        if n_inner:
            ib = np.column_stack([r - jk[inner].sum(1), jk[inner, 0], jk[inner, 1]]) / r
            rows_in = _basis_rows(ib, d)
            vin = vertices[base:].reshape(n_inner, nf, d)
            nin = normals[base:].reshape(n_inner, nf, normals.shape[1])
            uin = uv_pts[base:].reshape(n_inner, nf, 2)

            def interior_chunk(lo: int, hi: int) -> None:
                _write_samples(vin[:, lo:hi], nin[:, lo:hi], rows_in, ctrl[lo:hi])
                # uv of the samples: a matmul (an einsum here took 15x longer)
                corner_uv = _gather.rows(UV, F[lo:hi]).transpose(1, 0, 2).reshape(3, -1)
                uin[:, lo:hi] = (ib @ corner_uv).reshape(n_inner, hi - lo, 2)

            for lo, hi in work.task_chunks(nf):
                work.submit(interior_chunk, lo, hi)

        # --- edges: r - 1 samples on the owner face, one sample set per local index k
        if r > 1:
            t = np.arange(1, r) / r
            vb = vertices[nv:base].reshape(r - 1, ne, d)
            nb = normals[nv:base].reshape(r - 1, ne, normals.shape[1])
            ub = uv_pts[nv:base].reshape(r - 1, ne, 2)
            f_sorted, start_sorted, end_sorted = f0[order], start[order], end[order]
            bounds = np.searchsorted(k0[order], [0, 1, 2, 3])

            def edge_chunk(rows: np.ndarray, lo: int, hi: int) -> None:
                _write_samples(vb[:, lo:hi], nb[:, lo:hi], rows, _gather.rows(ctrl, f_sorted[lo:hi]))
                a, b = _gather.rows(UV, start_sorted[lo:hi]), _gather.rows(UV, end_sorted[lo:hi])
                ub[:, lo:hi] = (1.0 - t)[:, None, None] * a[None] + t[:, None, None] * b[None]

            for k in range(3):  # three relabelled sample sets, not a per-face loop
                eb = np.zeros((r - 1, 3))
                eb[:, (k + 1) % 3] = 1.0 - t
                eb[:, (k + 2) % 3] = t
                rows_e = _basis_rows(eb, d)
                for lo, hi in work.task_chunks(int(bounds[k + 1] - bounds[k])):
                    work.submit(edge_chunk, rows_e, int(bounds[k]) + lo, int(bounds[k]) + hi)

        # --- corners (here, while the tasks run): exact corner points; normals from the star points
        cf, ck = np.divmod(tri.vertex_corner, 3)  # each vertex's lowest corner
        vertices[:nv] = ctrl[cf, CORNER[ck]]
        uv_pts[:nv] = UV
        if d == 3:
            z = vertices[:nv].T
            s1 = ctrl[cf, STAR[ck, (ck + 1) % 3]].T - z
            s2 = ctrl[cf, STAR[ck, (ck + 2) % 3]].T - z
            normals[:nv] = _cross_normalise(s1, s2).T
    return Tessellation(vertices, triangles, normals, uv_pts)
