"""What the dense scan looks like locally: robust quadric fits over a uv cell grid.

    a = analyse_scan(V, F, uv)          # ScanAnalysis
    a.residual                          # (n,) distance of each vertex from its cell's robust quadric
    a.noise                             # robust noise estimate (model units)
    a.curvature, a.scale                # (ny, nx) per cell: RMS principal curvature, 3D length per uv length
    a.lookup(a.curvature, points)       # the cell values at uv points (k, 2)

The uv bounding box is cut into square cells of about :data:`POINTS_PER_CELL`
vertices; where the map compresses the surface, so that a cell holds many times that,
those vertices are fitted again on cells of half the size, and so on (cells adapted to
the map's local scale: an LSCM map's area ratio varies by 1e4-1e6 on the shared scans). In each cell the three coordinates are fitted by quadratics in the
cell's local uv, ``x(u, v) = sum c_k m_k(u, v)``, ``m = (1, u, v, u^2, uv, v^2)``,
from the weighted normal equations (sums over cells as one sparse product, so
linear in the scan and no per-cell Python loop), then refitted with Cauchy
weights scaled by the cell's median residual, so that outliers do not pull the
fit. A vertex's residual is its leave-one-out distance from the fit along the
fit's normal (``r / (1 - h)``, ``h`` its leverage: a vertex in a cell's corner
that the fit bends to is not hidden); its roughness, that residual over the
cell's level: noise and spikes stand out, smooth data does not. The curvature
``sqrt(k1^2 + k2^2)`` is that of the quadrics of a second, coarser grid
(``curvature_points`` vertices a cell, the robust weights of the first) at the
cell centres, less the noise's share: the fit averages the noise out over the
cell. The vertices of a cell with too few join the nearest cell with enough.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components
from scipy import ndimage

from trispline.param import face_areas_3d
from trispline.spline.checks import as_array
from trispline.spline.topology import outline_vertex_mask, signed_areas, undirected_edges

from .creases import clean_crease_edges

__all__ = ["ScanAnalysis", "analyse_scan", "edge_correlation", "vertex_area_element", "POINTS_PER_CELL", "CURVATURE_POINTS", "SPIKE_LEVELS"]

#: Vertices per cell aimed at (6 unknowns per coordinate: the fit averages over about 7x more points).
POINTS_PER_CELL = 40
#: A cell holding more than this many times :data:`POINTS_PER_CELL` vertices is split (:func:`_adaptive_fits`).
SPLIT_POINTS = 4.0
#: Most halvings of the cell step.
MAX_LEVELS = 10
#: A finer level's grid has at most this many cells per vertex it fits (its box, mostly empty elsewhere).
MAX_LEVEL_CELLS = 4.0
#: Vertices per cell of the curvature grid (default; the coarse domain asks for its own scale).
CURVATURE_POINTS = 200
#: The curvature grid's cells grow until the noise's share of ``kappa`` is about this over the diagonal.
CURVATURE_RESOLUTION = 0.5
#: A cell with fewer vertices than this joins the nearest valid cell.
MIN_CELL_POINTS = 12
#: A vertex joined to a valid cell farther than this (its local coordinate, 0.5 at the cell's edge) is
#: fitted again on coarser cells (:func:`_adaptive_fits`): beyond the next cell the quadric extrapolates
#: (a coarse region beside a dense one, whose spacing sets the cells: a clean square's corner 0.16 off).
FAR_JOIN = 1.5
#: Smallest variance of a valid cell's local vertex coordinates in any direction (a full cell: 1/12).
MIN_CELL_SPREAD = 0.02
#: Cauchy weight scale, in noise units (95% efficiency under Gaussian noise).
CAUCHY_SCALE = 2.385
#: Robust refits after the plain least-squares fit.
REFITS = 2
#: Normal-equation regularisation, relative to the matrix's trace (the monomials are O(1)).
RIDGE = 1e-10
#: A vertex whose residual exceeds this many local levels is a spike (see ``ScanAnalysis.roughness``).
SPIKE_LEVELS = 5.0
#: A spike's mesh neighbour whose deviation from a fit is within this factor of the spike's is comparable
#: (:meth:`ScanAnalysis.isolated`): a 6-sigma outlier's neighbours sit at about 0.7 sigma (one above 2 sigma
#: 4.6% of the time); along a clean cliff the spline cannot follow, 0.8-1.4x.
ISOLATION = 3.0
#: ... or a group of at most this many spikes, each comparable only with spikes of the group and none on the
#: outline: a cluster of outliers (a scanner's blob), where a feature's line of spikes is longer.
CLUSTER_MAX = 4
#: Smallest ``1 - leverage`` divided by (a vertex the fit interpolates gets a large, finite residual).
LEVERAGE_FLOOR = 1e-3
#: Smallest local residual level, relative to the diagonal (exact data: the level of rounding).
LEVEL_FLOOR = 1e-12
#: Median absolute deviation to the standard deviation of a Gaussian.
MAD_TO_SIGMA = 1.4826


@dataclass(frozen=True, eq=False)
class ScanAnalysis:
    """Per-vertex and per-cell results of :func:`analyse_scan`.

    residual : (n,) leave-one-out distance of each vertex from its cell's robust quadric, along its
        normal: ``|r| / (1 - h)`` with ``h`` the vertex's leverage in the fit
    noise : robust noise estimate ``1.4826 median(|r| / sqrt(1 - h))`` (model units)
    roughness : (n,) ``residual`` over the local level, ``1.4826`` times the cell's median (studentized)
        residual: the noise where there is noise, the quadric's model error where the data is exact,
        so each vertex is judged against its neighbours (the preferences of the coarse vertices, the loss scale)
    outlier : (n,) ``residual`` over the larger of that level and its mesh neighbours' (:func:`_ring_level`:
        on a graded scan a cell's median is its dense part's, while a vertex's neighbours share its spacing);
        above :data:`SPIKE_LEVELS`: a spike
    smooth : (n, 3) each vertex moved onto its cell's robust quadric (along the quadric's normal)
    calm : (n,) the same studentized residual as ``roughness`` but against the robust quadric of the
        coarser curvature grid's cell, over that cell's level: its fit averages ``curvature_points``
        vertices instead of :data:`POINTS_PER_CELL` (on noise its own error is about
        ``sigma sqrt(6 / points)`` instead of ``0.4 sigma``), so the vertex of smallest ``calm``
        near a spot is nearer the smooth surface than the one of smallest ``roughness``: where a
        corner point that interpolates its data vertex is put (the snap)
    cell : (n,) flat index (``iy * nx + ix``) of each vertex's cell of the curvature grid
    origin : (2,) uv of that grid's corner; step : its cell size in uv; shape : ``(ny, nx)``
    curvature : (ny, nx) RMS principal curvature ``sqrt(k1^2 + k2^2)`` (1 / model units)
    scale : (ny, nx) 3D length per uv length (square root of the area ratio)
    scan_spacing : (ny, nx) the scan's own vertex spacing in uv (square root of uv area per vertex)
    area : (ny, nx) 3D area of the scan's faces whose centroid is in the cell
    diagonal : the scan's bounding-box diagonal
    points : (n, 3) the scan's vertices as given
    area_element : (n,) the scan's own area element at each vertex, ``|x_u x x_v|`` of its map: the 3D area of
        its faces over their uv area (1 where it has none); what the surface's is measured against
        (:func:`~.pinch.relative_regularity`)
    coarse_noise : the same estimate as ``noise`` from the curvature grid's quadrics: about ``noise`` where
        the residuals are noise, larger where they are the quadrics' model error (creases, clean curved data)
    noise_correlation : the correlation of neighbouring vertices' (signed, leave-one-out) residuals over
        the mesh's edges (clipped at 3 ``noise``): about -0.1 where they are noise, which is independent
        vertex to vertex, 0.25-0.7 where they are the quadrics' model error, which varies smoothly
        (:func:`edge_correlation`)
    spike_ring : ``(spike (r,), neighbour (r,))`` every mesh neighbour of every spike (for :meth:`isolated`);
    spike_outline : (s,) the spikes on the scan's outline
    crease_edges : (e, 2) the scan's crease edges where it is clean (:func:`~.creases.clean_crease_edges`;
        none on a noisy scan)
    """

    residual: np.ndarray
    noise: float
    roughness: np.ndarray
    outlier: np.ndarray
    smooth: np.ndarray
    calm: np.ndarray
    cell: np.ndarray
    origin: np.ndarray
    step: float
    shape: tuple[int, int]
    curvature: np.ndarray
    scale: np.ndarray
    scan_spacing: np.ndarray
    area: np.ndarray
    diagonal: float
    points: np.ndarray
    coarse_noise: float
    noise_correlation: float = 0.0
    spike_ring: tuple[np.ndarray, np.ndarray] = field(
        default_factory=lambda: (np.empty(0, np.int64), np.empty(0, np.int64)))
    spike_outline: np.ndarray = field(default_factory=lambda: np.empty(0, np.int64))
    crease_edges: np.ndarray = field(default_factory=lambda: np.empty((0, 2), np.int64))
    area_element: np.ndarray | None = None

    @property
    def crease(self) -> np.ndarray:
        """(n,) bool: the vertices inside a crease line of a clean scan (two of ``crease_edges``): a feature where
        the spline needs vertices, never an outlier (:meth:`isolated`), even where its residual makes it a spike.
        A lone spike is none: every edge of its ring turns (its crease degree is its valence, its neighbours'
        three), and neither are a line's ends and junctions, nor a spike on the outline, where its only two
        interior edges may both turn (a grid's outline vertex lifted by 0.05 is an outlier, not a crease)."""
        on = np.bincount(self.crease_edges.ravel(), minlength=self.points.shape[0]) == 2
        on[self.spike_outline] = False
        return on

    @property
    def noise_share(self) -> float:
        """``(noise / coarse_noise)^2`` at most 1: about 1 where the residuals are noise (they do not grow
        with the cell), near 0 where they are the quadrics' model error (creases, clean curved data: the
        shared real scans' coarse estimate is 3.6-21x the fine one, a noisy generated scan's 1.05x). The
        preferences for calm vertices (the snap, refinement's candidates) are weighed by it: on clean data
        a vertex off its local quadric is a crease, where the spline needs a vertex, not noise."""
        return noise_share(self.noise, self.coarse_noise)

    @property
    def spike(self) -> np.ndarray:
        """(n,) bool: vertices far off their local fit (outliers, scanner spikes): ``outlier`` above
        :data:`SPIKE_LEVELS`."""
        return self.outlier > SPIKE_LEVELS

    def isolated(self, distance: np.ndarray) -> np.ndarray:
        """(n,) bool: the spikes that stand alone in ``distance (n,)`` (their deviation from a fit): at most one
        mesh neighbour within :data:`ISOLATION` times of theirs (two adjacent outliers pass), none on the
        outline; or in a group of at most :data:`CLUSTER_MAX` spikes comparable only with each other, none on
        the outline (a cluster of outliers). A feature the fit misses (a cliff or crease as sharp as the scan's
        spacing) is a line of such spikes, two neighbours along it comparable (one where it runs out at the
        outline), and runs on into clean vertices that the fit misses as much. On a clean scan a vertex inside a
        crease line (:attr:`crease`) is never isolated: where the fit's corner points interpolate the crease's
        other vertices, a few of its spikes left between them look like a small group (three faces of a cube:
        three vertices of a crease near its end were rejected, and refinement stalled there at 2.6x the tolerance)."""
        spike, neighbour = self.spike_ring
        n = distance.shape[0]
        crease = self.crease
        comparable = ISOLATION * distance[neighbour] >= distance[spike]
        count = np.bincount(spike[comparable], minlength=n)
        count[self.spike_outline] += 1
        alone = self.spike & (count <= 1) & ~crease
        # a small group of spikes, each comparable only with spikes of the group: a cluster of outliers
        ids = np.flatnonzero(self.spike)
        if ids.size:
            pos = np.full(n, -1)
            pos[ids] = np.arange(ids.size)
            other = comparable & (pos[neighbour] < 0)  # a comparable neighbour that is no spike
            link = comparable & (pos[neighbour] >= 0) & (ISOLATION * distance[spike] >= distance[neighbour])
            graph = sp.coo_matrix((np.ones(int(link.sum())), (pos[spike[link]], pos[neighbour[link]])),
                                  shape=(ids.size, ids.size))
            _, label = connected_components(graph, directed=False)
            size = np.bincount(label)[label]
            clean_near = np.bincount(pos[spike[other]], minlength=ids.size) > 0
            bad_group = np.bincount(label, clean_near | np.isin(ids, self.spike_outline)) > 0
            alone[ids] |= (size <= CLUSTER_MAX) & ~bad_group[label] & ~crease[ids]
        return alone

    def cell_of(self, points: np.ndarray) -> np.ndarray:
        """Flat cell index ``(k,)`` of uv ``points (k, 2)`` (clamped to the grid)."""
        return _cell_index(points, self.origin, self.step, self.shape)

    def lookup(self, field: np.ndarray, points: np.ndarray) -> np.ndarray:
        """The values ``(k,)`` of a per-cell ``field (ny, nx)`` at uv ``points (k, 2)``, bilinear between
        the cell centres (so a sizing field made of it has no steps)."""
        ij = (np.asarray(points, np.float64) - self.origin) / self.step - 0.5  # in cell-centre units
        return ndimage.map_coordinates(field, [ij[:, 1], ij[:, 0]], order=1, mode="nearest")


def _cell_index(points: np.ndarray, origin: np.ndarray, step: float, shape: tuple[int, int]) -> np.ndarray:
    """Flat index ``(k,)`` of the grid cell of each uv point ``(k, 2)``, clamped to the grid."""
    ny, nx = shape
    ij = np.floor((np.asarray(points, np.float64) - origin) / step).astype(np.int64)
    return np.clip(ij[:, 1], 0, ny - 1) * nx + np.clip(ij[:, 0], 0, nx - 1)


#: Exponents ``(p, q)`` of the quadric's monomials ``u^p v^q`` and of their pairwise products (degree <= 4).
_EXP2 = [(0, 0), (1, 0), (0, 1), (2, 0), (1, 1), (0, 2)]
_EXP4 = [(p, d - p) for d in range(5) for p in range(d, -1, -1)]
#: Which degree-4 moment each entry of the 6x6 normal matrix is.
_AIDX = np.array([[_EXP4.index((a[0] + b[0], a[1] + b[1])) for b in _EXP2] for a in _EXP2])


def _monomials(q: np.ndarray, exps: list[tuple[int, int]] = _EXP2) -> np.ndarray:
    """``(n, k)``: the monomials ``u^p v^q`` of local coordinates ``q (n, 2)`` (default ``1, u, v, u^2, uv, v^2``)."""
    deg = max(a + b for a, b in exps)
    pu, pv = [np.ones(q.shape[0])], [np.ones(q.shape[0])]
    for _ in range(deg):
        pu.append(pu[-1] * q[:, 0])
        pv.append(pv[-1] * q[:, 1])
    out = np.empty((q.shape[0], len(exps)))
    for k, (a, b) in enumerate(exps):
        np.multiply(pu[a], pv[b], out=out[:, k])
    return out


def _residuals(m: np.ndarray, X: np.ndarray, C: np.ndarray, Ainv: np.ndarray, cell: np.ndarray, w: np.ndarray,
               chunk: int = 1 << 17) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Signed distance ``(n,)`` of ``X (n, 3)`` from its cell's quadric (``C (ncell, 6, 3)``) along the
    quadric's unit normal ``(n, 3)``, and the vertex's leverage ``w m^T A^-1 m`` ``(n,)`` in that fit."""
    r, nrm, lev = np.empty(X.shape[0]), np.empty_like(X), np.empty(X.shape[0])
    for lo in range(0, X.shape[0], chunk):
        s = slice(lo, lo + chunk)
        c, q = C[cell[s]], m[s]
        val = np.einsum("nk,nkd->nd", q, c)
        du = c[:, 1] + 2 * c[:, 3] * q[:, 1:2] + c[:, 4] * q[:, 2:3]
        dv = c[:, 2] + c[:, 4] * q[:, 1:2] + 2 * c[:, 5] * q[:, 2:3]
        n = np.cross(du, dv)
        nrm[s] = n / np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-300)
        r[s] = np.einsum("nd,nd->n", X[s] - val, nrm[s])
        lev[s] = w[s] * np.einsum("nk,nkl,nl->n", q, Ainv[cell[s]], q)
    return r, nrm, lev


def _cell_median(x: np.ndarray, cell: np.ndarray, ncell: int) -> np.ndarray:
    """``(ncell,)`` median (the lower one) of ``x (n,)`` over each cell's vertices; 0 for an empty cell."""
    order = np.lexsort((x, cell))
    c = cell[order]
    start = np.searchsorted(c, np.arange(ncell))
    count = np.bincount(cell, minlength=ncell)
    out = np.zeros(ncell)
    has = count > 0
    out[has] = x[order[start[has] + (count[has] - 1) // 2]]
    return out


def _neighbour_pairs(F: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(i, j, outline)``: every mesh edge of ``F (m, 3)`` in both directions (``j`` a neighbour of ``i``),
    and ``(n,)`` bool the vertices on a boundary edge."""
    he, edges, he_edge, count = undirected_edges(F, n)
    outline = outline_vertex_mask(F, n, tables=(he, he_edge, count))
    edges = edges[edges[:, 0] != edges[:, 1]]
    return np.concatenate([edges[:, 0], edges[:, 1]]), np.concatenate([edges[:, 1], edges[:, 0]]), outline


def _ring_level(stud: np.ndarray, i: np.ndarray, j: np.ndarray, n: int) -> np.ndarray:
    """``(n,)`` the level of each vertex's mesh neighbours' (``j`` of ``i``) studentized residuals ``stud (n,)``:
    where the spacing changes within a cell (a graded scan) the cell's median is the dense part's, while a
    vertex's neighbours share its spacing and so its quadric's model error; an outlier's neighbours stay at the
    noise."""
    return MAD_TO_SIGMA * _cell_median(stud[j], i, n)


def _fill(field: np.ndarray, valid: np.ndarray) -> np.ndarray:
    """``field (ny, nx)`` with every invalid cell set to its nearest valid cell's value."""
    if valid.all() or not valid.any():
        return field
    _, (iy, ix) = ndimage.distance_transform_edt(~valid, return_indices=True)
    return field[iy, ix]


class _Grid:
    """A square cell grid over the uv bounding box. The vertices of a cell with fewer than
    :data:`MIN_CELL_POINTS`, or spread too thin to fix a quadric (a sliver of the cell along the
    outline: the variance of their local coordinates across it below :data:`MIN_CELL_SPREAD`),
    join the nearest valid cell (in that cell's local coordinates)."""

    def __init__(self, uv: np.ndarray, step: float) -> None:
        self.origin, self.step = uv.min(0), step
        nx, ny = np.maximum(np.ceil((uv.max(0) - self.origin) / step), 1).astype(int)
        self.shape = (int(ny), int(nx))
        self.n = int(nx * ny)
        cell = _cell_index(uv, self.origin, step, self.shape)
        q = (uv - self.origin) / step - np.column_stack([cell % nx, cell // nx]) - 0.5
        cnt = np.maximum(np.bincount(cell, minlength=self.n), 1)
        mean = [np.bincount(cell, q[:, k], minlength=self.n) / cnt for k in range(2)]
        cov = [np.bincount(cell, q[:, a] * q[:, b], minlength=self.n) / cnt - mean[a] * mean[b]
               for a, b in ((0, 0), (0, 1), (1, 1))]
        tr, det = cov[0] + cov[2], cov[0] * cov[2] - cov[1] ** 2
        spread = 0.5 * tr - np.sqrt(np.maximum(0.25 * tr * tr - det, 0.0))  # smaller eigenvalue
        valid = ((np.bincount(cell, minlength=self.n) >= MIN_CELL_POINTS) & (spread >= MIN_CELL_SPREAD)
                 ).reshape(self.shape)
        self.valid = valid if valid.any() else np.ones(self.shape, bool)
        self.cell = _fill(np.arange(self.n).reshape(self.shape), self.valid).reshape(-1)[cell]
        ij = np.column_stack([self.cell % nx, self.cell // nx])
        local = (uv - self.origin) / step - ij - 0.5  # in [-0.5, 0.5]^2 inside the cell
        self.far = np.abs(local).max(1) > FAR_JOIN  # joined to a cell beyond the next: its fit extrapolates
        m4 = _monomials(local, _EXP4)
        self.m, self.m4 = m4[:, [_EXP4.index(e) for e in _EXP2]], m4
        self.count = np.bincount(self.cell, minlength=self.n)
        # cell-membership matrix: sums over cells are one sparse product (faster than a bincount per column)
        self.S = sp.csr_matrix((np.ones(uv.shape[0]), (self.cell, np.arange(uv.shape[0]))), shape=(self.n, uv.shape[0]))

    def fit(self, V: np.ndarray, w: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Weighted least-squares quadrics of ``V (n, 3)`` per cell, weights ``w (n,)``.

        Returns the coefficients ``(ncell, 6, 3)`` of ``V - ref``, the inverse normal
        matrices ``(ncell, 6, 6)`` (for the leverages) and ``ref (ncell, 3)``: the cell means.
        """
        n = V.shape[0]
        tot = np.maximum(self.S @ w, 1e-300)[:, None]
        ref = (self.S @ (w[:, None] * V)) / tot
        X = V - ref[self.cell]
        A = (self.S @ (w[:, None] * self.m4))[:, _AIDX]  # (ncell, 6, 6)
        P = np.empty((n, 6, 3))  # C order: the broadcast product would come out in another and copy on reshape
        np.multiply((w[:, None] * self.m)[:, :, None], X[:, None, :], out=P)
        B = (self.S @ P.reshape(n, 18)).reshape(-1, 6, 3)
        tr = np.trace(A, axis1=1, axis2=2)
        A += (RIDGE * np.maximum(tr, 1e-300))[:, None, None] * np.eye(6)
        Ainv = np.linalg.inv(A)
        return Ainv @ B, Ainv, ref

    def curvature(self, C: np.ndarray, Ainv: np.ndarray, noise: float) -> tuple[np.ndarray, float]:
        """``(ny, nx)`` RMS principal curvature of each cell's quadric at its centre, less the noise's share,
        and the median of that share (``kappa^2`` units).

        ``k1^2 + k2^2 = 4 H^2 - 2 K`` is biased up by the noise in the second-order
        coefficients: about ``noise^2 (4 a_33 + 2 a_44 + 4 a_55) / (E G - F^2)`` (``a`` the
        inverse normal matrix, ``E, F, G`` the first fundamental form), which is taken
        off. Invalid cells are filled from the nearest valid one; then a 3x3 median filter.
        """
        from trispline.fit.render.geometry import curvatures

        du, dv = C[:, 1], C[:, 2]
        H, K = curvatures(du, dv, 2 * C[:, 3], C[:, 4], 2 * C[:, 5])
        det = np.einsum("nd,nd->n", du, du) * np.einsum("nd,nd->n", dv, dv) - np.einsum("nd,nd->n", du, dv) ** 2
        with np.errstate(over="ignore", invalid="ignore"):  # a cell whose quadric is degenerate: left invalid
            bias = noise**2 * (4 * Ainv[:, 3, 3] + 2 * Ainv[:, 4, 4] + 4 * Ainv[:, 5, 5]) / np.maximum(det, 1e-300)
            kappa = np.sqrt(np.maximum(4 * H * H - 2 * K - bias, 0.0)).reshape(self.shape)
        valid = self.valid & np.isfinite(kappa) & np.isfinite(bias).reshape(self.shape)
        smooth = ndimage.median_filter(_fill(np.where(valid, kappa, 0.0), valid), size=3, mode="nearest")
        return smooth, float(np.median(bias[valid.reshape(-1)])) if valid.any() else 0.0


def _studentized(r: np.ndarray, lev: np.ndarray) -> np.ndarray:
    """``(k,)`` the studentized residuals ``|r| / sqrt(1 - h)`` of residuals ``r`` at leverages ``lev``."""
    return np.abs(r) / np.sqrt(np.maximum(1.0 - lev, LEVERAGE_FLOOR))


def _level(stud: np.ndarray, grid: _Grid, diagonal: float) -> np.ndarray:
    """``(k,)`` the local level of studentized residuals ``stud`` over ``grid``'s cells: the noise where
    there is noise, the quadric's model error where the data is exact (floored by the diagonal)."""
    return np.maximum(MAD_TO_SIGMA * _cell_median(stud, grid.cell, grid.n)[grid.cell], LEVEL_FLOOR * diagonal)


def _robust_fit(grid: _Grid, V: np.ndarray, diagonal: float) -> tuple[np.ndarray, ...]:
    """The robust quadric fits of ``grid``'s cells to ``V (k, 3)``: per vertex ``(r, nrm, loo, stud,
    level, w)``, the signed residual, the quadric's normal ``(k, 3)``, the leave-one-out and the
    studentized residual, the cell's level and the Cauchy weight of the last refit."""
    w = np.ones(V.shape[0])
    for _ in range(REFITS + 1):
        C, Ainv, ref = grid.fit(V, w)
        r, nrm, lev = _residuals(grid.m, V - ref[grid.cell], C, Ainv, grid.cell, w)
        # leave-one-out residuals r / (1 - h): a vertex the fit bends to (high leverage) is not hidden
        loo = r / np.maximum(1.0 - lev, LEVERAGE_FLOOR)
        stud = _studentized(r, lev)
        level = _level(stud, grid, diagonal)
        w = 1.0 / (1.0 + (loo / (CAUCHY_SCALE * level)) ** 2)
    return r, nrm, loo, stud, level, w


def _adaptive_fits(V: np.ndarray, uv: np.ndarray, step: float, diagonal: float) -> tuple[np.ndarray, ...]:
    """:func:`_robust_fit` per vertex on cells adapted to the map's local scale: a vertex whose cell
    holds more than :data:`SPLIT_POINTS` times :data:`POINTS_PER_CELL` (a region the map compresses:
    one uniform cell would span a large, curved part of the surface) is fitted again on a grid of half
    the step over those vertices alone, down to :data:`MAX_LEVELS` halvings or :data:`MAX_LEVEL_CELLS`
    times their count in cells; a vertex in a region too sparse for its cells (joined to a valid cell
    beyond :data:`FAR_JOIN`) on grids of twice the step until it is not."""
    n = V.shape[0]
    out = [np.empty(n), np.empty((n, 3)), np.empty(n), np.empty(n), np.empty(n), np.empty(n)]
    todo = np.arange(n)
    far = np.zeros(n, bool)
    for k in range(MAX_LEVELS + 1):
        grid = _Grid(uv[todo], step / 2**k)
        res = _robust_fit(grid, V[todo], diagonal)
        if k == 0:
            far = grid.far
        dense = grid.count[grid.cell] > SPLIT_POINTS * POINTS_PER_CELL
        nxt = todo[dense]
        span = np.ptp(uv[nxt], axis=0) if nxt.size else np.zeros(2)
        more = (k < MAX_LEVELS and nxt.size >= SPLIT_POINTS * POINTS_PER_CELL
                and np.prod(span / (step / 2 ** (k + 1)) + 1) <= MAX_LEVEL_CELLS * nxt.size)
        done = ~dense if more else np.ones(todo.size, bool)
        for o, x in zip(out, res):
            o[todo[done]] = x[done]
        if not more:
            break
        todo = nxt
    for k in range(1, MAX_LEVELS + 1):  # sparse regions: the vertices a fine cell could only extrapolate
        if not far.any():
            break
        grid = _Grid(uv, step * 2**k)
        res = _robust_fit(grid, V, diagonal)
        ok = far & ~grid.far
        for o, x in zip(out, res):
            o[ok] = x[ok]
        far &= grid.far
    return tuple(out)


def analyse_scan(V: np.ndarray, F: np.ndarray, uv: np.ndarray, *, curvature_points: int = CURVATURE_POINTS
                 ) -> ScanAnalysis:
    """Robust local quadric fits of the scan ``V (n, 3)``, ``F (m, 3)`` over its uv map ``uv (n, 2)``.

    Residuals and the noise come from cells of :data:`POINTS_PER_CELL` vertices; the
    curvature from cells of ``curvature_points`` vertices, fitted with the robust weights
    of the fine cells, or larger cells where the noise's share of the curvature would
    exceed :data:`CURVATURE_RESOLUTION` over the diagonal (a quadric's curvature over a
    cell of width ``L`` carries noise of about ``sigma / L^2``; at most ``n / 16`` a cell).
    """
    V = as_array(V, "V", (None, 3), finite=True, min_rows=3)
    uv = as_array(uv, "uv", (V.shape[0], 2), finite=True)
    F = as_array(F, "F", (None, 3), integer=True, min_rows=1)
    n = V.shape[0]
    auv = np.abs(signed_areas(uv, F))
    unit = float(np.sqrt(max(float(auv.sum()), 1e-300) / n))  # uv spacing of the scan
    diagonal = float(np.linalg.norm(V.max(0) - V.min(0)))
    r, nrm, loo, stud, level, w = _adaptive_fits(V, uv, unit * np.sqrt(POINTS_PER_CELL), diagonal)
    i, j, on_outline = _neighbour_pairs(F, n)
    outlier_level = np.maximum(level, _ring_level(stud, i, j, n))
    outlier = np.abs(loo) / np.maximum(outlier_level, 1e-300)
    spike = outlier > SPIKE_LEVELS  # ScanAnalysis.spike
    ring = spike[i]  # the edges from a spike
    noise = MAD_TO_SIGMA * float(np.median(stud))
    points = max(int(curvature_points), MIN_CELL_POINTS)
    for _ in range(2):  # a noisy scan needs larger cells: the noise's share falls like (points per cell)^-3
        coarse = _Grid(uv, unit * np.sqrt(points))
        C, Ainv, cref = coarse.fit(V, w)
        kappa, bias = coarse.curvature(C, Ainv, noise)
        target = (CURVATURE_RESOLUTION / max(diagonal, 1e-300)) ** 2
        if bias <= target or points >= n // 16:
            break
        points = int(min(points * (bias / target) ** (1.0 / 3.0), n // 16))
    rc, _, levc = _residuals(coarse.m, V - cref[coarse.cell], C, Ainv, coarse.cell, w)
    studc = _studentized(rc, levc)
    levelc = _level(studc, coarse, diagonal)
    fc = _cell_index(uv[F].mean(1), coarse.origin, coarse.step, coarse.shape)
    a3 = face_areas_3d(V, F)
    s3, suv = np.bincount(fc, a3, minlength=coarse.n), np.bincount(fc, auv, minlength=coarse.n)
    has = (suv > 0).reshape(coarse.shape)
    scale = _fill(np.sqrt(np.where(suv > 0, s3 / np.where(suv > 0, suv, 1.0), 0.0)).reshape(coarse.shape), has)
    cnt = np.bincount(_cell_index(uv, coarse.origin, coarse.step, coarse.shape), minlength=coarse.n)
    dense = (suv > 0) & (cnt > 0)
    scan_spacing = _fill(np.sqrt(np.where(dense, suv / np.maximum(cnt, 1), 0.0)).reshape(coarse.shape),
                         dense.reshape(coarse.shape))
    coarse_noise = MAD_TO_SIGMA * float(np.median(studc))
    return ScanAnalysis(residual=np.abs(loo), noise=noise, roughness=np.abs(loo) / np.maximum(level, 1e-300),
                        outlier=outlier, spike_ring=(i[ring], j[ring]),
                        spike_outline=np.flatnonzero(on_outline & spike),
                        smooth=V - r[:, None] * nrm, calm=studc / levelc,
                        cell=_cell_index(uv, coarse.origin, coarse.step, coarse.shape), origin=coarse.origin,
                        step=coarse.step, shape=coarse.shape, curvature=kappa, scale=scale, scan_spacing=scan_spacing,
                        area=s3.reshape(coarse.shape), diagonal=diagonal, points=V,
                        coarse_noise=coarse_noise,
                        noise_correlation=edge_correlation(np.clip(loo, -3 * noise, 3 * noise), F),
                        crease_edges=clean_crease_edges(V, F, noise_share(noise, coarse_noise)),
                        area_element=vertex_area_element(F, a3, auv, n))


def vertex_area_element(F: np.ndarray, area_3d: np.ndarray, area_uv: np.ndarray, n: int) -> np.ndarray:
    """``(n,)`` each vertex's 3D area of its faces ``F (m, 3)`` over their uv area (``area_3d``, ``area_uv (m,)``):
    the map's area element there (1 where the faces have no uv area)."""
    s3 = np.bincount(F.ravel(), np.repeat(area_3d, 3), minlength=n)
    s2 = np.bincount(F.ravel(), np.repeat(area_uv, 3), minlength=n)
    return np.where(s2 > 0, s3 / np.where(s2 > 0, s2, 1.0), 1.0)


def noise_share(noise: float, coarse_noise: float) -> float:
    """:attr:`ScanAnalysis.noise_share` of the two noise estimates: ``(noise / coarse_noise)^2``, at most 1."""
    return float(min(1.0, (noise / max(coarse_noise, 1e-300)) ** 2))


def edge_correlation(x: np.ndarray, F: np.ndarray) -> float:
    """Pearson correlation ``[-1, 1]`` of ``x (n,)`` at the two ends of the edges of ``F (m, 3)`` (each
    undirected edge of a face once per face). Measured on the residuals of :func:`analyse_scan`: Gaussian
    noise -0.09 (2,500 and 50,000 vertices, sigma 1e-4 and 1e-3 of the diagonal), the shared real scans
    +0.26 (lilium, snail) to +0.66 (camelhead), clean generated scans +0.30."""
    e = np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]])
    a, b = x[e[:, 0]] - x.mean(), x[e[:, 1]] - x.mean()
    return float(np.mean(a * b) / max(float(np.sqrt(np.mean(a * a) * np.mean(b * b))), 1e-300))
