"""The raw planar maps of a validated mesh, one per method; :func:`~trispline.param.parameterize`
mirrors, checks, repairs and normalises them.

* ``harmonic``: the outer loop on the unit circle spaced by 3D arc length, the interior by
  ``igl.harmonic`` (cotangent weights), holes filled by fans for the solve.
* ``lscm``: least squares conformal, two far-apart boundary vertices pinned, free boundary:
  libigl's energy (``Q = -[L 0; 0 L] - 2 A``: ``igl.cotmatrix`` and ``igl.vector_area_matrix``,
  as ``igl.lscm`` builds it) solved by
  :func:`~trispline.spline.util.spd.solve_spd` (PARDISO): the same map as ``igl.lscm`` to
  about 1e-10 relative, 14x faster at 1M faces (5 s instead of 76 s; its dense-ordered solve
  grows faster than the scan).
* ``spectral`` (the default): the same conformal energy with a free boundary and no pins: the spectral
  conformal map of Mullen et al. 2008 (:func:`spectral_uv`), which depends on the surface alone. ``lscm``'s two
  pins are found from the outline loop's lowest vertex id, and its map depends on them beyond a similarity, so a
  renumbering can change it; ``spectral`` gives the same map however the file numbers and lists the mesh
  (docs/param.md, "The face order and the numbering").
* ``slim``: SLIM (Rabinovich et al. 2017) on the conformal (MIPS) energy ``s1/s2 + s2/s1``,
  started from the harmonic map where that is fold-free, else from the Tutte embedding (fold-free
  by Floater's theorem), holes filled: the energy is infinite on a fold, so every step stays
  fold-free, while it drives the map to conformal like LSCM; the boundary is free. From the harmonic
  map, already conformal inside, SLIM has only the outline to relax: on a noisy 100k-face scan 3
  iterations, 5 s, against 21 and 35 s from Tutte's, to a lower energy (docs/param.md). (SLIM's
  symmetric Dirichlet energy, which also evens out areas, sheared more triangles and fitted with larger spikes on the shared
  meshes and on nearly closed spheres: docs/param.md.)
* ``uv``: the given coordinates, or ``V[:, :2]`` (height fields).
"""
from __future__ import annotations

import time

import numpy as np

from trispline.spline.checks import as_array
from trispline.spline.errors import InputError, first_few
from trispline.spline.tolerances import SLIM_RTOL
from trispline.spline.topology import signed_areas
from trispline.spline.util.progress import Report, silent
from trispline.spline.util.spd import solve_spd, spd_factor

from . import _igl
from .distortion import conformal_energy, fold_mask
from .errors import MeshError
from .repair import fill_holes, tutte
from .validate import ValidatedMesh, face_areas_3d, sliver_message

__all__ = ["MAPS", "FREE_BOUNDARY_MAPS", "SPECTRAL_SHIFT", "spectral_uv", "SLIM_MAX_ITERATIONS", "SLIM_MAX_SECONDS", "harmonic_uv", "far_apart", "lscm_uv", "slim_start", "slim_uv",
           "raw_map"]

#: The methods with a map of their own (``parameterize`` adds ``"auto"``, a choice among them).
MAPS = ("harmonic", "lscm", "spectral", "slim", "uv")
#: The maps with a free boundary (a fold is repaired by a global map, not by one with its outline).
FREE_BOUNDARY_MAPS = ("lscm", "spectral", "slim")
#: Most SLIM iterations (each a sparse solve); measured on the shared meshes it meets
#: :data:`~trispline.spline.tolerances.SLIM_RTOL` within 10 to 30.
SLIM_MAX_ITERATIONS = 40
#: SLIM stops after the iteration that passes this many seconds: an iteration's sparse solve grows faster
#: than the mesh (0.1 s at 20k faces, 2.9 s at 200k, 62 s at 1M), so on a large mesh a few iterations
#: are all there is time for (most of the energy falls in the first ones).
SLIM_MAX_SECONDS = 60.0


def harmonic_uv(V: np.ndarray, F: np.ndarray, loop: np.ndarray) -> np.ndarray:
    """Harmonic map ``(nv, 2)``: ``loop (n,)`` onto the unit circle spaced by 3D arc length,
    the other vertices by ``igl.harmonic`` (cotangent weights). Holes other than ``loop``
    stay free (:func:`parameterize` fills them first)."""
    return _igl.harmonic(V, F, loop, _igl.circle_boundary(V, loop))


def far_apart(V: np.ndarray, loop: np.ndarray) -> tuple[int, int]:
    """Two vertices of ``loop`` far apart (two sweeps of farthest-point search)."""
    P = V[loop]
    i = int(np.argmax(((P - P[0]) ** 2).sum(1)))
    j = int(np.argmax(((P - P[i]) ** 2).sum(1)))
    return int(loop[i]), int(loop[j])


def lscm_uv(vm: ValidatedMesh, pins: np.ndarray, at: np.ndarray, *, backend: str | None = None) -> np.ndarray:
    """Least-squares conformal map ``(nv, 2)`` with vertices ``pins (k,)`` at ``at (k, 2)``.

    libigl's ``lscm``: its energy (:func:`._igl.lscm_hessian`) minimised with the pins fixed, by
    one sparse SPD solve (``backend``: :func:`~trispline.spline.util.spd.solve_spd`'s) instead of
    igl's own.
    """
    nv = vm.V.shape[0]
    Q = _igl.lscm_hessian(vm.V, vm.F)
    fixed = np.concatenate([pins, pins + nv])
    free = np.ones(2 * nv, bool)
    free[fixed] = False
    values = np.concatenate([at[:, 0], at[:, 1]])
    Qf = Q[free]
    x = np.empty(2 * nv)
    x[fixed] = values
    try:
        x[free] = solve_spd(Qf[:, free], -(Qf[:, fixed] @ values), backend=backend)
    except np.linalg.LinAlgError:  # a singular conformal energy: faces of (nearly) no area
        raise _undefined(vm, "lscm", "its system is singular") from None
    return x.reshape(2, nv).T.copy()


def _undefined(vm: ValidatedMesh, method: str, why: str) -> MeshError:
    """The error of a map whose conformal energy is singular on ``vm``: its thin triangles named where
    :func:`~.validate.sliver_message` finds them."""
    what = sliver_message(vm.V, vm.F) or "the mesh is nearly degenerate"
    return MeshError(f"the {method} map of this mesh is undefined ({why}): {what}", ["degenerate"])


#: The shift of :func:`spectral_uv`'s eigenproblem, relative to the largest diagonal entry of the conformal
#: energy: ``Q + shift B`` is positive definite (``Q`` is singular on the translations, which ``B`` weighs) with a
#: margin above float64's rounding of ``Q`` even where thin triangles make that entry large.
SPECTRAL_SHIFT = 1e-8
#: Mass of every vertex in :func:`spectral_uv`'s ``B``, beside the boundary's lumped lengths (mean 1): with a mass
#: of zero inside, ARPACK's Lanczos in the ``B`` inner product broke down on small meshes ("could not build an
#: Arnoldi factorization": a vector of zero ``B``-norm); this one moves the map by ~1e-9 of its extent.
SPECTRAL_INTERIOR_MASS = 1e-10
#: Lanczos vectors of :func:`spectral_uv` (eigsh's ``ncv``) and its tolerance (eigsh's ``tol``, relative to the
#: eigenvalue): 16 solves at 100k faces, 26 on a noisy 1M-face scan (0.3 s each). A looser tolerance (1e-8: 11
#: solves there) leaves the map depending on the start vector at the tolerance's level, which moved a sphere
#: cap's fit at map coordinates by 2.5e-6 of its energy; at 1e-12 the map is the same to rounding.
SPECTRAL_NCV = 10
SPECTRAL_TOL = 1e-12


def spectral_uv(vm: ValidatedMesh, *, backend: str | None = None) -> np.ndarray:
    """The spectral conformal map ``(nv, 2)`` (Mullen, Tong, Alliez, Desbrun 2008): LSCM's energy ``Q`` (as
    :func:`lscm_uv`'s) minimised over maps with ``x^T B x = 1`` that are ``B``-orthogonal to the translations,
    ``B`` the boundary vertices' lumped lengths (every loop): the lowest generalised eigenvector of
    ``Q x = lambda B x`` in that complement, by shift-invert Lanczos with one factorisation of ``Q + shift B``
    (:data:`SPECTRAL_SHIFT`) and the translations projected out of every solve (so a flat mesh, whose identity
    map has zero energy like the translations, gets that map; 100k faces: ~1 s, 16 solves). Its eigenvalue is
    double (the map turned by 90 degrees); any vector of the pair is the map up to a rotation. No pins, so the
    map depends on the surface only: it is centred, turned onto its principal axes (the sign by the third
    moment) and scaled to the mesh's area."""
    from scipy.sparse import diags
    from scipy.sparse.linalg import ArpackError, ArpackNoConvergence, LinearOperator, eigsh

    V, F = vm.V, vm.F
    nv = V.shape[0]
    Q = _igl.lscm_hessian(V, F)
    mass = _boundary_mass(vm)
    translations = np.zeros((2 * nv, 2))
    translations[:nv, 0] = translations[nv:, 1] = 1.0 / np.sqrt(mass[:nv].sum())  # B-orthonormal

    def project(y: np.ndarray) -> np.ndarray:  # the B-orthogonal complement of the translations
        return y - translations @ (translations.T @ (mass * y))

    shift = SPECTRAL_SHIFT * float(np.abs(Q.diagonal()).max())
    start = project(np.random.default_rng(0).standard_normal(2 * nv))  # generic, and the same every run
    try:
        with spd_factor(Q + shift * diags(mass).tocsr(), backend=backend) as solve:
            op = LinearOperator(Q.shape, matvec=lambda x: project(solve(x)), dtype=np.float64)
            values, vectors = eigsh(Q, k=1, M=diags(mass).tocsr(), sigma=-shift, OPinv=op, which="LM",
                                    tol=SPECTRAL_TOL, ncv=SPECTRAL_NCV, v0=start)
    except (np.linalg.LinAlgError, ArpackNoConvergence, ArpackError):  # faces of (nearly) no area
        raise _undefined(vm, "spectral", "its eigenproblem is singular") from None
    return _canonical(vectors[:, 0].reshape(2, nv).T, F, float(face_areas_3d(V, F).sum()))


def _boundary_mass(vm: ValidatedMesh) -> np.ndarray:
    """``(2 nv,)`` the diagonal of :func:`spectral_uv`'s ``B`` for ``u`` then ``v``: each boundary vertex's
    lumped length (half its two boundary edges, every loop) over their mean, plus :data:`SPECTRAL_INTERIOR_MASS`."""
    V = vm.V
    mass = np.zeros(V.shape[0])
    for loop in vm.boundary_loops:
        edge = np.linalg.norm(V[loop] - V[np.roll(loop, -1)], axis=1)
        mass[loop] += 0.5 * (edge + np.roll(edge, 1))
    return np.concatenate([mass, mass]) / mass[mass > 0].mean() + SPECTRAL_INTERIOR_MASS


def _canonical(uv: np.ndarray, F: np.ndarray, area: float) -> np.ndarray:
    """``uv (nv, 2)`` centred, turned onto its principal axes (the major one's sign: positive third moment),
    oriented like ``F`` and scaled to ``area``: the same map whichever similarity of it an eigensolver returns."""
    uv = uv - uv.mean(0)
    _, axes = np.linalg.eigh(uv.T @ uv)
    major = axes[:, 1]
    if np.sum((uv @ major) ** 3) < 0:
        major = -major
    uv = uv @ np.column_stack([major, [-major[1], major[0]]])  # a rotation: no mirror
    signed = float(signed_areas(uv, F).sum())
    if signed < 0:  # the mirrored map (not seen: the energy's area term penalises it)
        uv[:, 1] *= -1
        signed = -signed
    return uv * np.sqrt(area / signed) if signed > 0 else uv


def slim_uv(vm: ValidatedMesh, *, max_iterations: int = SLIM_MAX_ITERATIONS,
            max_seconds: float = SLIM_MAX_SECONDS, report: Report | None = None) -> np.ndarray:
    """SLIM map ``(nv, 2)`` of a validated mesh: :func:`slim_start`, conformal energy, free boundary.

    The holes stay filled by their fans during the iterations (so they cannot overlap);
    the start is scaled to the 3D area (SLIM's steps are scale-aware). Stops after
    ``max_iterations``, after the iteration that passes ``max_seconds``, or when an iteration lowers
    the energy by less than ``SLIM_RTOL``.
    ``report``: progress after each iteration (a share of ``max_iterations``; at 200k faces an
    iteration takes about half a second).
    """
    report = report or silent
    V, F = vm.V, vm.F
    nv = V.shape[0]
    Vx, Fx = fill_holes(V, F, vm.boundary_loops[1:])
    start = slim_start(Vx, Fx, vm.boundary_loops[0])
    start *= np.sqrt(face_areas_3d(Vx, Fx).sum() / signed_areas(start, Fx).sum())
    data = _igl.slim_start(Vx, Fx, start)
    energy = conformal_energy(V, F, start[:nv])  # the mesh's own faces, not the fans
    uv = start
    began = time.perf_counter()
    for k in range(max_iterations):
        step = _igl.slim_iterate(data, 1)
        report((k + 1) / max_iterations)
        e = conformal_energy(V, F, step[:nv])
        if not np.isfinite(e):  # a step that folded or broke down (NaN on some flat meshes): the last map stays
            break
        uv = step
        if energy - e <= SLIM_RTOL * energy or time.perf_counter() - began > max_seconds:
            break
        energy = e
    return uv[:nv]


def slim_start(Vx: np.ndarray, Fx: np.ndarray, outer: np.ndarray) -> np.ndarray:
    """SLIM's fold-free start ``(nv, 2)`` on a hole-filled mesh ``Vx, Fx`` with outline ``outer``: the
    harmonic map (:func:`harmonic_uv`) where it folds nothing, else the Tutte embedding (its cotangent
    weights can fold a mesh of obtuse triangles; Tutte's uniform ones cannot)."""
    start = harmonic_uv(Vx, Fx, outer)
    if np.isfinite(start).all() and not np.logical_or(*fold_mask(start, Fx)).any():
        return start
    return tutte(Fx, Vx.shape[0], outer, _igl.circle_boundary(Vx, outer))


def _given_uv(vm: ValidatedMesh, uv: np.ndarray | None) -> np.ndarray:
    """The ``uv`` method's map: ``uv`` checked (one finite row per vertex), or ``V[:, :2]``."""
    if uv is None:
        return vm.V[:, :2].copy()
    try:
        uv = as_array(uv, "uv", (vm.V.shape[0], 2))
    except InputError as exc:
        raise MeshError(f"{exc} (one per vertex)", ["uv_shape"]) from None
    if not np.isfinite(uv).all():
        raise MeshError(f"non-finite uv at vertices {first_few(np.flatnonzero(~np.isfinite(uv).all(1)))}",
                        ["non_finite"])
    return uv.copy()


def raw_map(vm: ValidatedMesh, method: str, uv: np.ndarray | None = None, report: Report | None = None
            ) -> np.ndarray:
    """The map ``(nv, 2)`` of ``method`` (one of :data:`MAPS`) before any check or repair; ``report``:
    progress (SLIM's iterations; the others are one sparse solve each)."""
    V, F = vm.V, vm.F
    if method == "harmonic":
        Vx, Fx = fill_holes(V, F, vm.boundary_loops[1:])
        return harmonic_uv(Vx, Fx, vm.boundary_loops[0])[: V.shape[0]]
    if method == "spectral":
        return spectral_uv(vm)
    if method == "lscm":
        i, j = far_apart(V, vm.boundary_loops[0])
        d = float(np.linalg.norm(V[i] - V[j]))
        return lscm_uv(vm, np.array([i, j]), np.array([[0.0, 0.0], [d, 0.0]]))
    if method == "slim":
        return slim_uv(vm, report=report)
    return _given_uv(vm, uv)
