"""The coarse control triangulation of a dense scan, in the scan's own uv domain.

    dom = coarse_domain(V, F, uv, n_vertices=2000)   # CoarseDomain
    dom.uv, dom.faces, dom.vertices                  # (k, 2), (f, 3) counter-clockwise, (k,) scan vertex ids
    dom.stats                                        # DomainStats: counts, the minimum angle, the noise
    hit = dom.locate_scan()                          # every scan vertex in the coarse domain (Located)
    dom = insert(dom, new_ids)                       # the refinement step: more scan vertices, re-triangulated

Every coarse vertex is a scan vertex (``uv == scan_uv[vertices]``), so a spline
corner point can interpolate its data vertex. How the vertices are chosen:

1. :func:`~.analysis.analyse_scan` fits robust quadrics over a uv cell grid: each
   vertex's residual and roughness (noise, spikes), the noise level and, on a
   coarser grid, the curvature of the data.
2. A sizing field: vertex density per 3D area proportional to
   ``(kappa + kappa_0) ** adapt`` with ``kappa_0`` the larger of the median
   curvature and one over the diagonal (denser where the data bends; the spacing
   within :data:`GRADING` times the median's either way), scaled to the vertex
   budget or to the given spacing, turned into a uv spacing by the cell's 3D/uv scale.
3. The boundary loops are thinned (:mod:`.boundary`): corners kept, straight
   runs spaced, curved runs kept within a sagitta.
4. Triangle (Shewchuk's, the ``triangle`` wheel; :mod:`.cdt`) fills the interior
   with a quality mesh: switches ``p`` (the boundary chords as segments, holes marked by
   a seed inside each), ``Y`` (no point inserted on a boundary segment), ``q``
   (minimum angle :data:`QUALITY_ANGLE`), ``a`` with per-triangle areas from the
   sizing field, refined a few rounds (``r``); the density is recalibrated until the
   count meets the budget (within 3%, an excess trimmed).
5. Each point Triangle added is snapped to a scan vertex within
   :data:`SNAP_RADIUS` local spacings (less near the boundary), the one of smallest
   ``(distance / radius)^2 + s (calm / SNAP_CALM)^2`` (near, and smooth where the scan is noisy:
   ``s`` is :attr:`~.analysis.ScanAnalysis.noise_share`, ~0 on clean or creased data, where a vertex
   off its local quadric is a crease the spline needs; never a spike:
   :attr:`~.analysis.ScanAnalysis.roughness`), inside the coarse polygon
   and not much nearer to its boundary than the point was (:data:`SNAP_CLEARANCE`).
6. The kept scan vertices are triangulated once more with ``p`` alone: a
   constrained Delaunay triangulation that inserts no point (checked: a chord
   crossing another would make Triangle insert one; its run then keeps one more
   scan vertex and the triangulation is repeated).
7. A few rounds of :func:`~.quality.better_vertices` move interior vertices of
   faces with a small angle to nearby smooth scan vertices where that widens
   their smallest angle, each round re-triangulated.

8. Every triangulation (the first and each :func:`insert`'s) has its interior edges flipped toward
   the data (:func:`~.flips.flip_to_data`): an edge whose quad the linear interpolant of the
   coarse vertices fits markedly better across the other diagonal, with a uv angle bound, so that
   coarse edges run along the scan's creases instead of across them (alone: beetle at 2%,
   ``corners="data"``, d>m RMS 2.49e-4 -> 2.35e-4, camelhead 7.6e-4 -> 6.6e-4; with the snap's and
   refinement's calm preferences weighed by the noise share: beetle 2.30e-4, camelhead 4.8e-4).

9. On a clean scan with creases (:mod:`.creases`: chains of scan edges of dihedral angle over
   :data:`~.creases.CREASE_ANGLE`), pairs of scan vertices one target spacing apart along each crease,
   one on each side a small fraction of the spacing off it, join the vertices first (within the budget;
   interior vertices near them give way), their sides constrained segments of every triangulation
   (never flipped): a thin strip of patches carries the bend that an
   isotropic domain's patches round over their whole width (beetle at 2%, ``corners="data"``: the
   crease vertices' d>m RMS 8.0e-4 -> 5.4e-4 of the diagonal, all of them 2.30e-4 -> 2.04e-4).

The fit locates the scan at :attr:`CoarseDomain.warped_uv`: its uv with the outline moved onto the
boundary chords (:mod:`.warp`). Scan vertices still outside the coarse polygon (between a boundary
chord and the scan's outline) are located by clamping them to the nearest boundary point
(:class:`~.locate.ClampedLocator`); ``Located.clamped`` says which.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property

import numpy as np
import scipy.sparse as sp
from scipy.spatial import cKDTree

from trispline.spline.checks import as_array, check_ids
from trispline.spline.errors import InputError, TriangulationError
from trispline.param import face_areas_3d, face_aspects, loop_successors, polygon_area, segment_crossings
from trispline.spline.tolerances import MAX_DOMAIN_ASPECT
from trispline.spline.topology import Triangulation, signed_areas

from .analysis import SPIKE_LEVELS, ScanAnalysis, analyse_scan
from .boundary import CORNER_ANGLE, thin_loop
from .creases import Strips, crease_strips
from .flips import flip_to_data
from .cdt import constrained, hole_seeds, loop_segments, quality_mesh
from .locate import ClampedLocator, Located
from .quality import REPAIR_ROUNDS, better_vertices, face_angles

__all__ = ["BoundaryBudgetError", "CoarseDomain", "LostHolesError", "TangledOutlineError", "DomainStats", "coarse_domain", "coarse_index", "insert", "separation", "ADAPT",
           "DEFAULT_FRACTION",
           "MIN_SEPARATION"]

#: Default vertex budget as a fraction of the scan's vertices.
DEFAULT_FRACTION = 0.02
#: Default exponent of the curvature in the vertex density (0: uniform in 3D).
ADAPT = 0.5
#: Largest ratio of the local spacing to the median spacing, either way (the density's: its square).
GRADING = 3.0
#: The target spacing stays at least this many scan spacings (finer, the snap to scan vertices spoils angles).
MIN_SCAN_SPACINGS = 2.5
#: Smoothing steps (half self, half the neighbours' mean, in logs) of the scan's local 3D/uv scale and spacing.
LOCAL_SCALE_SMOOTHING = 3
#: Minimum angle (degrees) asked of Triangle's quality mesh before the snap.
QUALITY_ANGLE = 28.0
#: Triangle's largest area per vertex spacing ``h``: this times the equilateral ``sqrt(3)/4 h^2``.
AREA_FACTOR = 1.6
#: Rounds of area refinement (``r``) after the first quality mesh.
REFINE_ROUNDS = 4
#: Smallest curvature cell (scan vertices); else about four coarse vertices' worth.
MIN_CURVATURE_POINTS = 64
#: Passes of budget calibration (the vertex count scales the density).
BUDGET_PASSES = 3
#: A Triangle point snaps to a scan vertex at most this many local spacings away (or to the nearest one).
SNAP_RADIUS = 0.3
#: ... inside the coarse polygon, at least this times the Triangle point's distance from its boundary.
SNAP_CLEARANCE = 0.5
#: The snap's score weighs ``(calm / SNAP_CALM)^2`` against ``(distance / radius)^2``.
SNAP_CALM = 0.5
#: Scan vertices considered per Triangle point.
SNAP_CANDIDATES = 16
#: Default of :func:`insert`'s ``min_separation`` (in face sizes).
MIN_SEPARATION = 0.2
#: Rounds of splitting chords that cross (each needs one more boundary vertex).
CROSSING_ROUNDS = 8
#: An interior vertex nearer than this many local spacings to a crease strip's vertex gives way to the strip.
STRIP_CLEARANCE = 0.5


@dataclass(frozen=True)
class DomainStats:
    """Counts and quality of a coarse domain.

    min_angle, mean_min_angle : the smallest face angle and the mean of each face's smallest (degrees)
    noise : the scan's robust noise estimate (model units); spacing : the median target spacing (3D)
    noise_correlation : of neighbouring vertices' residuals (:attr:`~.analysis.ScanAnalysis.noise_correlation`):
        about -0.1 where ``noise`` is noise, above 0.25 where it is the local quadrics' model error
    """

    n_vertices: int
    n_faces: int
    n_boundary: int
    n_corners: int
    n_holes: int
    n_scan: int
    min_angle: float
    mean_min_angle: float
    noise: float
    spacing: float
    noise_correlation: float = 0.0


@dataclass(frozen=True, eq=False)
class CoarseDomain:
    """A planar triangulation on a subset of a scan's vertices.

    uv : (k, 2) float64, ``scan_uv[vertices]``; faces : (f, 3) int64, counter-clockwise
    vertices : (k,) int64 scan vertex ids, the boundary loops' first (in loop order), then the interior
    boundary : tuple of (b_i,) scan ids kept on each scan boundary loop, in loop order
    corners : (c,) scan ids of the outline's corners (all kept)
    loops : tuple of (L_i,) the scan's boundary loops (domain on the left)
    scan_uv : (n, 2) the scan's uv (not copied)
    stats : DomainStats
    analysis : the :class:`ScanAnalysis` the vertices were chosen with
    creases : (s, 2) scan ids, the constrained segments along the sides of the crease strips
        (:mod:`.creases`; empty without creases): edges of the triangulation that never flip
    scan_faces : (m, 3) the scan's faces, counter-clockwise in ``scan_uv`` (what :attr:`warped_uv` needs), or None
    """

    uv: np.ndarray
    faces: np.ndarray
    vertices: np.ndarray
    boundary: tuple[np.ndarray, ...]
    corners: np.ndarray
    loops: tuple[np.ndarray, ...]
    scan_uv: np.ndarray
    stats: DomainStats
    analysis: ScanAnalysis
    creases: np.ndarray = field(default_factory=lambda: np.empty((0, 2), np.int64))
    scan_faces: np.ndarray | None = None

    @cached_property
    def warped_uv(self) -> np.ndarray:
        """``(n, 2)`` the scan's parameters in this domain: ``scan_uv`` with the outline on the boundary
        chords (:func:`~.warp.outline_warp`; ``scan_uv`` itself without ``scan_faces`` or with
        :data:`~.warp.OUTLINE_WARP` off). The coarse vertices keep their uv."""
        from .warp import outline_warp

        return outline_warp(self) if self.warped else self.scan_uv

    @property
    def warped(self) -> bool:
        """Whether the scan's parameters follow the boundary chords (:attr:`warped_uv`): the scan's faces known
        and :data:`~.warp.OUTLINE_WARP` on."""
        from .warp import OUTLINE_WARP

        return OUTLINE_WARP and self.scan_faces is not None

    @cached_property
    def outline_ids(self) -> np.ndarray:
        """``(b,)`` the scan's boundary vertices, loop after loop (:attr:`loops` joined)."""
        return np.concatenate(self.loops) if self.loops else np.empty(0, np.int64)

    @cached_property
    def triangulation(self) -> Triangulation:
        """The validated :class:`Triangulation` (what ``build_space`` takes)."""
        return Triangulation(self.uv, self.faces)

    @cached_property
    def locator(self) -> ClampedLocator:
        """The :class:`ClampedLocator` of the coarse domain (cached)."""
        return ClampedLocator(self.uv, self.faces, triangulation=self.triangulation)

    def locate(self, points: np.ndarray) -> Located:
        """Faces and barycentric coordinates of uv ``points (m, 2)``; points outside are clamped."""
        return self.locator(points)

    def locate_scan(self) -> Located:
        """Every scan vertex located in the coarse domain (``(n,)`` rows)."""
        return self.locator(self.scan_uv)


class _Sizing:
    """Target vertex spacing over the uv domain: density ``lam * w`` per 3D area, ``w`` from the curvature
    (per cell), turned into uv by the scan's own 3D/uv scale at the nearest scan vertex (a cell of a map
    with extreme area distortion, like camelhead's 8e4, holds regions of very different scales)."""

    def __init__(self, a: ScanAnalysis, adapt: float, local: "_LocalScale") -> None:
        k = a.curvature
        has = a.area > 0
        floor = max(float(np.median(k[has])) if has.any() else 0.0, 1.0 / max(a.diagonal, 1e-300))
        w = (k + floor) ** adapt
        wm = float(np.median(w[has])) if has.any() else 1.0
        self.w = np.clip(w, wm / GRADING**2, wm * GRADING**2)
        self.w_median, self.a, self.local = wm, a, local

    def lam_for_count(self, n: float) -> float:
        """Density scale giving about ``n`` vertices over the scan."""
        return n / max(float((self.w * self.a.area).sum()), 1e-300)

    def lam_for_spacing(self, spacing: float) -> float:
        """Density scale giving the spacing ``spacing`` (3D) where the weight is the median."""
        return 2.0 / (np.sqrt(3.0) * spacing**2) / self.w_median

    def spacing3d(self, lam: float, points: np.ndarray) -> np.ndarray:
        """Target 3D spacing ``(m,)`` at uv ``points (m, 2)``: an equilateral mesh of that density."""
        return np.sqrt(2.0 / (np.sqrt(3.0) * lam * self.a.lookup(self.w, points)))

    def spacing(self, lam: float, points: np.ndarray) -> np.ndarray:
        """Target uv spacing ``(m,)`` at uv ``points (m, 2)``, never below :data:`MIN_SCAN_SPACINGS` of the scan's."""
        scale, scan_spacing = self.local(points)
        return np.maximum(self.spacing3d(lam, points) / scale, MIN_SCAN_SPACINGS * scan_spacing)


class _LocalScale:
    """The scan's 3D length per uv length and its own uv vertex spacing at its vertices (over each vertex's
    fan, geometric means over the neighbours a few times), looked up at the nearest scan vertex."""

    def __init__(self, V: np.ndarray, F: np.ndarray, uv: np.ndarray, tree: cKDTree) -> None:
        n = uv.shape[0]
        a3 = np.bincount(F.ravel(), np.repeat(face_areas_3d(V, F), 3), minlength=n)
        auv = np.bincount(F.ravel(), np.repeat(np.abs(signed_areas(uv, F)), 3), minlength=n)
        ok = (a3 > 0) & (auv > 0)
        fields = np.log(np.column_stack([np.sqrt(np.where(ok, a3, 1.0) / np.where(ok, auv, 1.0)),
                                         np.sqrt(np.where(ok, auv, 1.0) / 3.0)]))
        fields[~ok] = np.median(fields[ok], axis=0) if ok.any() else 0.0
        e = np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]])
        A = sp.csr_matrix((np.ones(2 * e.shape[0]), (e.ravel(), e[:, ::-1].ravel())), shape=(n, n))
        deg = np.maximum(np.asarray(A.sum(1)).ravel(), 1.0)[:, None]
        for _ in range(LOCAL_SCALE_SMOOTHING):
            fields = 0.5 * fields + 0.5 * (A @ fields) / deg
        self.scale, self.scan_spacing = np.exp(fields[:, 0]), np.exp(fields[:, 1])
        self.tree = tree

    def __call__(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(scale (m,), scan_spacing (m,))`` at uv ``points (m, 2)``."""
        i = self.tree.query(np.asarray(points, np.float64))[1]
        return self.scale[i], self.scan_spacing[i]


def _thin_boundary(loops: tuple[np.ndarray, ...], uv: np.ndarray, sizing: _Sizing, lam: float,
                   corner_angle: float) -> tuple[list[np.ndarray], np.ndarray]:
    """Kept scan ids of every loop, and all corners (3D turns measured on the denoised scan)."""
    kept, corners = [], []
    for loop in loops:
        p = uv[loop]
        k, c = thin_loop(loop, uv, sizing.a.smooth, sizing.spacing(lam, p), sizing.local(p)[0],
                         sizing.a.roughness, corner_angle=corner_angle)
        kept.append(k)
        corners.append(c)
    return kept, np.concatenate(corners)


def _quality_mesh(P: np.ndarray, segments: np.ndarray, holes: np.ndarray, sizing: _Sizing, lam: float
                  ) -> tuple[np.ndarray, np.ndarray]:
    """Triangle's graded quality mesh inside the boundary ``P (b, 2)``; see :func:`~.cdt.quality_mesh`."""
    def area(pts: np.ndarray) -> np.ndarray:
        return AREA_FACTOR * np.sqrt(3.0) / 4.0 * sizing.spacing(lam, pts) ** 2

    return quality_mesh(P, segments, holes, area, QUALITY_ANGLE, REFINE_ROUNDS)


class BoundaryBudgetError(InputError):
    """A vertex budget below what the scan's outline needs; ``needed``: the vertices it took at the coarsest
    spacing tried (the corners kept depend on the spacing, so no floor is known before the passes)."""

    def __init__(self, budget: int, needed: int, corners: int, loops: int) -> None:
        kept = f"{corners} corner{'s' * (corners != 1)}, {loops} loop{'s' * (loops != 1)}"
        super().__init__(f"a budget of {budget} vertices is below what the boundary needs: it took {needed} "
                         f"vertices ({kept}) at the coarsest spacing tried")
        self.budget, self.needed = budget, needed


class LostHolesError(InputError):
    """The coarse domain's constrained triangulation filled holes of the scan; ``lost``: those loops (scan
    ids, the surface on the left), for a caller that can span them (:mod:`.holes`)."""

    def __init__(self, message: str, lost: list[np.ndarray]) -> None:
        super().__init__(message)
        self.lost = lost


class TangledOutlineError(InputError):
    """The boundary chords of the coarse domain kept crossing the scan's own outline: its map's outline touches
    or crosses itself where no vertex can be added between (two of its edges, e.g. beside a vertex that a repair
    split in two, meet in uv). A map with a convex outline (the harmonic one) has no such place."""


class _ScanIndex:
    """A KD-tree over the scan's uv, for snapping Triangle's points to scan vertices."""

    def __init__(self, uv: np.ndarray, loops: tuple[np.ndarray, ...]) -> None:
        self.uv = uv
        self.tree = cKDTree(uv)
        self.on_boundary = np.zeros(uv.shape[0], bool)
        self.on_boundary[np.concatenate(loops)] = True

    def snap(self, mesh: tuple[np.ndarray, np.ndarray], nb: int, spacing: np.ndarray, roughness: np.ndarray,
             calm: np.ndarray, share: float = 1.0) -> np.ndarray:
        """Scan ids ``(<= s,)`` for the points Triangle added (``mesh[0][nb:]``); module docstring, step 5.

        A candidate must lie inside the coarse polygon (the quality mesh covers it exactly)
        at least :data:`SNAP_CLEARANCE` times the Triangle point's own distance from the
        boundary chords, and off the scan's outline.
        """
        points = mesh[0][nb:]
        if points.shape[0] == 0:
            return np.empty(0, np.int64)
        k = min(SNAP_CANDIDATES, self.uv.shape[0])
        dist, cand = self.tree.query(points, k=k)
        dist, cand = dist.reshape(-1, k), cand.reshape(-1, k)
        poly = ClampedLocator(*mesh)
        gap = np.linalg.norm(poly.project(points)[2] - points, axis=1)  # Triangle point to the chords
        radius = SNAP_RADIUS * np.minimum(spacing, 2.0 * gap)[:, None]
        near = ((dist <= radius) | (np.arange(k) == 0)) & ~self.on_boundary[cand]
        near &= roughness[cand] <= SPIKE_LEVELS  # never a spike
        ok = np.zeros(cand.shape, bool)
        c = self.uv[cand[near]]
        inside = poly.locator(c)[0] >= 0
        ok[near] = inside & (np.linalg.norm(poly.project(c)[2] - c, axis=1) >= SNAP_CLEARANCE * np.broadcast_to(
            gap[:, None], cand.shape)[near])
        score = np.where(ok, (dist / radius) ** 2 + share * (calm[cand] / SNAP_CALM) ** 2, np.inf)
        j = np.argmin(score, axis=1)
        rows = np.arange(points.shape[0])
        good = np.isfinite(score[rows, j])
        return np.unique(cand[rows, j][good])


def _crossed(P: np.ndarray, segments: np.ndarray, extra: np.ndarray) -> np.ndarray:
    """Indices of the segments on which Triangle put the points ``extra (e, 2)`` (crossings)."""
    from .locate import segment_foot

    a, b = P[segments[:, 0]], P[segments[:, 1]]
    _, foot = segment_foot(extra[:, None, :], a[None], b[None])
    d = np.linalg.norm(foot - extra[:, None, :], axis=2)
    scale = np.linalg.norm(b - a, axis=1)[None, :]
    return np.unique(np.flatnonzero((d <= 1e-9 * scale + 1e-300).any(0)))


#: A chord may cross the scan's outline next to its own ends (a jagged outline) within this many of its
#: segments; farther away it has left the domain (:func:`_leaving_chords`).
CHORD_END_SEGMENTS = 2


def _leaving_chords(uv: np.ndarray, boundary: list[np.ndarray], loops: tuple[np.ndarray, ...],
                    position: np.ndarray) -> np.ndarray:
    """Stacked ids of the chords between consecutive kept vertices (``boundary``, scan ids) that cross the
    scan's own outline (``loops``; ``position (n,)`` each scan vertex's place in its loop) away from the run
    they replace and its ends: such a chord cuts across a hole or the gap between the turns of a wound
    strip, where a crossing with another chord need not show it (the thinned runs there cross nothing)."""
    fine = np.concatenate(loops)
    fine_next = fine[loop_successors([l.size for l in loops])]
    fine_loop = np.repeat(np.arange(len(loops)), [l.size for l in loops])
    kept = np.concatenate(boundary)
    kept_next = kept[loop_successors([b.size for b in boundary])]
    kept_loop = np.repeat(np.arange(len(boundary)), [b.size for b in boundary])
    c, f = segment_crossings(uv[kept], uv[kept_next], uv[fine], uv[fine_next])
    size = np.array([l.size for l in loops])[kept_loop[c]]
    p0, p1, q = position[kept[c]], position[kept_next[c]], position[fine[f]]
    run = np.where((p1 - p0) % size == 0, size, (p1 - p0) % size)  # a loop of one chord: the whole loop
    own = (kept_loop[c] == fine_loop[f]) & (((q - p0) % size < run) | ((p0 - q) % size <= CHORD_END_SEGMENTS)
                                            | ((q - p1) % size < CHORD_END_SEGMENTS))
    return np.unique(c[~own])


def _chords_past_holes(uv: np.ndarray, boundary: list[np.ndarray]) -> np.ndarray:
    """Stacked ids of the outer loop's chords (the kept loop of largest area) nearest to the kept vertices of
    other loops that lie outside its polygon: a chord that cut off a hole next to the outline along with
    the run it replaced (halftunnel thinned to 16 vertices: a hole of three vertices outside a triangle)."""
    if len(boundary) < 2:
        return np.zeros(0, np.int64)
    polys = [uv[b] for b in boundary]
    outer = int(np.argmax([polygon_area(p) for p in polys]))
    a, b = polys[outer], np.roll(polys[outer], -1, axis=0)
    pts = np.concatenate([p for k, p in enumerate(polys) if k != outer])
    # even-odd rule: crossings of a ray to +u with the outer polygon's edges
    straddle = (a[None, :, 1] > pts[:, None, 1]) != (b[None, :, 1] > pts[:, None, 1])
    with np.errstate(divide="ignore", invalid="ignore"):
        x = a[None, :, 0] + (pts[:, None, 1] - a[None, :, 1]) * (b - a)[None, :, 0] / (b - a)[None, :, 1]
    outside = (np.count_nonzero(straddle & (x > pts[:, None, 0]), axis=1) % 2) == 0
    if not outside.any():
        return np.zeros(0, np.int64)
    from .locate import segment_foot

    q = pts[outside][:, None, :]
    _, foot = segment_foot(q, a[None], b[None])
    nearest = np.argmin(np.linalg.norm(foot - q, axis=2), axis=1)
    return np.unique(nearest) + sum(bd.size for bd in boundary[:outer])


def _loop_chords(boundary: list[np.ndarray], which: np.ndarray) -> np.ndarray:
    """The stacked segment ids (as :func:`~.cdt.loop_segments` numbers them) of every chord of the loops
    ``which``."""
    base = np.cumsum([0] + [b.size for b in boundary])
    return np.concatenate([np.arange(base[i], base[i + 1]) for i in which] or [np.zeros(0, np.int64)])


def _split_runs(boundary: list[np.ndarray], loops: tuple[np.ndarray, ...], position: np.ndarray,
                chords: np.ndarray) -> list[np.ndarray]:
    """Each loop's kept ids plus, for every chord in ``chords`` (stacked segment ids), the
    scan loop vertex halfway along its run."""
    out, base = [], 0
    for kept, loop in zip(boundary, loops):
        mine = chords[(chords >= base) & (chords < base + kept.size)] - base
        pos = position[kept]
        nxt = np.roll(pos, -1)
        nxt = np.where(nxt <= pos, nxt + loop.size, nxt)
        mid = ((pos[mine] + nxt[mine]) // 2) % loop.size
        add = mid[(nxt[mine] - pos[mine]) > 1]
        out.append(loop[np.unique(np.concatenate([pos, add]))])
        base += kept.size
    return out


def _triangulate(uv: np.ndarray, boundary: list[np.ndarray], interior: np.ndarray, loops: tuple[np.ndarray, ...],
                 position: np.ndarray, creases: np.ndarray | None = None
                 ) -> tuple[list[np.ndarray], np.ndarray, np.ndarray, np.ndarray]:
    """Constrained Delaunay triangulation of kept scan vertices, inserting none.

    ``creases (s, 2)``: scan ids of more constrained segments (their vertices among ``interior``); one
    that crosses another segment is dropped. Returns the (possibly split) boundary, the vertex ids
    ``(k,)`` (boundary first), the faces ``(f, 3)`` counter-clockwise, unused interior vertices
    dropped, and the crease segments kept ``(s', 2)`` (scan ids).
    """
    creases = np.empty((0, 2), np.int64) if creases is None else creases
    for _ in range(CROSSING_ROUNDS):
        ids = np.concatenate([*boundary, interior])
        P = uv[ids]
        outline = loop_segments([b.size for b in boundary])
        local = coarse_index(ids, uv.shape[0])
        creases = creases[(local[creases] >= 0).all(1)]
        segments = np.concatenate([outline, local[creases]])
        leaving = np.union1d(_leaving_chords(uv, boundary, loops, position), _chords_past_holes(uv, boundary))
        if leaving.size:  # a chord across another part of the outline (a spiral strip's turns), or past a hole
            boundary = _split_runs(boundary, loops, position, leaving)
            continue
        faces, extra = constrained(P, segments, hole_seeds([uv[b] for b in boundary]))
        if not len(faces):  # Triangle ate every triangle: the thinned outline encloses nothing the right way
            boundary = _split_runs(boundary, loops, position, _loop_chords(boundary, np.arange(len(boundary))))
            continue
        if extra.shape[0] == 0:
            break
        crossed = _crossed(P, segments, extra)
        creases = np.delete(creases, crossed[crossed >= outline.shape[0]] - outline.shape[0], axis=0)
        boundary = _split_runs(boundary, loops, position, crossed[crossed < outline.shape[0]])
    else:
        raise TangledOutlineError("the coarse domain's boundary chords still cross after "
                                  f"{CROSSING_ROUNDS} rounds of splitting; the uv map's outline may touch itself")
    used = np.zeros(ids.size, bool)
    used[faces.ravel()] = True
    remap = np.cumsum(used) - 1
    return boundary, ids[used], remap[faces], creases


def _domain(scan_uv: np.ndarray, boundary: list[np.ndarray], interior: np.ndarray, corners: np.ndarray,
            loops: tuple[np.ndarray, ...], position: np.ndarray, analysis: ScanAnalysis, spacing: float,
            creases: np.ndarray | None = None, scan_faces: np.ndarray | None = None) -> CoarseDomain:
    """Triangulate (with the crease strips' segments ``creases (s, 2)``, scan ids), validate and collect the
    statistics; ``scan_faces (m, 3)``: the scan's faces (kept for :attr:`CoarseDomain.warped_uv`)."""
    boundary, ids, faces, creases = _triangulate(scan_uv, boundary, interior, loops, position, creases)
    uv = np.ascontiguousarray(scan_uv[ids])
    data = np.where(analysis.spike[:, None], analysis.smooth, analysis.points)  # spikes judge nothing
    faces = flip_to_data(uv, faces, data[ids], scan_uv, data, fixed=coarse_index(ids, scan_uv.shape[0])[creases])
    try:
        tri = Triangulation(uv, faces)
    except TriangulationError as exc:
        raise InputError(f"the coarse domain on {ids.size} scan vertices is not a valid triangulation ({exc}); "
                         "the vertex budget may be too small for the scan's outline and holes") from None
    if len(tri.boundary_loops) != len(loops):
        kept = {frozenset(ids[c].tolist()) for c in tri.boundary_loops}
        lost = [loop for loop, b in zip(loops, boundary) if frozenset(b.tolist()) not in kept]
        raise LostHolesError(f"the coarse domain on {ids.size} scan vertices has {len(tri.boundary_loops)} boundary "
                             f"loops, the scan {len(loops)}; the vertex budget may be too small for its outline and "
                             "holes", lost)
    aspect = face_aspects(uv, faces)
    if not aspect.max() <= MAX_DOMAIN_ASPECT:  # the scan's map is nearly degenerate: no fit is defined on it
        raise InputError(f"the scan's parameterization is too thin for a coarse domain: its triangles over {ids.size} "
                         f"scan vertices reach longest edge / height {aspect.max():.3g} (at most "
                         f"{MAX_DOMAIN_ASPECT:g}); is the scan a strip of nearly zero width?")
    ang = face_angles(uv, faces)
    nb = int(sum(b.size for b in boundary))
    stats = DomainStats(n_vertices=int(ids.size), n_faces=int(faces.shape[0]), n_boundary=nb,
                        n_corners=int(corners.size), n_holes=len(boundary) - 1, n_scan=int(scan_uv.shape[0]),
                        min_angle=float(ang.min()), mean_min_angle=float(ang.min(1).mean()),
                        noise=analysis.noise, spacing=float(spacing), noise_correlation=analysis.noise_correlation)
    for a in (uv, faces, ids, corners, creases, *boundary):
        a.setflags(write=False)
    dom = CoarseDomain(uv=uv, faces=faces, vertices=ids, boundary=tuple(boundary), corners=corners,
                       loops=loops, scan_uv=scan_uv, stats=stats, analysis=analysis, creases=creases,
                       scan_faces=scan_faces)
    dom.__dict__["triangulation"] = tri  # the cached property, already validated
    return dom


def coarse_index(ids: np.ndarray, n: int) -> np.ndarray:
    """``(n,)`` each scan vertex's position in ``ids (k,)`` (its coarse vertex id), -1 for the others."""
    local = np.full(n, -1, np.int64)
    local[ids] = np.arange(ids.size)
    return local


def _loop_position(loops: tuple[np.ndarray, ...], n: int) -> np.ndarray:
    """``(n,)`` position of each scan vertex in its boundary loop; -1 for interior vertices."""
    pos = np.full(n, -1, np.int64)
    for loop in loops:
        pos[loop] = np.arange(loop.size)
    return pos


def coarse_domain(V: np.ndarray, F: np.ndarray, uv: np.ndarray, *, n_vertices: int | None = None,
                  spacing: float | None = None, adapt: float = ADAPT, corner_angle: float = CORNER_ANGLE,
                  creases: bool = True, warp: bool = True) -> CoarseDomain:
    """Choose and triangulate a subset of the scan's vertices; see the module docstring.

    Parameters
    ----------
    V : (n, 3) scan vertices; F : (m, 3) faces, counter-clockwise in ``uv``; uv : (n, 2) fold-free
        planar map of the scan (e.g. ``parameterize(V, F, "lscm")``'s ``uv`` and ``faces``)
    n_vertices : vertex budget (the result has at most this many); default
        :data:`DEFAULT_FRACTION` of the scan when ``spacing`` is not given either
    spacing : target 3D spacing where the curvature weight is the median (with a budget too,
        the budget caps the count)
    adapt : exponent of the curvature in the density (0: uniform spacing in 3D)
    corner_angle : turn of the outline (degrees) kept as a corner
    creases : thin strips of patches along the scan's creases (:mod:`.creases`; clean scans only)
    warp : the scan's parameters follow the boundary chords (:attr:`CoarseDomain.warped_uv`; off for a
        caller's own uv, at which the surface is to be evaluated)

    Raises
    ------
    InputError
        Bad arrays, a non-positive budget or spacing, or a budget below what the
        boundary needs (the message names both counts).
    """
    V = as_array(V, "V", (None, 3), finite=True, min_rows=3)
    uv = as_array(uv, "uv", (V.shape[0], 2), finite=True)
    F = check_ids(as_array(F, "F", (None, 3), integer=True, min_rows=1), "F", V.shape[0])
    n = V.shape[0]
    if spacing is not None and not (np.isfinite(spacing) and spacing > 0):
        raise InputError(f"spacing must be finite and > 0, got {spacing}")
    if n_vertices is None and spacing is None:
        n_vertices = max(16, int(round(DEFAULT_FRACTION * n)))
    if n_vertices is not None and not (int(n_vertices) == n_vertices and 3 <= n_vertices):
        raise InputError(f"n_vertices must be an integer >= 3, got {n_vertices}")
    if not (np.isfinite(adapt) and adapt >= 0):
        raise InputError(f"adapt must be finite and >= 0, got {adapt}")
    if not (0 < corner_angle < 180):
        raise InputError(f"corner_angle must be in (0, 180) degrees, got {corner_angle}")
    loops = tuple(Triangulation(uv, F).boundary_loops)
    if not loops:
        raise InputError("the scan has no boundary loop; coarse domains are for open scans")
    per_vertex = n / n_vertices if n_vertices is not None else 1.0
    a = analyse_scan(V, F, uv, curvature_points=max(MIN_CURVATURE_POINTS, int(4 * per_vertex)))
    index = _ScanIndex(uv, loops)
    sizing = _Sizing(a, adapt, _LocalScale(a.smooth, F, uv, index.tree))  # denoised: a spike is no large face
    lam = sizing.lam_for_spacing(spacing) if spacing is not None else sizing.lam_for_count(n_vertices)
    position = _loop_position(loops, n)
    strips = crease_strips(V, F, uv, a, sizing, lam, index.tree, index.on_boundary) if creases else Strips.empty()
    budget = None if n_vertices is None else max(3, n_vertices - strips.vertices.size)
    boundary, interior, corners, lam = _choose(uv, loops, sizing, lam, budget, corner_angle, index, position)
    interior = _with_strips(uv, interior, strips, sizing, lam)
    allowed = ~index.on_boundary & ~a.spike
    fixed = np.isin(np.arange(n), strips.vertices)
    segments = strips.segments
    for _ in range(REPAIR_ROUNDS):
        boundary, ids, faces, segments = _triangulate(uv, boundary, interior, loops, position, segments)
        nb = sum(b.size for b in boundary)
        moved = better_vertices(uv, index.tree, ids, faces, (np.arange(ids.size) >= nb) & ~fixed[ids], allowed)
        if (moved == ids).all():
            break
        interior = moved[nb:]
    excess = 0 if n_vertices is None else nb + interior.size - n_vertices
    if excess > 0:  # the triangulation split chords that crossed the outline: inner vertices give way
        free = interior[~fixed[interior]]
        interior = np.union1d(interior[fixed[interior]], _trim(uv, free, excess, sizing, lam))
        boundary, ids, faces, segments = _triangulate(uv, boundary, interior, loops, position, segments)
        if ids.size > n_vertices:
            raise BoundaryBudgetError(n_vertices, ids.size - interior.size, corners.size, len(loops))
    median_spacing = float(np.median(sizing.spacing3d(lam, uv[:: max(1, n // 4096)])))
    return _domain(uv, boundary, interior, corners, loops, position, a, median_spacing, segments, F if warp else None)


def _with_strips(uv: np.ndarray, interior: np.ndarray, strips: Strips, sizing: _Sizing, lam: float) -> np.ndarray:
    """``interior (k,)`` without the vertices nearer than :data:`STRIP_CLEARANCE` local spacings to a strip
    vertex, and with the strips' vertices."""
    if strips.vertices.size == 0:
        return interior
    p = uv[interior]
    d = cKDTree(uv[strips.vertices]).query(p)[0]
    keep = d >= STRIP_CLEARANCE * sizing.spacing(lam, p)
    return np.union1d(interior[keep], strips.vertices)


def _choose(uv: np.ndarray, loops: tuple[np.ndarray, ...], sizing: _Sizing, lam: float, budget: int | None,
            corner_angle: float, index: "_ScanIndex", position: np.ndarray
            ) -> tuple[list[np.ndarray], np.ndarray, np.ndarray, float]:
    """Kept boundary ids per loop, interior ids, corners and the final density scale.

    With a budget, the density scale is recalibrated from the interior count reached
    (about proportional to it) until the total is within 3% below the budget or after
    :data:`BUDGET_PASSES` passes; an excess left then is trimmed (:func:`_trim`). A
    boundary that alone exceeds the budget is thinned with a coarser spacing first; where
    the passes end on such a boundary, the largest choice within the budget seen before is
    taken (the count is not monotone in the spacing: the corners found depend on it, so a
    square's budget of 6 overshot to 7-9 boundary vertices between passes of 4), and only a
    budget never met raises :class:`BoundaryBudgetError`.
    """
    counts: list[int] = []
    fallback: tuple | None = None  # (total within the budget, boundary, interior, corners, lam)
    for it in range(2 * BUDGET_PASSES):
        boundary, corners = _thin_boundary(loops, uv, sizing, lam, corner_angle)
        boundary = _triangulate(uv, boundary, np.empty(0, np.int64), loops, position)[0]  # chords uncrossed
        nb = sum(b.size for b in boundary)
        if budget is not None and nb > budget:
            # two coarser spacings that thinned nothing: the corners and three a loop are all left (64 holes: 29 s)
            if it == 2 * BUDGET_PASSES - 1 or counts[-2:] == [nb, nb]:
                if fallback is not None:
                    return fallback[1:]
                raise BoundaryBudgetError(budget, nb, corners.size, len(loops))
            lam *= 0.5 * (budget / nb) ** 2
            counts.append(nb)
            continue
        P = uv[np.concatenate(boundary)]
        mesh = _quality_mesh(P, loop_segments([b.size for b in boundary]), hole_seeds([uv[b] for b in boundary]),
                             sizing, lam)
        interior = index.snap(mesh, nb, sizing.spacing(lam, mesh[0][nb:]), sizing.a.roughness, sizing.a.calm,
                              sizing.a.noise_share)
        total = nb + interior.size
        if budget is None or 0.97 * budget <= total <= budget:
            break
        if it >= BUDGET_PASSES - 1 and total > budget:
            interior = _trim(uv, interior, total - budget, sizing, lam)
            break
        if total < budget and (fallback is None or total > fallback[0]):
            fallback = (total, boundary, interior, corners, lam)
        lam *= max(budget - nb, 1) / max(interior.size, 1)
    return boundary, interior, corners, lam


def _trim(uv: np.ndarray, interior: np.ndarray, excess: int, sizing: _Sizing, lam: float) -> np.ndarray:
    """``interior`` less the ``excess`` vertices nearest their neighbours against the local spacing."""
    if excess <= 0:
        return interior
    if excess >= interior.size:
        return interior[:0]
    p = uv[interior]
    d = cKDTree(p).query(p, k=2)[0][:, 1] / sizing.spacing(lam, p)
    return np.sort(interior[np.argsort(d, kind="stable")[excess:]])


def separation(domain: CoarseDomain, points: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """How far uv ``points (m,)`` are from the coarse vertices and boundary, in face sizes (what
    :func:`insert` tests): ``corner (m,)`` to the nearest vertex of the face a point falls in,
    ``chord (m,)`` to the coarse boundary (0 outside the domain), and ``size (m,)``, that face's
    size ``sqrt(2 area)`` in uv."""
    hit = domain.locate(points)
    size = np.sqrt(2.0 * domain.triangulation.areas[hit.face])
    corner = np.linalg.norm(domain.uv[domain.faces[hit.face]] - points[:, None, :], axis=2).min(1) / size
    chord = np.where(hit.clamped, 0.0, np.linalg.norm(domain.locator.project(points)[2] - points, axis=1) / size)
    return corner, chord, size


def insert(domain: CoarseDomain, new_vertices: np.ndarray, *, min_separation: float = MIN_SEPARATION
           ) -> CoarseDomain:
    """``domain`` with more scan vertices, re-triangulated (the refinement loop's step).

    ``new_vertices (m,)``: scan ids; ones already in the domain are ignored. A scan
    boundary vertex joins its loop's kept vertices (splitting that chord). A vertex
    outside the coarse polygon (between a chord and the outline), or nearer than
    ``min_separation`` face sizes (``sqrt(2 area)`` of the coarse face it falls in) to a
    boundary chord, brings in the scan boundary vertex nearest to it instead, which
    moves the chord out toward it. A vertex nearer than that to a vertex of its face,
    or to another new vertex (the first one stays), is skipped: it could only make a
    sliver. The crease strips' segments stay (a vertex inside a strip splits its faces).
    """
    n = domain.scan_uv.shape[0]
    ids = check_ids(as_array(new_vertices, "new_vertices", (None,), integer=True), "new_vertices", n)
    ids = np.setdiff1d(np.unique(ids), domain.vertices)
    position = _loop_position(domain.loops, n)
    on_loop, inner = ids[position[ids] >= 0], ids[position[ids] < 0]
    if inner.size:
        p = domain.scan_uv[inner]
        corner, chord, size = separation(domain, p)
        to_loop = chord < min_separation
        keep = ~to_loop & (corner >= min_separation)
        pairs = cKDTree(p).query_pairs(float(np.median(size)) * min_separation, output_type="ndarray")
        if pairs.size:
            keep[pairs.max(1)] = False
        if to_loop.any():
            bnd = np.concatenate(domain.loops)
            near = cKDTree(domain.scan_uv[bnd]).query(p[to_loop])[1]
            on_loop = np.union1d(on_loop, bnd[near])
        inner = inner[keep]
    boundary = []
    for kept, loop in zip(domain.boundary, domain.loops):
        add = on_loop[np.isin(on_loop, loop)]
        boundary.append(loop[np.unique(position[np.concatenate([kept, add])])])
    nb = sum(b.size for b in domain.boundary)
    interior = np.union1d(domain.vertices[nb:], inner)
    return _domain(domain.scan_uv, boundary, interior, domain.corners, domain.loops, position, domain.analysis,
                   domain.stats.spacing, domain.creases, domain.scan_faces)
