"""Synthetic truth for the approximation benchmarks: smooth open analytic surfaces, scanned.

    scan = truth_scan("bumps", 50_000, sigma=1e-3, outliers=0.005, outlier_sigmas=50, seed=0)
    scan.V, scan.F                  # (n, 3) noisy vertices, (m, 3) faces (m about 2 n)
    scan.clean, scan.normals        # (n, 3) the exact surface point and unit normal under each vertex
    scan.distance_to_truth(P)       # (k,) exact distance of points to the analytic surface
    scan.bending_energy()           # integral of k1^2 + k2^2 over the true surface

Each surface (:data:`SURFACES`) maps the parameter rectangle ``[-1, 1] x [-0.7, 0.7]``
with a round hole (:data:`HOLE_CENTRE`, :data:`HOLE_RADIUS`) into R^3 with exact first
and second derivatives: ``bumps`` (a height field with three bumps and a ripple),
``cap`` (a piece of a sphere), ``saddle`` (a hyperbolic paraboloid), ``barrel`` (a
strip of a barrel wrapped 140 degrees around its axis). The scan is a jittered grid
of the rectangle (random diagonals; straight outline with four corners, a staircase
hole) lifted onto the surface, with Gaussian noise of ``sigma`` (relative to the
bounding-box diagonal) along the exact normal and a fraction of outliers moved
``outlier_sigmas * sigma`` off the surface. Everything is vectorised: a 1M-face scan
takes about a second.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from trispline.spline.patches import PatchDerivatives
from trispline.spline.topology import signed_areas

__all__ = ["SURFACES", "HOLE_CENTRE", "HOLE_RADIUS", "PARAM_BOX", "TruthScan", "truth_scan",
           "surface_derivatives", "bending_density", "grid_with_hole"]

#: The parameter rectangle ``(s_min, s_max, t_min, t_max)``.
PARAM_BOX = (-1.0, 1.0, -0.7, 0.7)
#: Centre and radius of the round hole in the parameter rectangle.
HOLE_CENTRE = np.array([0.3, -0.1])
HOLE_RADIUS = 0.25
#: Jitter of the interior grid vertices, as a fraction of the grid step (keeps every triangle CCW).
JITTER = 0.15


def _height(s: np.ndarray, t: np.ndarray, h: tuple[np.ndarray, ...]) -> PatchDerivatives:
    """The graph ``(s, t, h(s, t))`` from ``h, h_s, h_t, h_ss, h_st, h_tt``."""
    z, o = np.zeros_like(s), np.ones_like(s)
    hv, hs, ht, hss, hst, htt = h
    col = lambda a, b, c: np.column_stack([a, b, c])  # noqa: E731
    return PatchDerivatives(col(s, t, hv), col(o, z, hs), col(z, o, ht), col(z, z, hss), col(z, z, hst),
                            col(z, z, htt))


def _bumps(s: np.ndarray, t: np.ndarray) -> PatchDerivatives:
    """Three Gaussian bumps, a ripple ``a sin(w s) cos(w t)`` and a gentle tilt of curvature."""
    h = [np.zeros_like(s) for _ in range(6)]
    for amp, b, cs, ct in ((0.25, 6.0, -0.45, 0.25), (-0.15, 10.0, 0.55, 0.35), (0.1, 14.0, -0.1, -0.4)):
        x, y = s - cs, t - ct
        g = amp * np.exp(-b * (x * x + y * y))
        for k, v in enumerate((g, -2 * b * x * g, -2 * b * y * g, (4 * b * b * x * x - 2 * b) * g,
                               4 * b * b * x * y * g, (4 * b * b * y * y - 2 * b) * g)):
            h[k] += v
    a, w = 0.03, 4.0
    ss, cs_, st, ct = np.sin(w * s), np.cos(w * s), np.sin(w * t), np.cos(w * t)
    for k, v in enumerate((a * ss * ct, a * w * cs_ * ct, -a * w * ss * st, -a * w * w * ss * ct,
                           -a * w * w * cs_ * st, -a * w * w * ss * ct)):
        h[k] += v
    h[0] += 0.08 * s * s - 0.05 * t * t
    h[1] += 0.16 * s
    h[2] += -0.1 * t
    h[3] += 0.16
    h[5] += -0.1
    return _height(s, t, tuple(h))


def _cap(s: np.ndarray, t: np.ndarray, R: float = 1.6) -> PatchDerivatives:
    """The upper sphere of radius ``R`` over the rectangle: ``h = sqrt(R^2 - s^2 - t^2)``."""
    q = np.sqrt(R * R - s * s - t * t)
    return _height(s, t, (q, -s / q, -t / q, -(R * R - t * t) / q**3, -s * t / q**3, -(R * R - s * s) / q**3))


def _saddle(s: np.ndarray, t: np.ndarray) -> PatchDerivatives:
    """The hyperbolic paraboloid ``h = 0.3 (s^2 - t^2)`` (a quadric)."""
    z, o = np.zeros_like(s), np.ones_like(s)
    return _height(s, t, (0.3 * (s * s - t * t), 0.6 * s, -0.6 * t, 0.6 * o, z, -0.6 * o))


def _barrel(s: np.ndarray, t: np.ndarray, wrap: float = 1.22, r0: float = 0.8, bulge: float = 0.15,
            half_height: float = 1.0) -> PatchDerivatives:
    """``(r(t) cos(wrap s), r(t) sin(wrap s), half_height t / 0.7)``, ``r = r0 (1 + bulge (1 - (t / 0.7)^2))``."""
    u, k = t / 0.7, half_height / 0.7
    r = r0 * (1 + bulge * (1 - u * u))
    rt = -2 * r0 * bulge * u / 0.7
    rtt = np.full_like(t, -2 * r0 * bulge / 0.49)
    a = wrap * s
    c, sn = np.cos(a), np.sin(a)
    z = np.zeros_like(s)
    return PatchDerivatives(
        values=np.column_stack([r * c, r * sn, k * t]),
        du=np.column_stack([-wrap * r * sn, wrap * r * c, z]),
        dv=np.column_stack([rt * c, rt * sn, z + k]),
        uu=np.column_stack([-wrap * wrap * r * c, -wrap * wrap * r * sn, z]),
        uv=np.column_stack([-wrap * rt * sn, wrap * rt * c, z]),
        vv=np.column_stack([rtt * c, rtt * sn, z]),
    )


#: The analytic surfaces: ``name -> f(s, t) -> PatchDerivatives`` (values and exact derivatives, ``(n, 3)``).
SURFACES: dict[str, Callable[[np.ndarray, np.ndarray], PatchDerivatives]] = {
    "bumps": _bumps, "cap": _cap, "saddle": _saddle, "barrel": _barrel,
}


def surface_derivatives(name: str, st: np.ndarray) -> PatchDerivatives:
    """Values and exact first and second derivatives ``(n, 3)`` of surface ``name`` at parameters ``st (n, 2)``."""
    if name not in SURFACES:
        raise ValueError(f"unknown surface {name!r}; choose one of {', '.join(SURFACES)}")
    st = np.asarray(st, np.float64)
    return SURFACES[name](st[:, 0], st[:, 1])


def bending_density(d: PatchDerivatives) -> np.ndarray:
    """``(k1^2 + k2^2) |S_s x S_t|`` ``(n,)``: the thin-plate integrand per unit of parameter area.

    Independent of the parameterization (``k1^2 + k2^2 = 4 H^2 - 2 K``), so the true
    surface and a spline over any uv domain are measured alike.
    """
    from trispline.fit.render.geometry import curvatures

    H, K = curvatures(d.du, d.dv, d.uu, d.uv, d.vv)
    return np.maximum(4 * H * H - 2 * K, 0.0) * np.linalg.norm(np.cross(d.du, d.dv), axis=1)


def _boundary_halfedge_starts(F: np.ndarray, nv: int) -> np.ndarray:
    """``(nv,)`` count of boundary half-edges leaving each vertex (2+ marks a bowtie)."""
    he = np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]])
    key = he[:, 0] * nv + he[:, 1]
    rev = he[:, 1] * nv + he[:, 0]
    alone = ~np.isin(rev, key)
    return np.bincount(he[alone, 0], minlength=nv)


def grid_with_hole(n_vertices: int, *, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """A jittered grid of :data:`PARAM_BOX` minus the hole: ``st (n, 2)``, ``F (m, 3)`` CCW.

    Random diagonals; boundary vertices slide only along their side (the outline stays a
    rectangle); faces whose centroid is in the hole are removed, then the faces around any
    vertex where the hole touches itself (a bowtie) until none is left.
    """
    s0, s1, t0, t1 = PARAM_BOX
    area = (s1 - s0) * (t1 - t0) - np.pi * HOLE_RADIUS**2
    h = float(np.sqrt(area / max(int(n_vertices), 16)))
    nx, ny = max(int(round((s1 - s0) / h)), 2), max(int(round((t1 - t0) / h)), 2)
    rng = np.random.default_rng(seed)
    S, T = np.meshgrid(np.linspace(s0, s1, nx + 1), np.linspace(t0, t1, ny + 1), indexing="xy")
    i, j = np.meshgrid(np.arange(nx + 1), np.arange(ny + 1), indexing="xy")
    hx, hy = (s1 - s0) / nx, (t1 - t0) / ny
    S = S + np.where((i > 0) & (i < nx), rng.uniform(-JITTER, JITTER, S.shape) * hx, 0.0)
    T = T + np.where((j > 0) & (j < ny), rng.uniform(-JITTER, JITTER, T.shape) * hy, 0.0)
    st = np.column_stack([S.ravel(), T.ravel()])
    idx = np.arange(st.shape[0]).reshape(ny + 1, nx + 1)
    a, b, c, d = idx[:-1, :-1].ravel(), idx[:-1, 1:].ravel(), idx[1:, 1:].ravel(), idx[1:, :-1].ravel()
    flip = rng.random(a.size) < 0.5
    F = np.concatenate([np.where(flip[:, None], np.column_stack([a, b, d]), np.column_stack([a, b, c])),
                        np.where(flip[:, None], np.column_stack([b, c, d]), np.column_stack([a, c, d]))])
    r = np.linalg.norm(st[F].mean(1) - HOLE_CENTRE, axis=1)
    near = F[(r > HOLE_RADIUS) & (r < HOLE_RADIUS + 4 * max(hx, hy))]  # the only faces a bowtie can touch
    for _ in range(32):
        bow = np.flatnonzero(_boundary_halfedge_starts(near, st.shape[0]) > 1)
        bow = bow[np.linalg.norm(st[bow] - HOLE_CENTRE, axis=1) < HOLE_RADIUS + 2 * max(hx, hy)]  # not the band's rim
        if bow.size == 0:
            break
        near = near[~np.isin(near, bow).any(1)]
    F = np.concatenate([F[r >= HOLE_RADIUS + 4 * max(hx, hy)], near])
    used = np.zeros(st.shape[0], bool)
    used[F.ravel()] = True
    remap = np.cumsum(used) - 1
    return np.ascontiguousarray(st[used]), np.ascontiguousarray(remap[F].astype(np.int64))


@dataclass(frozen=True, eq=False)
class TruthScan:
    """A noisy scan of an analytic surface, with the truth under it.

    V : (n, 3) the scanned (noisy) vertices; F : (m, 3) faces, counter-clockwise in ``params``
    clean : (n, 3) the exact surface points; normals : (n, 3) their exact unit normals
    params : (n, 2) surface parameters of the vertices; outliers : (n,) bool
    sigma : the noise standard deviation (model units); diagonal : bounding-box diagonal of ``clean``
    surface : the :data:`SURFACES` name
    """

    V: np.ndarray
    F: np.ndarray
    clean: np.ndarray
    normals: np.ndarray
    params: np.ndarray
    outliers: np.ndarray
    sigma: float
    diagonal: float
    surface: str

    def derivatives(self, st: np.ndarray) -> PatchDerivatives:
        """Exact values and derivatives ``(k, 3)`` of the true surface at ``st (k, 2)``."""
        return surface_derivatives(self.surface, st)

    def closest_params(self, points: np.ndarray, steps: int = 8) -> np.ndarray:
        """Parameters ``(k, 2)`` of the closest points on the true surface to ``points (k, 3)``.

        Starts at the closest point of the clean scan mesh, then Newton steps on the
        analytic surface (continued beyond the scanned outline, so points near the
        boundary are measured against the surface, not against its edge).
        """
        from trispline.fit.approx.deviation import newton_step, triangle_bary
        from trispline.param import closest_points

        P = np.asarray(points, np.float64)
        _, tri, C = closest_points(P, self.clean, self.F)
        w = np.clip(triangle_bary(C, self.clean[self.F[tri]]), 0.0, 1.0)
        st = np.einsum("nk,nkd->nd", w / w.sum(1, keepdims=True), self.params[self.F[tri]])
        for _ in range(steps):
            st = st + newton_step(self.derivatives(st), P)[0]
        return st

    def distance_to_truth(self, points: np.ndarray) -> np.ndarray:
        """Exact distance ``(k,)`` from ``points (k, 3)`` to the true surface."""
        P = np.asarray(points, np.float64)
        return np.linalg.norm(self.derivatives(self.closest_params(P)).values - P, axis=1)

    def bending_energy(self) -> float:
        """``integral (k1^2 + k2^2) dA`` of the true surface over the scanned region.

        Edge-midpoint rule on the scan's parameter triangles (exact for quadratics;
        relative error about ``h^2`` for the grid step ``h``).
        """
        T = self.params[self.F]  # (m, 3, 2)
        area = signed_areas(self.params, self.F)
        mids = 0.5 * (T + T[:, [1, 2, 0]])  # (m, 3, 2)
        dens = bending_density(self.derivatives(mids.reshape(-1, 2))).reshape(-1, 3)
        return float((area * dens.mean(1)).sum())


def truth_scan(surface: str = "bumps", n_vertices: int = 50_000, *, sigma: float = 1e-3, outliers: float = 0.0,
               outlier_sigmas: float = 50.0, seed: int = 0) -> TruthScan:
    """Scan the analytic ``surface`` at about ``n_vertices`` vertices (``2 n`` faces); see :class:`TruthScan`.

    ``sigma``: noise standard deviation relative to the bounding-box diagonal, along the
    exact normal; ``outliers``: the fraction of vertices moved ``+-outlier_sigmas * sigma``
    (random sign) off the surface instead. Deterministic per ``seed``.
    """
    if not (np.isfinite(sigma) and sigma >= 0):
        raise ValueError(f"sigma must be finite and >= 0, got {sigma}")
    if not (0.0 <= outliers <= 1.0):
        raise ValueError(f"outliers must be a fraction in [0, 1], got {outliers}")
    st, F = grid_with_hole(n_vertices, seed=seed)
    d = surface_derivatives(surface, st)
    nrm = np.cross(d.du, d.dv)
    nrm /= np.linalg.norm(nrm, axis=1, keepdims=True)
    clean = d.values
    diag = float(np.linalg.norm(clean.max(0) - clean.min(0)))
    rng = np.random.default_rng(seed + 1)
    off = rng.normal(0.0, sigma * diag, st.shape[0])
    mask = np.zeros(st.shape[0], bool)
    k = int(round(outliers * st.shape[0]))
    if k:
        pick = rng.choice(st.shape[0], k, replace=False)
        mask[pick] = True
        off[pick] = rng.choice([-1.0, 1.0], k) * outlier_sigmas * sigma * diag
    V = clean + off[:, None] * nrm
    return TruthScan(V=V, F=F, clean=clean, normals=nrm, params=st, outliers=mask, sigma=sigma * diag,
                     diagonal=diag, surface=surface)
