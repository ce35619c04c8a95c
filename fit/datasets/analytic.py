"""Analytic open surfaces sampled as clean meshes, with exact closest points, normals and outlines.

    m = analytic_mesh("cap", 800)             # AnalyticMesh: V (n, 3), F (m, 3), params (n, 2)
    st = m.surface.closest_params(P, st0)     # (k, 2) exact closest points of P (k, 3) by Newton
    m.surface.distance(P, st0)                # (k,) distance to the true surface
    m.surface.normals(st)                     # (k, 3) exact unit normals
    m.surface.outline_distance(P, st0)        # (k,) distance to the true boundary curve (outline)

The ground truth of ``benchmarks/bench_accuracy3d.py`` (issue 17): smooth open surfaces
given by charts ``f(s, t)`` with exact first and second derivatives over a parameter
domain (a disk, a rectangle, or a rectangle with a round hole), sampled without noise:
points on the outline spaced like the interior, the interior a jittered hexagonal
lattice, triangulated by Delaunay in the parameter plane (irregular valences and "ear"
triangles with three outline vertices, as in scans). The charts of ``cap``, ``bump_hole``
and ``barrel`` are those of :mod:`.truth` (sphere of radius 1.6, three bumps and a ripple,
barrel) over other domains; closest points use :func:`~trispline.fit.approx.deviation.newton_step`,
continued beyond the outline (so a point near the boundary is measured against the
surface, not against its edge).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np
from scipy.spatial import Delaunay

from trispline.spline.patches import PatchDerivatives
from trispline.spline.testing.domains import compact, orient_ccw
from trispline.spline.topology import signed_areas

from .truth import HOLE_CENTRE, HOLE_RADIUS, PARAM_BOX, SURFACES as TRUTH_CHARTS, _height

__all__ = ["Curve", "Domain", "AnalyticSurface", "AnalyticMesh", "ANALYTIC", "analytic_mesh",
           "analytic_surface"]

Chart = Callable[[np.ndarray, np.ndarray], PatchDerivatives]

#: Newton steps of the closest-point searches (quadratic convergence from a start O(h^2) away).
NEWTON_STEPS = 10
#: Interior lattice points closer than this times the spacing to the outline are dropped.
OUTLINE_CLEARANCE = 0.6
#: Jitter of the interior lattice and of the outline points, in units of the spacing.
JITTER = 0.2


@dataclass(frozen=True)
class Curve:
    """One smooth piece of a parameter domain's outline: a circle or a segment.

    ``kind="circle"``: ``c(tau) = a + r (cos tau, sin tau)``, ``tau`` in ``[0, 2 pi)``,
    counter-clockwise (``r < 0``: clockwise, a hole); ``kind="segment"``:
    ``c(tau) = a + tau (b - a)``, ``tau`` in ``[0, 1]``.
    """

    kind: str
    a: tuple[float, float]
    b: tuple[float, float] = (0.0, 0.0)
    r: float = 0.0

    @property
    def length(self) -> float:
        """Length in the parameter plane."""
        if self.kind == "circle":
            return 2 * np.pi * abs(self.r)
        return float(np.hypot(self.b[0] - self.a[0], self.b[1] - self.a[1]))

    def at(self, tau: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``c, c', c''`` at ``tau (n,)``, each ``(n, 2)``."""
        a = np.asarray(self.a)
        if self.kind == "circle":
            cs = np.column_stack([np.cos(tau), np.sin(tau)]) * self.r
            return a + cs, cs[:, ::-1] * np.array([-1.0, 1.0]), -cs
        d = np.asarray(self.b) - a
        z = np.zeros((tau.size, 2))
        return a + tau[:, None] * d, z + d, z

    def project(self, st: np.ndarray) -> np.ndarray:
        """``tau (n,)`` of the closest curve point to ``st (n, 2)`` in the parameter plane."""
        a = np.asarray(self.a)
        if self.kind == "circle":
            q = (st - a) * np.sign(self.r)
            return np.arctan2(q[:, 1], q[:, 0])
        d = np.asarray(self.b) - a
        return np.clip((st - a) @ d / (d @ d), 0.0, 1.0)

    def bounds(self) -> np.ndarray:
        """``(2, 2)`` rows ``lo``, ``hi`` of the curve's bounding box."""
        if self.kind == "circle":
            return np.asarray(self.a) + np.array([[-1.0], [1.0]]) * abs(self.r)
        p = np.array([self.a, self.b])
        return np.array([p.min(0), p.max(0)])

    def clamp(self, tau: np.ndarray) -> np.ndarray:
        """``tau`` kept on the curve (segments end at their end points)."""
        return tau if self.kind == "circle" else np.clip(tau, 0.0, 1.0)


@dataclass(frozen=True)
class Domain:
    """A parameter domain: the outer outline (curves in counter-clockwise order) and an optional hole."""

    curves: tuple[Curve, ...]
    hole: tuple[tuple[float, float], float] | None = None

    def clearance(self, st: np.ndarray) -> np.ndarray:
        """``(n,)`` distance of ``st (n, 2)`` to the outline, negative outside the domain."""
        c0 = self.curves[0]
        if c0.kind == "circle":
            d = c0.r - np.linalg.norm(st - np.asarray(c0.a), axis=1)
        else:
            lo = np.min([c.a for c in self.curves], 0)
            hi = np.max([c.a for c in self.curves], 0)
            d = np.min(np.column_stack([st - lo, hi - st]), axis=1)
        if self.hole is not None:
            d = np.minimum(d, np.linalg.norm(st - np.asarray(self.hole[0]), axis=1) - self.hole[1])
        return d

    @property
    def outline(self) -> tuple[Curve, ...]:
        """Every outline curve, the hole's (clockwise) included."""
        if self.hole is None:
            return self.curves
        return self.curves + (Curve("circle", self.hole[0], r=-self.hole[1]),)

    def area(self) -> float:
        """Area of the domain."""
        c0 = self.curves[0]
        a = np.pi * c0.r**2 if c0.kind == "circle" else float(np.prod(np.ptp([c.a for c in self.curves], 0)))
        return a - (np.pi * self.hole[1] ** 2 if self.hole is not None else 0.0)


def disk(radius: float) -> Domain:
    """The disk of ``radius`` about the origin."""
    return Domain((Curve("circle", (0.0, 0.0), r=radius),))


def rectangle(s0: float, s1: float, t0: float, t1: float, hole: tuple | None = None) -> Domain:
    """The rectangle ``[s0, s1] x [t0, t1]`` (sides counter-clockwise), optionally with a round hole."""
    p = [(s0, t0), (s1, t0), (s1, t1), (s0, t1)]
    return Domain(tuple(Curve("segment", p[k], p[(k + 1) % 4]) for k in range(4)), hole)


def _torus(s: np.ndarray, t: np.ndarray, R: float = 1.0, r: float = 0.4) -> PatchDerivatives:
    """Torus ``((R + r cos p) cos q, (R + r cos p) sin q, r sin p)``, ``q = s / R``, ``p = t / r`` (arc lengths)."""
    q, p = s / R, t / r
    cq, sq, cp, sp = np.cos(q), np.sin(q), np.cos(p), np.sin(p)
    w = R + r * cp
    z = np.zeros_like(s)
    col = np.column_stack
    return PatchDerivatives(
        values=col([w * cq, w * sq, r * sp]),
        du=col([-w * sq / R, w * cq / R, z]), dv=col([-sp * cq, -sp * sq, cp]),
        uu=col([-w * cq / R**2, -w * sq / R**2, z]), uv=col([sp * sq / R, -sp * cq / R, z]),
        vv=col([-cp * cq / r, -cp * sq / r, -sp / r]),
    )


def _monkey(s: np.ndarray, t: np.ndarray, a: float = 0.5) -> PatchDerivatives:
    """Monkey saddle ``h = a (s^3 - 3 s t^2)``."""
    return _height(s, t, (a * (s**3 - 3 * s * t * t), a * 3 * (s * s - t * t), -6 * a * s * t, 6 * a * s,
                          -6 * a * t, -6 * a * s))


def _wavy(s: np.ndarray, t: np.ndarray, a: float = 0.12, w: float = 4.0, k: float = 3.0) -> PatchDerivatives:
    """Wavy sheet ``h = a sin(w s + 1) sin(k t)``."""
    S, C, Sk, Ck = np.sin(w * s + 1), np.cos(w * s + 1), np.sin(k * t), np.cos(k * t)
    return _height(s, t, (a * S * Sk, a * w * C * Sk, a * k * S * Ck, -a * w * w * S * Sk, a * w * k * C * Ck,
                          -a * k * k * S * Sk))


def _enneper(s: np.ndarray, t: np.ndarray, c: float = 0.5) -> PatchDerivatives:
    """Enneper's minimal surface ``c (u - u^3/3 + u v^2, v - v^3/3 + v u^2, u^2 - v^2)``
    (no self-contact for ``|(u, v)| < sqrt 3``)."""
    u, v = s, t
    z = np.zeros_like(s)
    col = lambda x, y, w: c * np.column_stack([x, y, w])  # noqa: E731
    return PatchDerivatives(
        values=col(u - u**3 / 3 + u * v * v, v - v**3 / 3 + v * u * u, u * u - v * v),
        du=col(1 - u * u + v * v, 2 * u * v, 2 * u), dv=col(2 * u * v, 1 - v * v + u * u, -2 * v),
        uu=col(-2 * u, 2 * v, z + 2), uv=col(2 * v, 2 * u, z), vv=col(2 * u, -2 * v, z - 2),
    )


def _helicoid(s: np.ndarray, t: np.ndarray, pitch: float = 0.35) -> PatchDerivatives:
    """Helicoid ``(s cos t, s sin t, pitch t)``: a ruled minimal surface."""
    c, sn = np.cos(t), np.sin(t)
    z = np.zeros_like(s)
    col = np.column_stack
    return PatchDerivatives(values=col([s * c, s * sn, pitch * t]), du=col([c, sn, z]),
                            dv=col([-s * sn, s * c, z + pitch]), uu=col([z, z, z]), uv=col([-sn, c, z]),
                            vv=col([-s * c, -s * sn, z]))


def _cap_conformal(st: np.ndarray, R: float = 1.6) -> np.ndarray:
    """The sphere cap's stereographic projection from its south pole, ``(s, t) R / (R + h)``."""
    h = np.sqrt(R * R - (st * st).sum(1))
    return st * (R / (R + h))[:, None]


def _torus_conformal(st: np.ndarray, R: float = 1.0, r: float = 0.4) -> np.ndarray:
    """``(s, integral R / (R + r cos(t / r)) dt)``: the torus's metric ``(w / R)^2 ds^2 + dt^2`` made conformal."""
    p = st[:, 1] / r
    y = r * R * 2.0 / np.sqrt(R * R - r * r) * np.arctan(np.sqrt((R - r) / (R + r)) * np.tan(p / 2.0))
    return np.column_stack([st[:, 0], y])


def _helicoid_conformal(st: np.ndarray, pitch: float = 0.35) -> np.ndarray:
    """``(asinh(s / pitch), t)``: the helicoid's metric ``ds^2 + (s^2 + pitch^2) dt^2`` made conformal."""
    return np.column_stack([np.arcsinh(st[:, 0] / pitch), st[:, 1]])


def _barrel_conformal(st: np.ndarray, wrap: float = 1.22, r0: float = 0.8, bulge: float = 0.15,
                      half_height: float = 1.0) -> np.ndarray:
    """``(s, integral sqrt(r'^2 + k^2) / (wrap r) dt)`` (by quadrature): the barrel's metric
    ``wrap^2 r(t)^2 ds^2 + (r'(t)^2 + k^2) dt^2`` made conformal (see :mod:`.truth`'s barrel)."""
    t = np.linspace(-1.0, 1.0, 40001)  # beyond the strip (|t| <= 0.7): no clamping at its edges
    r = r0 * (1 + bulge * (1 - (t / 0.7) ** 2))
    g = np.sqrt((2 * r0 * bulge * t / 0.49) ** 2 + (half_height / 0.7) ** 2) / (wrap * r)
    y = np.concatenate([[0.0], np.cumsum(0.5 * (g[1:] + g[:-1]) * np.diff(t))])
    return np.column_stack([st[:, 0], np.interp(st[:, 1], t, y - np.interp(0.0, t, y))])


@dataclass(frozen=True)
class AnalyticSurface:
    """A chart ``f(s, t)`` with exact derivatives over a parameter :class:`Domain`; ``conformal``, where known in
    closed form, maps ``st (n, 2)`` to conformal coordinates ``(n, 2)`` of the surface (a map no discretisation
    error roughens: the yardstick of what a conformal parameterization can give)."""

    name: str
    chart: Chart
    domain: Domain
    conformal: Callable[[np.ndarray], np.ndarray] | None = None

    def derivatives(self, st: np.ndarray) -> PatchDerivatives:
        """Values and first and second derivatives ``(n, 3)`` at ``st (n, 2)``."""
        st = np.asarray(st, np.float64)
        return self.chart(st[:, 0], st[:, 1])

    def normals(self, st: np.ndarray) -> np.ndarray:
        """Unit normals ``(n, 3)``, ``f_s x f_t`` (the side the counter-clockwise faces face)."""
        d = self.derivatives(st)
        n = np.cross(d.du, d.dv)
        return n / np.linalg.norm(n, axis=1, keepdims=True)

    def closest_params(self, P: np.ndarray, st0: np.ndarray) -> np.ndarray:
        """``(n, 2)`` parameters of the closest points to ``P (n, 3)``: Newton from ``st0 (n, 2)``."""
        from trispline.fit.approx.deviation import newton_step

        st = np.array(st0, np.float64)
        for _ in range(NEWTON_STEPS):
            st = st + newton_step(self.derivatives(st), P)[0]
        return st

    def distance(self, P: np.ndarray, st0: np.ndarray) -> np.ndarray:
        """``(n,)`` distance from ``P (n, 3)`` to the surface (Newton from ``st0 (n, 2)``)."""
        return np.linalg.norm(self.derivatives(self.closest_params(P, st0)).values - P, axis=1)

    def outline_distance(self, P: np.ndarray, st0: np.ndarray) -> np.ndarray:
        """``(n,)`` distance from ``P (n, 3)`` to the image of the domain's outline (every curve, the hole's too).

        Per curve: Newton on ``|f(c(tau)) - P|^2`` in ``tau`` from the projection of ``st0 (n, 2)``
        (Gauss--Newton where the second derivative is not positive); the nearest curve wins.
        """
        best = np.full(len(P), np.inf)
        for curve in self.domain.outline:
            tau = curve.project(st0)
            for _ in range(NEWTON_STEPS):
                c, c1, c2 = curve.at(tau)
                d = self.chart(c[:, 0], c[:, 1])
                T = d.du * c1[:, :1] + d.dv * c1[:, 1:]
                T2 = (d.uu * c1[:, :1] ** 2 + 2 * d.uv * c1[:, :1] * c1[:, 1:] + d.vv * c1[:, 1:] ** 2
                      + d.du * c2[:, :1] + d.dv * c2[:, 1:])
                r = d.values - P
                g, h = (r * T).sum(1), (T * T).sum(1)
                h2 = h + (r * T2).sum(1)
                tau = curve.clamp(tau - g / np.where(h2 > 0, h2, h))
            c = curve.at(tau)[0]
            best = np.minimum(best, np.linalg.norm(self.chart(c[:, 0], c[:, 1]).values - P, axis=1))
        return best


#: The surfaces of the benchmark, by name (parameter domains of about unit size).
ANALYTIC: dict[str, AnalyticSurface] = {s.name: s for s in (
    AnalyticSurface("cap", TRUTH_CHARTS["cap"], disk(1.0), _cap_conformal),
    AnalyticSurface("torus", _torus, rectangle(-1.0, 1.0, -0.8, 0.8), _torus_conformal),
    AnalyticSurface("monkey", _monkey, disk(1.0)),
    AnalyticSurface("bump_hole", TRUTH_CHARTS["bumps"], rectangle(*PARAM_BOX, hole=(tuple(HOLE_CENTRE), HOLE_RADIUS))),
    AnalyticSurface("enneper", _enneper, disk(1.0), lambda st: np.array(st, np.float64)),  # its own are conformal
    # truth's barrel wraps 1.22 rad per unit of s: s in +-1.717 is a 240-degree strip
    AnalyticSurface("barrel240", TRUTH_CHARTS["barrel"], rectangle(-1.717, 1.717, -0.7, 0.7), _barrel_conformal),
    AnalyticSurface("wavy", _wavy, rectangle(-1.0, 1.0, -0.7, 0.7)),
    AnalyticSurface("helicoid", _helicoid, rectangle(0.3, 1.1, -1.4, 1.4), _helicoid_conformal),
)}


def analytic_surface(name: str) -> AnalyticSurface:
    """The :data:`ANALYTIC` surface ``name``."""
    if name not in ANALYTIC:
        raise ValueError(f"unknown analytic surface {name!r}; choose one of {', '.join(ANALYTIC)}")
    return ANALYTIC[name]


@dataclass(frozen=True, eq=False)
class AnalyticMesh:
    """A clean mesh of an analytic surface.

    V : (n, 3) vertices on the surface; F : (m, 3) faces, counter-clockwise in ``params``
    params : (n, 2) the vertices' surface parameters (the true uv); normals : (n, 3) exact unit normals
    spacing : the sampling step in the parameter plane; surface : the :class:`AnalyticSurface`
    """

    V: np.ndarray
    F: np.ndarray
    params: np.ndarray
    normals: np.ndarray
    spacing: float
    surface: AnalyticSurface


def _spacing(domain: Domain, n: int) -> float:
    """Step ``h`` with about ``n`` vertices: ``L / h`` on the outline, ``2 A' / (sqrt 3 h^2)`` inside,
    ``A' = A - OUTLINE_CLEARANCE h L`` (the lattice's points near the outline are dropped)."""
    A, L = domain.area(), sum(c.length for c in domain.outline)
    L = L * (1 - 2 * OUTLINE_CLEARANCE / np.sqrt(3))
    a = 2 * A / np.sqrt(3)
    x = (-L + np.sqrt(L * L + 4 * a * n)) / (2 * a)  # x = 1 / h
    return 1.0 / x


def _outline_points(domain: Domain, h: float, rng: np.random.Generator) -> np.ndarray:
    """``(k, 2)`` points along every outline curve about ``h`` apart (jittered; segment ends kept)."""
    pts = []
    for c in domain.outline:
        m = max(int(round(c.length / h)), 3)
        if c.kind == "circle":
            tau = (np.arange(m) + rng.uniform(-JITTER, JITTER, m)) * 2 * np.pi / m
        else:
            tau = (np.arange(m) + np.r_[0.0, rng.uniform(-JITTER, JITTER, m - 1)]) / m
        pts.append(c.at(tau)[0])
    return np.concatenate(pts)


def _interior_points(domain: Domain, h: float, rng: np.random.Generator) -> np.ndarray:
    """``(k, 2)`` jittered hexagonal lattice of step ``h``, at least ``OUTLINE_CLEARANCE h`` inside."""
    box = np.concatenate([c.bounds() for c in domain.curves])
    lo, hi = box.min(0) - h, box.max(0) + h
    j, i = np.mgrid[0:int((hi[1] - lo[1]) / (h * np.sqrt(3) / 2)) + 1, 0:int((hi[0] - lo[0]) / h) + 2]
    st = np.column_stack([(lo[0] + h * (i + 0.5 * (j % 2))).ravel(), (lo[1] + h * np.sqrt(3) / 2 * j).ravel()])
    st = st + rng.uniform(-JITTER, JITTER, st.shape) * h
    return st[domain.clearance(st) > OUTLINE_CLEARANCE * h]


def analytic_mesh(name: str, n_vertices: int, *, seed: int = 0) -> AnalyticMesh:
    """Sample surface ``name`` (:data:`ANALYTIC`) at about ``n_vertices`` vertices (deterministic per ``seed``)."""
    surface = analytic_surface(name)
    dom = surface.domain
    h = _spacing(dom, max(int(n_vertices), 30))
    rng = np.random.default_rng(seed)
    st = np.concatenate([_outline_points(dom, h, rng), _interior_points(dom, h, rng)])
    F = orient_ccw(st, Delaunay(st).simplices)
    F = F[dom.clearance(st[F].mean(1)) > 0]  # the hole's faces
    a = signed_areas(st, F)
    F = F[a > 1e-9 * a.mean()]  # slivers of collinear outline points
    st, F = compact(st, F)
    d = surface.derivatives(st)
    n = np.cross(d.du, d.dv)
    return AnalyticMesh(V=d.values, F=F, params=st, normals=n / np.linalg.norm(n, axis=1, keepdims=True),
                        spacing=h, surface=surface)

