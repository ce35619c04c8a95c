"""One coarse fit: the spline over a fixed coarse domain that fits every scan point.

    fit = fit_domain(dom, V, loss="huber", scale=1.345 * dom.stats.noise, corners="fit")   # CoarseFit
    fit.surface, fit.energies, fit.iterations, fit.converged

Every scan vertex is located in the coarse domain at its uv (:meth:`CoarseDomain.locate`);
one outside the coarse polygon (between a boundary chord and the scan's outline) keeps
its own uv as an extrapolation of the boundary patch that reaches it with the least
extrapolation (:meth:`~.locate.ClampedLocator.extension`; not simply the nearest edge's,
whose patch can be far off beyond a boundary vertex), unless that is farther than
:data:`EXTRAPOLATION` outside it in barycentric terms (then it sits on the chord, a
parameter a polynomial's data do not fit). Such a point is **unreached**
(:func:`scan_location`): the fit gives it no data weight (it is left out of the data term),
so a polynomial is still reproduced exactly; the pipeline counts them (``stats["unreached"]``).
The problem (:mod:`.problem`) is solved in coordinates normalised to the scan's size:
the plain loss by one solve with the host factor of its normal matrix (its exact
minimum; :mod:`trispline.fit.solve`), a robust loss by optimistix Gauss--Newton started
there, each step a solve with that same factor (:data:`GN_MODE`) and a backtracking line search
(:class:`DescentGaussNewton`: every step lowers the robust objective).
"""
from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import jax
import jax.numpy as jnp
import numpy as np
import optimistix as optx
import scipy.sparse as sp

from trispline.param import face_areas_3d
from trispline.spline.bernstein import basis
from trispline.spline.patches import regularity
from trispline.spline.polynomial import Polynomial, polynomial_control_net
from trispline.spline.propagation import SplineSpace, build_space, working_origin
from trispline.spline.surface import SplineSurface
from trispline.spline.util.spd import spd_backend
from trispline.spline.tolerances import APPROX_CG_RTOL, APPROX_CONVERGED_GRAD_RTOL, APPROX_GN_ATOL, APPROX_GN_RTOL

from ..gauss_newton import DescentGaussNewton
from ..reach import surface_reach
from ..solve import FactorSolver, SparseCholesky
from ..weights import FitWeights
from .domain import CoarseDomain
from ..energy.data import DataPoints
from .problem import (CORNER_MODES, ApproxProblem, PlainSystem, plain_system, residual_function, robust_points,
                      setup_problem)

__all__ = ["CoarseFit", "fit_domain", "bend_face_weights", "BEND_WEIGHT_RANGE", "scan_parameters",
           "scan_location", "corrected_parameters", "corrected_location", "outline_faces", "outline_factor", "OUTLINE_DATA_WEIGHT",
           "WARPED_OUTLINE_DATA_WEIGHT", "quadric_reference",
           "cross_validated_weight", "DescentGaussNewton",
           "APPROX_WEIGHTS", "DATA_WEIGHTS", "EXTRAPOLATION"]

#: Default weights of the approximation: thin-plate (less the reference quadric) and data. The
#: interpolation's tilt and local terms pull toward local fits of the coarse vertices' data alone.
APPROX_WEIGHTS = FitWeights(bend=1.0, tilt=0.0, local=0.0, data=10.0, angle=0.0)
#: Data weights :func:`cross_validated_weight` tries (the smoothing length is about ``h / w^(1/4)``).
DATA_WEIGHTS = (3.0, 10.0, 30.0, 100.0, 300.0, 1000.0, 3000.0, 10000.0, 3e4, 1e5, 3e5, 1e6)
#: ... leaving out every this-many-th scan vertex.
HOLDOUT = 10
#: A patch whose :func:`~trispline.spline.patches.regularity` (its smallest area element over its largest) is
#: below this is nearly singular somewhere: its curvature spikes there. Measured: the built-in noisy scan
#: (4,000 faces) at 1% of its diagonal with the data weight 1e6: an ear on the hole at 0.033, |H| 6.5e3 there
#: against the interpolant's largest 78; with 1e4 0.26 (docs/approximate.md).
PINCHED = 0.1
#: :func:`cross_validated_weight` with ``regular``: a weight whose fit has no :data:`PINCHED` patch is taken if
#: its held-out score is at most this much worse than the best's (the noisy built-in scan: 3e4 at 1.024x; a
#: terrain tile whose hull slivers pinch at every weight but the smallest: 300 at 1.52x, 3 at 2.81x, refused).
REGULAR_SLACK = 0.1
#: A candidate data weight whose fit reaches farther than this many bounding-box diagonals outside the scan's box
#: (:func:`~trispline.fit.reach.surface_reach`) is passed over while another stays within: held-out scan vertices
#: do not see a patch overshooting between them (a steep ramp of 85 vertices at 3e-3 of its diagonal: 3e4 scored
#: best and its surface spiked 0.69 diagonals above the scan; 1e6 met it within 0.0096). Sound fits stay within 0.04;
#: a fair surface through the four corners of a saddle of two triangles bulges 0.057 out of their thin box.
WILD_REACH = 0.1
#: Monomial exponents of the reference quadric.
QUADRIC_POWERS = np.array([(0, 0), (1, 0), (0, 1), (2, 0), (1, 1), (0, 2)])
#: The robust Gauss--Newton steps' linear solve (:class:`~trispline.fit.solve.FactorSolver`): ``"pcg"``,
#: CG on the exact Gauss--Newton matrix preconditioned by the reweighted factor, or ``"direct"``, the
#: factor alone (an inexact Gauss--Newton step: the factor is reweighted at the IRLS start, so close to
#: the robust loss's matrix). Measured on the 100k-face speed scan: "direct" 5 steps, compile 6.2 s and
#: run 0.8 s against "pcg" 5 steps, 8.4 s and 1.2 s (load 9 on 2 cores); both converged.
GN_MODE = "direct"
#: Largest factor of :func:`bend_face_weights`, either way.
BEND_WEIGHT_RANGE = 1e4
#: The patches along the outline are smoothed at most as little as this data weight does
#: (:func:`outline_factor`).
OUTLINE_DATA_WEIGHT = 1e4
#: ... and over a warped domain (:attr:`~.domain.CoarseDomain.warped`), whose outline patches have the scan's
#: outline under them (but for a jagged run's teeth): beetle at 2% ``corners="data"``, m>d RMS 0.37 of
#: qslim's with 1e4, 0.31 with this, 0.26 with none; ``corners="fit"`` on face_gpjs m>d max 0.63 with 1e4
#: and with none (a patch swings out), 0.23 with this.
WARPED_OUTLINE_DATA_WEIGHT = 1e5
#: A scan point outside the coarse polygon extrapolates its patch down to this barycentric coordinate.
EXTRAPOLATION = -0.5


@dataclass(frozen=True)
class CoarseFit:
    """A spline fitted to the scan over one coarse domain.

    Attributes
    ----------
    surface : SplineSurface over ``(space.tri.uv, dom.faces)`` (``dom.uv`` unless the spline core snapped
        nearly singular vertices onto exact crossings: ``space.stats["snapped_vertices"]``)
    free : (n_free, 3) the free points; space : SplineSpace
    energies : dict term -> energy (``bend``, ``data``; weights included, data units)
    iterations : Gauss--Newton steps (0: the plain loss, solved directly)
    converged : bool
    n_unknowns : free points solved for
    unreached : (n,) bool, the scan points left out of the data term (:func:`scan_location`)
    factor : the SparseCholesky of its normal matrix (another fit over the same domain reuses its analysis)
    system : its PlainSystem, whose bend half another fit over the same domain, with the same ``weights``
        (bend, data, corner mode) and reference, reuses
    """

    surface: SplineSurface
    free: np.ndarray
    space: SplineSpace
    energies: dict
    iterations: int
    converged: bool
    n_unknowns: int
    unreached: np.ndarray | None = None
    factor: SparseCholesky | None = None
    system: PlainSystem | None = None
    weights: tuple = ()


def scan_location(dom: CoarseDomain) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``face (n,)``, ``bary (n, 3)`` of every scan vertex in the coarse domain (see the module docstring)
    and ``unreached (n,)`` bool: outside the domain and farther than :data:`EXTRAPOLATION` from every
    boundary patch that could extend to it (on its chord instead, where its data do not belong)."""
    uv = dom.warped_uv
    hit = dom.locate(uv)
    face, bary = hit.face.copy(), hit.bary.copy()
    unreached = np.zeros(uv.shape[0], bool)
    out = np.flatnonzero(hit.clamped)
    if out.size:
        ext, own = dom.locator.extension(uv[out])
        near = own.min(1) >= EXTRAPOLATION
        face[out[near]], bary[out[near]] = ext[near], own[near]
        unreached[out[~near]] = True
    return face, bary, unreached


def scan_parameters(dom: CoarseDomain) -> tuple[np.ndarray, np.ndarray]:
    """``face (n,)``, ``bary (n, 3)`` of every scan vertex in the coarse domain (:func:`scan_location`)."""
    return scan_location(dom)[:2]


def corrected_location(dom: CoarseDomain, closest_uv: np.ndarray, on_boundary: np.ndarray
                       ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``face (n,)``, ``bary (n, 3)``, ``unreached (n,)``: every scan vertex at its closest point on an earlier
    fit's surface (``closest_uv (n, 2)``, :attr:`~.deviation.Deviation.uv`), located in ``dom`` (parameter
    correction).

    A least-squares fit at fixed parameters measures each point's error at its own uv, so the map's
    tangential distortion (which a coarse spline cannot follow) counts as error; at the closest
    point only the true 3D distance does, and refitting there lowers it (camelhead at 2%: d>m RMS
    -17% after three corrections). Points whose closest point lies on the surface's boundary curve
    (``on_boundary (n,)``) or outside ``dom`` keep :func:`scan_location` (their own uv's extrapolation,
    or unreached), and so do the scan's boundary vertices: the warp put them on the coarse boundary
    (:mod:`.warp`), where they hold the boundary curve to the scan's outline; at their closest points,
    often just inside, they would let it swing out past the outline (a 30 x 30 grid's height field at 1e-3
    of its diagonal: the outline gap 0.81 of the tolerance after three corrections, 0.45 with them kept).
    """
    face, bary, unreached = scan_location(dom)
    hit = dom.locate(np.asarray(closest_uv, np.float64))
    use = ~hit.clamped & ~np.asarray(on_boundary, bool)
    use[dom.outline_ids] = False
    face[use], bary[use] = hit.face[use], hit.bary[use]
    unreached[use] = False
    return face, bary, unreached


def corrected_parameters(dom: CoarseDomain, closest_uv: np.ndarray, on_boundary: np.ndarray
                         ) -> tuple[np.ndarray, np.ndarray]:
    """``face (n,)``, ``bary (n, 3)`` of :func:`corrected_location`."""
    return corrected_location(dom, closest_uv, on_boundary)[:2]


def quadric_reference(dom: CoarseDomain, V: np.ndarray) -> Polynomial:
    """The scan's best-fit quadric over uv, ``(u, v) -> (3,)``: least squares on the scan analysis's
    denoised vertices (each on its cell's robust quadric), so outliers barely move it.

    It depends on ``dom.scan_uv`` and ``dom.analysis.smooth`` alone, which the refinement rounds'
    domains share: the pipeline computes it once per domain family and passes it on as ``reference``
    (1M scan points: 0.3 s a fit)."""
    uv = dom.scan_uv
    centre = 0.5 * (uv.min(0) + uv.max(0))
    x = uv - centre
    m = x[:, :1] ** QUADRIC_POWERS[:, 0] * x[:, 1:] ** QUADRIC_POWERS[:, 1]  # (n, 6)
    coeffs = np.linalg.lstsq(m, dom.analysis.smooth, rcond=None)[0]
    return Polynomial(powers=QUADRIC_POWERS, coeffs=coeffs, centre=centre)


def bend_face_weights(dom: CoarseDomain) -> np.ndarray:
    """``(f,)`` the thin-plate energy's factor per coarse face: the map's area ratio over the face's.

    Over uv, the thin-plate energy of a given 3D shape scales like the map's local area ratio
    ``lambda^2`` (3D area over uv area; second derivatives grow like ``lambda^2``, the uv area
    shrinks like ``lambda^-2``); the data term per uv area grows like ``lambda^2`` as well, so its
    balance would smooth a region the map compresses over a 3D length ``sqrt(lambda)`` times longer.
    The factor ``rho / lambda_f^2`` (``rho`` the whole domain's ratio; each face's from its corners'
    denoised positions, clipped to :data:`BEND_WEIGHT_RANGE` either way) makes the smoothing length
    uniform in 3D; 1 everywhere for an isometric map.
    """
    a3 = face_areas_3d(dom.analysis.smooth[dom.vertices], dom.faces)
    auv = dom.triangulation.areas
    rho = float(a3.sum()) / max(float(auv.sum()), 1e-300)
    ratio = a3 / np.maximum(auv, 1e-300)
    return np.clip(rho / np.maximum(ratio, 1e-300), 1.0 / BEND_WEIGHT_RANGE, BEND_WEIGHT_RANGE)


def outline_faces(dom: CoarseDomain) -> np.ndarray:
    """``(f,)`` bool: the coarse faces with an edge on the domain's boundary."""
    tri = dom.triangulation
    return tri.boundary_edge_mask[tri.face_edges].any(1)


def outline_factor(data_weight: float, warped: bool = False) -> float:
    """The thin-plate factor of the :func:`outline_faces` at ``data_weight``: ``max(1, w / OUTLINE_DATA_WEIGHT)``
    (``warped``: :data:`WARPED_OUTLINE_DATA_WEIGHT`).

    A patch on the outline has data over part of it only (a boundary chord cuts off scan, or
    spans a hole or a concave run of the outline), and the rest is extrapolation. With little
    smoothing (the data weights above :data:`OUTLINE_DATA_WEIGHT` that clean scans choose) a
    quintic fitted to a part of its patch swings out over the rest (camelhead at 2%, weight 1e6:
    scan-to-surface max 1.2e-2 of the diagonal on one outline patch, 4.9e-3 with this factor);
    the interior patches, covered by data, get the small smoothing.
    """
    return max(1.0, float(data_weight) / (WARPED_OUTLINE_DATA_WEIGHT if warped else OUTLINE_DATA_WEIGHT))


def _normalisation(V: np.ndarray) -> tuple[np.ndarray, float]:
    """``(centre (3,), size)``: the fit works on ``(V - centre) / size`` (optimistix's stopping tests are per element)."""
    return 0.5 * (V.min(0) + V.max(0)), float(np.ptp(V, axis=0).max()) or 1.0


def _reference_net(dom: CoarseDomain, V: np.ndarray, reference: Polynomial | None, centre: np.ndarray,
                   size: float) -> np.ndarray:
    """``(f, 21, 3)`` the bend term's reference per patch, normalised (default :func:`quadric_reference`)."""
    ref = quadric_reference(dom, V) if reference is None else reference
    return (polynomial_control_net(dom.uv, dom.faces, ref) - centre) / size


def cross_validated_weight(dom: CoarseDomain, V: np.ndarray, *, weights: FitWeights = APPROX_WEIGHTS,
                           corners: str = "data", candidates: tuple[float, ...] = DATA_WEIGHTS,
                           holdout: int = HOLDOUT, located: tuple[np.ndarray, np.ndarray] | None = None,
                           unreached: np.ndarray | None = None, reference: Polynomial | None = None,
                           regular: bool = False) -> tuple[float, dict[float, float]]:
    """The data weight of :data:`DATA_WEIGHTS` whose plain fit best predicts held-out scan vertices.

    Every ``holdout``-th scan vertex (not a coarse vertex) is left out; the others are fitted
    once per candidate (one assembly of the split normal equations, one PARDISO analysis, one
    numerical factorisation per candidate: :meth:`~trispline.fit.solve.SparseCholesky.refactor`)
    and the left-out ones scored by their residual at their own parameter, RMS over
    all but the worst 1% (outliers). Noisy scans want a small weight (more smoothing), clean
    ones with detail a large one. ``located``: the scan's parameters (default :func:`scan_location`;
    the pipeline passes :func:`corrected_location`), ``unreached (n,)`` its points left out (default
    :func:`scan_location`'s), ``reference`` the bend term's (default :func:`quadric_reference`). ``regular``:
    the best weight whose fit has no :data:`PINCHED` patch, if its score is within :data:`REGULAR_SLACK` of the
    best (else the best: a pinch that only a much smoother fit loses is not the weight's doing).
    Returns ``(weight, {weight: score})``; ``(weights.data, {})`` when no scan vertex is left to hold out.
    """
    face, bary, unreached = _location(dom, located, unreached)
    n = V.shape[0]
    test = np.arange(n) % holdout == holdout // 2
    test[dom.vertices] = False
    train = ~test & ~unreached
    test &= ~unreached
    if not test.any():  # a scan (nearly) all coarse vertices: nothing left to predict
        return weights.data, {}
    centre, size = _normalisation(V)
    Vn = (V - centre) / size
    space = build_space(dom.triangulation)
    corner_xyz = Vn[dom.vertices] if corners == "data" else None
    ref_net = _reference_net(dom, V, reference, centre, size)
    train = DataPoints(face[train], bary[train], Vn[train])
    bw, edge = bend_face_weights(dom), outline_faces(dom)
    sys = plain_system(space, train, corner_xyz, weights, "l2", ref_net, bend_weight=bw * ~edge)
    none = DataPoints(face[:0], bary[:0], Vn[:0])
    rim = plain_system(space, none, corner_xyz, weights, "l2", ref_net, bend_weight=bw * edge)  # the outline's bend
    B = basis(bary[test])
    scores, least, reach = {}, {}, {}
    factor = None
    backend = spd_backend(None, sys.unknowns.size, pardiso_min=0)  # one analysis for every candidate
    for w in candidates:
        o, d = outline_factor(w, dom.warped), w / weights.data
        U = sp.triu(sys.H_bend + o * rim.H_bend + d * sys.H_data, format="csr")
        if factor is None or not factor.refactor(U):
            factor = SparseCholesky(U, backend=backend, upper=True)
        free = np.zeros((space.n_free, 3))
        if corner_xyz is not None:
            free[space.corner_free] = corner_xyz
        free[sys.unknowns] = factor.solve(sys.rhs_bend + o * rim.rhs_bend + d * sys.rhs_data)
        ctrl = space.control_points(free)
        r = np.linalg.norm(np.einsum("nk,nkc->nc", B, ctrl[face[test]]) - Vn[test], axis=1)
        kept = np.sort(r)[: max(1, int(np.ceil(0.99 * r.size)))]
        scores[w] = float(np.sqrt(np.mean(kept**2))) * size
        reach[w] = surface_reach(ctrl, Vn, WILD_REACH)
        if regular:
            least[w] = float(regularity(space.tri.uv, space.tri.faces, ctrl).min(initial=1.0))
    tame = [w for w in scores if reach[w] <= WILD_REACH] or list(scores)
    best = min(tame, key=scores.get)
    ok = [w for w in tame if w in least and least[w] >= PINCHED and scores[w] <= (1.0 + REGULAR_SLACK) * scores[best]]
    return (min(ok, key=scores.get) if ok else best), scores


def fit_domain(dom: CoarseDomain, V: np.ndarray, *, weights: FitWeights = APPROX_WEIGHTS, loss: str = "huber",
               scale: float | np.ndarray | None = None, corners: str = "data",
               located: tuple[np.ndarray, np.ndarray] | None = None, unreached: np.ndarray | None = None,
               point_weight: np.ndarray | None = None, gauss_newton: bool = True, reference: Polynomial | None = None,
               solver: optx.AbstractLeastSquaresSolver | None = None, max_steps: int = 50,
               like: CoarseFit | None = None) -> CoarseFit:
    """Fit the spline over ``dom`` to every scan vertex ``V (n, 3)``.

    Parameters
    ----------
    loss : ``"l2"``, ``"huber"`` or ``"cauchy"``; scale : the robust loss's scale (data units, > 0),
        one or ``(n,)`` one per scan vertex (e.g. ``TUNING[loss] * dom.stats.noise``,
        :data:`~trispline.fit.energy.robust.TUNING`; the pipeline's: :func:`~.pipeline.loss_scale`)
    corners : ``"data"`` (corner points = their scan vertices) or ``"fit"``
    located : ``(face (n,), bary (n, 3))`` from :func:`scan_location`, if already known
    unreached : (n,) bool, the points left out of the data term (no data weight; default
        :func:`scan_location`'s, found again if ``located`` is given without it)
    point_weight : (n,) reweighting of the plain normal equations (the robust loss's weights at
        an earlier fit): their solution starts Gauss--Newton and their factor preconditions it
    gauss_newton : False: stop at that reweighted least-squares solution (one IRLS step, the
        refinement rounds' cheap fit); True: the robust loss's minimum
    reference : the bend term's reference surface over uv (default :func:`quadric_reference`)
    solver : an optimistix least-squares solver for the robust loss (default :class:`DescentGaussNewton`
        with the start's factor, :data:`GN_MODE`); max_steps : its step cap
    like : an earlier fit of the same scan over the same domain and reference (a reweighted or corrected
        refit): its spline space, its factor's analysis (PARDISO's numerical phase alone, where the normal
        matrix has its pattern: that factor is refactored in place) and, with the same bend and data
        weights and corner mode, its bend half
    """
    if corners not in CORNER_MODES:
        raise ValueError(f"corners must be one of {', '.join(CORNER_MODES)}, got {corners!r}")
    if loss != "l2" and scale is None:
        raise ValueError(f"the {loss} loss needs its scale (data units)")
    face, bary, unreached = _location(dom, located, unreached)
    centre, size = _normalisation(V)
    space = like.space if like is not None else build_space(dom.triangulation)
    keep = np.flatnonzero(~unreached) if unreached.any() else slice(None)  # unreached: no data weight
    sc = size if scale is None else np.asarray(scale)
    points = robust_points(face[keep], bary[keep], (V[keep] - centre) / size, loss,
                           (sc if np.ndim(sc) == 0 else sc[keep]) / size)
    point_weight = None if point_weight is None else np.asarray(point_weight)[keep]
    corner_xyz = (V[dom.vertices] - centre) / size if corners == "data" else None
    bend_of = like.system if like is not None and like.weights == (weights.bend, weights.data, corners) else None
    if bend_of is None:
        ref_net = _reference_net(dom, V, reference, centre, size)
        bw = bend_face_weights(dom) * np.where(outline_faces(dom), outline_factor(weights.data, dom.warped), 1.0)
    else:  # the same domain, weights and reference: the bend half as it was
        ref_net, bw = bend_of.terms["reference"], None
    prob = setup_problem(space, points, corner_xyz, weights, loss, ref_net, point_weight, bw, bend_of)
    factor = like.factor if like is not None and like.factor is not None else None
    if factor is None or not factor.refactor(sp.triu(prob.H, format="csr")):
        factor = SparseCholesky(prob.H)
    x, steps, ok = _solve(prob, factor, solver, max_steps, gauss_newton)
    free = np.zeros((space.n_free, 3))
    if corner_xyz is not None:
        free[space.corner_free] = V[dom.vertices]
    k = prob.unknowns.size
    free[prob.unknowns] = x[:k] * size + centre
    ctrl = space.control_points(free, about=working_origin(V))
    energies = prob.energies((ctrl - centre) / size, size)
    surface = SplineSurface(space.tri.uv, dom.faces, ctrl)  # the domain used: nearly singular vertices snapped
    return CoarseFit(surface=surface, free=free, space=space, energies=energies, iterations=steps, converged=ok,
                     n_unknowns=k, unreached=unreached, factor=factor, system=prob.plain,
                     weights=(weights.bend, weights.data, corners))


def _location(dom: CoarseDomain, located: tuple[np.ndarray, np.ndarray] | None, unreached: np.ndarray | None
              ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(face, bary, unreached)``: the given ones, the missing ones from :func:`scan_location`."""
    if located is not None and unreached is not None:
        return located[0], located[1], np.asarray(unreached, bool)
    face, bary, found = scan_location(dom)
    if located is not None:
        face, bary = located
    return face, bary, found if unreached is None else np.asarray(unreached, bool)


def _half_sum_squares(x: jax.Array, args: dict) -> jax.Array:
    return 0.5 * sum(jnp.sum(r * r) for r in residual_function("huber")(x, args).values())


_gradient = jax.jit(jax.grad(_half_sum_squares))


def _compiled_gradient(shape: tuple[int, ...], args: dict):
    """:data:`_gradient` compiled ahead of time for ``x`` of ``shape`` and these ``args``: run in a thread
    while optimistix compiles its solve (XLA compiles without the GIL: the two compilations, 0.7 s and
    1.8 s of the 100k-face scan's final fit, overlap on two cores)."""
    return _gradient.lower(jax.ShapeDtypeStruct(shape, jnp.float64), args).compile()


def _solve(prob: ApproxProblem, factor: SparseCholesky, solver, max_steps: int, gauss_newton: bool
           ) -> tuple[np.ndarray, int, bool]:
    """``(x (kp, 3), Gauss--Newton steps, converged)``: the (reweighted) plain optimum, then
    optimistix for a robust loss."""
    x0 = factor.solve(prob.rhs)
    if not prob.nonlinear or not gauss_newton:
        return x0, 0, True
    if solver is None:
        solver = DescentGaussNewton(APPROX_GN_RTOL, APPROX_GN_ATOL, optx.rms_norm,
                                    FactorSolver(factor, mode=GN_MODE, rtol=APPROX_CG_RTOL))
    with ThreadPoolExecutor(1, thread_name_prefix="trispline-compile") as pool:
        gradient = pool.submit(_compiled_gradient, x0.shape, prob.args)
        sol = optx.least_squares(residual_function(prob.loss), solver, jnp.asarray(x0), prob.args,
                                 max_steps=max_steps, throw=False)
        gradient = gradient.result()
    x = sol.value
    gnorm = float(jnp.abs(gradient(x, prob.args)).max())
    gref = float(jnp.abs(gradient(jnp.zeros_like(x), prob.args)).max()) or 1.0
    ok = sol.result == optx.RESULTS.successful and gnorm <= APPROX_CONVERGED_GRAD_RTOL * gref
    return np.asarray(x), int(sol.stats["num_steps"]), bool(ok)
