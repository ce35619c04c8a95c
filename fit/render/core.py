"""Pictures of a spline surface, rendered headless: shaded, zebra, curvature, deviation, control net.

    from trispline.fit.render import render, draw
    render(surface, "zebra.png", mode="zebra", view="iso", size=(800, 600))
    render(surface, "dev.png", mode="deviation", mesh=(V, F))       # against the data mesh
    pic = draw(surface, mode="curvature")                           # Picture: image (h, w, 3) uint8, stats

Every scalar is computed from the analytic surface, sampled per patch on a
barycentric grid of ``resolution`` steps per edge (each patch keeps its own
samples, so a jump across a patch boundary stays a jump in the picture):

* **zebra** -- highlight lines (Beier and Chen 1994), a view-independent form of
  reflection lines. A panel of parallel light tubes hangs between the camera and
  the surface; the stripe coordinate of a surface point ``P`` with analytic unit
  normal ``N`` is where the normal line ``P + s N`` meets the panel, measured
  across the tubes (:func:`stripe_function`). It depends on ``N`` itself, so a
  C1 surface has continuous stripes and a kink (a normal jump) breaks them, and a
  plane has straight, parallel, equally spaced stripes.
* **curvature** -- mean ``H = (k1 + k2) / 2`` or Gaussian ``K = k1 k2`` from the
  first and second fundamental forms of the analytic first and second derivatives
  (:func:`curvatures`); the sign of ``H`` follows the normal ``F_u x F_v``.
* **deviation** -- signed distance from each sampled surface point to the data
  mesh (surface -> data; ``+`` on the side the data face's normal points to),
  exact point-to-triangle distances through libigl's AABB tree
  (:func:`deviation`). Data -> surface would be zero at every data vertex of an
  interpolating fit and shows nothing.

Drawing uses PyVista/VTK off-screen (no display, no GPU: EGL or OSMesa from the
VTK wheels) and falls back to matplotlib (Agg, a painter's-algorithm projection)
when VTK cannot be imported or fails, with a :class:`RenderFallbackWarning`.
``TRISPLINE_RENDER_BACKEND=matplotlib`` (or ``backend=``) picks one explicitly.
"""
from __future__ import annotations

import io
import os
import warnings
from contextlib import contextmanager
from dataclasses import dataclass, field
from functools import lru_cache
from pathlib import Path
from typing import TYPE_CHECKING, Any, Iterator, Sequence

import numpy as np

from trispline.spline.index import NCTRL
from trispline.spline.bernstein import basis, basis_gradient_bary, basis_hessian_bary

from trispline.spline.util.atomic import atomic_path
from ..errors import RenderError, RenderFallbackWarning

if TYPE_CHECKING:  # pragma: no cover
    from trispline.spline.surface import SplineSurface

__all__ = [
    "MODES", "VIEWS", "BACKENDS", "CURVATURES", "RenderError", "RenderFallbackWarning",
    "View", "parse_view", "parse_size", "SurfaceSample", "sample_surface", "unit_normals",
    "curvatures", "surface_curvatures", "ZebraLight", "zebra_light", "stripe_function",
    "stripe_pattern", "deviation", "Panel", "Picture", "draw", "draw_panels", "render",
    "render_panels", "write_png",
]

MODES = ("shaded", "zebra", "curvature", "deviation", "controlnet")
#: Named views: (azimuth, elevation) in degrees; the camera looks at the surface from
#: direction (cos el cos az, cos el sin az, sin el), z up.
VIEWS = {"iso": (-60.0, 30.0), "top": (-90.0, 90.0), "front": (-90.0, 0.0), "side": (0.0, 0.0)}
BACKENDS = ("auto", "pyvista", "matplotlib")
CURVATURES = ("mean", "gaussian")
#: Largest picture side (pixels).
MAX_SIDE = 8192
#: Triangles aimed at by the automatic resolution (per backend), and its bounds.
TARGET_TRIANGLES = {"pyvista": 1_700_000, "matplotlib": 120_000}
MAX_AUTO_RESOLUTION = 8
#: Faces evaluated per block (bounds the memory of the derivative arrays).
BLOCK_FACES = 20_000
#: Highlight lines: |N . W| below this (normal almost parallel to the light panel) is left grey.
ZEBRA_MIN_COS = 1e-3
#: Patch boundaries are drawn by default up to this many patches.
PATCH_LINES_MAX = 2000
#: Robust colour range of curvature maps: this percentile of |value|.
CURVATURE_PERCENTILE = 98.0

_SURFACE_RGB = (0.55, 0.70, 0.95)
_DATA_RGB = (0.80, 0.78, 0.72)
_NET_RGB = (0.75, 0.12, 0.10)
_BACKGROUND = (1.0, 1.0, 1.0)
_NAN_RGB = (0.6, 0.6, 0.6)
_STRIPE_RGB = ((0.97, 0.97, 0.97), (0.08, 0.08, 0.08))




# ============================================================================ options
@dataclass(frozen=True)
class View:
    """A camera direction: ``azimuth`` and ``elevation`` in degrees (z up)."""

    azimuth: float
    elevation: float

    @property
    def toward(self) -> np.ndarray:
        """(3,) unit vector from the surface toward the camera."""
        a, e = np.radians(self.azimuth), np.radians(self.elevation)
        return np.array([np.cos(e) * np.cos(a), np.cos(e) * np.sin(a), np.sin(e)])

    @property
    def up(self) -> np.ndarray:
        """(3,) screen up (the derivative of :attr:`toward` by elevation; y at the top view)."""
        a, e = np.radians(self.azimuth), np.radians(self.elevation)
        return np.array([-np.sin(e) * np.cos(a), -np.sin(e) * np.sin(a), np.cos(e)])

    @property
    def right(self) -> np.ndarray:
        """(3,) screen right, ``up x toward``."""
        return np.cross(self.up, self.toward)


def parse_view(view: "str | View | Sequence[float]") -> View:
    """A :class:`View` from a name in :data:`VIEWS`, ``"azimuth,elevation"`` or a pair."""
    if isinstance(view, View):
        return view
    if isinstance(view, str):
        name = view.strip().lower()
        if name in VIEWS:
            return View(*VIEWS[name])
        parts = name.split(",")
        try:
            pair = [float(p) for p in parts]
        except ValueError:
            pair = []
        if len(pair) != 2:
            raise RenderError(f"unknown view {view!r}: use one of {', '.join(VIEWS)} or 'azimuth,elevation' "
                              f"in degrees, e.g. '-60,30'")
    else:
        try:
            pair = [float(p) for p in view]
        except (TypeError, ValueError):
            raise RenderError(f"a view must be a name, 'azimuth,elevation' or a pair of numbers, got {view!r}") from None
        if len(pair) != 2:
            raise RenderError(f"a view needs two angles (azimuth, elevation), got {len(pair)}")
    az, el = pair
    if not (np.isfinite(az) and np.isfinite(el)) or abs(el) > 90:
        raise RenderError(f"view angles must be finite with |elevation| <= 90, got azimuth {az}, elevation {el}")
    return View(az, el)


def parse_size(size: "str | Sequence[int]") -> tuple[int, int]:
    """``(width, height)`` in pixels from ``"WxH"`` or a pair; each 16..:data:`MAX_SIDE`."""
    if isinstance(size, str):
        parts = size.lower().replace("*", "x").split("x")
        try:
            w, h = (int(p) for p in parts)
        except ValueError:
            raise RenderError(f"size must look like WIDTHxHEIGHT, e.g. 800x600, got {size!r}") from None
    else:
        try:
            w, h = (int(s) for s in size)
        except (TypeError, ValueError):
            raise RenderError(f"size must be (width, height), got {size!r}") from None
        if any(float(s) != int(s) for s in size):
            raise RenderError(f"size must be whole pixels, got {tuple(size)}")
    if not (16 <= w <= MAX_SIDE and 16 <= h <= MAX_SIDE):
        raise RenderError(f"picture size must be between 16 and {MAX_SIDE} pixels per side, got {w}x{h}")
    return w, h


def _check_mode(mode: str) -> str:
    if mode not in MODES:
        raise RenderError(f"unknown mode {mode!r}: use one of {', '.join(MODES)}")
    return mode


# ============================================================================ sampling
@lru_cache(maxsize=16)
def _grid(r: int) -> tuple[np.ndarray, np.ndarray]:
    """Barycentric grid with ``r`` steps per edge: ``bary (n, 3)`` and CCW ``triangles (r^2, 3)``."""
    ijk = [(i, j, r - i - j) for i in range(r, -1, -1) for j in range(r - i + 1)]
    index = {p: n for n, p in enumerate(ijk)}
    tris = []
    for i in range(r, 0, -1):
        for j in range(r - i + 1):
            k = r - i - j
            tris.append((index[i, j, k], index[i - 1, j + 1, k], index[i - 1, j, k + 1]))
            if i >= 2:
                tris.append((index[i - 1, j + 1, k], index[i - 2, j + 1, k + 1], index[i - 1, j, k + 1]))
    bary = np.array(ijk, np.float64) / r
    bary.setflags(write=False)
    t = np.array(tris, np.int64)
    t.setflags(write=False)
    return bary, t


@lru_cache(maxsize=16)
def _grid_basis(r: int) -> np.ndarray:
    """``(6 n, 21)``: value, d/ds, d/dt, d2/ds2, d2/dsdt, d2/dt2 of the Bernstein basis on
    :func:`_grid`, in the local parameters ``(s, t) = (l_b, l_c)``, ``l_a = 1 - s - t``."""
    bary, _ = _grid(r)
    B = basis(bary)
    dB = basis_gradient_bary(bary)  # (3, n, 21)
    H = basis_hessian_bary(bary)  # (3, 3, n, 21)
    stack = np.concatenate([
        B, dB[1] - dB[0], dB[2] - dB[0],
        H[1, 1] - 2 * H[0, 1] + H[0, 0],
        H[1, 2] - H[0, 1] - H[0, 2] + H[0, 0],
        H[2, 2] - 2 * H[0, 2] + H[0, 0],
    ])
    stack.setflags(write=False)
    return stack


def unit_normals(du: np.ndarray, dv: np.ndarray) -> np.ndarray:
    """Unit normals ``(n, 3)`` = normalised ``du x dv`` (NaN where the tangents are parallel)."""
    c = np.cross(du, dv)
    nrm = np.linalg.norm(c, axis=-1, keepdims=True)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(nrm > 0, c / np.where(nrm > 0, nrm, 1.0), np.nan)


def curvatures(du: np.ndarray, dv: np.ndarray, uu: np.ndarray, uv: np.ndarray, vv: np.ndarray
               ) -> tuple[np.ndarray, np.ndarray]:
    """Mean and Gaussian curvature ``(n,)`` from first and second derivatives ``(n, 3)``.

    First fundamental form ``E, F, G`` and second ``L, M, N`` (against the unit normal
    ``du x dv / |du x dv|``): ``K = (L N - M^2) / (E G - F^2)``,
    ``H = (E N - 2 F M + G L) / (2 (E G - F^2))``. Any regular parameterization gives
    the same values. NaN where the surface is singular (``E G - F^2 = 0``).
    """
    n = unit_normals(du, dv)
    E = np.einsum("nd,nd->n", du, du)
    F = np.einsum("nd,nd->n", du, dv)
    G = np.einsum("nd,nd->n", dv, dv)
    L = np.einsum("nd,nd->n", uu, n)
    M = np.einsum("nd,nd->n", uv, n)
    N = np.einsum("nd,nd->n", vv, n)
    det = E * G - F * F
    with np.errstate(invalid="ignore", divide="ignore"):
        inv = np.where(det > 0, 1.0 / np.where(det > 0, det, 1.0), np.nan)
    return 0.5 * (E * N - 2 * F * M + G * L) * inv, (L * N - M * M) * inv


def surface_curvatures(surface: "SplineSurface", face_idx: np.ndarray, bary: np.ndarray
                       ) -> tuple[np.ndarray, np.ndarray]:
    """Mean and Gaussian curvature ``(n,)`` at ``face_idx (n,)``, ``bary (n, 3)`` (uv derivatives)."""
    d = surface.evaluate_derivatives(face_idx, bary, second=True)
    return curvatures(d.du, d.dv, d.uu, d.uv, d.vv)


@dataclass(frozen=True)
class SurfaceSample:
    """The surface sampled per patch on a barycentric grid (``n = F (r+1)(r+2)/2`` points).

    points, normals : (n, 3); normals analytic and unit (NaN where singular)
    triangles : (F r^2, 3) int64, counter-clockwise like the faces
    face_idx : (n,) patch of each point; bary : (n, 3) its barycentric coordinates
    mean_curvature, gaussian_curvature : (n,) or None (``curvature=False``)
    resolution : r
    """

    points: np.ndarray
    normals: np.ndarray
    triangles: np.ndarray
    face_idx: np.ndarray
    bary: np.ndarray
    mean_curvature: np.ndarray | None
    gaussian_curvature: np.ndarray | None
    resolution: int


def sample_surface(surface: "SplineSurface", resolution: int = 4, *, curvature: bool = True) -> SurfaceSample:
    """Sample every patch on the grid with ``resolution`` steps per edge; see :class:`SurfaceSample`.

    Values, analytic normals and (with ``curvature``) mean and Gaussian curvature
    come from one ``(6 n, 21) @ (21, 3 F)`` product per block of faces.
    """
    r = int(resolution)
    if r < 1 or r != resolution:
        raise RenderError(f"resolution must be an integer >= 1, got {resolution}")
    ctrl = np.asarray(surface.ctrl, np.float64)
    nf = ctrl.shape[0]
    bary, tri = _grid(r)
    n = bary.shape[0]
    stack = _grid_basis(r) if curvature else _grid_basis(r)[: 3 * n]
    q = stack.shape[0] // n
    points = np.empty((nf, n, 3))
    normals = np.empty((nf, n, 3))
    H = np.empty((nf, n)) if curvature else None
    K = np.empty((nf, n)) if curvature else None
    for lo in range(0, nf, BLOCK_FACES):
        hi = min(lo + BLOCK_FACES, nf)
        flat = ctrl[lo:hi].transpose(1, 0, 2).reshape(NCTRL, -1)
        out = (stack @ flat).reshape(q, n, hi - lo, 3).transpose(0, 2, 1, 3)  # (q, f, n, 3)
        points[lo:hi] = out[0]
        ds, dt = out[1].reshape(-1, 3), out[2].reshape(-1, 3)
        normals[lo:hi] = unit_normals(ds, dt).reshape(hi - lo, n, 3)
        if curvature:
            h, k = curvatures(ds, dt, out[3].reshape(-1, 3), out[4].reshape(-1, 3), out[5].reshape(-1, 3))
            H[lo:hi] = h.reshape(hi - lo, n)
            K[lo:hi] = k.reshape(hi - lo, n)
    triangles = (tri[None, :, :] + (n * np.arange(nf))[:, None, None]).reshape(-1, 3)
    return SurfaceSample(
        points=points.reshape(-1, 3), normals=normals.reshape(-1, 3), triangles=triangles,
        face_idx=np.repeat(np.arange(nf), n), bary=np.tile(bary, (nf, 1)),
        mean_curvature=None if H is None else H.ravel(), gaussian_curvature=None if K is None else K.ravel(),
        resolution=r,
    )


def _auto_resolution(n_faces: int, backend: str) -> int:
    target = TARGET_TRIANGLES.get(backend, TARGET_TRIANGLES["pyvista"])
    return int(np.clip(np.floor(np.sqrt(target / max(n_faces, 1))), 1, MAX_AUTO_RESOLUTION))


# ============================================================================ zebra
@dataclass(frozen=True)
class ZebraLight:
    """A panel of parallel light tubes for highlight lines.

    along : (3,) unit direction of the tubes; across : (3,) unit direction across them
    facing : (3,) unit normal of the panel (toward the camera); height : panel at ``P . facing = height``
    spacing : distance between neighbouring tubes (one black and one white stripe)
    """

    along: np.ndarray
    across: np.ndarray
    facing: np.ndarray
    height: float
    spacing: float


def zebra_light(points: np.ndarray, view: "View | str | Sequence[float]" = "iso", *, stripes: float = 12.0,
                angle: float = 45.0, distance: float | None = None) -> ZebraLight:
    """The light panel for ``points (n, 3)`` seen from ``view``.

    The panel faces the camera, ``distance`` (default: half the bounding-box diagonal
    ``d``) in front of the nearest point; its tubes run at ``angle`` degrees to screen
    right, ``d / stripes`` apart.
    """
    view = parse_view(view)
    if not (np.isfinite(stripes) and stripes > 0):
        raise RenderError(f"stripes must be a positive number, got {stripes}")
    P = np.asarray(points, np.float64)
    ok = np.isfinite(P).all(1)
    P = P[ok]
    diag = float(np.linalg.norm(P.max(0) - P.min(0))) if P.size else 1.0
    diag = diag if diag > 0 else 1.0
    a = np.radians(angle)
    along = np.cos(a) * view.right + np.sin(a) * view.up
    across = -np.sin(a) * view.right + np.cos(a) * view.up
    W = view.toward
    dist = 0.5 * diag if distance is None else float(distance)
    height = float((P @ W).max() if P.size else 0.0) + dist
    return ZebraLight(along, across, W, height, diag / float(stripes))


def stripe_function(points: np.ndarray, normals: np.ndarray, light: ZebraLight) -> np.ndarray:
    """Highlight-line coordinate ``t (n,)`` of surface points ``(n, 3)`` with unit normals ``(n, 3)``.

    ``t`` is where the normal line ``P + s N`` meets the light panel, measured across
    the tubes in tube spacings: ``t = (P.D + (N.D) (h - P.W) / (N.W)) / spacing``
    (``D`` across, ``W`` facing, ``h`` the panel height). Stripes are
    ``floor(2 t) mod 2``. Invariant under ``N -> -N`` (two-sided); NaN where
    ``|N.W| <`` :data:`ZEBRA_MIN_COS` or the normal is undefined.
    """
    P = np.asarray(points, np.float64)
    N = np.asarray(normals, np.float64)
    nw = N @ light.facing
    nd = N @ light.across
    with np.errstate(invalid="ignore", divide="ignore"):
        t = (P @ light.across + nd * (light.height - P @ light.facing) / nw) / light.spacing
    t[~(np.abs(nw) >= ZEBRA_MIN_COS)] = np.nan
    return t


def stripe_pattern(t: np.ndarray) -> np.ndarray:
    """``(n,)`` 0 (white) or 1 (black) stripes of the highlight coordinate ``t``; -1 where NaN."""
    t = np.asarray(t, np.float64)
    out = np.full(t.shape, -1, np.int64)
    ok = np.isfinite(t)
    out[ok] = np.floor(2.0 * t[ok]).astype(np.int64) % 2
    return out


# ============================================================================ deviation
def _as_mesh(mesh: Any) -> tuple[np.ndarray, np.ndarray]:
    """``(V, F)`` from a pair, a trimesh-like object, or a mesh file path."""
    if isinstance(mesh, (str, os.PathLike)):
        from ..io import read_mesh

        md = read_mesh(mesh)
        return np.asarray(md.V, np.float64), np.asarray(md.F, np.int64)
    if hasattr(mesh, "vertices") and hasattr(mesh, "faces"):
        mesh = (mesh.vertices, mesh.faces)
    try:
        V, F = mesh
        V = np.asarray(V, np.float64)
        F = np.asarray(F)
    except (TypeError, ValueError):
        raise RenderError("a data mesh must be (V, F) arrays, a trimesh or a mesh file path") from None
    if V.ndim != 2 or V.shape[1] != 3 or F.ndim != 2 or F.shape[1] != 3 or F.shape[0] == 0:
        raise RenderError(f"a data mesh needs V (nv, 3) and F (nf >= 1, 3), got {V.shape} and {F.shape}")
    if not np.issubdtype(F.dtype, np.integer):
        raise RenderError(f"data mesh faces must be integers, got {F.dtype}")
    F = F.astype(np.int64)
    bad = np.flatnonzero((F < 0).any(1) | (F >= V.shape[0]).any(1))
    if bad.size:
        raise RenderError(f"data mesh: {bad.size} faces index missing vertices (of {V.shape[0]}); "
                          f"first: {bad[:5].tolist()}")
    bad = np.flatnonzero(~np.isfinite(V).all(1))
    if bad.size:
        raise RenderError(f"data mesh: {bad.size} vertices are not finite; first: {bad[:5].tolist()}")
    return V, F


def deviation(points: np.ndarray, V: np.ndarray, F: np.ndarray) -> np.ndarray:
    """Signed distance ``(n,)`` from ``points (n, 3)`` to the triangle mesh ``V (nv, 3)``, ``F (nf, 3)``.

    Exact point-to-triangle distance (libigl ``point_mesh_squared_distance``, an
    AABB tree); the sign is that of ``(P - C) . n_f`` with ``C`` the closest point
    and ``n_f`` the normal of its face (``+`` on the side the face normal points to).
    """
    from trispline.param import closest_points  # libigl AABB tree: about 2 s per million points

    P = np.ascontiguousarray(points, np.float64)
    V, F = _as_mesh((V, F))
    d = np.full(P.shape[0], np.nan)
    ok = np.isfinite(P).all(1)
    if not ok.any():
        return d
    sq, idx, C = closest_points(P[ok], V, F)
    T = V[F[idx]]
    fn = np.cross(T[:, 1] - T[:, 0], T[:, 2] - T[:, 0])
    side = np.einsum("nd,nd->n", P[ok] - C, fn)
    d[ok] = np.sqrt(np.maximum(sq, 0.0)) * np.where(side < 0, -1.0, 1.0)
    return d


def _data_mesh_of(surface: "SplineSurface") -> tuple[np.ndarray, np.ndarray] | None:
    """The fitted data mesh stored with a fit (``data_vertices`` + the surface's faces), if any."""
    D = surface.extras.get("data_vertices")
    if D is None:
        return None
    D = np.asarray(D, np.float64)
    if D.shape != (surface.n_vertices, 3):
        return None
    return D, np.asarray(surface.faces, np.int64)


# ============================================================================ scenes
@dataclass
class _Layer:
    kind: str                      # "surface" | "lines" | "points"
    points: np.ndarray             # (m, 3)
    cells: np.ndarray | None = None  # (t, 3) triangles or (s, 2) segments
    normals: np.ndarray | None = None
    color: tuple = _SURFACE_RGB
    scalars: np.ndarray | None = None   # colour-mapped
    stripes: np.ndarray | None = None   # highlight coordinate t
    cmap: str = "RdBu_r"
    clim: tuple[float, float] = (0.0, 1.0)
    lit: bool = True
    edges: bool = False
    width: float = 1.0


@dataclass
class _Scene:
    layers: list[_Layer]
    frame: np.ndarray               # (m, 3) points to fit in the picture
    view: View
    title: str
    legend: list[str]
    bar: tuple[str, tuple[float, float], str] | None = None  # cmap, clim, label


@dataclass
class Panel:
    """One picture of a side-by-side figure (:func:`draw_panels`).

    Give ``surface`` (any of :data:`MODES`) or only ``mesh`` (a data mesh ``(V, F)``,
    drawn flat with its edges, e.g. the scan next to its fit). ``options`` go to
    :func:`draw` (``stripes``, ``stripe_angle``, ``curvature``, ``resolution``, ...).
    """

    surface: Any = None
    mode: str = "shaded"
    mesh: Any = None
    title: str | None = None
    options: dict = field(default_factory=dict)


@dataclass(frozen=True)
class Picture:
    """A rendered picture: ``image (h, w, 3) uint8``, the backend used, legend lines and stats."""

    image: np.ndarray
    backend: str
    legend: tuple[str, ...]
    stats: dict


def _symmetric_clim(values: np.ndarray, percentile: float) -> float:
    v = np.abs(values[np.isfinite(values)])
    if v.size == 0:
        return 1.0
    c = float(np.percentile(v, percentile))
    if not c > 0:
        c = float(v.max())
    return c if c > 0 else 1.0


def _patch_curves(surface: "SplineSurface", steps: int) -> tuple[np.ndarray, np.ndarray]:
    """The images of the domain edges as polylines: points ``(E (steps+1), 3)``, segments."""
    tri = surface.triangulation
    t = np.linspace(0.0, 1.0, steps + 1)
    f = np.where(tri.edge_faces[:, 0] >= 0, tri.edge_faces[:, 0], tri.edge_faces[:, 1])
    k = np.where(tri.edge_faces[:, 0] >= 0, tri.edge_opposite[:, 0], tri.edge_opposite[:, 1])
    ne, m = f.size, t.size
    bary = np.zeros((ne, m, 3))
    rows = np.arange(ne)[:, None]
    cols = np.arange(m)[None, :]
    bary[rows, cols, ((k + 1) % 3)[:, None]] = 1.0 - t
    bary[rows, cols, ((k + 2) % 3)[:, None]] = t
    pts = surface.evaluate(np.repeat(f, m), bary.reshape(-1, 3))
    base = (np.arange(ne) * m)[:, None] + np.arange(m - 1)[None, :]
    seg = np.stack([base, base + 1], axis=-1).reshape(-1, 2)
    return pts, seg


def _wrap(lines: Sequence[str], chars: float) -> str:
    """Legend lines wrapped to about ``chars`` characters."""
    import textwrap

    width = max(int(chars), 20)
    return "\n".join(w for line in lines for w in textwrap.wrap(line, width, subsequent_indent="  "))


@lru_cache(maxsize=1)
def _net_edges() -> np.ndarray:
    """(45, 2) storage indices of the control-net edges of one patch."""
    from trispline.spline.index import DEGREE, index_of

    e = set()
    n = DEGREE
    for i in range(n, 0, -1):
        for j in range(n - i + 1):
            k = n - i - j
            a, b, c = index_of(i, j, k), index_of(i - 1, j + 1, k), index_of(i - 1, j, k + 1)
            e |= {tuple(sorted(x)) for x in ((a, b), (b, c), (c, a))}
    return np.array(sorted(e), np.int64)


def _fmt(x: float) -> str:
    return f"{x:.3g}"


def _scene(surface: "SplineSurface | None", mode: str, *, mesh: Any, view: View, backend: str,
           resolution: int | None, curvature: str, stripes: float, stripe_angle: float,
           patch_lines: bool | None, title: str | None) -> tuple[_Scene, dict]:
    """Build what to draw (backend independent) and the picture's statistics."""
    if surface is None:  # a data mesh alone
        V, F = _as_mesh(mesh)
        layer = _Layer("surface", V, F, color=_DATA_RGB, edges=F.shape[0] <= 60_000)
        return _Scene([layer], V, view, title or f"data mesh: {V.shape[0]} vertices, {F.shape[0]} triangles",
                      ["flat-shaded data triangles" + (" with edges" if layer.edges else "")]), \
            dict(vertices=int(V.shape[0]), triangles=int(F.shape[0]))
    _check_mode(mode)
    if curvature not in CURVATURES:
        raise RenderError(f"unknown curvature {curvature!r}: use one of {', '.join(CURVATURES)}")
    nf = surface.n_faces
    r = _auto_resolution(nf, backend) if resolution is None else int(resolution)
    data = None
    if mode == "deviation":
        data = _as_mesh(mesh) if mesh is not None else _data_mesh_of(surface)
        if data is None:
            raise RenderError("deviation needs a data mesh (--mesh DATA_MESH, or mesh=(V, F)); this surface "
                              "file stores no data vertices")
    s = sample_surface(surface, r, curvature=(mode == "curvature"))
    stats: dict[str, Any] = dict(patches=nf, resolution=r, samples=int(s.points.shape[0]),
                                 triangles=int(s.triangles.shape[0]))
    name = f"{nf} quintic patches"
    layer = _Layer("surface", s.points, s.triangles, normals=s.normals)
    layers = [layer]
    legend: list[str] = []
    bar = None
    if mode in ("shaded", "controlnet"):
        head = "shaded (analytic normals)" if mode == "shaded" else "control net over the shaded surface"
        legend.append(f"{head}; {r}x{r} samples per patch")
    elif mode == "zebra":
        light = zebra_light(s.points, view, stripes=stripes, angle=stripe_angle)
        t = stripe_function(s.points, s.normals, light)
        layer.stripes, layer.lit = t, False
        stats.update(stripe_spacing=light.spacing, stripes=float(stripes), stripe_angle=float(stripe_angle),
                     panel_distance=float(light.height - (s.points @ light.facing).max()))
        legend += [f"zebra: highlight lines of the analytic normals, {stripes:g} tube spacings per "
                   f"bounding-box diagonal (spacing {_fmt(light.spacing)}), tubes at {stripe_angle:g} deg",
                   "continuous stripes = C1; broken stripes = a kink"]
    elif mode == "curvature":
        vals = s.mean_curvature if curvature == "mean" else s.gaussian_curvature
        c = _symmetric_clim(vals, CURVATURE_PERCENTILE)
        layer.scalars, layer.clim, layer.cmap = vals, (-c, c), "RdBu_r"
        finite = vals[np.isfinite(vals)]
        label = "mean curvature H" if curvature == "mean" else "Gaussian curvature K"
        bar = ("RdBu_r", (-c, c), "H, 1/length" if curvature == "mean" else "K, 1/length^2")
        stats.update(curvature=curvature, clim=c, min=float(finite.min()) if finite.size else None,
                     max=float(finite.max()) if finite.size else None)
        legend += [f"{label} from the analytic 1st and 2nd derivatives ({'(k1+k2)/2' if curvature == 'mean' else 'k1 k2'})",
                   f"colour range +-{_fmt(c)} ({CURVATURE_PERCENTILE:g}th percentile of the absolute value); "
                   f"min {_fmt(stats['min'])}, max {_fmt(stats['max'])}"]
    elif mode == "deviation":
        d = deviation(s.points, *data)
        finite = d[np.isfinite(d)]
        m = float(np.abs(finite).max()) if finite.size else 0.0
        rms = float(np.sqrt(np.mean(finite**2))) if finite.size else 0.0
        diag = float(np.linalg.norm(data[0].max(0) - data[0].min(0)))
        c = m if m > 0 else 1.0
        layer.scalars, layer.clim, layer.cmap = d, (-c, c), "PuOr_r"
        bar = ("PuOr_r", (-c, c), "deviation")
        stats.update(max_abs=m, rms=rms, data_vertices=int(data[0].shape[0]), data_triangles=int(data[1].shape[0]),
                     relative_max=m / diag if diag > 0 else None)
        legend += ["deviation: signed distance surface -> data mesh (+ along the data face normal)",
                   f"max abs {_fmt(m)} ({_fmt(100 * m / diag) if diag > 0 else '?'}% of the diagonal), "
                   f"RMS {_fmt(rms)}"]
    if mode == "controlnet":
        # per patch (shared boundary points drawn once per patch: no global de-duplication)
        pts = np.asarray(surface.ctrl, np.float64).reshape(-1, 3)
        seg = (_net_edges()[None] + NCTRL * np.arange(nf)[:, None, None]).reshape(-1, 2)
        tri = surface.triangulation
        n_points = tri.n_vertices + 4 * tri.n_edges + 6 * tri.n_faces
        layer.color = (0.85, 0.88, 0.92)
        layers += [_Layer("lines", pts, seg, color=_NET_RGB, lit=False, width=1.0),
                   _Layer("points", pts, color=(0.1, 0.1, 0.1), lit=False, width=3.0)]
        stats.update(control_points=int(n_points))
        legend.append(f"{n_points} control points (V + 4E + 6F), 45 net segments per patch")
    draw_lines = (nf <= PATCH_LINES_MAX) if patch_lines is None else bool(patch_lines)
    if draw_lines and mode != "controlnet":
        cp, cs = _patch_curves(surface, max(r, 2))
        layers.append(_Layer("lines", cp, cs, color=(0.15, 0.15, 0.25), lit=False, width=0.6))
        legend.append("thin lines: patch boundaries")
    frame = s.points[np.isfinite(s.points).all(1)]
    return _Scene(layers, frame, view, title or f"{mode}: {name}", legend, bar), stats


# ============================================================================ framing
#: Normalised picture box the object is fitted into (left, right, bottom, top), with and without a colour bar.
_BOX = {False: (0.03, 0.97, 0.17, 0.90), True: (0.03, 0.80, 0.17, 0.90)}


def _frame(scene: _Scene, size: tuple[int, int]) -> tuple[np.ndarray, float]:
    """Camera focal point ``(3,)`` and parallel half-height fitting the scene into its box."""
    v = scene.view
    R, U, W = v.right, v.up, v.toward
    P = scene.frame if scene.frame.size else np.zeros((1, 3))
    x, y, z = P @ R, P @ U, P @ W
    x0, x1, y0, y1 = _BOX[scene.bar is not None]
    w, h = size
    aspect = w / h
    half_w = 0.5 * max(float(x.max() - x.min()), 1e-12)
    half_h = 0.5 * max(float(y.max() - y.min()), 1e-12)
    # the object spans (x1 - x0) of the width 2 * ps * aspect and (y1 - y0) of the height 2 * ps
    ps = max(half_h / (y1 - y0), half_w / ((x1 - x0) * aspect)) * 1.02
    cx, cy = 0.5 * (x.max() + x.min()), 0.5 * (y.max() + y.min())
    # shift so that the object's centre sits at the box centre
    bx, by = (x0 + x1) - 1.0, (y0 + y1) - 1.0  # box centre in [-1, 1] picture coordinates
    fx = cx - bx * ps * aspect
    fy = cy - by * ps
    focal = fx * R + fy * U + float(0.5 * (z.max() + z.min())) * W
    return focal, ps


# ============================================================================ pyvista
@contextmanager
def _quiet_vtk() -> Iterator[None]:
    """Silence VTK's logger and warning window (e.g. 'bad X server connection') for a render."""
    from vtkmodules.vtkCommonCore import vtkLogger, vtkObject

    old_level = vtkLogger.GetCurrentVerbosityCutoff()
    old_warn = vtkObject.GetGlobalWarningDisplay()
    vtkLogger.SetStderrVerbosity(vtkLogger.VERBOSITY_OFF)
    vtkObject.GlobalWarningDisplayOff()
    try:
        yield
    finally:
        vtkObject.SetGlobalWarningDisplay(old_warn)
        vtkLogger.SetStderrVerbosity(vtkLogger.ConvertToVerbosity(int(old_level)))


def _polydata(layer: _Layer, keep: np.ndarray | None = None):
    import pyvista as pv

    cells = layer.cells if keep is None else layer.cells[keep]
    if layer.kind == "points":
        return pv.PolyData(np.ascontiguousarray(layer.points))
    lead = np.full((cells.shape[0], 1), cells.shape[1], np.int64)
    arr = np.hstack([lead, cells]).ravel()
    if layer.kind == "lines":
        return pv.PolyData(np.ascontiguousarray(layer.points), lines=arr)
    poly = pv.PolyData(np.ascontiguousarray(layer.points), faces=arr)
    if layer.normals is not None:
        nrm = np.nan_to_num(layer.normals)
        poly.point_data["Normals"] = nrm
        poly.point_data.active_normals_name = "Normals"
    return poly


def _draw_pyvista(scenes: Sequence[_Scene], size: tuple[int, int]) -> np.ndarray:
    with _quiet_vtk():
        import pyvista as pv

        pl = pv.Plotter(off_screen=True, window_size=list(size), shape=(1, len(scenes)), border=False)
        try:
            pl.set_background(_BACKGROUND)
            sub_size = (size[0] / len(scenes), size[1])
            font = int(np.clip(sub_size[1] / 45, 8, 24))
            for col, sc in enumerate(scenes):
                pl.subplot(0, col)
                for layer in sc.layers:
                    _add_layer_pyvista(pl, layer, sc, col)
                pl.add_text(sc.title, position="upper_edge", font_size=font, color="black")
                if sc.legend:
                    small = max(7, int(font * 0.7))
                    legend = sc.legend if sub_size[1] >= 300 else sc.legend[:1]
                    pl.add_text(_wrap(legend, (sub_size[0] - 12) / (1.2 * small)), position=(6, 6),
                                font_size=small, color="black")
                focal, ps = _frame(sc, (int(sub_size[0]), int(sub_size[1])))
                cam = pl.camera
                cam.parallel_projection = True
                cam.focal_point = focal
                cam.position = focal + sc.view.toward * float(10.0 * ps + 1.0)
                cam.up = sc.view.up
                cam.parallel_scale = ps
                pl.renderer.ResetCameraClippingRange()
            img = pl.screenshot(return_img=True)
        finally:
            pl.close()
    return np.ascontiguousarray(img[..., :3], dtype=np.uint8)


def _add_layer_pyvista(pl, layer: _Layer, sc: _Scene, col: int) -> None:
    import pyvista as pv

    if layer.kind == "points":
        pl.add_mesh(_polydata(layer), color=layer.color, point_size=layer.width, style="points",
                    lighting=False, render_points_as_spheres=False)
        return
    if layer.kind == "lines":
        # lift the lines toward the camera (parallel projection: no shift on screen) so
        # that curves lying on the surface are not half hidden by it (z-fighting)
        P = sc.frame
        lift = 2e-3 * float(np.linalg.norm(P.max(0) - P.min(0))) if P.size else 0.0
        moved = _Layer("lines", layer.points + lift * sc.view.toward, layer.cells)
        pl.add_mesh(_polydata(moved), color=layer.color, line_width=layer.width, lighting=False)
        return
    light = dict(ambient=0.25, diffuse=0.75, specular=0.15, specular_power=20.0)
    if layer.stripes is not None:
        t = layer.stripes
        bad = ~np.isfinite(t)
        badtri = bad[layer.cells].any(1)
        good = ~badtri
        if good.any():
            poly = _polydata(layer, good)
            poly.active_texture_coordinates = np.column_stack([np.nan_to_num(t), np.zeros_like(t)])
            stripes = np.array([[_STRIPE_RGB[0], _STRIPE_RGB[1]]]) * 255
            tex = pv.Texture(stripes.astype(np.uint8))
            tex.repeat = True
            tex.interpolate = False
            pl.add_mesh(poly, texture=tex, lighting=False)
        if badtri.any():
            pl.add_mesh(_polydata(layer, badtri), color=_NAN_RGB, lighting=False)
        return
    poly = _polydata(layer)
    kw: dict[str, Any] = dict(lighting=layer.lit, show_edges=layer.edges, edge_color=(0.3, 0.3, 0.3),
                              line_width=0.5)
    if layer.lit:
        kw.update(light)
    if layer.normals is not None:
        kw["smooth_shading"] = True
    if layer.scalars is not None:
        poly.point_data["values"] = layer.scalars
        bar_title = sc.bar[2] + " " * col if sc.bar else "values"
        pl.add_mesh(poly, scalars="values", cmap=layer.cmap, clim=list(layer.clim), nan_color=_NAN_RGB,
                    show_scalar_bar=False, **kw)
        pl.add_scalar_bar(title=bar_title, n_labels=5, fmt="%.3g", vertical=True, position_x=0.84,
                          position_y=0.2, width=0.1, height=0.62, color="black",
                          title_font_size=int(np.clip(pl.window_size[1] / 40, 8, 24)),
                          label_font_size=int(np.clip(pl.window_size[1] / 48, 7, 20)))
    else:
        pl.add_mesh(poly, color=layer.color, **kw)


# ============================================================================ matplotlib
def _draw_matplotlib(scenes: Sequence[_Scene], size: tuple[int, int]) -> np.ndarray:
    from matplotlib import colormaps
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.cm import ScalarMappable
    from matplotlib.collections import LineCollection, PolyCollection
    from matplotlib.colors import Normalize
    from matplotlib.figure import Figure

    dpi = 100.0
    w, h = size
    fig = Figure(figsize=(w / dpi, h / dpi), dpi=dpi, facecolor=_BACKGROUND)
    FigureCanvasAgg(fig)
    n = len(scenes)
    sub = (w / n, h)
    font = float(np.clip(sub[1] / 38, 7, 28)) * 0.75
    for col, sc in enumerate(scenes):
        ax = fig.add_axes((col / n, 0.0, 1.0 / n, 1.0))
        ax.set_axis_off()
        focal, ps = _frame(sc, (int(sub[0]), int(sub[1])))
        R, U, W = sc.view.right, sc.view.up, sc.view.toward
        aspect = sub[0] / sub[1]
        fx, fy = focal @ R, focal @ U
        ax.set_xlim(fx - ps * aspect, fx + ps * aspect)
        ax.set_ylim(fy - ps, fy + ps)
        key = np.array([0.3, 0.4, 1.0]) @ np.stack([R, U, W])
        key /= np.linalg.norm(key)
        for layer in sc.layers:
            P = layer.points
            x, y, z = P @ R, P @ U, P @ W
            if layer.kind == "points":
                ax.scatter(x, y, s=layer.width, c=[layer.color], linewidths=0, zorder=3)
                continue
            if layer.kind == "lines":
                seg = np.stack([np.column_stack([x, y])[layer.cells[:, 0]], np.column_stack([x, y])[layer.cells[:, 1]]], 1)
                ax.add_collection(LineCollection(seg, colors=[layer.color], linewidths=layer.width * 0.7, zorder=2))
                continue
            T = layer.cells
            ok = np.isfinite(P).all(1)[T].all(1)
            T = T[ok]
            order = np.argsort(z[T].mean(1), kind="stable")  # far (small z) first
            T = T[order]
            if layer.stripes is not None:
                tm = np.nanmean(layer.stripes[T], axis=1) if T.size else np.zeros(0)
                pat = stripe_pattern(tm)
                colors = np.where((pat == 0)[:, None], _STRIPE_RGB[0], _STRIPE_RGB[1])
                colors[pat < 0] = _NAN_RGB
            else:
                if layer.scalars is not None:
                    sm = np.nanmean(layer.scalars[T], axis=1) if T.size else np.zeros(0)
                    cmap = colormaps[layer.cmap]
                    colors = cmap(Normalize(*layer.clim)(sm))[:, :3]
                    colors[~np.isfinite(sm)] = _NAN_RGB
                else:
                    colors = np.tile(np.asarray(layer.color, float), (T.shape[0], 1))
                if layer.lit:
                    if layer.normals is not None:
                        fn = np.nanmean(layer.normals[T], axis=1)
                    else:
                        Q = P[T]
                        fn = np.cross(Q[:, 1] - Q[:, 0], Q[:, 2] - Q[:, 0])
                    fn /= np.maximum(np.linalg.norm(fn, axis=1, keepdims=True), 1e-300)
                    lam = np.abs(np.nan_to_num(fn @ key))
                    colors = np.clip(colors * (0.3 + 0.7 * lam)[:, None] + 0.15 * lam[:, None] ** 20, 0, 1)
            xy = np.column_stack([x, y])[T]
            ec = (0.3, 0.3, 0.3) if layer.edges else colors
            ax.add_collection(PolyCollection(xy, facecolors=colors, edgecolors=ec,
                                             linewidths=0.3 if layer.edges else 0.15, zorder=1))
        ax.text(0.5, 0.985, sc.title, transform=ax.transAxes, ha="center", va="top", fontsize=font)
        if sc.legend:
            ax.text(0.01, 0.01, _wrap(sc.legend if sub[1] >= 300 else sc.legend[:1], sub[0] / (0.6 * font * 0.62 * 1.39)), transform=ax.transAxes, ha="left", va="bottom",
                    fontsize=font * 0.62)
        if sc.bar is not None:
            cmap, clim, label = sc.bar
            cax = fig.add_axes(((col + 0.86) / n, 0.22, 0.03 / n, 0.6))
            cb = fig.colorbar(ScalarMappable(Normalize(*clim), colormaps[cmap]), cax=cax)
            cb.set_label(label, fontsize=font * 0.7)
            cb.ax.tick_params(labelsize=font * 0.6)
    fig.canvas.draw()
    img = np.asarray(fig.canvas.buffer_rgba())[..., :3]
    return np.ascontiguousarray(img, dtype=np.uint8)


# ============================================================================ public
def _backend_choice(backend: str | None) -> str:
    b = backend or os.environ.get("TRISPLINE_RENDER_BACKEND", "auto") or "auto"
    b = b.strip().lower()
    if b not in BACKENDS:
        raise RenderError(f"unknown render backend {b!r}: use one of {', '.join(BACKENDS)}")
    return b


def _pyvista_usable() -> str | None:
    """None if PyVista/VTK import, else the reason."""
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            import pyvista  # noqa: F401
            import vtkmodules.vtkCommonCore  # noqa: F401
    except Exception as exc:  # noqa: BLE001 - any import failure means: use the fallback
        return f"{type(exc).__name__}: {exc}"
    return None


def draw_panels(panels: Sequence[Panel], *, view: "str | View | Sequence[float]" = "iso",
                size: "str | Sequence[int]" = (800, 600), backend: str | None = None) -> Picture:
    """Draw several panels side by side into one picture of ``size`` (width, height).

    Returns a :class:`Picture`; its ``stats`` has one dict per panel under ``"panels"``.
    """
    if not panels:
        raise RenderError("nothing to draw: no panels")
    size = parse_size(size)
    want = _backend_choice(backend)
    reason = None if want == "matplotlib" else _pyvista_usable()
    if want == "pyvista" and reason is not None:
        raise RenderError(f"the pyvista backend is not usable here ({reason}); install trispline[render] "
                          f"or use backend='matplotlib'")
    use = "matplotlib" if want == "matplotlib" or reason is not None else "pyvista"
    v = parse_view(view)
    scenes, stats = [], []
    for p in panels:
        opts = dict(p.options)
        pv_view = parse_view(opts.pop("view", v))
        sc, st = _scene(p.surface, p.mode, mesh=p.mesh, view=pv_view, backend=use,
                        resolution=opts.pop("resolution", None), curvature=opts.pop("curvature", "mean"),
                        stripes=float(opts.pop("stripes", 12.0)), stripe_angle=float(opts.pop("stripe_angle", 45.0)),
                        patch_lines=opts.pop("patch_lines", None), title=p.title)
        if opts:
            raise RenderError(f"unknown render options: {', '.join(sorted(opts))}")
        scenes.append(sc)
        stats.append(st)
    legend = tuple(line for sc in scenes for line in sc.legend)
    if use == "pyvista":
        try:
            img = _draw_pyvista(scenes, size)
            return Picture(img, "pyvista", legend, dict(panels=stats))
        except Exception as exc:  # noqa: BLE001 - VTK failed at run time (no OpenGL context, ...)
            if want == "pyvista":
                raise
            reason = f"{type(exc).__name__}: {exc}"
    if reason is not None:
        warnings.warn(f"PyVista/VTK rendering is not available ({reason.splitlines()[0][:200]}); "
                      f"drawing with matplotlib instead", RenderFallbackWarning, stacklevel=2)
    img = _draw_matplotlib(scenes, size)
    return Picture(img, "matplotlib", legend, dict(panels=stats))


def draw(surface: "SplineSurface", mode: str = "shaded", *, mesh: Any = None,
         view: "str | View | Sequence[float]" = "iso", size: "str | Sequence[int]" = (800, 600),
         resolution: int | None = None, curvature: str = "mean", stripes: float = 12.0,
         stripe_angle: float = 45.0, patch_lines: bool | None = None, title: str | None = None,
         backend: str | None = None) -> Picture:
    """Draw one picture of ``surface`` (see :func:`render`); returns a :class:`Picture`."""
    _check_mode(mode)
    pic = draw_panels([Panel(surface, mode, mesh, title, dict(
        resolution=resolution, curvature=curvature, stripes=stripes, stripe_angle=stripe_angle,
        patch_lines=patch_lines))], view=view, size=size, backend=backend)
    return Picture(pic.image, pic.backend, pic.legend, pic.stats["panels"][0])


def write_png(image: np.ndarray, path: str | os.PathLike) -> Path:
    """Write ``image (h, w, 3) uint8`` to a PNG file atomically."""
    from PIL import Image

    from ..io.export import check_export_path

    check_export_path(path, (".png",))
    buf = io.BytesIO()
    Image.fromarray(np.asarray(image, np.uint8)).save(buf, format="PNG")
    with atomic_path(path) as tmp:
        tmp.write_bytes(buf.getvalue())
    return Path(path)


def render(surface: "SplineSurface", path: str | os.PathLike, mode: str = "shaded", *, mesh: Any = None,
           view: "str | View | Sequence[float]" = "iso", size: "str | Sequence[int]" = (800, 600),
           resolution: int | None = None, curvature: str = "mean", stripes: float = 12.0,
           stripe_angle: float = 45.0, patch_lines: bool | None = None, title: str | None = None,
           backend: str | None = None) -> Path:
    """Render ``surface`` to the PNG file ``path`` (written atomically); returns the path.

    Parameters
    ----------
    mode : one of :data:`MODES`
    mesh : data mesh for ``deviation``: ``(V, F)``, a trimesh or a file path
        (default: the fit's data vertices stored in the surface file)
    view : ``"iso" | "top" | "front" | "side"``, ``"azimuth,elevation"`` or a pair (degrees)
    size : ``(width, height)`` or ``"WxH"`` in pixels
    resolution : samples per patch edge (default: about 1.7M triangles, at most 8)
    curvature : ``"mean"`` or ``"gaussian"`` (mode ``curvature``)
    stripes, stripe_angle : zebra tube count per bounding-box diagonal and direction (degrees)
    patch_lines : draw patch boundaries (default: up to :data:`PATCH_LINES_MAX` patches)
    backend : ``"auto"`` (PyVista, else matplotlib), ``"pyvista"`` or ``"matplotlib"``
    """
    from ..io.export import check_export_path

    check_export_path(path, (".png",))
    pic = draw(surface, mode, mesh=mesh, view=view, size=size, resolution=resolution, curvature=curvature,
               stripes=stripes, stripe_angle=stripe_angle, patch_lines=patch_lines, title=title, backend=backend)
    return write_png(pic.image, path)


def render_panels(panels: Sequence[Panel], path: str | os.PathLike, *,
                  view: "str | View | Sequence[float]" = "iso", size: "str | Sequence[int]" = (1200, 500),
                  backend: str | None = None) -> Path:
    """Render several :class:`Panel` side by side to the PNG file ``path`` (atomically)."""
    from ..io.export import check_export_path

    check_export_path(path, (".png",))
    return write_png(draw_panels(panels, view=view, size=size, backend=backend).image, path)
