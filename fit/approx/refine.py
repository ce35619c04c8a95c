"""Tolerance-driven refinement: insert scan vertices where the deviation exceeds the tolerance, refit.

    state = measure(dom, V, fit, scale, loss)            # Round: the fit, its deviation, the rejected points
    ids = pick_vertices(state, tolerance, room)         # scan vertices to insert (one per face over the tolerance)

Each round fits the spline over the current coarse domain, measures the true 3D deviation
of every scan vertex (:func:`~.deviation.surface_deviation`) and, while the inliers'
largest deviation exceeds the tolerance and the budget allows, inserts one scan vertex
into every coarse face holding an inlier over the tolerance (the worst faces first):
the one that is far over the tolerance, well inside the face and smooth (low roughness:
with ``corners="data"`` the surface passes through it). :func:`~.domain.insert`
re-triangulates (boundary vertices move chords out toward the scan's outline).

With a robust loss a scan vertex is **rejected** (an outlier: the tolerance does not
apply to it) when the scan analysis marks it a spike (far off the robust quadric of its
neighbours, :attr:`~.analysis.ScanAnalysis.spike`; on the outline, with an outlier score of at
least :data:`OUTLINE_REJECT_ROUGHNESS`), the fit leaves it farther than :data:`REJECT_SIGMAS` times
the scan's noise away, and that quadric's distance and the fit's agree within a factor
``1 / REJECT_AGREEMENT`` (the point, not the surface or the quadric, is off), and it stands alone in
the fit's deviation (:meth:`~.analysis.ScanAnalysis.isolated`: a line of spikes is a feature as sharp as
the scan's spacing). All are needed: a coherent region the coarse surface cannot follow yet is far from
the fit but not a spike, and stays an inlier, so refinement fixes it instead of ignoring it. With the plain
loss nothing is rejected.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from trispline.spline.patches import regularity

from .deviation import Deviation, distance_to_mesh, summary, surface_deviation
from .domain import MIN_SEPARATION, CoarseDomain, coarse_index, separation
from .fit import PINCHED, CoarseFit

__all__ = ["Round", "measure", "outline_gaps", "outline_humps", "surface_gaps", "faceting", "pick_vertices", "REJECT_SIGMAS", "GROWTH",
           "GAP_RESOLUTION"]

#: A spike farther than this many noise standard deviations from the fit is rejected (robust losses only).
REJECT_SIGMAS = 6.0
#: ... a scan boundary vertex only with an outlier score (local noise levels) of at least this: at a corner of
#: the outline the scan analysis's leave-one-out residual is large even on clean data (face_gpjs: a
#: boundary vertex at 5.5, the scan's largest deviation at 2%), a 50-sigma outlier's is 37-51 (generated
#: scans, sigma 1e-3 and 1e-4).
OUTLINE_REJECT_ROUGHNESS = 10.0
#: ... and only where its own leave-one-out residual (its distance from the scan's local quadric without it)
#: and its deviation agree within this factor, both ways: a residual below this share of the deviation says
#: the surface, not the point, is off (a clean square's corner cut off by a coarse chord: residual 1e-9 of the
#: diagonal, deviation 4% of it, was rejected and the tolerance reported met); a deviation below this share
#: of the residual, that the local quadric is (a graded clean scan's sparse flank: residual 0.13, deviation
#: 6e-4, was rejected); a spike's residual is about its deviation.
REJECT_AGREEMENT = 0.5
#: A round at most multiplies the vertex count by this.
GROWTH = 2.0
#: Candidates closer to their face's boundary than this barycentric coordinate are less preferred.
INTERIOR_BARY = 0.2
#: Roughness (in local noise levels) that halves a candidate's preference.
ROUGHNESS_SCALE = 1.5
#: Samples per coarse boundary edge of :func:`outline_gaps`' boundary curves: the polyline stands within
#: ``L^2 kappa / (8 * 32^2)`` of the curve (6e-6 for an edge of 0.1 on a radius of 0.2).
GAP_CURVE_SAMPLES = 32
#: Scan boundary vertices per chunk of :func:`outline_gaps` (temporaries of about 20 MB each).
GAP_CHUNK = 8192
#: The scan faces' distance from a smooth surface, in curvature times squared spacing (:func:`faceting`): a
#: circle's chord of length ``h`` stands ``k h^2 / 8`` from it, a triangle's centre about ``k h^2 / 6``;
#: ``curvature`` is ``sqrt(k1^2 + k2^2)``, the larger of the two at most.
FACETING = 0.25
#: Tessellation steps per patch edge of :func:`surface_gaps`'s surface samples.
GAP_RESOLUTION = 4


@dataclass(frozen=True)
class Round:
    """One refinement round: a coarse domain, the fit over it and its deviation.

    dom : CoarseDomain; fit : CoarseFit; located : ``(face (n,), bary (n, 3))`` of the scan in ``dom``
    deviation : Deviation of every scan vertex; rejected : (n,) bool
    inliers : :func:`~.deviation.summary` of the inliers' deviation; seconds : the round's time
    outline : (n,) or None, each scan boundary vertex's distance to the surface's boundary curve beside it
        (the chord's sagitta in 3D, :func:`outline_gaps`; 0 elsewhere), which refinement
        treats as a deviation: it is the surface-to-scan distance where a chord crosses a hole or a
        concave run of the outline (the surface there has no data under it)
    face_gap : (f,) or None, each coarse face's largest distance of its surface samples to the scan mesh
        (:func:`surface_gaps`), which refinement treats as a deviation of the face: the surface-to-scan side
        that the scan vertices cannot see (a patch swinging out where it has few data)
    corrections : parameter corrections behind ``located`` (0: the scan's own uv)
    regularity : (f,) each coarse patch's :func:`~trispline.spline.patches.regularity` (:attr:`pinched`)
    """

    dom: CoarseDomain
    fit: CoarseFit
    located: tuple[np.ndarray, np.ndarray]
    deviation: Deviation
    rejected: np.ndarray
    inliers: dict
    seconds: float
    outline: np.ndarray | None = None
    face_gap: np.ndarray | None = None
    corrections: int = 0
    regularity: np.ndarray | None = None

    @property
    def pinched(self) -> np.ndarray:
        """``(f,)`` bool: the patches nearly singular somewhere (:data:`PINCHED`)."""
        n = self.dom.stats.n_faces
        return np.zeros(n, bool) if self.regularity is None else self.regularity < PINCHED

    @property
    def worst(self) -> float:
        """The larger of :attr:`data_worst` and :attr:`gap_worst` (model units)."""
        return max(self.data_worst, self.gap_worst)

    @property
    def data_worst(self) -> float:
        """The inliers' largest :attr:`pick_distance` (model units): the deviation, with :attr:`outline` the
        outline's gaps too."""
        d = self.pick_distance[~self.rejected]
        return float(d.max()) if d.size else 0.0

    @property
    def gap_worst(self) -> float:
        """The largest :attr:`face_gap` (0 without): the surface-to-scan side, at least the scan's own
        faceting (the distance of a smooth surface from flat faces), so a surface nearer the truth can have
        a larger one than a flatter, worse one."""
        return 0.0 if self.face_gap is None else float(self.face_gap.max(initial=0.0))

    @property
    def pick_distance(self) -> np.ndarray:
        """``(n,)`` what refinement reduces: the deviation, and with :attr:`outline` the larger of the two."""
        d = self.deviation.distance
        return d if self.outline is None else np.maximum(d, self.outline)

    @property
    def max_deviation(self) -> float:
        """The inliers' largest deviation (model units)."""
        return self.inliers["max"]

    def record(self) -> dict:
        """The round in a few numbers (vertices, patches, deviation max, rms and median, rejected, seconds)."""
        return dict(vertices=int(self.dom.stats.n_vertices), patches=int(self.dom.stats.n_faces),
                    max=self.inliers["max"], rms=self.inliers["rms"], p50=self.inliers["p50"],
                    rejected=int(self.rejected.sum()),
                    iterations=int(self.fit.iterations), seconds=self.seconds)


def measure(dom: CoarseDomain, V: np.ndarray, fit: CoarseFit, located: tuple[np.ndarray, np.ndarray],
            robust: bool, seconds: float = 0.0, outline: bool = False, scan_faces: np.ndarray | None = None
            ) -> Round:
    """The deviation of every scan vertex ``V (n, 3)`` from ``fit``, and the rejected ones (none unless ``robust``);
    with ``outline`` the outline's gaps too (:func:`outline_gaps`), with ``scan_faces (m, 3)`` the faces' gaps
    to the scan (:func:`surface_gaps`)."""
    dev = surface_deviation(fit.surface, V)
    rejected = np.zeros(V.shape[0], bool)
    if robust:
        resid = dom.analysis.residual
        rejected = (dom.analysis.isolated(dev.distance) & (dev.distance > REJECT_SIGMAS * dom.stats.noise)
                    & (resid >= REJECT_AGREEMENT * dev.distance) & (REJECT_AGREEMENT * resid <= dev.distance))
        ids = dom.outline_ids
        rejected[ids] &= dom.analysis.outlier[ids] >= OUTLINE_REJECT_ROUGHNESS
    return Round(dom=dom, fit=fit, located=located, deviation=dev, rejected=rejected,
                 inliers=summary(dev.distance, ~rejected), seconds=seconds,
                 outline=outline_gaps(dom, V, fit) if outline else None,
                 face_gap=None if scan_faces is None else surface_gaps(dom, V, scan_faces, fit),
                 regularity=regularity(fit.space.tri.uv, fit.space.tri.faces, np.asarray(fit.surface.ctrl)))


def outline_gaps(dom: CoarseDomain, V: np.ndarray, fit: CoarseFit) -> np.ndarray:
    """``(n,)`` each scan boundary vertex's distance to the surface's boundary curve beside it, 0 for the other
    scan vertices: where a boundary chord runs over a hole or a concave run of the outline, the surface between
    it and the scan's outline has no data under it and stands about this far from the scan.

    The curve is that of the coarse boundary edge nearest the vertex in uv and of the two beside it, each
    sampled at :data:`GAP_CURVE_SAMPLES` steps (a polyline), in chunks of :data:`GAP_CHUNK` vertices. Measured
    to the curve, not at the vertex's nearest boundary parameter: a curve that passes by the scan's outline
    with its parameters slid along it is no gap (a half-pipe's outline 0.71 of the tolerance away, its
    points 1.11 from the curve's point at their own parameters)."""
    ids = dom.outline_ids
    edge, _, _ = dom.locator.project(dom.scan_uv[ids])
    near = dom.locator.beside(edge)  # (m, 3)
    E, slot = np.unique(near, return_inverse=True)
    t = np.linspace(0.0, 1.0, GAP_CURVE_SAMPLES + 1)
    face, bary, _ = dom.locator.on_edge(np.repeat(E, t.size), np.tile(t, E.size))
    P = np.asarray(fit.surface.evaluate(face, bary)).reshape(E.size, t.size, -1)
    slot = slot.reshape(near.shape)
    gap = np.zeros(V.shape[0])
    for lo in range(0, ids.size, GAP_CHUNK):
        s = slot[lo:lo + GAP_CHUNK]
        a = P[s, :-1].reshape(s.shape[0], -1, P.shape[2])  # (c, 3 * samples, 3) segment starts
        ab = P[s, 1:].reshape(a.shape) - a
        x = V[ids[lo:lo + GAP_CHUNK]][:, None, :]
        u = np.clip(np.einsum("cki,cki->ck", x - a, ab) / np.maximum(np.einsum("cki,cki->ck", ab, ab), 1e-300), 0, 1)
        gap[ids[lo:lo + GAP_CHUNK]] = np.linalg.norm(x - a - u[..., None] * ab, axis=2).min(axis=1)
    return gap


def surface_gaps(dom: CoarseDomain, V: np.ndarray, F: np.ndarray, fit: CoarseFit) -> np.ndarray:
    """``(f,)`` each coarse face's largest distance from the samples of its patch (the tessellation at
    :data:`GAP_RESOLUTION`, its edges' samples included) to the scan ``V (n, 3)``, ``F (m, 3)`` (exact
    closest points on its triangles), less the scan's own :func:`faceting` there."""
    mesh = fit.surface.tessellate(GAP_RESOLUTION)
    d = np.maximum(distance_to_mesh(mesh.vertices, V, F) - faceting(dom, mesh.uv), 0.0)
    return d[mesh.triangles].reshape(dom.stats.n_faces, -1).max(1)  # a patch's triangles are its r^2 rows


def faceting(dom: CoarseDomain, uv: np.ndarray) -> np.ndarray:
    """``(k,)`` how far the scan's flat faces may stand from the smooth surface they sample at uv ``points``:
    :data:`FACETING` times the local curvature times the squared 3D spacing of the scan (the scan
    analysis's cells). A surface nearer the truth than the scan's faces is that far from them; without
    it the surface-to-scan gap of a fine, smooth scan was its faceting, and refinement chased it."""
    a = dom.analysis
    h = a.lookup(a.scan_spacing, uv) * a.lookup(a.scale, uv)
    return FACETING * a.lookup(a.curvature, uv) * h * h


def outline_humps(loops: list[np.ndarray], gap: np.ndarray, over: np.ndarray) -> np.ndarray:
    """Scan ids: along each loop (scan ids in loop order), the vertex of largest ``gap (n,)`` in every run of
    consecutive vertices where ``over (n,)`` holds (cyclic): one vertex per notch a chord spans."""
    picks = []
    for loop in loops:
        o = over[loop]
        if not o.any():
            continue
        if o.all():
            picks.append(loop[np.argmax(gap[loop])])
            continue
        r = np.roll(loop, -int(np.argmin(o)))  # starts outside a run: no run wraps around
        o = over[r]
        run = np.cumsum(o & ~np.r_[False, o[:-1]])[o]  # run number of each vertex over
        ids = r[o]
        order = np.lexsort((-gap[ids], run))
        picks.append(ids[order[np.r_[True, run[order][1:] != run[order][:-1]]]])
    return np.unique(np.concatenate([np.atleast_1d(p) for p in picks])) if picks else np.empty(0, np.int64)


def pick_vertices(state: Round, tolerance: float, room: int, exclude: np.ndarray | None = None,
                  humps: bool = False) -> np.ndarray:
    """Scan ids ``(<= room,)`` to insert: per coarse face holding an inlier over ``tolerance``, its best candidate.

    A face counts when any inlier located in it is over the tolerance, and every face around a
    coarse vertex whose own point is (with ``corners="fit"`` a corner can miss its vertex); a face that counts
    but has no candidate passes its count to its edge neighbours. Its candidates are all its
    scan points but coarse vertices, rejected points and interior spikes (a scan boundary vertex
    may be one: the leave-one-out residual of the scan analysis is large at a corner of the
    outline even on exact data; a vertex inside a crease line of a clean scan,
    :attr:`~.analysis.ScanAnalysis.crease`, is a feature: a candidate even where it is a spike) and points :func:`~.domain.insert` would skip (too near a vertex
    of their face), scored ``(d / tolerance) * min(1, b /
    INTERIOR_BARY + 0.25) / (1 + s (roughness / ROUGHNESS_SCALE)^2)`` (``s`` the scan analysis's
    :attr:`~.analysis.ScanAnalysis.noise_share`: on clean data a rough vertex is a crease; ``b`` the smallest
    barycentric coordinate, taken as ``INTERIOR_BARY`` for a scan boundary vertex: it moves the
    coarse boundary out to the scan's). Faces go in order of their largest deviation, at most
    ``room`` and at most ``(GROWTH - 1)`` times the vertex count. ``exclude``: scan ids not to pick
    (ones an earlier try could not insert). ``humps`` (with :attr:`Round.outline`): also the outline's
    :func:`outline_humps` over the tolerance, every notch a chord spans at once rather than one a face a round
    (within the same limit, after the faces' picks; the 100k speed scan at 1e-3: 9 -> 6 rounds, 14.7 -> 7.7 s,
    the 1M one 6 -> 3 rounds, 64 -> 41 s).
    """
    dom, d = state.dom, state.pick_distance
    face, bary = state.located
    over = ~state.rejected & (d > tolerance)
    worst = np.zeros(dom.stats.n_faces) if state.face_gap is None else np.where(state.face_gap > tolerance,
                                                                                  state.face_gap, 0.0)
    np.maximum.at(worst, face[over], d[over])
    local = coarse_index(dom.vertices, d.size)
    star_face, star_corner = np.nonzero(np.isin(dom.faces, local[dom.vertices[over[dom.vertices]]]))
    np.maximum.at(worst, star_face, d[dom.vertices[dom.faces[star_face, star_corner]]])  # a coarse vertex: its star
    limit = int(min(room, np.ceil((GROWTH - 1.0) * dom.stats.n_vertices)))
    on_loop = np.zeros(d.size, bool)
    on_loop[dom.outline_ids] = True
    usable = (~dom.analysis.spike | on_loop | dom.analysis.crease) & ~state.rejected
    usable[dom.vertices] = False
    if exclude is not None:
        usable[exclude] = False
    adj = dom.triangulation.face_adjacency
    near = worst > 0
    reach = adj[near]
    near[reach[reach >= 0]] = True  # the faces over the tolerance and their neighbours
    ids = np.flatnonzero(usable & near[face])
    if ids.size == 0 or limit <= 0:
        return np.empty(0, np.int64)
    corner, chord, _ = separation(dom, dom.scan_uv[ids])
    ids = ids[(corner >= MIN_SEPARATION) | (chord < MIN_SEPARATION) | on_loop[ids]]  # what insert would skip: not
    has = np.zeros(dom.stats.n_faces, bool)
    has[face[ids]] = True
    orphan = np.flatnonzero((worst > 0) & ~has)  # over the tolerance, nothing to insert: its neighbours instead
    nbr = adj[orphan]
    ok = nbr >= 0
    np.maximum.at(worst, nbr[ok], np.broadcast_to(worst[orphan][:, None], nbr.shape)[ok])
    ids = ids[worst[face[ids]] > 0]
    if ids.size == 0 or limit <= 0:
        return np.empty(0, np.int64)
    inside = np.minimum(1.0, np.clip(bary[ids].min(1), 0.0, None) / INTERIOR_BARY + 0.25)
    inside[on_loop[ids]] = 1.0  # a scan boundary vertex splits its chord: no sliver
    rough = dom.analysis.noise_share * (dom.analysis.roughness[ids] / ROUGHNESS_SCALE) ** 2
    score = d[ids] / tolerance * inside / (1.0 + rough)
    f = face[ids]
    order = np.lexsort((-score, f))  # by face, best first
    first = order[np.r_[True, f[order][1:] != f[order][:-1]]]  # the best candidate of each face
    first = first[np.argsort(-worst[f[first]], kind="stable")][:limit]
    picked = ids[first]
    if humps and state.outline is not None:
        ok = usable & on_loop
        ok[picked] = False
        extra = outline_humps(dom.loops, state.outline, ok & (state.outline > tolerance))
        picked = np.concatenate([picked, extra[:max(limit - picked.size, 0)]])
    return np.sort(picked)
