"""What the energy's targets come from: vertex normals and local interpolants of the data over uv.

* :func:`area_weighted_normals` -- the mesh's area-weighted face normals, summed per
  vertex (a first-order estimate of the tangent plane; the fallback of the angle term).
* :func:`local_rbf_fit` -- for each vertex a polyharmonic spline interpolant of the data
  of its k-ring (kernel chosen per vertex by leave-one-out error): its gradient sets the
  ``tilt`` targets, its values the ``local`` targets, :func:`fitted_normals` the ``angle``
  targets.

Every function is vectorised over all vertices; neighbourhoods are padded to a fixed
width (the nearest ``max_neighbours`` in uv are kept).
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
import scipy.sparse as sp

from trispline.spline.topology import outline_vertex_mask
from trispline.spline.tolerances import DEGENERATE_TANGENT_RTOL, TINY
from trispline.spline.util.parallel import Workers, single_threaded_blas

from .progress import Report, map_reporting

#: Neighbourhoods are truncated to this many nearest vertices.
MAX_NEIGHBOURS = 32
#: Whether a vertex on the outline takes one ring more than the others (issue 17): its k-ring is
#: about half an inner vertex's, one-sided, and often too small for the cubic kernel's polynomial
#: (20 points), so its fit fell back to lower degree. Measured (true uv, 800 vertices): the
#: outline vertices' gradient error 3.2e-4 -> 1.4e-4 (cap), 6.6e-4 -> 2e-15 (monkey saddle, a
#: cubic), 1.1e-3 -> 5.5e-4 (torus); see docs/fit.md, "The boundary".
OUTLINE_RING = True
#: Where :data:`OUTLINE_RING` applies (``local_rbf_fit(outline_fits=True)``: the fit's context where the
#: uv were given), the vertices on the outline and the ring next to it take a second fit over a wider
#: neighbourhood (:data:`OUTLINE_FIT_RINGS`, up to :data:`OUTLINE_MAX_NEIGHBOURS` points) whose kernels
#: carry polynomials of degree 4 to 6 (:data:`OUTLINE_KERNELS`), kept where their leave-one-out error is
#: below the first fit's: a polyharmonic interpolant loses accuracy toward the edge of its points (its natural
#: boundary conditions), and every target of a boundary face is read there. An oracle with the true
#: parameters located the boundary band's error (cap, 800 vertices: band 6.2e-7, inner 5.6e-8): exact
#: fits at the outline vertices alone leave 1.6e-7, at them and the next ring 5.7e-9 (measured in
#: docs/fit.md, "The boundary").
OUTLINE_FITS = True
#: Rings of the outline vertices' second fits, and of the next ring's.
OUTLINE_FIT_RINGS = (6, 5)
OUTLINE_MAX_NEIGHBOURS = 90
#: The second fits' kernels (power, polynomial degree; as :data:`RBF_KERNELS`); a second fit is kept where
#: its leave-one-out error is below the first's.
OUTLINE_KERNELS: tuple[tuple[int, int], ...] = ((7, 4), (7, 5), (7, 6))
#: Whether the fit's own (smoothed) map takes the second fits too, with the kernels
#: :data:`OWN_MAP_OUTLINE_KERNELS` (degree 4 only: the map is least accurate near its outline, and degrees
#: 5-6 follow that more; measured in benchmarks/README.md, issue 17, helper H38).
OWN_MAP_OUTLINE_FITS = True
OWN_MAP_OUTLINE_KERNELS: tuple[tuple[int, int], ...] = ((7, 4),)
#: Over the fit's own map a vertex takes a second fit only where its first fit's leave-one-out error is at
#: most this fraction of its mean 3D edge length (a rough-data guard: the wide interpolant follows a scan's
#: noise; beetle got 3 patches above 20x the data's largest |H| without it, worst 22.9; with it 0, worst
#: 8.5). Near the outline the analytic meshes' p99 is 4e-3 at 200 vertices and 7e-4 at 800 (the monkey
#: saddle at 200: 1.7e-2), beetle's 2e-2. At 1e-3 the torus at 200 and 800 lost to the first fits alone (a
#: mix of first and second fits along the outline), so the guard sits above the clean meshes.
OWN_MAP_OUTLINE_LOO = 1e-2
#: ... and none at all where the first fits near the outline leave, as their median, more than this
#: fraction of the relief their points have about their planes (:func:`fit_relief`; scale free: rough
#: data as a whole). Measured medians: the analytic meshes 0.044 at most (the monkey saddle at 200
#: vertices), beetle 0.009, face_gpjs 0.021, mountain (a terrain) 0.097: there the second fits took the
#: band p99 over 2x the interior's (1.99 -> 2.01), at any per-vertex limit that left some of them.
OWN_MAP_OUTLINE_SKILL = 0.07


def area_weighted_normals(V: np.ndarray, F: np.ndarray) -> np.ndarray:
    """Unit vertex normals: the sum of the incident faces' (area-weighted) normals.

    Parameters
    ----------
    V : (nv, 3) float, F : (nf, 3) int

    Returns
    -------
    (nv, 3) float64, unit length (zero rows stay zero).
    """
    V = np.asarray(V, float)
    F = np.asarray(F, np.int64)
    fn = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])  # twice the area
    n = np.zeros_like(V)
    for k in range(3):
        np.add.at(n, F[:, k], fn)
    length = np.linalg.norm(n, axis=1, keepdims=True)
    return np.divide(n, length, out=np.zeros_like(n), where=length > 0)


def vertex_rings(faces: np.ndarray, nv: int, rings: int = 2) -> sp.csr_matrix:
    """Boolean ``(nv, nv)`` CSR: ``[v, w]`` set when ``w != v`` is within ``rings`` edges of ``v``."""
    F = np.asarray(faces, np.int64)
    i = np.concatenate([F[:, 0], F[:, 1], F[:, 2]])
    j = np.concatenate([F[:, 1], F[:, 2], F[:, 0]])
    A = sp.csr_matrix((np.ones(2 * i.size, np.int8), (np.r_[i, j], np.r_[j, i])), shape=(nv, nv))
    A.data[:] = 1
    R = A.copy()
    for _ in range(rings - 1):
        R = R + R @ A
        R.data[:] = 1
    R.setdiag(0)
    R.eliminate_zeros()
    R.sort_indices()
    return R.tocsr()


def padded_neighbours(
    uv: np.ndarray, faces: np.ndarray, rings: int = 2, max_neighbours: int = MAX_NEIGHBOURS,
    wider: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Padded k-ring neighbour lists, nearest first in uv; the vertices of ``wider`` (``(nv,)`` bool)
    take ``rings + 1`` rings.

    Returns
    -------
    nbr : (nv, K) int64, ``-1`` padding
    count : (nv,) int64
    """
    uv = np.asarray(uv, float)
    nv = uv.shape[0]
    R = vertex_rings(faces, nv, rings)
    if wider is not None and wider.any():
        # the wider rows' rings + 1 rings made for them alone (the same sets as vertex_rings(rings + 1)'s
        # rows; at 100k faces 0.05 against 0.4 s for all rows) and put in place of theirs
        rows = np.flatnonzero(wider)
        w = wider.astype(np.int8)[:, None]
        place = sp.csr_matrix((np.ones(rows.size, np.int8), (rows, np.arange(rows.size))), shape=(nv, rows.size))
        R = sp.csr_matrix(R.multiply(1 - w) + place @ rings_of(faces, nv, rows, np.full(rows.size, rings + 1)))
        R.eliminate_zeros()
        R.sort_indices()
    return _nearest_first(R, uv, np.arange(nv), max_neighbours)


#: Rows of :func:`_nearest_first` sorted per chunk: its padded ``(rows, width)`` arrays stay small where a
#: few rows are very wide (a random Delaunay scan's 3-rings reach 292 vertices beside a mean of 39).
NEAREST_CHUNK = 4096
#: Neighbour distances within this share of the row's farthest are ties, taken in vertex order: on a regular grid
#: many are equal, and their roundings (which a scale, a rotation or map coordinates change: a unit grid at UTM
#: offsets rounds its map by ~1e-8) picked different neighbours for the local fits (a 12 x 12 grid's harmonic fit
#: moved by 7.7e-4 of the diagonal when scaled by 1e-3).
TIE_RTOL = 1e-6


def _nearest_first(R: sp.csr_matrix, uv: np.ndarray, centre: np.ndarray, max_neighbours: int
                   ) -> tuple[np.ndarray, np.ndarray]:
    """The rows of ``R (m, nv)`` (bool CSR, sorted, without ``centre``) as padded lists ``(m, K)``, nearest
    to ``uv[centre] (m,)`` first (ties, to :data:`TIE_RTOL`, in column order), truncated to ``max_neighbours``;
    and their counts.

    In chunks of :data:`NEAREST_CHUNK` rows, each padded to its own widest row (the padding sorts last)."""
    m = R.shape[0]
    degree = np.diff(R.indptr)
    count = np.minimum(degree, max_neighbours)
    K = int(count.max()) if m else 0
    out = np.full((m, K), -1, np.int64)
    for lo in range(0, m, NEAREST_CHUNK):
        hi = min(lo + NEAREST_CHUNK, m)
        a, b = R.indptr[lo], R.indptr[hi]
        deg = degree[lo:hi]
        row = np.repeat(np.arange(hi - lo), deg)
        slot = np.arange(b - a) - (R.indptr[lo:hi] - a)[row]  # CSR order within the row: the tie-break
        col = R.indices[a:b].astype(np.int64)
        # per coordinate: the rounding of np.linalg.norm's sqrt(du^2 + dv^2), without (n, 2) temporaries
        du = uv[col, 0] - np.repeat(uv[centre[lo:hi], 0], deg)
        dv = uv[col, 1] - np.repeat(uv[centre[lo:hi], 1], deg)
        du *= du
        dv *= dv
        du += dv
        width = int(deg.max(initial=0))
        dist = np.full((hi - lo, width), np.inf)
        dist[row, slot] = np.sqrt(du, out=du)
        cols = np.full((hi - lo, width), -1, np.int64)
        cols[row, slot] = col
        k = min(K, width)
        out[lo:hi, :k] = _ties_in_column_order(dist, cols)[:, :k]
    return out, count


def _ties_in_column_order(dist: np.ndarray, cols: np.ndarray) -> np.ndarray:
    """``cols (m, w)`` sorted by ``dist (m, w)`` (padding: inf), a run of distances each within :data:`TIE_RTOL` of
    the row's farthest from the one before being a tie, taken in column order. Runs rather than rounded
    distances: a tie whose members differ by a rounding never straddles a rounding step."""
    order = np.argsort(dist, axis=1, kind="stable")
    near = np.take_along_axis(dist, order, axis=1)
    cols = np.take_along_axis(cols, order, axis=1)
    farthest = np.max(np.where(np.isfinite(near), near, 0.0), axis=1, keepdims=True)
    with np.errstate(invalid="ignore"):  # inf - inf between paddings: no step
        step = np.diff(near, axis=1) > TIE_RTOL * farthest
    run = np.concatenate([np.zeros((near.shape[0], 1), np.int64), np.cumsum(step, axis=1)], axis=1)
    key = run * (int(cols.max(initial=0)) + 2) + (cols + 1)  # run first, then the column (padding -1)
    return np.take_along_axis(cols, np.argsort(key, axis=1, kind="stable"), axis=1)


def rings_of(faces: np.ndarray, nv: int, centre: np.ndarray, rings: np.ndarray) -> sp.csr_matrix:
    """``(m, nv)`` bool CSR: row ``i`` the vertices within ``rings[i]`` edges of ``centre[i]`` (itself not)."""
    A = vertex_rings(faces, nv, 1)
    m = centre.size
    S = sp.csr_matrix((np.ones(m, np.int8), (np.arange(m), centre)), shape=(m, nv))
    R, out = S.copy(), sp.csr_matrix((m, nv), dtype=np.int8)
    for k in range(1, int(rings.max(initial=0)) + 1):
        R = R + R @ A
        R.data[:] = 1
        out = out + sp.csr_matrix(R.multiply((rings == k).astype(np.int8)[:, None]))
    out = out - out.multiply(S)
    out.eliminate_zeros()
    out.sort_indices()
    return sp.csr_matrix(out)


def fitted_normals(fit: "LocalRBFFit", reference: np.ndarray | None = None) -> np.ndarray:
    """Unit normals ``(nv, 3)`` of the fitted tangent planes ``grad_u x grad_v``.

    ``reference`` (``(nv, 3)``, e.g. area-weighted normals) replaces degenerate
    estimates (parallel or vanishing tangents).
    """
    n = np.cross(fit.grad[:, :, 0], fit.grad[:, :, 1])
    length = np.linalg.norm(n, axis=1, keepdims=True)
    out = np.divide(n, length, out=np.zeros_like(n), where=length > 0)
    if reference is not None:
        bad = length[:, 0] <= DEGENERATE_TANGENT_RTOL * np.maximum(np.abs(fit.grad).max(axis=(1, 2)) ** 2, TINY)
        out[bad] = reference[bad]
    return out


# ------------------------------------------------------------------ local RBF interpolants
#: Polyharmonic kernels ``phi(r) = r**power`` with the polynomial degree each needs
#: (conditionally positive definite of order ``degree + 1``), as (power, degree).
RBF_KERNELS: tuple[tuple[int, int], ...] = ((3, 1), (5, 2), (7, 3))
#: Leave-one-out errors are measured at this many points nearest each vertex (itself included).
RBF_LOO_POINTS = 7
#: Vertices are solved in chunks of this many: a chunk's matrices (chunk * (K + 10)**2 floats,
#: 7.6 MB) stay in cache, which made building them 3x faster than in chunks of 4096.
RBF_CHUNK = 512
_NPOLY = 10  # cubic polynomial columns, constant included
#: A kernel is not tried at a vertex whose points leave its polynomial part undetermined: the scaled Gram matrix
#: of its monomials has an eigenvalue below this (relative to its diagonal of ones). Points on three lines (a strip
#: three vertices wide: a cubic vanishes on them) read 1e-14 and below, and the interpolant took any multiple of
#: that cubic (gradients 3e4 times the data's, a surface 6.7 diagonals out); the analytic surfaces and the shared
#: scans read at least 1.3e-7 for the cubic and 2.6e-11 for the sextic of the outline fits (benchmarks/README.md,
#: issue 17, the twenty-seventh session).
UNISOLVENT_RTOL = 1e-12
#: Damping of the linear trend's 2 x 2 normal matrix, relative to its trace: keeps a
#: neighbourhood on one line solvable without touching any other (a regularisation, not a test).
TREND_RIDGE = 1e-12


def _poly3(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Monomials up to degree 3 with the constant: 1, u, v, u^2, uv, v^2, u^3, u^2 v, u v^2, v^3."""
    xx, xy, yy = x * x, x * y, y * y
    return np.stack([np.ones_like(x), x, y, xx, xy, yy, xx * x, xx * y, xy * y, yy * y], axis=-1)


def _monomials(x: np.ndarray, y: np.ndarray, degree: int) -> np.ndarray:
    """``(..., (degree + 1)(degree + 2) / 2)`` monomials up to ``degree`` (at least 3), in :func:`_poly3`'s
    order continued: by total degree, then falling powers of ``u``."""
    if degree <= 3:
        return _poly3(x, y)
    return np.concatenate([_poly3(x, y)] + [np.stack([x ** (k - j) * y ** j for j in range(k + 1)], axis=-1)
                                            for k in range(4, degree + 1)], axis=-1)


def _degree(npoly: int) -> int:
    """The polynomial degree whose monomials number ``npoly`` (10: 3, 15: 4, 21: 5, 28: 6)."""
    return int(round((np.sqrt(8 * npoly + 1) - 3) / 2))


#: Kernel evaluations per chunk of :meth:`LocalRBFFit.evaluate` (temporaries of 4 MB): at 100k faces the
#: blended targets took 1.17-1.23 s against 1.57-1.60 s with 1 MB chunks (2**17; 2**20 1.47-1.51 s), the
#: per-chunk Python work between the two threads' numpy calls being the cost.
EVAL_CHUNK = 1 << 19


def _squared_distances(P: np.ndarray, C: np.ndarray) -> np.ndarray:
    """``(b, p, K)`` squared distances between points ``P (b, p, 2)`` and centres ``C (b, K, 2)``.

    ``dx * dx + dy * dy`` with two buffers of the result's size (the plain expression makes five:
    fresh memory costs more than the arithmetic here).
    """
    r2 = np.subtract(P[:, :, None, 0], C[:, None, :, 0])
    np.multiply(r2, r2, out=r2)
    dy = np.subtract(P[:, :, None, 1], C[:, None, :, 1])
    np.multiply(dy, dy, out=dy)
    r2 += dy
    return r2


def _kernel(r2: np.ndarray, power, *, overwrite: bool = False) -> np.ndarray:
    """``r**power`` from squared distances ``r2`` (an array), for odd integer powers 3, 5, 7 (scalar or
    broadcast). ``overwrite``: ``r2`` may be used as workspace (one temporary instead of three);
    the roundings are the same either way: ``r2 sqrt(r2)``, times ``r2`` or ``r2 r2``."""
    phi = np.sqrt(r2)
    phi *= r2  # r^3
    if np.ndim(power) == 0:
        if int(power) == 5:
            phi *= r2
        elif int(power) == 7:
            phi *= np.multiply(r2, r2, out=r2 if overwrite else None)
        return phi
    phi *= np.where(power == 3, 1.0, np.where(power == 5, r2, r2 * r2))
    return phi


@dataclass(frozen=True)
class LocalRBFFit:
    """Local polyharmonic interpolants, one per vertex (see :func:`local_rbf_fit`).

    Attributes
    ----------
    grad : (nv, d, 2) first partials of each data coordinate at the vertex
    power : (nv,) kernel power chosen at each vertex (0: linear fit only)
    loo : (nv,) leave-one-out error (RMS over the data coordinates) of the chosen kernel
    scale : (nv,) local length (mean distance to the 1-ring)
    origin : (nv, 2), value : (nv, d) uv and data of each vertex
    centres : (nv, K, 2) scaled centres (the vertex first, then its neighbours; padding at 0)
    lam : (nv, K, d) kernel coefficients (0 on padding)
    coef : (nv, 10, d) polynomial coefficients (cubic monomials, constant first)
    slope : (nv, 2, d) linear trend removed before the interpolation (scaled units)
    outline : the second fits of the vertices near the outline (``local_rbf_fit(outline_fits=True)``), or
        None; ``outline_rows (nv,)``: each vertex's row there (-1: its own fit). :meth:`evaluate`,
        ``grad``, ``power``, ``loo`` and ``slope`` are theirs at those vertices; ``centres``, ``lam``
        and ``coef`` stay the first fit's
    """

    grad: np.ndarray
    power: np.ndarray
    loo: np.ndarray
    scale: np.ndarray
    origin: np.ndarray
    value: np.ndarray
    centres: np.ndarray
    lam: np.ndarray
    coef: np.ndarray
    slope: np.ndarray
    outline: "LocalRBFFit | None" = None
    outline_rows: np.ndarray | None = None

    def evaluate(self, vertex: np.ndarray, points: np.ndarray, report: Report | None = None) -> np.ndarray:
        """Value of vertex ``vertex[i]``'s interpolant at ``points[i]``: ``(n, d)``.

        Grouped form: ``points (m, p, 2)`` with ``vertex (m,)`` gives ``(m, p, d)``,
        gathering each vertex's centres and coefficients once per group. ``report``:
        progress as chunks finish (:mod:`trispline.fit.progress`).
        """
        vertex = np.asarray(vertex, np.int64)
        points = np.asarray(points, float)
        grouped = points if points.ndim == 3 else points[:, None, :]
        if self.outline is None:
            out = self._evaluate_grouped(vertex, grouped, report)
        else:  # the vertices near the outline: their second fits
            rows = self.outline_rows[vertex]
            near = rows >= 0
            out = np.empty(grouped.shape[:2] + (self.value.shape[1],))
            out[~near] = self._evaluate_grouped(vertex[~near], grouped[~near], report)
            out[near] = self.outline._evaluate_grouped(rows[near], grouped[near], None)
        return out if points.ndim == 3 else out[:, 0]

    def _evaluate_grouped(self, vertex: np.ndarray, points: np.ndarray, report: Report | None) -> np.ndarray:
        """``(m, p, d)`` values at ``points (m, p, 2)``: chunks of groups of one kernel power, in threads."""
        m, p = points.shape[:2]
        K = self.centres.shape[1]
        out = np.empty((m, p, self.value.shape[1]))
        order = np.argsort(self.power[vertex], kind="stable")
        step = max(1, EVAL_CHUNK // max(p * K, 1))
        degree = _degree(self.coef.shape[1])

        def part(lo: int, hi: int) -> None:
            g = order[lo:hi]
            v = vertex[g]
            X = (points[g] - self.origin[v][:, None]) / self.scale[v][:, None, None]  # (b, p, 2)
            out[g] = self.value[v][:, None] + X @ self.slope[v] + _monomials(X[..., 0], X[..., 1], degree) @ self.coef[v]
            power = self.power[v]
            if not power.any():
                return  # linear fits only: no kernel terms
            uniform = (power == power[0]).all()
            phi = _kernel(_squared_distances(X, self.centres[v]), power[0] if uniform else power[:, None, None],
                          overwrite=True)
            out[g] += phi @ self.lam[v]

        with Workers(m * p * K, parallel_min=2 * EVAL_CHUNK) as work:
            map_reporting(work, part, m, step, report)
        return out


def _solve_batch(A: np.ndarray, B: np.ndarray) -> np.ndarray:
    """Batched ``A \\ B``; exactly singular systems give NaN instead of failing the batch."""
    try:
        return np.linalg.solve(A, B)
    except np.linalg.LinAlgError:
        out = np.full(B.shape, np.nan)
        for i in range(A.shape[0]):  # rare: degenerate neighbourhoods only
            try:
                out[i] = np.linalg.solve(A[i], B[i])
            except np.linalg.LinAlgError:
                pass
        return out


def _local_scale(uv: np.ndarray, faces: np.ndarray, nv: int) -> np.ndarray:
    """``(nv,)`` mean uv distance to the 1-ring (1 where a vertex has none)."""
    R1 = vertex_rings(faces, nv, 1)
    r1 = np.repeat(np.arange(nv), np.diff(R1.indptr))
    l1 = np.linalg.norm(uv[R1.indices] - uv[r1], axis=1)
    scale = np.bincount(r1, l1, minlength=nv) / np.maximum(np.diff(R1.indptr), 1)
    return np.where(scale > 0, scale, 1.0)


def _linear_trend(X: np.ndarray, Y: np.ndarray) -> np.ndarray:
    """``(nv, 2, d)`` least-squares slopes through each vertex of ``Y (nv, K, d)`` over ``X (nv, K, 2)``."""
    G = np.einsum("vki,vkj->vij", X, X)
    G += (TREND_RIDGE * np.einsum("vii->v", G) + TINY)[:, None, None] * np.eye(2)
    return np.linalg.solve(G, np.einsum("vki,vkd->vid", X, Y))


@dataclass
class _KernelFits:
    """The kernel choice and coefficients of every vertex, filled chunk by chunk (disjoint rows)."""

    best: np.ndarray  # (nv,) leave-one-out score of the chosen kernel (inf: none)
    power: np.ndarray  # (nv,) chosen power (0: none)
    lam: np.ndarray  # (nv, K, d)
    coef: np.ndarray  # (nv, npoly, d): _NPOLY, or more for kernels of higher degree


def _kernel_matrix(r3: np.ndarray, r2: np.ndarray, P0: np.ndarray, pad: np.ndarray, p: int, m: int) -> np.ndarray:
    """``(b, K + m, K + m)``: the interpolation matrices of kernel ``r**p`` and the first ``m`` monomials.

    ``[[phi, P], [P^T, 0]]`` with the padded centres (``pad (b, K)``) decoupled by a unit
    diagonal; ``r3 = r2**1.5`` already zero between padded centres, and ``r2 (b, K, K)``. Exactly
    ``K + m`` wide (36, 39, 43 for the three kernels at ``K = 33``): a quarter fewer flops than one
    width for all. One product per kernel into place, the diagonal through a strided view.
    """
    b, K = r2.shape[:2]
    n = K + m
    out = np.empty((b, n, n))
    phi = out[:, :K, :K]
    if p == 3:
        np.copyto(phi, r3)
    elif p == 5:
        np.multiply(r3, r2, out=phi)
    else:
        np.multiply(r2, r2, out=phi)
        phi *= r3
    out[:, :K, K:] = P0[..., :m]
    out[:, K:, :K] = P0[..., :m].transpose(0, 2, 1)
    out[:, K:, K:] = 0.0
    out.reshape(b, n * n)[:, : K * (n + 1) : n + 1] += pad  # the first K diagonal entries
    return out


def _monomial_gram(P: np.ndarray) -> np.ndarray:
    """``(b, m, m)`` the Gram matrices of the monomial columns ``P (b, K, m)`` (padded rows zero), each column
    scaled to unit length: their leading ``j x j`` blocks are those of the first ``j`` monomials."""
    G = np.matmul(P.transpose(0, 2, 1), P)
    n = np.sqrt(np.einsum("bii->bi", G))
    n = np.where(n > 0, n, 1.0)
    return G / n[:, :, None] / n[:, None, :]


def _unisolvent(gram: np.ndarray) -> np.ndarray:
    """``(b,)`` bool: the polynomial part of a kernel's system is determined by the points (the scaled Gram
    matrices ``gram (b, m, m)`` of its monomials have no eigenvalue below :data:`UNISOLVENT_RTOL`). One batched
    Cholesky factorisation decides where all are; only a batch where one is not takes the eigenvalues."""
    if not gram.shape[0]:
        return np.zeros(0, bool)
    shifted = gram - UNISOLVENT_RTOL * np.eye(gram.shape[1])
    try:
        np.linalg.cholesky(shifted)
        return np.ones(gram.shape[0], bool)
    except np.linalg.LinAlgError:
        return np.linalg.eigvalsh(gram)[:, 0] > UNISOLVENT_RTOL


def _fit_chunk(out: _KernelFits, lo: int, hi: int, X: np.ndarray, Y: np.ndarray, valid: np.ndarray,
               npts: np.ndarray, kernels: list[tuple[int, int]], nloo: int) -> None:
    """Interpolate vertices ``lo:hi`` with each kernel; keep the one with the smallest leave-one-out error.

    ``X (nv, K, 2)`` scaled centres, ``Y (nv, K, d)`` detrended data, ``valid (nv, K)``,
    ``npts (nv,)`` points per vertex. Rippa: ``e_k = c_k / (A^-1)_kk`` from one solve with
    the data and the first ``nloo`` unit vectors as right-hand sides. Distances and their
    powers are computed once for all kernels, in chunks small enough to stay in cache.
    """
    K, d = X.shape[1], Y.shape[2]
    Xc, vc = X[lo:hi], valid[lo:hi]
    r2 = _squared_distances(Xc, Xc)  # (b, K, K)
    r3 = np.sqrt(r2)
    r3 *= r2
    r3 *= vc[:, :, None] & vc[:, None, :]  # zero between padded centres (exact: every kernel is r3 times a power)
    npoly = out.coef.shape[1]
    P0 = _monomials(Xc[..., 0], Xc[..., 1], _degree(npoly)) * vc[..., None]
    gram = _monomial_gram(P0)
    B = np.zeros((hi - lo, K + npoly, d + nloo))
    B[:, :K, :d] = Y[lo:hi]
    B[:, np.arange(nloo), d + np.arange(nloo)] = 1.0
    for p, q in kernels:
        m = (q + 1) * (q + 2) // 2
        ok = npts[lo:hi] >= max(2 * m, 3)
        ok[ok] = _unisolvent(gram[ok, :m, :m])
        if not ok.any():
            continue
        A = _kernel_matrix(r3, r2, P0, ~vc, p, m)
        sel = slice(None) if ok.all() else ok
        # A is exactly symmetric, and its transpose is the layout LAPACK reads: numpy copies it
        # without a transposition (the same matrix, the same numbers: 8% less time in the solve)
        S = _solve_batch(A[sel].transpose(0, 2, 1), B[sel, :K + m])
        c = S[:, :, :d]
        dg = S[:, np.arange(nloo), d + np.arange(nloo)]  # (A^-1)_kk
        vk = vc[sel][:, :nloo]
        e = c[:, :nloo, :] / np.where(vk, dg, 1.0)[..., None]
        score = np.sqrt(np.sum(np.where(vk[..., None], e * e, 0.0), axis=(1, 2)))
        score = np.where(np.isfinite(score) & np.isfinite(c).all(axis=(1, 2)), score, np.inf)
        idx = lo + np.flatnonzero(ok)
        take = score < out.best[idx]
        t = idx[take]
        out.best[t] = score[take]
        out.power[t] = p
        out.lam[t] = c[take, :K]
        out.coef[t] = 0.0
        out.coef[t, :m] = c[take, K:]


def _vertex_gradient(X: np.ndarray, fits: _KernelFits, slope: np.ndarray, scale: np.ndarray) -> np.ndarray:
    """``(nv, d, 2)`` gradient at each vertex: trend + kernel terms + linear coefficients, in uv units."""
    r2 = np.einsum("vki,vki->vk", X, X)
    pw = fits.power[:, None]
    # d/dx of |x - x_j|^p at x = 0 is -p r_j^(p-2) x_j
    dphi = -pw * np.sqrt(r2) * np.where(pw == 5, r2, np.where(pw == 7, r2 * r2, 1.0))
    return (slope.transpose(0, 2, 1) + np.einsum("vk,vki,vkd->vdi", dphi, X, fits.lam)
            + fits.coef[:, 1:3, :].transpose(0, 2, 1)) / scale[:, None, None]


def outline_fit_kernels(curved_outline: bool) -> tuple[tuple[int, int], ...]:
    """The kernels of :func:`local_rbf_fit`'s second fits near the outline (:data:`OUTLINE_FITS`) for a fit
    over the user's uv (``curved_outline`` False: :data:`OUTLINE_KERNELS`) or over its own map
    (:data:`OWN_MAP_OUTLINE_KERNELS` where :data:`OWN_MAP_OUTLINE_FITS`); ``()``: no second fits."""
    if not OUTLINE_FITS:
        return ()
    if not curved_outline:
        return OUTLINE_KERNELS
    return OWN_MAP_OUTLINE_KERNELS if OWN_MAP_OUTLINE_FITS else ()


def smooth_rows(vals: np.ndarray, faces: np.ndarray, loo: np.ndarray, rows: np.ndarray, limit: float) -> np.ndarray:
    """``(m,)`` bool: the vertices ``rows (m,)`` whose fits' leave-one-out errors ``loo (nv,)`` are at most
    ``limit`` times their mean edge length in ``vals (nv, d)`` (over ``faces (nf, 3)``)."""
    nv = len(vals)
    e = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
    length = np.linalg.norm(vals[e[:, 0]] - vals[e[:, 1]], axis=1)
    h = np.bincount(e.ravel(), np.repeat(length, 2), nv) / np.maximum(np.bincount(e.ravel(), minlength=nv), 1)
    return loo[rows] <= limit * h[rows]


def fit_relief(uv: np.ndarray, vals: np.ndarray, centre: np.ndarray, nbr: np.ndarray, scale: np.ndarray) -> np.ndarray:
    """``(m,)`` RMS (per coordinate) of the values ``vals (nv, d)`` of each vertex ``centre (m,)``'s
    neighbours ``nbr (m, K)`` (-1 padded) about the least-squares linear trend through the vertex (in uv
    scaled by ``scale (m,)``): the relief its fit has to explain."""
    valid = np.concatenate([np.ones((centre.size, 1), bool), nbr >= 0], axis=1)
    nb = np.concatenate([centre[:, None], np.where(nbr >= 0, nbr, 0)], axis=1)
    X = np.where(valid[..., None], (uv[nb] - uv[centre][:, None, :]) / scale[:, None, None], 0.0)
    Y = np.where(valid[..., None], vals[nb] - vals[centre][:, None, :], 0.0)
    R = Y - np.einsum("vki,vid->vkd", X, _linear_trend(X, Y))
    return np.sqrt((R * R).sum((1, 2)) / (vals.shape[1] * valid.sum(1)))


def local_rbf_fit(
    uv: np.ndarray,
    values: np.ndarray,
    faces: np.ndarray,
    *,
    rings: int = 3,
    max_degree: int = 3,
    max_neighbours: int = MAX_NEIGHBOURS,
    loo_points: int = RBF_LOO_POINTS,
    outline_ring: bool | None = None,
    outline_fits: bool = False,
    outline_kernels: tuple[tuple[int, int], ...] | None = None,
    outline_loo: float | None = None,
    report: Report | None = None,
) -> LocalRBFFit:
    """Polyharmonic spline interpolant of each vertex's k-ring data, kernel chosen by cross-validation.

    For each vertex ``v`` the data of ``v`` and of its nearest ``max_neighbours``
    vertices within ``rings`` edges are interpolated exactly (in uv scaled by the mean
    1-ring edge length) by ``sum_j lam_j |x - x_j|**p + polynomial``, for each kernel
    ``(p, degree)`` of :data:`RBF_KERNELS` with ``degree <= max_degree`` and enough
    points (``>= 2 x`` the polynomial's coefficients). The kernel with the smallest
    leave-one-out error (Rippa's formula ``e_k = c_k / (A^-1)_kk``, over the
    ``loo_points`` points nearest ``v``, all data coordinates together) is kept: smooth
    data pick the smooth ``r^7``, kinks and cone points the stiffer ``r^3``.

    Parameters
    ----------
    uv : (nv, 2), values : (nv, d) or (nv,), faces : (nf, 3)
    rings : neighbourhood size in edges
    max_degree : 2 (kernels r^3, r^5) or 3 (also r^7)
    outline_ring : the vertices on the outline of ``faces`` take ``rings + 1`` rings (default
        :data:`OUTLINE_RING`)
    outline_fits : the vertices on the outline and next to it take second, wider fits of higher degree
        (:data:`OUTLINE_FITS`; only with ``max_degree`` 3): :attr:`LocalRBFFit.outline`
    outline_kernels : the second fits' kernels (default :data:`OUTLINE_KERNELS`; :func:`outline_fit_kernels`)
    outline_loo : second fits only where the first fit's leave-one-out error is at most this fraction of
        the vertex's mean edge length in ``values`` (:func:`smooth_rows`), and none where the first fits
        near the outline leave more than :data:`OWN_MAP_OUTLINE_SKILL` of their relief (median,
        :func:`fit_relief`); default: no guard
    report : progress as chunks of vertices finish (:mod:`trispline.fit.progress`)

    Returns
    -------
    LocalRBFFit

    Notes
    -----
    A linear least-squares trend through ``v`` is removed first, so linear data give
    zero kernel and polynomial coefficients and exact gradients (the fit reproduces
    linear data to rounding). The interpolant is linear in the data and the kernel
    choice is shared by all coordinates and rotation invariant, so planar data stay
    in their plane. Vertices with too few neighbours (< 3) keep the linear trend.
    """
    if max_degree not in (2, 3):
        raise ValueError(f"max_degree must be 2 or 3, got {max_degree}")
    uv = np.asarray(uv, float)
    vals = np.asarray(values, float)
    if vals.ndim == 1:
        vals = vals[:, None]
    nv = vals.shape[0]
    ring = OUTLINE_RING if outline_ring is None else outline_ring
    wider = outline_vertex_mask(faces, nv) if ring else None
    nbr, count = padded_neighbours(uv, faces, rings, max_neighbours, wider)
    scale = _local_scale(uv, faces, nv)
    kernels = [(p, q) for p, q in RBF_KERNELS if q <= max_degree]
    fit = _fit_rows(uv, vals, np.arange(nv), nbr, count, scale, kernels, loo_points, _NPOLY, report)
    if not (outline_fits and OUTLINE_FITS and max_degree == 3):
        return fit
    # the second fits of the vertices on the outline and next to it (OUTLINE_FITS)
    on = outline_vertex_mask(faces, nv)
    rows = np.flatnonzero(on | ((vertex_rings(faces, nv, 1) @ on.astype(np.int8)) > 0))
    if outline_loo is not None:
        rows = rows[smooth_rows(vals, faces, fit.loo, rows, outline_loo)]
        if rows.size and np.median(fit.loo[rows] / np.maximum(fit_relief(uv, vals, rows, nbr[rows], scale[rows]), TINY)
                                   ) > OWN_MAP_OUTLINE_SKILL:
            rows = rows[:0]
    if not rows.size:
        return fit
    R = rings_of(faces, nv, rows, np.where(on[rows], *OUTLINE_FIT_RINGS))
    nbr2, count2 = _nearest_first(R, uv, rows, OUTLINE_MAX_NEIGHBOURS)
    with single_threaded_blas():  # systems of ~110: BLAS threads per system oversubscribe the cores (40x slower)
        kernels2 = OUTLINE_KERNELS if outline_kernels is None else outline_kernels
        second = _fit_rows(uv, vals, rows, nbr2, count2, scale[rows], list(kernels2), loo_points,
                           max((q + 1) * (q + 2) // 2 for _, q in kernels2), None)
    # a second fit replaces the first where it predicts the same nearest points better (leave-one-out)
    better = (second.power > 0) & (second.loo < fit.loo[rows])  # power 0: too few points for its kernels
    at = np.full(nv, -1, np.int64)
    at[rows[better]] = np.flatnonzero(better)
    merged = {k: getattr(fit, k).copy() for k in ("grad", "power", "loo", "slope")}
    for k, a in merged.items():
        a[rows[better]] = getattr(second, k)[better]
    return replace(fit, **merged, outline=second, outline_rows=at)


def _fit_rows(uv: np.ndarray, vals: np.ndarray, centre: np.ndarray, nbr: np.ndarray, count: np.ndarray,
              scale: np.ndarray, kernels: list[tuple[int, int]], loo_points: int, npoly: int,
              report: Report | None) -> LocalRBFFit:
    """:func:`local_rbf_fit`'s interpolants of the vertices ``centre (m,)`` over their neighbours
    ``nbr (m, K)`` (``-1`` padding; ``count (m,)`` of them), in uv scaled by ``scale (m,)``;
    ``npoly`` polynomial columns (at least those of the highest degree among ``kernels``)."""
    m, d = centre.size, vals.shape[1]
    valid = np.concatenate([np.ones((m, 1), bool), nbr >= 0], axis=1)  # the vertex first
    nb = np.concatenate([centre[:, None], np.where(nbr >= 0, nbr, 0)], axis=1)
    K = nb.shape[1]
    X = (uv[nb] - uv[centre][:, None, :]) / scale[:, None, None]
    X[~valid] = 0.0
    Y = vals[nb] - vals[centre][:, None, :]
    Y[~valid] = 0.0
    slope = _linear_trend(X, Y)
    Y = Y - np.einsum("vki,vid->vkd", X, slope)

    nloo = min(loo_points, K)
    fits = _KernelFits(best=np.full(m, np.inf), power=np.zeros(m, np.int64), lam=np.zeros((m, K, d)),
                       coef=np.zeros((m, npoly, d)))
    # numpy releases the GIL in the batched solves and array arithmetic: a thread each from two chunks on
    with Workers(m, parallel_min=RBF_CHUNK + 1) as work:
        map_reporting(work, lambda lo, hi: _fit_chunk(fits, lo, hi, X, Y, valid, count + 1, kernels, nloo), m,
                      RBF_CHUNK, report)
    loo = np.where(np.isfinite(fits.best), fits.best / np.sqrt(d * np.maximum(nloo, 1)), 0.0)
    return LocalRBFFit(grad=_vertex_gradient(X, fits, slope, scale), power=fits.power, loo=loo, scale=scale,
                       origin=uv[centre], value=vals[centre], centres=X, lam=fits.lam, coef=fits.coef, slope=slope)
