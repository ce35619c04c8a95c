"""True 3D deviation between a spline surface and data, both ways.

    dev = surface_deviation(surface, P)        # Deviation: distance, face, bary, uv, closest
    summary(dev.distance)                      # {"count", "rms", "mean", "max", "p50", "p95", "p99"}
    d = mesh_deviation(surface, V, F)          # (m,) distance of dense surface samples to the mesh

Data -> surface is the distance to the closest point ON the surface, not the
residual at a located parameter. Each point starts at its closest point on a
tessellation of the surface (libigl's AABB tree, :func:`trispline.param.closest_points`)
and takes a few vectorised Newton steps on ``|S(u) - P|^2`` over the uv domain
(:func:`distance_model`). A step is relocated in the whole domain, so it continues
into the neighbouring patch across an edge; a step that leaves the domain is put on
the nearest boundary edge and continued along it (Newton in the edge parameter),
which finds the closest point of the surface's boundary curve. A step is kept only
where it brings the point closer, so the result is never worse than the
tessellation's. Points run in chunks (bounded memory; no per-point Python loop).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from trispline.spline.checks import as_array
from trispline.spline.patches import PatchDerivatives
from trispline.spline.tessellate import patch_points
from trispline.spline.util import gather

from .locate import ClampedLocator

if TYPE_CHECKING:  # pragma: no cover
    from trispline.spline.surface import SplineSurface

__all__ = ["Deviation", "distance_model", "newton_step", "surface_deviation", "mesh_deviation", "distance_to_mesh",
           "summary", "triangle_bary"]

#: Newton steps per point at most (quadratic convergence from the tessellation: 2-3 suffice).
NEWTON_STEPS = 8
#: A step moving the surface point by less than this times the surface size is the last one.
NEWTON_FINAL_STEP = 1e-6
#: A rejected (damped) step this short (relative) ends a point's iterations.
NEWTON_RTOL = 1e-13
#: A closest point with a barycentric coordinate below this opposite a boundary edge is on the boundary.
BOUNDARY_BARY = 1e-12
#: Newton iterations along a boundary edge for a step that left the domain.
EDGE_STEPS = 3
#: Points refined together (the second-derivative arrays take about 1.5 kB a point).
CHUNK = 1 << 16
#: Default tessellation steps per patch edge for the starting points.
START_RESOLUTION = 6


@dataclass(frozen=True)
class Deviation:
    """Closest points on a surface.

    distance : (n,) Euclidean distance from each point to the surface
    face : (n,) patch of the closest point, bary : (n, 3) its barycentric coordinates
    uv : (n, 2) its domain point, closest : (n, 3) the closest point itself
    on_boundary : (n,) bool, the closest point lies on the surface's boundary curve
    """

    distance: np.ndarray
    face: np.ndarray
    bary: np.ndarray
    uv: np.ndarray
    closest: np.ndarray
    on_boundary: np.ndarray


def summary(distance: np.ndarray, mask: np.ndarray | None = None) -> dict[str, float]:
    """``count``, ``rms``, ``mean``, ``max``, ``p50``, ``p95``, ``p99`` of ``distance (n,)`` (``mask``: the rows kept)."""
    d = np.abs(np.asarray(distance, np.float64))
    if mask is not None:
        d = d[np.asarray(mask, bool)]
    if d.size == 0:
        return dict(count=0, rms=0.0, mean=0.0, max=0.0, p50=0.0, p95=0.0, p99=0.0)
    p50, p95, p99 = np.percentile(d, [50, 95, 99])
    return dict(count=int(d.size), rms=float(np.sqrt(np.mean(d * d))), mean=float(d.mean()),
                max=float(d.max()), p50=float(p50), p95=float(p95), p99=float(p99))


def distance_model(d: PatchDerivatives, P: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Gradient ``(n, 2)`` and Hessian ``(n, 2, 2)`` of ``|S - P|^2 / 2`` in the surface's parameters.

    ``d`` holds values and first and second derivatives ``(n, 3)`` at the current
    parameters; ``P (n, 3)``. ``H = J^T J + sum_k r_k Hess S_k`` with ``r = S - P``.
    """
    r = d.values - P
    J = np.stack([d.du, d.dv], axis=2)  # (n, 3, 2)
    g = np.einsum("nd,ndk->nk", r, J)
    H = np.einsum("ndk,ndl->nkl", J, J)
    H[:, 0, 0] += np.einsum("nd,nd->n", r, d.uu)
    off = np.einsum("nd,nd->n", r, d.uv)
    H[:, 0, 1] += off
    H[:, 1, 0] += off
    H[:, 1, 1] += np.einsum("nd,nd->n", r, d.vv)
    return g, H


def newton_step(d: PatchDerivatives, P: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Newton step ``(n, 2)`` toward the closest point of the surface to ``P (n, 3)``, and ``(n,)`` where
    it is the true Newton step (quadratic convergence).

    Where the Hessian of :func:`distance_model` is not positive definite (a point
    beyond a focal point of the surface) the Gauss--Newton matrix ``J^T J`` is used
    instead (linear convergence).
    """
    g, H = distance_model(d, P)
    det = H[:, 0, 0] * H[:, 1, 1] - H[:, 0, 1] * H[:, 1, 0]
    bad = ~((H[:, 0, 0] > 0) & (det > 0))
    if bad.any():
        J = np.stack([d.du[bad], d.dv[bad]], axis=2)
        H[bad] = np.einsum("ndk,ndl->nkl", J, J)
        det = H[:, 0, 0] * H[:, 1, 1] - H[:, 0, 1] * H[:, 1, 0]
    det = np.where(np.abs(det) > 0, det, np.inf)
    step = -np.column_stack([H[:, 1, 1] * g[:, 0] - H[:, 0, 1] * g[:, 1],
                             H[:, 0, 0] * g[:, 1] - H[:, 1, 0] * g[:, 0]]) / det[:, None]
    return step, ~bad


def triangle_bary(C: np.ndarray, T: np.ndarray) -> np.ndarray:
    """Barycentric coordinates ``(n, 3)`` of points ``C (n, 3)`` in the plane of triangles ``T (n, 3, 3)``."""
    e1, e2, q = T[:, 1] - T[:, 0], T[:, 2] - T[:, 0], C - T[:, 0]
    d11, d12, d22 = (np.einsum("nd,nd->n", a, b) for a, b in ((e1, e1), (e1, e2), (e2, e2)))
    q1, q2 = np.einsum("nd,nd->n", q, e1), np.einsum("nd,nd->n", q, e2)
    den = d11 * d22 - d12 * d12
    den = np.where(den > 0, den, np.inf)
    b1 = (d22 * q1 - d12 * q2) / den
    b2 = (d11 * q2 - d12 * q1) / den
    return np.column_stack([1.0 - b1 - b2, b1, b2])


_FIELDS = ("values", "du", "dv", "uu", "uv", "vv")


class _Refiner:
    """Newton refinement of closest points on one surface (state shared by the chunks)."""

    def __init__(self, surface: "SplineSurface", loc: ClampedLocator, steps: int) -> None:
        self.surface, self.loc, self.steps = surface, loc, steps
        c = surface.ctrl.reshape(-1, 3)
        self.size = max(float(np.linalg.norm(c.max(0) - c.min(0))), 1e-300)
        self.uv, self.faces = surface.uv, surface.faces

    def uv_of(self, face: np.ndarray, bary: np.ndarray) -> np.ndarray:
        """Domain points ``(n, 2)`` of ``face (n,)``, ``bary (n, 3)``."""
        return np.einsum("nk,nkd->nd", bary, gather.rows(self.uv, gather.rows(self.faces, face)))

    def along_edges(self, P: np.ndarray, edge: np.ndarray, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Newton in the parameter ``t`` along boundary ``edge``, turning onto the next boundary
        edge at a vertex where the distance still falls: ``(face, bary)`` of the result."""
        edge, t = edge.copy(), t.copy()
        for _ in range(EDGE_STEPS):
            face, bary, _ = self.loc.on_edge(edge, t)
            d = self.surface.evaluate_derivatives(face, bary, second=True)
            ends = self.loc.tri.edges[edge]
            e = gather.rows(self.uv, ends[:, 1]) - gather.rows(self.uv, ends[:, 0])  # (n, 2)
            g, H = distance_model(d, P)
            den = np.einsum("nk,nkl,nl->n", e, H, e)
            tangent = d.du * e[:, :1] + d.dv * e[:, 1:]  # dS/dt
            den = np.where(den > 0, den, np.einsum("nd,nd->n", tangent, tangent))  # else Gauss-Newton
            slope = np.einsum("nk,nk->n", g, e)
            # at an end and still pushed outward: continue on the neighbouring boundary edge
            turn = np.flatnonzero(((t == 1.0) & (slope < 0)) | ((t == 0.0) & (slope > 0)))
            t = np.clip(t - slope / np.where(den > 0, den, np.inf), 0.0, 1.0)
            if turn.size:
                edge[turn], t[turn] = self.loc.turn(edge[turn], np.where(t[turn] >= 0.5, 1.0, 0.0))
        face, bary, _ = self.loc.on_edge(edge, t)
        return face, bary

    def refine(self, P: np.ndarray, face: np.ndarray, bary: np.ndarray) -> tuple[np.ndarray, ...]:
        """Refined ``face, bary, values`` for points ``P (n, 3)`` starting at ``face, bary``.

        A full Newton step shorter than :data:`NEWTON_FINAL_STEP` (relative) ends a point's
        iterations: quadratic convergence leaves an error of about its square.
        """
        n = P.shape[0]
        damp = np.ones(n)
        act = np.arange(n)
        d0 = self.surface.evaluate_derivatives(face, bary, second=True)
        store = {k: getattr(d0, k) for k in _FIELDS}  # (n, 3) each: derivatives at the current points
        val = store["values"]
        D = np.einsum("nd,nd->n", val - P, val - P)
        for _ in range(self.steps):
            if act.size == 0:
                break
            d = PatchDerivatives(**{k: a[act] for k, a in store.items()})
            step, exact = newton_step(d, P[act])
            step *= damp[act, None]
            size = np.linalg.norm(d.du * step[:, :1] + d.dv * step[:, 1:], axis=1)
            hit = self.loc(self.uv_of(face[act], bary[act]) + step, hint=face[act])
            f_new, b_new = hit.face, hit.bary
            c = np.flatnonzero(hit.clamped)
            if c.size:
                f_new[c], b_new[c] = self.along_edges(P[act[c]], hit.edge[c], hit.t[c])
            last = (size < NEWTON_FINAL_STEP * self.size) & exact & (damp[act] == 1.0) & ~hit.clamped
            v_new = np.empty((act.size, 3))
            v_new[last] = self.surface.evaluate(f_new[last], b_new[last])
            d_new = self.surface.evaluate_derivatives(f_new[~last], b_new[~last], second=True)
            v_new[~last] = d_new.values
            D_new = np.einsum("nd,nd->n", v_new - P[act], v_new - P[act])
            # closer; or, for a step inside the domain, not farther up to rounding (near the minimum a
            # step changes |S - P|^2 by less than an ulp)
            better = (D_new < D[act]) | ((D_new <= D[act] * (1.0 + 4 * np.finfo(float).eps)) & ~hit.clamped)
            k = act[better]
            face[k], bary[k], D[k] = f_new[better], b_new[better], D_new[better]
            val[k] = v_new[better]
            moved = (better & ~last)[~last]
            for name in _FIELDS[1:]:
                store[name][act[better & ~last]] = getattr(d_new, name)[moved]
            damp[act[~better]] *= 0.25
            go = (better & ~last) | (~better & (damp[act] > 1e-3) & (size > NEWTON_RTOL * self.size))
            act = act[go]
        return face, bary, val


def surface_deviation(surface: "SplineSurface", points: np.ndarray, *, resolution: int = START_RESOLUTION,
                      steps: int = NEWTON_STEPS, chunk: int = CHUNK) -> Deviation:
    """Closest points on ``surface`` of ``points (n, 3)`` and their distances; see :class:`Deviation`.

    ``resolution``: tessellation steps per patch edge for the starting points (higher:
    more memory, fewer Newton steps); ``steps``: Newton steps at most; ``chunk``: points
    refined at once.
    """
    from trispline.param import closest_points  # libigl AABB tree

    P = as_array(points, "points", (None, 3), finite=True)
    mesh = surface.tessellate(resolution)
    loc = ClampedLocator(surface.uv, surface.faces, triangulation=surface.triangulation)
    n = P.shape[0]
    face, bary = np.empty(n, np.int64), np.empty((n, 3))
    closest, on_b = np.empty((n, 3)), np.empty(n, bool)
    if n == 0:
        return Deviation(np.empty(0), face, bary, np.empty((0, 2)), closest, on_b)
    _, tri, C = closest_points(P, mesh.vertices, mesh.triangles)
    T = gather.rows(mesh.triangles, tri)  # (n, 3) tessellation vertex ids
    w = np.clip(triangle_bary(C, gather.rows(mesh.vertices, T)), 0.0, 1.0)
    start_face, start_bary = patch_points(resolution, tri, w / w.sum(1, keepdims=True))
    ref = _Refiner(surface, loc, int(steps))
    for lo in range(0, n, chunk):
        s = slice(lo, min(lo + chunk, n))
        face[s], bary[s], closest[s] = ref.refine(P[s], start_face[s], start_bary[s])
    # on the boundary curve: a barycentric coordinate ~0 opposite a boundary edge of the face
    tri = surface.triangulation
    on_b = ((bary <= BOUNDARY_BARY) & tri.boundary_edge_mask[tri.face_edges[face]]).any(1)
    return Deviation(distance=np.linalg.norm(closest - P, axis=1), face=face, bary=bary,
                     uv=ref.uv_of(face, bary), closest=closest, on_boundary=on_b)


def mesh_deviation(surface: "SplineSurface", V: np.ndarray, F: np.ndarray, *, resolution: int = 4,
                   ) -> np.ndarray:
    """Distance ``(m,)`` from each vertex of ``surface.tessellate(resolution)`` to the mesh ``V (nv, 3)``, ``F (nf, 3)``.

    The other direction of :func:`surface_deviation`: dense samples of the surface
    (``m = V + (r-1) E + (r-1)(r-2)/2 F`` of them) to their exact closest points on the
    scan's triangles.
    """
    V = as_array(V, "V", (None, 3), finite=True)
    F = as_array(F, "F", (None, 3), integer=True, min_rows=1)
    return distance_to_mesh(surface.tessellate(resolution).vertices, V, F)


def distance_to_mesh(P: np.ndarray, V: np.ndarray, F: np.ndarray) -> np.ndarray:
    """Distance ``(m,)`` from each point ``P (m, 3)`` to its exact closest point on the triangles ``V``, ``F``."""
    from trispline.param import closest_points  # libigl AABB tree

    sq, _, _ = closest_points(P, V, F)
    return np.sqrt(np.maximum(sq, 0.0))
