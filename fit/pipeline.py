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

import time
from dataclasses import dataclass, field, asdict
from typing import Any, Callable

import jax
import jax.numpy as jnp
import numpy as np
import optimistix as optx
import scipy.sparse as sp

from trispline.spline.index import CORNER, NCTRL, STAR
from trispline.spline.bernstein import basis
from trispline.spline.continuity import continuity_report
from trispline.spline.errors import InputError, first_few
from trispline.spline.propagation import SplineSpace, build_space
from trispline.spline.topology import Triangulation, signed_areas

from . import energy as en
from .energy.gram import thin_plate_gram
from .targets import area_weighted_normals, fitted_normals, local_rbf_fit
from .solve import FactorSolver, SparseCholesky, require_x64
from .errors import FitError

__all__ = ["FitWeights", "FitResult", "FitError", "fit_surface", "DataPoints"]

#: Gauss--Newton tolerances (relative to the data's size).
GN_RTOL = 1e-9
GN_ATOL = 1e-9
#: The solve must reach this relative stationarity to count as converged.
CONVERGED_GRAD_RTOL = 1e-6



@dataclass(frozen=True)
class FitWeights:
    """Weights of the fairness energy terms (all dimensionless, see docs/fit.md).

    Attributes
    ----------
    bend : thin-plate bending over the uv domain
    tilt : corner frames toward the local fit's tangent frame
    local : other control points toward the blended local fits
    data : extra sample points (``data_points`` of :func:`fit_surface`)
    angle : nonlinear: the frame's unit normal toward the data normal
    fit_degree : highest polynomial degree of the local fits: 2 (kernels r^3, r^5) or 3 (also r^7);
        the local fits are polyharmonic interpolants of each vertex's ``fit_rings``-ring, kernel
        chosen per vertex by leave-one-out error (:func:`trispline.fit.targets.local_rbf_fit`)
    fit_rings : neighbourhood (edge rings) of the local fits
    blend_power : exponent of the corner blend of the local targets
    """

    bend: float = 1.0
    tilt: float = 30.0
    local: float = 3.0
    data: float = 1.0
    angle: float = 0.0
    fit_degree: int = 3
    fit_rings: int = 3
    blend_power: float = 2.0

    def __post_init__(self) -> None:
        for name in ("bend", "tilt", "local", "data", "angle"):
            v = getattr(self, name)
            if not (np.isfinite(v) and v >= 0):
                raise InputError(f"weight {name} must be finite and >= 0, got {v}")
        if self.bend <= 0 and self.local <= 0:
            raise InputError("at least one of the bend and local weights must be positive")
        if self.fit_degree not in (2, 3):
            raise InputError(f"fit_degree must be 2 or 3, got {self.fit_degree}")
        if self.fit_rings < 1:
            raise InputError(f"fit_rings must be >= 1, got {self.fit_rings}")


@dataclass(frozen=True)
class DataPoints:
    """Extra samples for the data term: ``F(face[i], bary[i]) ~ xyz[i]``."""

    face: np.ndarray
    bary: np.ndarray
    xyz: np.ndarray


@dataclass(frozen=True)
class FitResult:
    """Outcome of :func:`fit_surface`.

    Attributes
    ----------
    surface : SplineSurface (or None when trispline.spline.surface is unavailable)
    ctrl : (F, 21, 3) control points
    free : (n_free, 3) all free points (corners included)
    space : SplineSpace
    energies : dict term -> energy (weights included)
    iterations : Gauss--Newton steps
    converged : bool
    c1_residual : worst C1 diamond residual relative to the net's size
    max_interpolation_error : max |corner point - data vertex|
    timings : dict stage -> seconds
    parameterization : the Parameterization (None when ``uv`` was given)
    uv, faces : the domain
    """

    surface: Any
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


def _data_points(data_points, nf: int) -> DataPoints:
    if isinstance(data_points, DataPoints):
        face, bary, xyz = data_points.face, data_points.bary, data_points.xyz
    else:
        try:
            face, bary, xyz = data_points
        except (TypeError, ValueError) as exc:
            raise InputError("data_points must be DataPoints or a (face, bary, xyz) tuple") from exc
    face = np.asarray(face)
    bary = np.asarray(bary, float)
    xyz = np.asarray(xyz, float)
    n = face.shape[0] if face.ndim == 1 else -1
    if face.ndim != 1 or not np.issubdtype(face.dtype, np.integer):
        raise InputError(f"data_points face must be a 1-D integer array, got {face.shape} {face.dtype}")
    if bary.shape != (n, 3) or xyz.shape != (n, 3):
        raise InputError(f"data_points bary and xyz must have shape ({n}, 3), got {bary.shape} and {xyz.shape}")
    bad = np.flatnonzero((face < 0) | (face >= nf))
    if bad.size:
        raise InputError(f"data_points face ids outside [0, {nf}): {first_few(bad)}")
    bad = np.flatnonzero(~np.isfinite(bary).all(1) | ~np.isfinite(xyz).all(1))
    if bad.size:
        raise InputError(f"non-finite data_points: {first_few(bad)}")
    return DataPoints(face.astype(np.int64), bary, xyz)


def _check_mesh(V: np.ndarray, F: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    V = np.asarray(V)
    F = np.asarray(F)
    if V.ndim != 2 or V.shape[1] != 3:
        raise InputError(f"V must have shape (nv, 3), got {V.shape}")
    if F.ndim != 2 or F.shape[1] != 3:
        raise InputError(f"F must have shape (nf, 3), got {F.shape}")
    if not np.issubdtype(F.dtype, np.integer):
        raise InputError(f"F must be integers, got dtype {F.dtype}")
    V = np.asarray(V, np.float64)
    bad = np.flatnonzero(~np.isfinite(V).all(1))
    if bad.size:
        raise InputError(f"non-finite vertex coordinates at {first_few(bad)}")
    return V, F.astype(np.int64)


def _domain(V, F, uv, param):
    """``(uv, faces, parameterization)``."""
    if uv is not None:
        uv = np.asarray(uv, np.float64)
        if uv.shape != (V.shape[0], 2):
            raise InputError(f"uv must have shape ({V.shape[0]}, 2), got {uv.shape}")
        area = signed_areas(uv, F)
        faces = F
        if (area < 0).all():
            faces = F[:, [0, 2, 1]]
        return uv, faces, None
    from trispline.param import parameterize

    p = parameterize(V, F, method=param)
    return p.uv, p.faces, p


def fit_surface(
    V: np.ndarray,
    F: np.ndarray,
    *,
    uv: np.ndarray | None = None,
    param: str = "lscm",
    weights: FitWeights = FitWeights(),
    data_points: DataPoints | tuple | None = None,
    solver: optx.AbstractLeastSquaresSolver | None = None,
    progress: Callable[[str, float], None] | None = None,
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
    param : {"lscm", "harmonic", "uv"}
        Parameterization method when ``uv`` is None (see :mod:`trispline.param`). The
        default ``lscm`` (free boundary) keeps corners of the outline undistorted; on the
        shared real meshes it gave far smaller extreme curvature than ``harmonic``, whose
        circle boundary squeezes corners (inspired_mesh: max |H| L 3 against 5107).
    weights : FitWeights
    data_points : DataPoints or (face (n,), bary (n, 3), xyz (n, 3)), optional
    solver : an optimistix least-squares solver; default Gauss--Newton with the
        host sparse Cholesky (direct when the energy is quadratic, factor-preconditioned
        CG when ``weights.angle > 0``)
    progress : ``progress(stage, seconds)`` called after each stage
    throw : raise :class:`FitError` if the solver did not converge
    max_steps : Gauss--Newton step cap

    Returns
    -------
    FitResult
    """
    require_x64()
    if not isinstance(weights, FitWeights):
        raise InputError(f"weights must be a FitWeights, got {type(weights).__name__}")
    timings: dict[str, float] = {}
    clock = [time.perf_counter()]

    def stage(name: str) -> None:
        now = time.perf_counter()
        timings[name] = timings.get(name, 0.0) + now - clock[0]
        clock[0] = now
        if progress is not None:
            progress(name, timings[name])

    V, F = _check_mesh(V, F)
    uv, faces, parameterization = _domain(V, F, uv, param)
    stage("parameterize")
    tri = Triangulation(uv, faces)
    space = build_space(tri)
    stage("build")
    # solve in normalised coordinates (optimistix's stopping tests are per element)
    centre = 0.5 * (V.min(0) + V.max(0))
    size = float(np.ptp(V, axis=0).max()) or 1.0
    Vn = (V - centre) / size
    prob = _setup(Vn, space, weights, data_points, centre, size)
    stage("assemble")
    factor = SparseCholesky(prob.H)
    stage("factor")
    x, steps, ok = _solve(prob, factor, weights, solver, max_steps)
    stage("solve")

    free = np.zeros((space.n_free, 3))
    free[space.corner_free] = V
    free[prob.free_r] = x * size + centre
    ctrl = space.control_points(free)
    args_np = prob.args
    # energies in data units (the residuals are linear in the scale, except the angle term's)
    en_vals = {k: float(v) * (size**2 if k != "angle" else 1.0)
               for k, v in _energies_jit(jnp.asarray(x), args_np).items()}
    rep = continuity_report(tri, ctrl)
    interp = float(np.abs(ctrl[np.arange(tri.n_faces)[:, None], CORNER[None, :]] - V[faces]).max())
    surface = _make_surface(uv, faces, ctrl, V, free, weights)
    stage("finish")
    result = FitResult(
        surface=surface, ctrl=ctrl, free=free, space=space, energies=en_vals, iterations=steps,
        converged=bool(ok), c1_residual=float(rep["c1_relative"]), max_interpolation_error=interp,
        timings=timings, parameterization=parameterization, uv=uv, faces=faces, weights=weights,
        stats=dict(n_free=space.n_free, n_solved=int(prob.free_r.size), H_nnz=int(prob.H.nnz),
                   continuity=rep),
    )
    if throw and not ok:
        raise FitError(
            f"the fit did not converge in {steps} Gauss-Newton steps (max_steps={max_steps}); "
            "pass throw=False to inspect the result"
        )
    return result


def _make_surface(uv, faces, ctrl, V, free, weights):
    try:
        from trispline.spline.surface import SplineSurface
    except ImportError:  # the surface module is optional for the fit itself
        return None
    extras = dict(data_vertices=V, free=free, fit_weights=np.array(list(asdict(weights).values()), float))
    try:
        return SplineSurface(uv, faces, ctrl, extras=extras)
    except TypeError:
        return SplineSurface(uv, faces, ctrl)


# --------------------------------------------------------------------------- problem setup
@dataclass
class _Problem:
    args: dict
    H: sp.csr_matrix
    free_r: np.ndarray
    scale: float
    nonlinear: bool


def _setup(V: np.ndarray, space: SplineSpace, w: FitWeights, data_points,
           centre: np.ndarray | float = 0.0, size: float = 1.0) -> _Problem:
    """Targets, residual arrays and the normal matrix of the quadratic terms."""
    tri = space.tri
    uv, faces = tri.uv, tri.faces
    nv, nf = tri.n_vertices, tri.n_faces
    M = sp.csc_matrix(space.M)
    is_fixed = np.zeros(space.n_free, bool)
    is_fixed[space.corner_free] = True
    free_r = np.flatnonzero(~is_fixed)
    pos = np.full(space.n_free, -1, np.int64)
    pos[free_r] = np.arange(free_r.size)
    M_r = sp.csr_matrix(M[:, free_r])
    c0 = np.asarray(M[:, space.corner_free] @ V)
    M_r.sort_indices()
    Mc = M_r.tocoo()

    # local interpolants of the data over uv (polyharmonic, kernel by leave-one-out error)
    fit = local_rbf_fit(uv, V, faces, max_degree=w.fit_degree, rings=w.fit_rings)
    scale = float(np.ptp(V, axis=0).max()) or 1.0

    # tilt: frame points -> fitted frame
    d = space.frame_scale
    vert_area = np.bincount(faces.ravel(), np.repeat(tri.areas / 3.0, 3), minlength=nv)
    tilt_target = np.concatenate(
        [V + fit.grad[:, :, 0] * (d / 5.0)[:, None], V + fit.grad[:, :, 1] * (d / 5.0)[:, None]]
    )
    tilt_pos = np.concatenate([pos[space.frame_free[:, 0]], pos[space.frame_free[:, 1]]])
    tilt_scale = np.tile(np.sqrt(w.tilt * vert_area) * 5.0 / d**2, 2)

    # local: other patch points -> blended polynomial nets
    target = en.blended_targets(uv, faces, fit.evaluate, power=w.blend_power)  # (F, 21, 3)
    mask = np.ones(NCTRL, bool)
    mask[CORNER] = False
    mask[STAR[STAR >= 0]] = False
    pw = np.zeros((nf, NCTRL))
    pw[:, mask] = (w.local / tri.areas)[:, None]
    if w.local > 0:
        sel = np.nonzero(np.broadcast_to(mask, (nf, NCTRL)))
        local_idx = space.point_index[sel]
        local_target = target[sel]
        local_scale = np.sqrt(pw[sel])
    else:
        local_idx = np.zeros(0, np.int64)
        local_target = np.zeros((0, 3))
        local_scale = np.zeros(0)

    # data term
    if data_points is not None:
        dp = _data_points(data_points, nf)
        dscale = np.full(dp.face.size, np.sqrt(w.data * nv / tri.areas.sum()))
        dbasis = basis(dp.bary)
        dface, dtarget = dp.face, (dp.xyz - centre) / size
    else:
        dscale, dbasis = np.zeros(0), np.zeros((0, NCTRL))
        dface, dtarget = np.zeros(0, np.int64), np.zeros((0, 3))

    # angle term (nonlinear)
    nonlinear = w.angle > 0
    if nonlinear:
        normal = fitted_normals(fit, reference=area_weighted_normals(V, faces))
        slope = np.linalg.norm(fit.grad, axis=(1, 2)) / np.sqrt(2.0)
        angle_scale = np.sqrt(w.angle * vert_area) * slope / d
        angle_frame = np.column_stack([pos[space.frame_free[:, 0]], pos[space.frame_free[:, 1]]])
        angle_z = V
    else:
        normal = np.zeros((0, 3))
        angle_scale = np.zeros(0)
        angle_frame = np.zeros((0, 2), np.int64)
        angle_z = np.zeros((0, 3))

    # normal matrix of the quadratic part
    gram = thin_plate_gram(tri.bary_gradients, tri.areas)
    A = en.patch_expansion(M_r, space.point_index)
    n = free_r.size
    extra = [sp.csr_matrix((tilt_scale**2, (tilt_pos, tilt_pos)), shape=(n, n))]
    if dface.size:
        rows = np.repeat(np.arange(dface.size), NCTRL)
        S = sp.csr_matrix((dbasis.ravel(), (rows, space.point_index[dface].ravel())),
                          shape=(dface.size, space.n_points))
        Sr = sp.csr_matrix(S @ M_r)
        extra.append(sp.csr_matrix(Sr.T @ sp.diags(dscale**2) @ Sr))
    H = en.assemble_normal_matrix(A, gram, w.bend, pw.ravel(), extra)

    D, sqw = en.bend_tables()
    args = dict(
        M_rows=Mc.row.astype(np.int64), M_cols=Mc.col.astype(np.int64), M_vals=Mc.data, c0=c0,
        point_index=space.point_index,
        bend_D=D, bend_W=en.bend_weights(tri.bary_gradients, tri.areas, w.bend), bend_sqw=sqw,
        tilt_pos=tilt_pos, tilt_target=tilt_target, tilt_scale=tilt_scale,
        local_idx=local_idx, local_target=local_target, local_scale=local_scale,
        data_face=dface, data_basis=dbasis, data_target=dtarget, data_scale=dscale,
        angle_z=angle_z, angle_frame=angle_frame, angle_normal=normal, angle_scale=angle_scale,
    )
    args = {k: jnp.asarray(v) for k, v in args.items()}
    return _Problem(args=args, H=H, free_r=free_r, scale=scale, nonlinear=nonlinear)


def _half_sum_squares(x: jax.Array, args: dict) -> jax.Array:
    return 0.5 * sum(jnp.sum(r * r) for r in en.residuals(x, args).values())


_gradient_jit = jax.jit(jax.grad(_half_sum_squares))
_energies_jit = jax.jit(en.energies)


def _solve(prob: _Problem, factor: SparseCholesky, w: FitWeights, solver, max_steps: int):
    """Gauss--Newton; returns ``(x (n_r, 3), steps, converged)``."""
    n = prob.free_r.size
    if solver is None:
        lin = FactorSolver(factor, mode="pcg" if prob.nonlinear else "direct")
        solver = optx.GaussNewton(rtol=GN_RTOL, atol=GN_ATOL, norm=optx.rms_norm, linear_solver=lin)
    # Start from the quadratic terms' optimum: one host solve with the factor, using
    # the gradient at zero that the convergence check needs anyway. For a quadratic
    # energy Gauss--Newton then only confirms stationarity (2 steps instead of 3).
    zero = jnp.zeros((n, 3))
    lin_args = prob.args
    if prob.nonlinear:
        lin_args = dict(prob.args, angle_scale=jnp.zeros_like(prob.args["angle_scale"]))
    g_ref = _gradient_jit(zero, prob.args)
    g_lin = g_ref if not prob.nonlinear else _gradient_jit(zero, lin_args)
    x0 = jnp.asarray(-factor.solve(np.asarray(g_lin)))
    sol = optx.least_squares(en.residuals, solver, x0, prob.args, max_steps=max_steps, throw=False)
    x = sol.value
    steps = int(sol.stats["num_steps"])
    ok = sol.result == optx.RESULTS.successful
    # independent stationarity check: |J^T r| small relative to the terms' scale
    g = _gradient_jit(x, prob.args)
    gnorm = float(jnp.abs(g).max())
    gref = float(jnp.abs(g_ref).max()) or 1.0
    ok = bool(ok) and gnorm <= CONVERGED_GRAD_RTOL * gref
    return np.asarray(x), steps, ok
