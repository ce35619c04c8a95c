"""Fit an exactly C1 quintic spline to an open mesh: interpolate, then fair.

    result = fit_surface(V, F, param="harmonic")        # FitResult
    result.surface.save("scan.npz")

Pipeline: parameterize (unless ``uv`` is given) -> build the spline space
``P = M @ free`` -> fix the corner points to the data (``z_v = V[v]``) -> choose
every other free point by minimising

    w_bend * thin-plate + w_tilt * tilt + w_local * local + w_data * data (+ w_angle * angle)

(see :mod:`trispline.fit.energy`) with optimistix Gauss--Newton whose linear
solve is a host sparse Cholesky of the quadratic part (:mod:`trispline.fit.solve`).
"""
from __future__ import annotations

from dataclasses import asdict, dataclass, field
from typing import Any, Callable

import numpy as np
import optimistix as optx

from trispline.param import DEFAULT_METHOD, face_aspects, hull_sliver_faces, refuse_slivers
from trispline.spline.checks import as_array, callback, flag, whole_number
from trispline.spline.continuity import continuity_report
from trispline.spline.errors import InputError
from trispline.spline.index import CORNER
from trispline.spline.propagation import SplineSpace, build_space, working_origin
from trispline.spline.surface import SplineSurface
from trispline.spline.topology import Triangulation, signed_areas
from trispline.spline.util.timer import StageTimer

from . import energy as en
from .energy.data import DataPoints, as_data_points
from .errors import FitError, NotPositiveDefinite
from .gauss_newton import QuadraticStep, iterate
from .limits import check_fit_memory
from .progress import counting, silent, span, stage_reporter
from .reach import surface_reach
from .solve import PatternAnalysis, check_memory, estimate_factor_bytes, release_free_heap, require_x64
from .stages import ASSEMBLE, BUILD, FACTOR, FINISH, PARAMETERIZE, SOLVE
from .weights import FitWeights

__all__ = ["FitWeights", "FitResult", "FitError", "fit_surface", "DataPoints"]


@dataclass(frozen=True)
class FitResult:
    """Outcome of :func:`fit_surface`.

    Attributes
    ----------
    surface : SplineSurface (with the data vertices, free points and weights as extras, and
        ``domain_max_move`` where nearly singular domain vertices were snapped)
    ctrl : (F, 21, 3) control points
    free : (n_free, 3) all free points (corners included)
    space : SplineSpace
    energies : dict term -> energy (weights included, data units)
    iterations : Gauss--Newton steps
    converged : bool
    c1_residual : worst C1 diamond residual relative to the net's size
    max_interpolation_error : max |corner point - data vertex|
    timings : dict stage -> seconds
    parameterization : the Parameterization (None when ``uv`` was given)
    uv, faces : the domain, (nv, 2) and (F, 3)
    weights : FitWeights
    stats : n_free, n_solved, H_nnz, continuity (the full report), analysis_seconds (the factor's
        analysis, run beside the assembly: :class:`~trispline.fit.solve.PatternAnalysis`) and
        analysis_wait_seconds (how long the factor stage waited for it)
    curved_outline : whether the boundary patches' targets followed the outline faired as a curve
        (the fit made its domain: :mod:`trispline.fit.boundary`); the re-fair
        (:mod:`trispline.fit.refair`) and :func:`~trispline.fit.refair.fairness_energy` need it
    smooth_map : whether the map was smooth up to its outline (given uv, or a polynomial map of the
        parameterization: :mod:`trispline.param.polymap`), so the outline took the given map's fits
        (:func:`~trispline.fit.energy.context.term_context`); the re-fair needs it too
    """

    surface: SplineSurface
    ctrl: np.ndarray
    free: np.ndarray
    space: SplineSpace
    energies: dict
    iterations: int
    converged: bool
    c1_residual: float
    max_interpolation_error: float
    timings: dict
    parameterization: Any
    uv: np.ndarray
    faces: np.ndarray
    weights: FitWeights
    stats: dict = field(default_factory=dict)
    curved_outline: bool = False
    smooth_map: bool = True


def _check_mesh(V, F) -> tuple[np.ndarray, np.ndarray]:
    """``V (nv, 3)`` finite float64 and ``F (nf, 3)`` int64; float faces are refused."""
    V = as_array(V, "V", (None, 3), finite=True)
    F_in = np.asarray(F)
    if F_in.size and not np.issubdtype(F_in.dtype, np.integer):
        raise InputError(f"F must be integers, got dtype {F_in.dtype}")
    return V, as_array(F_in, "F", (None, 3), integer=True)


def _domain(V: np.ndarray, F: np.ndarray, uv, param: str, report: Callable[[float], None] | None = None
            ) -> tuple[np.ndarray, np.ndarray, Any]:
    """``(uv (nv, 2), faces (nf, 3), parameterization or None)``; ``report``: the map's progress."""
    if uv is not None:
        uv = as_array(uv, "uv", (V.shape[0], 2))
        faces = F[:, [0, 2, 1]] if (signed_areas(uv, F) < 0).all() else F
        return uv, faces, None
    from trispline.param import Parameterization, parameterize

    if isinstance(param, Parameterization):  # made beforehand (the command line's, with its own progress bar)
        if param.uv.shape != (V.shape[0], 2) or param.faces.shape != F.shape:
            raise InputError(f"param is a parameterization of another mesh (uv {param.uv.shape}, faces "
                             f"{param.faces.shape}; the mesh has {V.shape[0]} vertices, {F.shape[0]} faces)")
        return param.uv, param.faces, (None if param.method == "uv" else param)  # a user's uv: as given

    p = parameterize(V, F, method=param, report=report)
    return p.uv, p.faces, p


#: Most Gauss-Newton steps a fit may ask for (optimistix counts them in a 32-bit integer).
MAX_STEPS = 1_000_000


def fit_surface(
    V: np.ndarray,
    F: np.ndarray,
    *,
    uv: np.ndarray | None = None,
    param: str = DEFAULT_METHOD,
    weights: FitWeights = FitWeights(),
    data_points: DataPoints | tuple | None = None,
    solver: optx.AbstractLeastSquaresSolver | None = None,
    progress: Callable[..., None] | None = None,
    throw: bool = True,
    max_steps: int = 50,
) -> FitResult:
    """Interpolate the mesh vertices with an exactly C1 quintic spline and fair it.

    Parameters
    ----------
    V : (nv, 3) float, F : (nf, 3) int
        An open mesh (disk, or disk with holes).
    uv : (nv, 2) float, optional
        The domain. When given it is used as is (e.g. ``V[:, :2]`` for a height
        field) and ``param`` is ignored; faces are reversed if all are clockwise.
    param : {"lscm", "spectral", "harmonic", "slim", "uv", "auto"} or Parameterization
        Parameterization method when ``uv`` is None (see :mod:`trispline.param`). The
        default (``trispline.param.DEFAULT_METHOD``, ``spectral``: conformal, free boundary) keeps corners of the
        outline undistorted; on the shared real meshes it gave far smaller extreme curvature than
        ``harmonic``, whose circle boundary squeezes corners (inspired_mesh: max |H| L 3 against 5107).
        Or a :class:`~trispline.param.Parameterization` of this mesh made beforehand (``parameterize``
        with options of your own): fitted as the fit's own map (its outline faired as a curve), but one
        of ``method="uv"`` as given uv.
    weights : FitWeights
    data_points : DataPoints or (face (n,), bary (n, 3), xyz (n, 3)), optional
    solver : an optimistix least-squares solver; default Gauss--Newton with the
        host sparse Cholesky (direct when the energy is quadratic, factor-preconditioned
        CG and a line search when ``weights.angle > 0``: :func:`~trispline.fit.gauss_newton.iterate`)
    progress : ``progress(stage, seconds)`` called after each stage (the names of
        :data:`~trispline.fit.stages.FIT_STAGES`); a callback taking a third argument is
        also called as ``progress(stage, seconds so far, fraction)`` while a long stage's
        chunks of work finish (the command line's progress bar)
    throw : raise :class:`FitError` if the solver did not converge
    max_steps : Gauss--Newton step cap

    Returns
    -------
    FitResult
    """
    require_x64()
    if not isinstance(weights, FitWeights):
        raise InputError(f"weights must be a FitWeights, got {type(weights).__name__}")
    if solver is not None and not isinstance(solver, optx.AbstractLeastSquaresSolver):
        raise InputError(f"solver must be an optimistix least-squares solver or None, got {type(solver).__name__}")
    progress, throw = callback(progress, "progress"), flag(throw, "throw")
    max_steps = whole_number(max_steps, "max_steps", least=1, most=MAX_STEPS)
    clock = StageTimer(progress)
    V, F = _check_mesh(V, F)
    check_fit_memory(F.shape[0])  # before the parameterization: at 1M faces it alone can take minutes
    uv, faces, parameterization = _domain(V, F, uv, param, stage_reporter(progress, PARAMETERIZE))
    # thin triangles make the normal matrix indefinite
    refuse_slivers(uv, faces, V=V, method="given" if parameterization is None else parameterization.method)
    clock(PARAMETERIZE)
    tri = Triangulation(uv, faces)
    space = build_space(tri, report=stage_reporter(progress, BUILD))
    # refuse a factorisation that cannot fit in memory before assembling it (the analysis checks again)
    check_memory(estimate_factor_bytes(space.n_free - tri.n_vertices, 0), "available")
    clock(BUILD)
    dp = None if data_points is None else as_data_points(data_points, tri.n_faces)
    # solve in normalised coordinates (optimistix's stopping tests are per element)
    centre = 0.5 * (V.min(0) + V.max(0))
    size = float(np.ptp(V, axis=0).max()) or 1.0
    if dp is not None:
        dp = DataPoints(dp.face, dp.bary, (dp.xyz - centre) / size)
    analysis = PatternAnalysis()  # the factor's analysis runs on the pattern while the terms are set up
    curved = parameterization is not None  # fit.boundary: a user's uv stays the surface's parameters
    smooth_map = not curved or parameterization.smoothing.get("polynomial", 0) > 0
    prob = en.setup_problem((V - centre) / size, space, weights, dp, report=stage_reporter(progress, ASSEMBLE),
                            on_pattern=analysis.start, curved_outline=curved, smooth_map=smooth_map)
    clock(ASSEMBLE)
    release_free_heap()
    step = QuadraticStep(prob) if solver is None and not prob.nonlinear else None  # compiles meanwhile
    try:
        factor = analysis.factor(prob.H_upper, max_bytes="available", report=stage_reporter(progress, FACTOR))
    except BaseException as exc:
        if step is not None:
            step.close()
        if isinstance(exc, NotPositiveDefinite):
            raise NotPositiveDefinite(_thin_triangles(space.tri.uv, space.tri.faces, V, str(exc))) from exc
        raise
    clock(FACTOR)
    if step is not None:  # the bar moves as each host solve inside the compiled step ends
        factor.on_solve = counting(span(stage_reporter(progress, SOLVE), 0.0, 0.9), QuadraticStep.HOST_SOLVES)
        x, energies, steps, ok = step.run(factor)
        factor.on_solve = None
    else:
        x, energies, steps, ok = iterate(prob, factor, solver, max_steps)
    clock(SOLVE)
    result = _finish(V, space, prob, x, energies, centre, size, steps, ok, weights, parameterization,
                     stage_reporter(progress, FINISH))
    if (reach := surface_reach(result["ctrl"], V, OVERSHOOT)) > WILD_NET:  # a nearly indefinite matrix that happened to factor
        raise NotPositiveDefinite(_thin_triangles(space.tri.uv, space.tri.faces, V, (
            f"the normal matrix is nearly indefinite (it factored, but the solved surface reaches {reach:.3g} "
            "bounding-box diagonals outside the scan)")))
    result["stats"].update(analysis_seconds=factor.analysis_seconds, analysis_wait_seconds=analysis.wait_seconds,
                           reach=reach)
    clock(FINISH)
    if throw and not ok:
        raise FitError(
            f"the fit did not converge in {steps} Gauss-Newton steps (max_steps={max_steps}); "
            "pass throw=False to inspect the result", steps=int(steps), max_steps=int(max_steps))
    return FitResult(**result, timings=clock.timings, curved_outline=curved, smooth_map=smooth_map)


def _finish(V: np.ndarray, space: SplineSpace, prob: en.Problem, x: np.ndarray, energies: dict[str, float],
            centre: np.ndarray, size: float, steps: int, ok: bool, weights: FitWeights, parameterization,
            report: Callable[[float], None] = silent) -> dict:
    """The result's fields (all but the timings): control points, energies in data units, checks;
    ``report``: progress after the control points and after the continuity check."""
    tri = space.tri
    free = np.zeros((space.n_free, 3))
    free[space.corner_free] = V
    free[prob.free_r] = x * size + centre
    ctrl = space.control_points(free, about=working_origin(V))  # far-off data: C1 to its coordinates' rounding
    report(0.5)
    # the residuals are linear in the data's scale, except the angle term's
    units = en.energy_units(size)
    energies = {k: v * units[k] for k, v in energies.items()}
    rep = continuity_report(tri, ctrl)
    report(0.9)
    interp = float(np.abs(ctrl[np.arange(tri.n_faces)[:, None], CORNER[None, :]] - V[tri.faces]).max())
    extras = dict(data_vertices=V, free=free, fit_weights=np.array(list(asdict(weights).values()), float))
    if space.stats["snapped_vertices"]:  # uv moved onto exact crossings (spline.propagation.snap): by how much
        extras.update(domain_max_move=space.stats["max_move"],
                      domain_max_relative_move=space.stats["max_relative_move"])
    return dict(
        surface=SplineSurface(tri.uv, tri.faces, ctrl, extras=extras), ctrl=ctrl, free=free, space=space,
        energies=energies, iterations=steps, converged=bool(ok), c1_residual=float(rep["c1_relative"]),
        max_interpolation_error=interp, parameterization=parameterization, uv=tri.uv, faces=tri.faces,
        weights=weights, stats=dict(n_free=space.n_free, n_solved=int(prob.free_r.size), H_nnz=prob.H_nnz,
                                    continuity=rep))


#: Thinnest triangles a failed factorisation names.
THIN_NAMED = 5
#: A solved surface reaching farther than this many bounding-box diagonals outside the data's box is refused like
#: a matrix that does not factor: whether a nearly indefinite normal matrix factors is rounding luck (the random
#: square of ``tests/test_bad_input.py``, a hull triangle of aspect 7.3e5: refused, but a rounding-level change of
#: its map let it factor, and its net reached 2.9 diagonals out). The surface is judged, not its net: the net of a
#: hull sliver of scattered points reaches 0.5-1.2 diagonals out while its patch stays within 0.04 (6 of 15 random
#: Delaunay height fields of 500-8000 faces).
WILD_NET = 0.5
#: ... and one reaching farther than this is reported (``stats["reach"]``; the command line warns): an interpolant
#: passing through a spike or a step of coarse data overshoots (a 10 x 10 grid with one vertex 3 above a gentle
#: wave: 0.21 diagonals; on a 20 x 20 grid 0.04).
OVERSHOOT = 0.1


#: Domain triangles no thinner than this (longest edge / height) are not named as the cause of a normal matrix
#: that float64 cannot factor (the failures measured had 1e5-1e8; a mesh of aspect-6 triangles failed under a
#: SLIM map that squeezed areas 67-fold).
UNREMARKABLE_ASPECT = 100.0


def _thin_triangles(uv: np.ndarray, faces: np.ndarray, V: np.ndarray, why: str) -> str:
    """The message of a normal matrix float64 cannot factor: the domain's thinnest triangles, whose C1
    conditions span too many orders of magnitude (a point 1.4e-6 from the outline of a unit square: aspect
    7e5, its diagonal 651 to 5e21). A ridge that let it factor gave a surface 25-250x the scan's size.
    Where one of them is a hull sliver of scattered points (``V (n, 3)``), peeling them is the cure."""
    aspect = face_aspects(uv, faces)
    worst = np.argsort(aspect)[::-1][:THIN_NAMED]
    named = ", ".join(f"{tuple(int(v) for v in faces[f])} {aspect[f]:.3g}" for f in worst)
    if aspect[worst[0]] < UNREMARKABLE_ASPECT:  # no sliver to blame: the map itself
        return (f"the fit cannot be solved in float64: {why}; no triangle of the domain is thin (the thinnest, "
                f"longest edge / height: {named}): the map distorts the mesh too much; try another --param "
                "(lscm, harmonic, slim), or approximate the scan (--tolerance-rel)")
    hull = bool(hull_sliver_faces(V, faces)[worst].any())
    return (f"the fit cannot be solved in float64: {why}; the thinnest triangles (vertices, longest edge / height) "
            f"are {named}: " + ("hull slivers of scattered points, which repair_mesh (--repair) peels off; or "
                                if hull else "remove or merge them (a vertex almost on an edge), or ")
            + "approximate the scan (--tolerance-rel)")
