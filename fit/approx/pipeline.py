"""Approximate a dense scan by a coarse, fair C1 spline within a tolerance.

    res = approximate_surface(V, F, tolerance_rel=1e-3)        # ApproxResult
    res.surface.save("scan.npz")                                # with the deviation and settings as extras
    res.stats["deviation"], res.stats["met"], res.vertices      # inliers' deviation, tolerance met, scan ids

Pipeline: parameterize the scan (as :func:`_smoothed` sees it: spikes removed, a few
umbrella steps, so that scanner spikes do not fold the map) -> a coarse domain on a
subset of the scan's vertices (:func:`~.domain.coarse_domain`) -> rounds of fit
(:func:`~.fit.fit_domain`), true deviation and refinement (:mod:`.refine`) until the
inliers are within the tolerance or the budget is spent -> with a robust loss, the
final robust fit by optimistix Gauss--Newton. The rounds fit a robust loss by a plain
and one reweighted least-squares solve each (weights afresh from the round's own plain
fit), so the vertex count can change every round without compiling anything; the final
fit converges the robust loss itself, preconditioned by the reweighted factor. The
refinement keeps the round of smallest maximum inlier deviation (it never makes that
worse); the final fit replaces it unless it would break a tolerance met (or do worse). A budget
alone measures the deviation both ways (the surface's samples to the scan too,
:func:`~.refine.surface_gaps`) and ends with parameter corrections (:func:`_final`).
"""
from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass, field
from typing import Any, Callable

import numpy as np
import scipy.sparse as sp

from trispline.param import DEFAULT_METHOD, face_areas_3d, hull_sliver_faces
from trispline.param.polymap import grid_centre
from trispline.spline.checks import as_array, callback, check_ids, flag, real_number, whole_number
from trispline.spline.continuity import continuity_report
from trispline.spline.errors import InputError, first_few
from trispline.spline.index import CORNER
from trispline.spline.polynomial import Polynomial
from trispline.spline.surface import SplineSurface
from trispline.spline.tolerances import MIN_RELATIVE_AREA_3D
from trispline.spline.topology import Triangulation
from trispline.spline.util.memory import format_bytes
from trispline.spline.util.timer import StageTimer

from ..energy.robust import LOSSES, TUNING, inlier_weight
from ..errors import FactorMemoryError
from ..limits import APPROX_BYTES_PER_VERTEX, approx_vertex_room, estimate_approx_bytes
from ..reach import surface_reach
from ..solve import require_x64
from ..weights import FitWeights
from .analysis import SPIKE_LEVELS
from .deviation import Deviation, summary
from .domain import (DEFAULT_FRACTION, BoundaryBudgetError, CoarseDomain, LostHolesError, TangledOutlineError,
                     coarse_domain, insert)
from .fit import (APPROX_WEIGHTS, PINCHED, WILD_REACH, corrected_location, cross_validated_weight, fit_domain,
                  quadric_reference, scan_location)
from .creases import near_creases
from .holes import SMALL_HOLE, folded_holes, small_holes, span_holes, wide_holes
from .problem import CORNER_MODES
from .pinch import relative_regularity
from .refine import Round, measure, outline_gaps, pick_vertices

__all__ = ["ApproxResult", "approximate_surface", "APPROX_STAGES", "LOSS_NAMES", "DEFAULT_BUDGET_FRACTION",
           "DEFAULT_BUDGET_MIN", "PINCHED", "WILD_REACH", "surface_extras"]

#: Every data loss: the plain one and the robust ones.
LOSS_NAMES = ("l2",) + LOSSES
#: Stages reported to ``progress`` and timed in ``ApproxResult.timings``.
APPROX_STAGES = ("parameterize", "domain", "smoothing", "fit", "deviation", "refine", "final")
#: Vertex budget with a tolerance and no ``n_vertices``: this fraction of the scan (plus what the outline
#: needs where it alone needs more: :class:`~.domain.BoundaryBudgetError`).
DEFAULT_BUDGET_FRACTION = 0.10
#: ... and at least this many (a small scan's 10% would be its first domain: no room to refine).
DEFAULT_BUDGET_MIN = 64
#: With a tolerance, the first coarse domain has this fraction of the scan (at most the budget).
INITIAL_FRACTION = 0.005
#: ... and at least this many vertices.
INITIAL_MIN = 16
#: A budget alone (no tolerance): the first coarse domain has this fraction of the budget; refinement
#: spends the rest where the deviation is largest (:func:`_refine`).
BUDGET_SEED = 0.25
#: ... into every face with an inlier farther than this fraction of the scan's size (any: the worst faces first),
BUDGET_THRESHOLD = 1e-12
#: ... at most this fraction of the remaining room a round (the last vertices go one round at a time to
#: the worst faces),
BUDGET_STEP = 0.5
#: ... unless the scan is at the noise floor: the seed's inliers' median deviation within this many noise
#: estimates (about 1.5x that of Gaussian noise alone, 0.67) ...
BUDGET_FLOOR = 1.0
#: ... and the next round's median above this fraction of it (more vertices did not help: noise, not a
#: shape the spline misses; the noise estimate alone is no test, as on clean scans with creases it is the
#: local quadrics' error). Such a scan is fitted at the whole budget at once.
BUDGET_GAIN = 0.9
#: A budget alone: a round with more vertices (or the final fit) replaces the best one so far unless its
#: inliers' worst deviation (:attr:`~.refine.Round.data_worst`) is larger by more than this share ...
WORST_TIE = 0.1
#: ... or its surface-to-scan gap (:attr:`~.refine.Round.gap_worst`) larger than this many times the best's
#: (or its data's). The gap's floor is the scan's own faceting, which a flatter, worse surface can sit nearer
#: (a 30 x 30 sine grid: 1.6e-4 at 16 vertices, 1.9e-4 at 50 and for the true surface), so comparing the
#: larger of the two kept a seed of a quarter of the budget; a patch swinging out where it has few data
#: (what the gap is for) is many times it.
GAP_TIE = 1.5
#: With a tolerance (a budget alone asks for the least deviation, and gets the weight chosen at its start):
#: whether a refinement round whose fit has a nearly singular patch (:data:`~.fit.PINCHED`) chooses the data
#: weight again on its domain (cross-validated, :func:`~.fit.cross_validated_weight` with ``regular``) and, where
#: that differs, refits and refines on with it: a weight chosen on a few vertices can overfit many (the peeled
#: 3,000-point terrain tile at 3e-3: 1e6 from its first domain, 124 vertices later 0.2% of a patch's area
#: element left somewhere, |H| 484 against the terrain's 0.03); either way, as the domain's own optimum moves.
#: Not with a budget alone: the beetle at 2% of its vertices then took 1e5 -> 3e3 -> 1e4 over the rounds and
#: its data-to-model RMS rose from 0.21 to 0.42 of quadric decimation's (issue 15's target: 1/3).
REWEIGH_PINCHED = True
#: A budget alone: the final fit (at the closest points, its RMS often half the round's) replaces the best
#: round unless its worst deviation is larger by more than this share (a 100k-face clean scan: RMS 1.9e-5
#: -> 7.9e-6 for a maximum 12% larger; a tiny scan's poorly cross-validated weight: 7000x larger).
FINAL_TIE = 1.0
#: Refinement rounds at most.
MAX_ROUNDS = 20
#: Tries of a refinement round's insertion, each with the faces' next candidates (:func:`_grow`).
GROW_TRIES = 3
#: Reweighted least-squares steps after each round's plain fit (a robust loss).
IRLS_STEPS = 1
#: A budget alone: parameter corrections after the final fit (each a refit at the last fit's closest points,
#: :func:`~.fit.corrected_parameters`, and its deviation both ways). The rounds keep the scan's own uv.
FINAL_CORRECTIONS = 3
#: A tolerance: parameter corrections after its final fit (each a refit and its scan-to-surface deviation; the fit
#: of the smallest largest deviation kept). At 1e-3 of the diagonal on the shared scans the deviation's RMS fell
#: 6-36% and its maximum up to 31%, the outline's gap up to 61% (snail 4.0 -> 1.6 times the tolerance, lilium
#: 1.5 -> 1.0), with the same vertices (benchmarks/README.md, issue 15, the twenty-third session).
TOLERANCE_CORRECTIONS = 3
#: ... stopping at the first whose inliers' RMS deviation is above this share of the last fit's (the maximum may
#: rise at one correction and fall at the next: face_gpjs 0.99 -> 1.04 -> 0.93 -> 0.90 of the tolerance, its RMS
#: 0.178 -> 0.151 -> 0.141 -> 0.135; the generated bumps scan's RMS 0.104 -> 0.103, its maximum up: stopped).
CORRECTION_GAIN = 0.98
#: ... on scans of at most this many vertices (one correction of a 1M-face scan costs ~11 s, beside the 84 s of
#: its whole approximation: issue 15's speed target is 90 s).
TOLERANCE_CORRECTION_POINTS = 250_000

#: Uniform-Laplacian steps on the interior vertices before parameterizing (boundary fixed).
PARAM_SMOOTHING = 3
#: A vertex this many median edge lengths off its neighbours' mean is a spike (the parameterization
#: moves it there; a corner of the outline is within one).
SPIKE_EDGES = 3.0
#: Rounds of spike removal.
SPIKE_ROUNDS = 4
#: The robust loss's scale is at least this times the diagonal (noise-free data).
MIN_SCALE = 1e-9


@dataclass(frozen=True)
class ApproxResult:
    """Outcome of :func:`approximate_surface`.

    Attributes
    ----------
    surface : SplineSurface over the coarse domain (extras: :func:`surface_extras`)
    domain : the CoarseDomain (coarse triangulation ``domain.uv``, ``domain.faces``)
    vertices : (k,) scan vertex of each coarse vertex (``domain.vertices``)
    deviation : Deviation of every scan vertex (closest points on the surface)
    rejected : (n,) bool, the points the robust loss rejected (outliers; the tolerance does not apply)
    stats : deviation (the inliers' :func:`~.deviation.summary`), deviation_all, rejected, unreached (scan
        points outside the coarse domain that no boundary patch reaches, left out of the fit's data term:
        :func:`~.fit.scan_location`; their deviation still counts), vertices,
        patches, tolerance, budget, met, stop (why the refinement stopped), rounds, noise, scale,
        data_weight, cross_validated (whether it was chosen so), corrections (the parameter corrections
        of the fit kept, :func:`_final`) and hull_slivers (the scan's outline faces that
        :func:`trispline.param.hull_sliver_faces` finds: where there are any, no coarse vertex can go
        along the hull's long edges and ``repair_mesh`` peels them); where a tolerance was missed,
        over_tolerance (the inliers over it) and over_near_creases (those of them on or beside a sharp
        crease of the scan, :func:`~.creases.near_creases`, which a C1 surface rounds; else both 0);
        regularity, the smallest patch's :func:`~.pinch.relative_regularity`: its area element against the scan's
        own under it (below :data:`PINCHED` the surface is nearly singular somewhere: its curvature
        spikes there, where the scan's does not), regularity_plain the smallest
        :func:`~trispline.spline.patches.regularity` (what refinement reweighs by: the map's own spread counts)
    energies : dict term -> energy (``bend``, ``data``; data units); iterations : Gauss--Newton steps
    converged : bool; history : one record per round (vertices, max, rms, rejected, seconds)
    timings : dict stage -> seconds; parameterization : the Parameterization (``method="uv"`` with ``uv``)
    settings : the options, as stored in the surface file
    uv, faces, ctrl : the surface's domain and control points ``(f, 21, 3)``: ``domain.uv`` (normalised)
        with nearly singular vertices snapped (extras ``domain_max_move``, ``domain_max_relative_move``),
        and with ``uv`` given (or ``param="uv"``) in the caller's own uv
    c1_residual : worst C1 residual (relative); max_interpolation_error : corners vs their scan vertices
    located : ``(face (n,), bary (n, 3))``, the scan's parameters in the fit: their own uv
        (:func:`~.fit.scan_parameters`) or, after a kept parameter correction (``stats["corrections"]``), an
        earlier fit's closest points
    """

    surface: SplineSurface
    domain: CoarseDomain
    vertices: np.ndarray
    deviation: Deviation
    rejected: np.ndarray
    stats: dict
    energies: dict
    iterations: int
    converged: bool
    history: list
    timings: dict
    parameterization: Any
    settings: dict
    uv: np.ndarray
    faces: np.ndarray
    ctrl: np.ndarray
    c1_residual: float
    max_interpolation_error: float
    weights: FitWeights = field(default=APPROX_WEIGHTS)
    located: tuple | None = None


@dataclass(frozen=True)
class _Options:
    """Validated options of one approximation."""

    tolerance: float | None
    budget: int
    refine: bool
    corners: str
    loss: str
    weights: FitWeights
    auto: bool
    #: the bend term's reference of the current domain family (:func:`~.fit.quadric_reference`, once)
    reference: Polynomial | None = None
    #: the scan's parameters follow the coarse boundary chords (:mod:`.warp`); off with the caller's own uv
    warp: bool = True
    #: the caller set the budget (``n_vertices``); else it is the default, and grows to the outline's need
    budget_given: bool = True
    #: a tolerance holds for the outline's gaps too (:func:`~.refine.outline_gaps`), not only the scan's vertices
    outline_tolerance: bool = False
    #: holes with at most this many vertices around are spanned before the map (0: every hole kept) ...
    fill_holes: int = 0
    #: ... and how many of the scan's were
    filled: int = 0

    @property
    def outline(self) -> bool:
        """Whether the rounds measure (and refine by) the outline's gaps: a budget alone, or asked."""
        return not self.refine or self.outline_tolerance

    def deviation(self, state: Round) -> float:
        """What a tolerance is judged by: the inliers' largest deviation, with the outline's gaps if asked."""
        return state.data_worst if self.outline_tolerance else state.max_deviation


def _options(n: int, diagonal: float, tolerance, tolerance_rel, n_vertices, corners, loss, weights,
             outline_tolerance: bool = False, fill_holes: int = 0) -> _Options:
    """Check every option (clear messages naming the bad value) and derive the budget."""
    if tolerance is not None and tolerance_rel is not None:
        raise InputError("give tolerance (model units) or tolerance_rel (of the diagonal), not both")
    tolerance, tolerance_rel = (None if v is None else real_number(v, name, positive=True)
                                for name, v in (("tolerance", tolerance), ("tolerance_rel", tolerance_rel)))
    tol = tolerance if tolerance_rel is None else tolerance_rel * diagonal
    if n_vertices is not None:
        n_vertices = whole_number(n_vertices, "n_vertices", least=3)
    if corners not in CORNER_MODES:
        raise InputError(f"corners must be one of {', '.join(CORNER_MODES)}, got {corners!r}")
    if loss not in LOSS_NAMES:
        raise InputError(f"loss must be one of {', '.join(LOSS_NAMES)}, got {loss!r}")
    if weights is not None and not isinstance(weights, FitWeights):
        raise InputError(f"weights must be a FitWeights or None, got {type(weights).__name__}")
    fill_holes = whole_number(fill_holes, "fill_holes", least=0)  # the most vertices around a hole to span
    if n_vertices is not None:
        budget = int(n_vertices)
    else:
        budget = (max(16, int(round(DEFAULT_FRACTION * n))) if tol is None
                  else max(DEFAULT_BUDGET_MIN, int(round(DEFAULT_BUDGET_FRACTION * n))))
    return _Options(tolerance=tol, budget=min(budget, n), refine=tol is not None, corners=corners, loss=loss,
                    weights=APPROX_WEIGHTS if weights is None else weights, auto=weights is None,
                    budget_given=n_vertices is not None, outline_tolerance=bool(outline_tolerance),
                    fill_holes=int(fill_holes))


def _memory_budget(opt: _Options, n_faces: int) -> tuple[_Options, list[str]]:
    """``(options, notes)``: the vertex budget checked against the memory available before any work
    (:func:`~trispline.fit.limits.approx_vertex_room`): a budget given beyond it is refused, the default one
    lowered to it (said in the notes); a scan too large for any budget is refused."""
    room = approx_vertex_room(n_faces)
    if room is None or opt.budget <= room:
        return opt, []
    if opt.budget_given:
        need, have = estimate_approx_bytes(n_faces, opt.budget), estimate_approx_bytes(n_faces, room)
        raise FactorMemoryError(
            f"a budget of {opt.budget:,} vertices may need about {format_bytes(need)} (about "
            f"{format_bytes(APPROX_BYTES_PER_VERTEX)} a coarse vertex), but only {format_bytes(have)} of memory are "
            f"available: give at most {room:,} vertices", estimate=need, available=have)
    note = (f"the default budget of {opt.budget:,} vertices was lowered to {max(room, 3):,}, what the available "
            f"memory allows (about {format_bytes(APPROX_BYTES_PER_VERTEX)} a coarse vertex)")
    return dataclasses.replace(opt, budget=max(room, 3)), [note]


def _smoothed(V: np.ndarray, F: np.ndarray, steps: int = PARAM_SMOOTHING) -> np.ndarray:
    """The scan ``V (n, 3)`` as the parameterization sees it: spikes (farther than :data:`SPIKE_EDGES`
    median edge lengths from the mean of their neighbours, for an outline vertex its two outline
    neighbours, and farther than any neighbour) moved there, a few rounds (not where that would
    flatten a face, like an ear of the outline), then ``steps`` uniform-Laplacian steps of the
    interior vertices. Moved by :func:`~trispline.param.polymap.grid_centre` (the maps do not depend on
    it): averages of map coordinates (5e6) rounded the map by 1e-9 of its size; now a tile at UTM offsets
    gets the map of the same stored data at the origin, bit for bit."""
    V = V - grid_centre(V)
    n = V.shape[0]
    key = np.sort(np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]), axis=1)
    edge, count = np.unique(key[:, 0] * n + key[:, 1], return_counts=True)
    a, b = edge // n, edge % n
    on = count == 1  # boundary edges belong to one face
    bnd = np.zeros(n, bool)
    bnd[np.r_[a[on], b[on]]] = True
    adjacency = lambda sel: sp.csr_matrix((np.ones(2 * int(sel.sum())), (np.r_[a[sel], b[sel]], np.r_[b[sel], a[sel]])),
                                          shape=(n, n))  # noqa: E731
    A = adjacency(np.ones(edge.size, bool))
    deg = np.maximum(np.asarray(A.sum(1)).ravel(), 1.0)[:, None]
    B = adjacency(on)
    X = V.copy()
    h = float(np.median(np.linalg.norm(V[a] - V[b], axis=1)))
    for _ in range(SPIKE_ROUNDS):  # a spike's neighbours are judged again once it is gone
        mid = np.where(bnd[:, None], (B @ X) / 2.0, (A @ X) / deg)
        off = np.linalg.norm(X - mid, axis=1)
        spike = (off > SPIKE_EDGES * h) & (off >= np.asarray(A.multiply(off[None, :]).max(axis=1).todense()).ravel())
        if not spike.any():
            break
        X[spike] = mid[spike]
    area = face_areas_3d(X, F)
    flat = F[area <= MIN_RELATIVE_AREA_3D * area.mean()].ravel()  # e.g. an ear of the outline flattened
    X[flat] = V[flat]
    for _ in range(steps):
        X = np.where(bnd[:, None], X, (A @ X) / deg)
    return X


def _domain_uv(V: np.ndarray, F: np.ndarray, uv, param: str, span: list[np.ndarray] = (),
               fill: list[np.ndarray] = ()) -> tuple[np.ndarray, np.ndarray, Any]:
    """``(uv (n, 2) normalised, faces (m, 3) counter-clockwise, parameterization)``.

    Given ``uv`` (or ``param="uv"``: ``V[:, :2]``) is normalised by ``parameterize(method="uv")``
    and the surface goes back onto it at the end (:func:`_user_net`). Otherwise the scan is
    parameterized as :func:`_smoothed` sees it. A folded LSCM map is not repaired (on a large
    noisy scan the repair can take minutes and distorts the whole map): the harmonic map of the
    same smoothed scan replaces it. The map must be one-to-one (``embedded``: the coarse domain is a
    triangulation of the region it covers); one that covers part of the plane twice is replaced too.
    Holes the map turns inside out (:func:`~.holes.folded_holes`), and the loops ``span`` (holes a coarse
    domain lost: :class:`~.domain.LostHolesError`), are spanned by faces and the map made again, unless one is wide
    in space (:func:`~.holes.wide_holes`: an opening, such as a tube's end): then the harmonic map replaces the map: the
    returned ``faces`` hold those faces too. The holes ``fill`` (``fill_holes``: :func:`~.holes.small_holes`)
    are spanned before the map.
    """
    from trispline.param import parameterize

    if uv is not None or param == "uv":
        if fill:
            raise InputError("fill_holes needs trispline's own map (spanned holes are mapped with the rest): "
                             "not with a given uv or param='uv'")
        uv = None if uv is None else as_array(uv, "uv", (V.shape[0], 2), finite=True)
        p = parameterize(V, F, method="uv", uv=uv, embedded=True)
        return p.uv, p.faces, p
    F = span_holes(F, list(fill)) if fill else F
    X = _smoothed(V, F)
    p = _free_map(X, F, param, V)
    shut = folded_holes(p.uv, p.faces, Triangulation(p.uv, p.faces).boundary_loops) + list(span)
    wide = wide_holes(V, shut)
    if wide and p.method != "harmonic":  # an opening the map squeezed shut, not a crack: the harmonic map keeps it
        method = p.method
        p = _free_map(X, F, "harmonic", V)
        p.messages.insert(0, f"the {method} map squeezed shut {len(wide)} holes of the scan that are wide in space "
                             f"(first: {wide[0].size} vertices around): the harmonic map is used, which keeps them")
        shut = (folded_holes(p.uv, p.faces, Triangulation(p.uv, p.faces).boundary_loops)
                + [h for h in span if not wide_holes(V, [h])])
    if shut:  # spanned, and the map made again over them
        messages, method = p.messages, p.method
        p = _free_map(X, span_holes(p.faces, shut), param, V)
        left = folded_holes(p.uv, p.faces, Triangulation(p.uv, p.faces).boundary_loops)
        if left:
            raise InputError(f"the {p.method} map folds {len(left)} holes of the scan shut even after spanning "
                             f"{len(shut)} (first at scan vertices {first_few(left[0])}); fill them first")
        sizes = ", ".join(str(h.size) for h in shut[:5]) + (", ..." if len(shut) > 5 else "")
        p.messages[:0] = [*messages, f"spanned {len(shut)} holes of the scan ({sizes} vertices around) that the "
                          f"{method} map squeezed shut: each is far narrower than its vertices' spacing"]
    if fill:
        p.messages.insert(0, f"filled {len(fill)} holes of the scan with at most {max(h.size for h in fill)} "
                             "vertices around (fill_holes): the surface spans them")
    return p.uv, p.faces, p


def _free_map(X: np.ndarray, F: np.ndarray, param: str, V: np.ndarray):
    """The ``param`` map of the smoothed scan ``X``, one-to-one; a folded conformal map (spectral, lscm) replaced by
    the same map of the scan ``V`` itself where that folds nothing (the smoothing can turn a hull sliver over: a flat scan's), else by
    the harmonic map of ``X``. No polynomial map (``parameterize(polynomial=False)``): not measured on the
    approximation's benchmarks."""
    from trispline.param import MeshError, parameterize

    try:
        return parameterize(X, F, method=param, repair=param not in ("lscm", "spectral"), embedded=True,
                            polynomial=False)
    except MeshError as exc:
        if "folded" not in exc.kinds:
            raise
        why = str(exc).splitlines()[0].split(':')[0]
        try:
            p = parameterize(V, F, method=param, repair=False, embedded=True, polynomial=False)
            p.messages.append(f"{why} after the scan's smoothing; the map of the scan itself is used")
            return p
        except MeshError as raw:
            if "folded" not in raw.kinds:
                raise
        p = parameterize(X, F, method="harmonic", embedded=True, polynomial=False)
        p.messages.append(f"{why}; the harmonic map is used instead")
        return p


def _user_net(p, dom: CoarseDomain, space, ctrl: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(uv (k, 2), faces (f, 3), ctrl (f, 21, 3))``: the fitted net on the domain the fit used
    (``space.tri.uv``, snapped vertices moved), for ``method="uv"`` in the caller's own uv
    (:func:`trispline.param.user_domain` on the coarse vertices' share of the parameterization)."""
    from trispline.param import user_domain

    if p.method != "uv" or p.source_uv is None:
        return space.tri.uv, dom.faces, ctrl
    coarse = dataclasses.replace(p, uv=dom.uv, faces=dom.faces, source_uv=p.source_uv[dom.vertices])
    return user_domain(coarse, ctrl, space.tri.uv)


def _budgeted_domain(V: np.ndarray, faces: np.ndarray, uv: np.ndarray, opt: "_Options", max_rounds: int
                     ) -> tuple[CoarseDomain, "_Options"]:
    """:func:`_first_domain`; where the default budget is below what the outline needs, with that need on top."""
    try:
        return _first_domain(V, faces, uv, opt, max_rounds), opt
    except BoundaryBudgetError as exc:
        if opt.budget_given or opt.budget >= V.shape[0]:
            raise
        opt = dataclasses.replace(opt, budget=min(V.shape[0], exc.needed + opt.budget))
        return _first_domain(V, faces, uv, opt, max_rounds), opt


def _first_domain(V: np.ndarray, F: np.ndarray, uv: np.ndarray, opt: _Options, rounds: int) -> CoarseDomain:
    """The starting coarse domain: with a tolerance a coarser start (more if the outline needs it), with a
    budget alone :data:`BUDGET_SEED` of it (all of it with one round)."""
    seed = INITIAL_FRACTION * V.shape[0] if opt.refine else BUDGET_SEED * opt.budget if rounds > 1 else opt.budget
    k = min(opt.budget, max(INITIAL_MIN, int(round(seed))))
    while k < opt.budget:
        try:
            return coarse_domain(V, F, uv, n_vertices=k, warp=opt.warp)
        except InputError:
            k = min(opt.budget, 2 * k)
    return coarse_domain(V, F, uv, n_vertices=opt.budget, warp=opt.warp)  # raises when the budget is below the outline's need


def approximate_surface(
    V: np.ndarray,
    F: np.ndarray,
    *,
    tolerance: float | None = None,
    tolerance_rel: float | None = None,
    n_vertices: int | None = None,
    corners: str = "data",
    loss: str = "huber",
    weights: FitWeights | None = None,
    uv: np.ndarray | None = None,
    param: str = DEFAULT_METHOD,
    progress: Callable[[str, dict], None] | None = None,
    max_rounds: int = MAX_ROUNDS,
    outline_tolerance: bool = True,
    fill_holes: int = 0,
) -> ApproxResult:
    """Fit a coarse C1 spline to every vertex of the scan, refined until within the tolerance.

    Parameters
    ----------
    V : (n, 3) float, F : (m, 3) int
        An open scan (disk, or disk with holes).
    tolerance : largest deviation of an inlier (model units); tolerance_rel : the same as a
        fraction of the bounding-box diagonal. Without either, ``n_vertices`` spent by refinement where
        the deviation is largest (:func:`_refine`; ``max_rounds=1``: one domain of the whole budget).
    n_vertices : vertex budget (default :data:`~.domain.DEFAULT_FRACTION` of the scan without a
        tolerance, :data:`DEFAULT_BUDGET_FRACTION` with one)
    corners : ``"data"`` (each corner point interpolates its scan vertex) or ``"fit"`` (fitted
        like every other free point: better on noisy scans, see docs/approximate.md)
    loss : ``"huber"``, ``"cauchy"`` (robust, scaled by the noise estimate) or ``"l2"``
    weights : FitWeights; ``bend`` and ``data`` are used (the data weight sets the smoothing
        length, about the coarse spacing over ``data ** 0.25``). None (default): :data:`~.fit.APPROX_WEIGHTS`
        with the data weight chosen by cross-validation (:func:`~.fit.cross_validated_weight`) on the
        first coarse domain, and again on the final one of a refinement
    uv : (n, 2), optional: the scan's domain (else ``param`` parameterizes it); the surface comes out in it
    progress : ``progress(stage, info)`` after each stage of :data:`APPROX_STAGES`; ``info`` has
        ``seconds`` and, after a round's deviation, that round's record
    max_rounds : refinement rounds at most
    outline_tolerance : the tolerance holds for the outline's gaps too (default; ``stats["outline_gap"]``:
        where a coarse chord spans a notch or a bay, the surface stands that far from the scan's outline, which
        the scan-to-surface deviation cannot see); more vertices along ragged outlines (the shared scans at
        1e-3: up to 55x the tolerance without; beetle 398 -> 679 vertices). False: the gap is reported, not
        refined by (a budget alone always refines by it)
    fill_holes : holes with at most this many vertices around (scanner dropouts) are spanned by faces before
        the map, so that the surface goes over them instead of keeping each with three coarse vertices or
        more (``stats["holes_filled"]``; 0, the default: every hole kept). Not with a given ``uv``

    Returns
    -------
    ApproxResult; ``stats["met"]`` says whether the tolerance was met (never raises for that).
    """
    require_x64()
    V = as_array(V, "V", (None, 3), finite=True, min_rows=3)
    F_in = np.asarray(F)
    if F_in.size and not np.issubdtype(F_in.dtype, np.integer):
        raise InputError(f"F must be integers, got dtype {F_in.dtype}")
    F = check_ids(as_array(F_in, "F", (None, 3), integer=True, min_rows=1), "F", V.shape[0])
    progress = callback(progress, "progress")
    max_rounds = whole_number(max_rounds, "max_rounds", least=1)
    outline_tolerance = flag(outline_tolerance, "outline_tolerance")
    diagonal = float(np.linalg.norm(V.max(0) - V.min(0)))
    opt = _options(V.shape[0], diagonal, tolerance, tolerance_rel, n_vertices, corners, loss, weights,
                   outline_tolerance, fill_holes)
    opt, notes = _memory_budget(opt, F.shape[0])
    clock = StageTimer(None)
    report = progress or (lambda stage, info: None)

    def stage(name: str, **info) -> None:
        report(name, dict(info, seconds=clock(name)))

    fill = small_holes(V, F, opt.fill_holes)
    uv, faces, parameterization = _domain_uv(V, F, uv, param, fill=fill)
    parameterization.messages[:0] = notes
    opt = dataclasses.replace(opt, warp=parameterization.method != "uv", filled=len(fill))
    stage("parameterize")
    try:
        dom, opt = _budgeted_domain(V, faces, uv, opt, max_rounds)
    except LostHolesError as exc:  # holes the map squeezed shut: spanned, and the map made again
        if parameterization.method == "uv":
            raise
        uv, faces, parameterization = _domain_uv(V, F, None, param, span=exc.lost, fill=fill)
        dom, opt = _budgeted_domain(V, faces, uv, opt, max_rounds)
    except TangledOutlineError as exc:  # the map's outline meets itself: the harmonic map's is convex
        if parameterization.method == "uv" or param == "harmonic":
            raise
        method = parameterization.method
        uv, faces, parameterization = _domain_uv(V, F, None, "harmonic", fill=fill)
        parameterization.messages.insert(0, f"the {method} map's outline meets itself where the coarse domain needs "
                                            f"it apart ({exc}); the harmonic map (its outline on a circle) is used")
        dom, opt = _budgeted_domain(V, faces, uv, opt, max_rounds)
    opt = dataclasses.replace(opt, reference=quadric_reference(dom, V))
    stage("domain")
    if opt.auto:
        opt = dataclasses.replace(opt, weights=_smoothing(dom, V, opt))
        stage("smoothing")
    scale = None if opt.loss == "l2" else loss_scale(dom, opt.loss, diagonal)
    best, history, stop, opt = _refine(V, faces, dom, opt, scale, max_rounds, stage)
    if not opt.refine and best.dom.stats.n_vertices < opt.budget and stop == "noise floor":
        dom, opt, best, more, stop = _whole_budget(V, faces, uv, opt, scale, stage)
        history += more
    final, weights = _final(V, faces, best, opt, scale, best.dom is not dom, stage)
    return _result(V, final, opt, weights, scale, history, stop, clock.timings, parameterization)


def _whole_budget(V: np.ndarray, F: np.ndarray, uv: np.ndarray, opt: _Options, scale: np.ndarray | None,
                  stage: Callable) -> tuple[CoarseDomain, _Options, Round, list[dict], str]:
    """A noise-dominated scan (a budget alone): one domain of the whole budget, its own cross-validated
    smoothing (not the seed's spacing's) and one round; ``(domain, options, round, history, stop)``."""
    dom = coarse_domain(V, F, uv, n_vertices=opt.budget, warp=opt.warp)
    opt = dataclasses.replace(opt, reference=quadric_reference(dom, V))
    stage("domain")
    if opt.auto:
        opt = dataclasses.replace(opt, weights=_smoothing(dom, V, opt))
        stage("smoothing")
    best, history, _, opt = _refine(V, F, dom, opt, scale, 1, stage)
    return dom, opt, best, history, "noise floor"


def _smoothing(dom: CoarseDomain, V: np.ndarray, opt: _Options, located: tuple | None = None,
               unreached: np.ndarray | None = None, regular: bool = False) -> FitWeights:
    """:data:`~.fit.APPROX_WEIGHTS` with the cross-validated data weight of ``dom`` (scan at ``located``,
    ``unreached`` left out; ``regular``: a weight whose fit has no nearly singular patch)."""
    return dataclasses.replace(APPROX_WEIGHTS, data=cross_validated_weight(dom, V, corners=opt.corners,
                                                                           located=located, unreached=unreached,
                                                                           reference=opt.reference,
                                                                           regular=regular)[0])


def _located(dom: CoarseDomain, previous: Round | None) -> tuple[tuple[np.ndarray, np.ndarray], np.ndarray]:
    """``((face, bary), unreached)``: the scan's parameters in ``dom``, at the closest points of
    ``previous``'s surface (:func:`~.fit.corrected_location`), or their own uv without one, and the
    points left out of the data term."""
    if previous is None:
        face, bary, unreached = scan_location(dom)
    else:
        face, bary, unreached = corrected_location(dom, previous.deviation.uv, previous.deviation.on_boundary)
    return (face, bary), unreached


def loss_scale(dom: CoarseDomain, loss: str, diagonal: float) -> np.ndarray:
    """``(n,)`` the robust loss's scale at each scan vertex (model units).

    ``TUNING[loss] * noise`` (the scan's noise estimate, at least :data:`MIN_SCALE` of the
    diagonal), widened by ``SPIKE_LEVELS / roughness`` where the scan analysis finds a vertex
    consistent with its neighbours' robust quadric (roughness below :data:`~.analysis.SPIKE_LEVELS`).
    An M-estimate alone cannot tell a spike from a region the coarse surface does not follow yet
    (both are far from the fit) and would push such a region farther off; the scan's own local
    fits can: a spike keeps the nominal scale, coherent data get plain least squares.
    """
    base = TUNING[loss] * max(dom.stats.noise, MIN_SCALE * diagonal)
    return base * np.maximum(1.0, SPIKE_LEVELS / np.maximum(dom.analysis.roughness, 1e-12))


def _irls_weights(fit, located: tuple[np.ndarray, np.ndarray], V: np.ndarray, scale: np.ndarray, loss: str
                  ) -> np.ndarray:
    """``(n,)`` the robust loss's weights at the residuals of ``fit`` (the next reweighted step's)."""
    r = np.linalg.norm(fit.surface.evaluate(*located) - V, axis=1)
    return inlier_weight(r, scale, loss)


def _round_fit(V: np.ndarray, dom: CoarseDomain, opt: _Options, scale: np.ndarray | None) -> tuple[Any, tuple]:
    """``(fit, located)``: the plain fit over ``dom``, then (a robust loss) :data:`IRLS_STEPS` reweighted ones.

    The weights start afresh each round: a region the last domain could not follow is not
    kept down-weighted once refinement has given it the vertices to follow it.
    """
    located, unreached = _located(dom, None)
    pw, fit = None, None
    for _ in range(1 + (IRLS_STEPS if scale is not None else 0)):
        fit = fit_domain(dom, V, weights=opt.weights, loss=opt.loss, scale=scale, corners=opt.corners,
                         located=located, unreached=unreached, point_weight=pw, reference=opt.reference,
                         gauss_newton=False, like=fit)
        if scale is not None:
            pw = _irls_weights(fit, located, V, scale, opt.loss)
    return fit, located


def _insert(dom: CoarseDomain, ids: np.ndarray) -> CoarseDomain:
    """:func:`~.domain.insert`, or with only the interior ids when the new chords would cross (else ``dom``)."""
    try:
        return insert(dom, ids)
    except InputError:
        inner = ids[~np.isin(ids, dom.outline_ids)]
        try:
            return insert(dom, inner) if inner.size < ids.size else dom
        except InputError:
            return dom


def _grow(dom: CoarseDomain, state: Round, threshold: float, room: int, budget: int, humps: bool = False
          ) -> CoarseDomain:
    """``dom`` with the vertices :func:`~.refine.pick_vertices` asks for (faces over ``threshold``, at most
    ``room``; ``humps``: every notch of the outline over it too), within the budget. Where none of them could be
    inserted (each skipped, or chords that would cross), the faces' next candidates are tried,
    :data:`GROW_TRIES` times at most."""
    tried = np.empty(0, np.int64)
    for _ in range(GROW_TRIES):
        ids = pick_vertices(state, threshold, room, exclude=tried, humps=humps)
        if ids.size == 0:
            return dom
        new = _insert(dom, ids)
        while new.stats.n_vertices > budget and ids.size > 1:  # chord splits can add a few
            ids = ids[: ids.size // 2]
            new = _insert(dom, ids)
        if dom.stats.n_vertices < new.stats.n_vertices <= budget:
            return new
        tried = np.union1d(tried, ids)
    return dom


def _refine(V: np.ndarray, F: np.ndarray, dom: CoarseDomain, opt: _Options, scale: float | None, max_rounds: int,
            stage: Callable) -> tuple[Round, list[dict], str, _Options]:
    """The refinement rounds: ``(best round, history, why it stopped, options)``.

    With a tolerance: every face holding an inlier over it gets a vertex (at most doubling the count)
    until it is met. A budget alone: from :data:`BUDGET_SEED` of it, each round half the remaining room
    goes to the faces of largest deviation (the boundary chords' 3D sagitta included,
    :func:`~.refine.outline_gaps`), so the last vertices go a few at a time to the worst places
    (camelhead at 2%: d>m RMS 3.3e-3 -> 7.8e-4, max 2.6e-2 -> 3.8e-3); a scan at the noise floor
    (:func:`_at_noise_floor`, after the second round) stops it (``"noise floor"``: more
    vertices would follow noise and unflagged outliers, which ``corners="data"`` interpolates).
    """
    best, history, stop = None, [], "rounds"
    threshold = opt.tolerance if opt.refine else BUDGET_THRESHOLD * float(np.ptp(V, axis=0).max())
    def fitted(t0: float) -> tuple[Round, dict]:
        """The round's fit over ``dom`` with ``opt``'s weights, measured, and its record."""
        fit, located = _round_fit(V, dom, opt, scale)
        stage("fit")
        state = measure(dom, V, fit, located, scale is not None, seconds=time.perf_counter() - t0,
                        outline=opt.outline, scan_faces=None if opt.refine else F)
        return state, dict(state.record(), round=r + 1, tolerance=opt.tolerance, budget=opt.budget)

    for r in range(max_rounds):
        t0 = time.perf_counter()
        state, record = fitted(t0)
        history.append(record)
        stage("deviation", record=record)
        if opt.refine and opt.auto and REWEIGH_PINCHED and state.pinched.any():  # the weight chosen again here
            weights = _smoothing(dom, V, opt, state.located, state.fit.unreached, regular=True)
            if weights.data != opt.weights.data:
                opt = dataclasses.replace(opt, weights=weights)
                state, history[-1] = fitted(t0)
                stage("smoothing", record=history[-1])
        if best is None or _better(state, best, opt):  # with a tolerance, the inliers' maximum deviation
            best = state
        if not opt.refine and r == 1 and _at_noise_floor(history, dom.stats.noise):
            stop = "noise floor"
            break
        if opt.refine and opt.deviation(state) <= opt.tolerance:
            stop = "tolerance met"
            break
        if dom.stats.n_vertices >= opt.budget:
            stop = "budget"
            break
        if r + 1 == max_rounds:
            break
        room = opt.budget - dom.stats.n_vertices
        new = _grow(dom, state, threshold, room if opt.refine else int(np.ceil(BUDGET_STEP * room)), opt.budget,
                     humps=opt.refine and opt.outline_tolerance)
        stage("refine")
        if new.stats.n_vertices == dom.stats.n_vertices:
            stop = "stalled"  # nothing could be inserted (every candidate too close to a vertex, or budget)
            break
        dom = new
    return best, history, stop, opt


def _better(state: Round, best: Round, opt: _Options, tie: float = WORST_TIE) -> bool:
    """Whether ``state`` (more vertices, or the final fit) should replace ``best``: with a tolerance a
    smaller inliers' maximum; with a budget alone, a worst deviation not larger by more than ``tie``
    (:data:`WORST_TIE`; the final fit :data:`FINAL_TIE`) and a surface-to-scan gap within :data:`GAP_TIE`
    of the best's."""
    if opt.refine:  # a round that meets the tolerance with no nearly singular patch beats one with
        if state.pinched.any() != best.pinched.any():  # (refinement's pick, _refine), and only such a round
            regular = best if state.pinched.any() else state
            if opt.deviation(regular) <= opt.tolerance:
                return regular is state
        return state.worst < best.worst
    return (state.data_worst <= best.data_worst * (1.0 + tie)
            and state.gap_worst <= GAP_TIE * max(best.gap_worst, best.data_worst))


def _at_noise_floor(history: list[dict], noise: float) -> bool:
    """Whether the first two rounds' median deviations say noise: the seed's within :data:`BUDGET_FLOOR`
    noise estimates and the second's not below :data:`BUDGET_GAIN` of it."""
    first, second = history[-2]["p50"], history[-1]["p50"]
    return first <= BUDGET_FLOOR * noise and second > BUDGET_GAIN * first


def _final(V: np.ndarray, F: np.ndarray, best: Round, opt: _Options, scale: np.ndarray | None, refined: bool,
           stage: Callable) -> tuple[Round, FitWeights]:
    """The final fit on the best round's domain: with a robust loss its minimum by Gauss--Newton; with
    cross-validated weights and a refined domain, the weight chosen again on it. Then parameter corrections
    (the scan at the last fit's closest points, :func:`_located`; :data:`FINAL_CORRECTIONS` with a budget
    alone; with a tolerance up to :data:`TOLERANCE_CORRECTIONS`, stopping by :data:`CORRECTION_GAIN` or at the
    scan's noise estimate), keeping the fit of smallest
    :attr:`~.refine.Round.worst` (the largest deviation, both ways with a budget: what the refinement minimises;
    on exact data the corrections change nothing, the closest points being the scan's own parameters). With a
    tolerance it replaces the best round only if it meets the tolerance too or does not raise the maximum
    deviation. Returns the state kept and its weights."""
    t0 = time.perf_counter()
    located, unreached = (best.located, best.fit.unreached) if opt.refine else _located(best.dom, best)
    weights = (_smoothing(best.dom, V, opt, located, unreached, regular=opt.refine and bool(best.pinched.any()))
               if (opt.auto and refined) else opt.weights)
    state, kept, rms = best, None, np.inf
    for k in range(1 + _corrections(opt, V.shape[0])):
        pw = None if scale is None else _irls_weights(state.fit, located, V, scale, opt.loss)
        fit = fit_domain(best.dom, V, weights=weights, loss=opt.loss, scale=scale, corners=opt.corners,
                         located=located, unreached=unreached, point_weight=pw, reference=opt.reference,
                         gauss_newton=scale is not None, like=state.fit)
        state = measure(best.dom, V, fit, located, scale is not None, seconds=time.perf_counter() - t0,
                        outline=opt.outline, scan_faces=None if opt.refine else F)
        state = dataclasses.replace(state, corrections=k + (not opt.refine))
        if kept is None or state.worst < kept.worst:
            kept = state
        # a tolerance: stop where a correction does not help, or where none can: the fit's RMS is already the scan's
        # noise estimate (at that floor none lowered it: the generated 100k-face scan at 1.09 times its noise,
        # beetle 1.65, ~2 s a correction for nothing; the scans they improved 0.16-0.74)
        if opt.refine and (state.inliers["rms"] > CORRECTION_GAIN * rms or state.inliers["rms"] >= best.dom.stats.noise):
            break
        rms = state.inliers["rms"]
        located, unreached = _located(best.dom, state)
    stage("final")
    # the final fit, unless it would break a tolerance the best round met (or do worse)
    keep = (_better(kept, best, opt, FINAL_TIE) if opt.tolerance is None
            else opt.deviation(kept) <= max(opt.tolerance, opt.deviation(best))
            and (best.pinched.any() or not kept.pinched.any()))  # nor pinch a regular surface
    return (kept, weights) if keep else (best, dataclasses.replace(opt.weights, data=best.fit.weights[1]))


def _corrections(opt: "_Options", n_points: int) -> int:
    """How many parameter corrections :func:`_final` tries: :data:`FINAL_CORRECTIONS` with a budget alone,
    :data:`TOLERANCE_CORRECTIONS` with a tolerance on scans of at most :data:`TOLERANCE_CORRECTION_POINTS`."""
    if not opt.refine:
        return FINAL_CORRECTIONS
    return TOLERANCE_CORRECTIONS if n_points <= TOLERANCE_CORRECTION_POINTS else 0


def _outline_gap(state: Round, V: np.ndarray) -> float:
    """The largest distance of a kept scan boundary vertex from the surface's boundary curve beside it
    (:func:`~.refine.outline_gaps`): where a chord spans a notch of the outline, the surface
    stands this far from the scan, which the scan-to-surface deviation cannot see. A budget refines by it;
    a tolerance reports it (counted in the refinement it cost the 100k-face scan 4 more rounds, +5 s)."""
    gap = state.outline if state.outline is not None else outline_gaps(state.dom, V, state.fit)
    return float(gap[~state.rejected].max(initial=0.0))


def _crease_misses(V: np.ndarray, F: np.ndarray, state: Round, tolerance: float | None) -> dict[str, int]:
    """``over_tolerance``: the inliers a missed ``tolerance`` leaves over it, ``over_near_creases``: how many of
    them lie on or beside a sharp crease of a clean scan (:func:`~.creases.near_creases`), which a C1 surface
    rounds: there more vertices may not help. Both 0 where the tolerance was met or not given."""
    if tolerance is None:
        return dict(over_tolerance=0, over_near_creases=0)
    over = ~state.rejected & (state.deviation.distance > tolerance)
    near = near_creases(F, state.dom.analysis)
    return dict(over_tolerance=int(over.sum()), over_near_creases=int((over & near).sum()))


def _result(V: np.ndarray, state: Round, opt: _Options, weights: FitWeights, scale: np.ndarray | None,
            history: list[dict], stop: str,
            timings: dict, parameterization) -> ApproxResult:
    """Assemble the result: statistics, checks and the surface with its file extras."""
    dom, fit = state.dom, state.fit
    ctrl = np.asarray(fit.surface.ctrl)
    tri = fit.space.tri
    corners = ctrl[np.arange(tri.n_faces)[:, None], CORNER[None, :]]
    met = opt.tolerance is not None and opt.deviation(state) <= opt.tolerance
    nominal = None if scale is None else float(np.min(scale))  # the spikes' scale
    stats = dict(deviation=state.inliers, deviation_all=summary(state.deviation.distance),
                 rejected=int(state.rejected.sum()), unreached=int(np.count_nonzero(fit.unreached)),
                 vertices=int(dom.stats.n_vertices), patches=int(tri.n_faces),
                 tolerance=opt.tolerance, budget=opt.budget, met=bool(met), stop=stop, rounds=len(history),
                 noise=float(dom.stats.noise), noise_correlation=float(dom.stats.noise_correlation), scale=nominal,
                 scan_vertices=int(V.shape[0]), outline_gap=_outline_gap(state, V))
    stats.update(_crease_misses(V, parameterization.faces, state, opt.tolerance if not met else None))
    stats.update(data_weight=float(weights.data), cross_validated=opt.auto, corrections=state.corrections,
                 hull_slivers=int(hull_sliver_faces(V, parameterization.faces).sum()),
                 holes_filled=opt.filled,
                 small_holes=len(small_holes(V, parameterization.faces, SMALL_HOLE)),
                 regularity=float(relative_regularity(fit.surface, dom.scan_uv, dom.analysis.area_element)
                                  .min(initial=1.0)),
                 regularity_plain=float(state.regularity.min(initial=1.0)), reach=surface_reach(ctrl, V, WILD_REACH))
    settings = dict(loss=opt.loss, corners=opt.corners, tolerance=opt.tolerance, budget=opt.budget, scale=nominal,
                    data_weight=float(weights.data), fill_holes=opt.fill_holes,
                    outline_tolerance=opt.refine and opt.outline_tolerance)
    extras = surface_extras(dom, fit, V, stats, settings, weights)
    if fit.space.stats["snapped_vertices"]:  # uv moved onto exact crossings (spline.propagation.snap): by how much
        extras.update(domain_max_move=fit.space.stats["max_move"],
                      domain_max_relative_move=fit.space.stats["max_relative_move"])
    uv, faces, net = _user_net(parameterization, dom, fit.space, ctrl)
    surface = SplineSurface(uv, faces, net, extras=extras)
    return ApproxResult(
        surface=surface, domain=dom, vertices=dom.vertices, deviation=state.deviation, rejected=state.rejected,
        stats=stats, energies=fit.energies, iterations=fit.iterations, converged=fit.converged, history=history,
        timings=dict(timings), parameterization=parameterization, settings=settings, uv=uv, faces=faces,
        ctrl=net, c1_residual=float(continuity_report(tri, ctrl)["c1_relative"]),
        max_interpolation_error=float(np.abs(corners - V[dom.vertices][tri.faces]).max()), weights=weights,
        located=state.located)


#: The deviation statistics stored in the surface file, in order (``approx_deviation``).
DEVIATION_KEYS = ("count", "rms", "mean", "max", "p50", "p95", "p99")


def surface_extras(dom: CoarseDomain, fit, V: np.ndarray, stats: dict, settings: dict,
                   weights: FitWeights) -> dict[str, np.ndarray]:
    """The surface file's optional keys of an approximation (readers ignore keys they do not know).

    ``approx_scan_vertices (k,)``: the scan vertex of each coarse vertex; ``approx_deviation``
    (names in ``approx_deviation_names``): the inliers' deviation statistics, then ``rejected``,
    ``all_rms``, ``all_max``, ``outline_gap``; ``approx_loss``, ``approx_corners``, ``approx_tolerance`` (NaN:
    none), ``approx_budget``, ``approx_scale`` (NaN: plain loss), ``approx_noise``, ``approx_met``,
    ``approx_stop``, ``approx_fill_holes`` and ``approx_holes_filled`` (the setting, and the holes it spanned),
    ``approx_outline_tolerance`` (whether the tolerance held for the outline's gap too); ``free``, ``fit_weights``
    as for an interpolating fit, and ``data_vertices``
    (the corners' scan vertices) when the corners interpolate them.
    """
    from dataclasses import asdict

    dev = stats["deviation"]
    names = list(DEVIATION_KEYS) + ["rejected", "all_rms", "all_max", "outline_gap"]
    values = [float(dev[k]) for k in DEVIATION_KEYS] + [float(stats["rejected"]), stats["deviation_all"]["rms"],
                                                       stats["deviation_all"]["max"], float(stats["outline_gap"])]
    nan = lambda v: float("nan") if v is None else float(v)  # noqa: E731
    extras = dict(
        approx_scan_vertices=np.asarray(dom.vertices, np.int64), approx_deviation_names=np.array(names, dtype=str),
        approx_deviation=np.array(values), approx_loss=np.array(settings["loss"]),
        approx_corners=np.array(settings["corners"]), approx_tolerance=np.array(nan(settings["tolerance"])),
        approx_budget=np.array(int(settings["budget"])), approx_scale=np.array(nan(settings["scale"])),
        approx_noise=np.array(float(stats["noise"])), approx_met=np.array(bool(stats["met"])),
        approx_stop=np.array(stats["stop"]), approx_fill_holes=np.array(int(settings.get("fill_holes", 0))),
        approx_holes_filled=np.array(int(stats.get("holes_filled", 0))),
        approx_outline_tolerance=np.array(bool(settings.get("outline_tolerance", False))), free=fit.free,
        fit_weights=np.array(list(asdict(weights).values()), float))
    if settings["corners"] == "data":
        extras["data_vertices"] = V[dom.vertices]
    return extras
