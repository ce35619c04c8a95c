"""What a picture shows, independent of the backend that draws it: layers, panels, legends.

    scene, stats = panel_scene(Panel(surface, "zebra"), parse_view("iso"), backend="pyvista")

A :class:`Scene` is a list of :class:`Layer` (shaded triangles, line segments or
points, each with its colouring) plus the view, the title, the legend lines and the
colour bar; :mod:`.backends` turn scenes into pixels. One builder per mode adds
its colouring and its statistics (stripe spacing, curvature range, deviation).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from trispline.spline.index import DEGREE, NCTRL, lattice_edges

from ..errors import RenderError
from .deviation import as_mesh, deviation, stored_data_mesh
from .geometry import CURVATURES
from .sampling import SurfaceSample, auto_resolution, patch_curves, sample_surface
from .view import View, parse_view
from .zebra import stripe_function, zebra_light

if TYPE_CHECKING:  # pragma: no cover
    from trispline.spline.surface import SplineSurface

__all__ = [
    "MODES", "PATCH_LINES_MAX", "CURVATURE_PERCENTILE", "SURFACE_RGB", "DATA_RGB", "NET_RGB", "BACKGROUND",
    "NAN_RGB", "STRIPE_RGB", "Layer", "Scene", "Panel", "Picture", "check_mode", "panel_scene",
    "surface_scene", "wrap_legend",
]

MODES = ("shaded", "zebra", "curvature", "deviation", "controlnet")
#: Patch boundaries are drawn by default up to this many patches.
PATCH_LINES_MAX = 2000
#: Robust colour range of curvature maps: this percentile of |value|.
CURVATURE_PERCENTILE = 98.0

#: Colours (RGB in [0, 1]) of the surface, a data mesh, the control net, the background,
#: undefined values, and the white and black zebra stripes; both backends draw with them.
SURFACE_RGB = (0.55, 0.70, 0.95)
DATA_RGB = (0.80, 0.78, 0.72)
NET_RGB = (0.75, 0.12, 0.10)
BACKGROUND = (1.0, 1.0, 1.0)
NAN_RGB = (0.6, 0.6, 0.6)
STRIPE_RGB = ((0.97, 0.97, 0.97), (0.08, 0.08, 0.08))


@dataclass
class Layer:
    """One thing to draw: ``points (m, 3)`` and ``cells`` (``(t, 3)`` triangles or ``(s, 2)`` segments).

    A ``"surface"`` is coloured by ``scalars (m,)`` through ``cmap``/``clim``, by
    ``stripes (m,)`` (the highlight coordinate) or in ``color``; ``normals (m, 3)``
    smooth its shading. ``width`` is the line width or point size.
    """

    kind: str                      # "surface" | "lines" | "points"
    points: np.ndarray
    cells: np.ndarray | None = None
    normals: np.ndarray | None = None
    color: tuple = SURFACE_RGB
    scalars: np.ndarray | None = None
    stripes: np.ndarray | None = None
    cmap: str = "RdBu_r"
    clim: tuple[float, float] = (0.0, 1.0)
    lit: bool = True
    edges: bool = False
    width: float = 1.0


@dataclass
class Scene:
    """A panel's layers, the ``frame (m, 3)`` points to fit in it, view, title, legend, colour bar."""

    layers: list[Layer]
    frame: np.ndarray
    view: View
    title: str
    legend: list[str]
    bar: tuple[str, tuple[float, float], str] | None = None  # cmap, clim, label


@dataclass
class Panel:
    """One picture of a side-by-side figure (:func:`~trispline.fit.render.draw_panels`).

    Give ``surface`` (any of :data:`MODES`) or only ``mesh`` (a data mesh ``(V, F)``,
    drawn flat with its edges, e.g. the scan next to its fit). ``options`` go to
    :func:`~trispline.fit.render.draw` (``stripes``, ``stripe_angle``, ``curvature``,
    ``resolution``, ``patch_lines``, ``view``).
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


_PANEL_OPTIONS = ("view", "resolution", "curvature", "stripes", "stripe_angle", "patch_lines")


def check_mode(mode: str) -> str:
    """``mode`` if it is one of :data:`MODES`; else a RenderError."""
    if mode not in MODES:
        raise RenderError(f"unknown mode {mode!r}: use one of {', '.join(MODES)}")
    return mode


def wrap_legend(lines: list[str] | tuple[str, ...], chars: float) -> str:
    """Legend lines wrapped to about ``chars`` characters."""
    import textwrap

    width = max(int(chars), 20)
    return "\n".join(w for line in lines for w in textwrap.wrap(line, width, subsequent_indent="  "))


def _fmt(x: float) -> str:
    return f"{x:.3g}"


def _symmetric_clim(values: np.ndarray, percentile: float) -> float:
    """Half-width of a colour range symmetric about 0: the ``percentile`` of ``|values (n,)|``."""
    v = np.abs(values[np.isfinite(values)])
    if v.size == 0:
        return 1.0
    c = float(np.percentile(v, percentile))
    if not c > 0:
        c = float(v.max())
    return c if c > 0 else 1.0


def panel_scene(panel: Panel, view: View, backend: str) -> tuple[Scene, dict]:
    """The scene and statistics of ``panel``; ``view`` unless its options name one."""
    opts = dict(panel.options)
    unknown = sorted(set(opts) - set(_PANEL_OPTIONS))
    if unknown:
        raise RenderError(f"unknown render options: {', '.join(unknown)}")
    own_view = parse_view(opts.pop("view", view))
    if panel.surface is None:
        return _mesh_scene(panel.mesh, own_view, panel.title)
    return surface_scene(panel.surface, panel.mode, mesh=panel.mesh, view=own_view, backend=backend,
                         title=panel.title, **opts)


def _mesh_scene(mesh: Any, view: View, title: str | None) -> tuple[Scene, dict]:
    """A data mesh alone, flat-shaded with its edges (up to 60k triangles)."""
    V, F = as_mesh(mesh)
    layer = Layer("surface", V, F, color=DATA_RGB, edges=F.shape[0] <= 60_000)
    scene = Scene([layer], V, view, title or f"data mesh: {V.shape[0]} vertices, {F.shape[0]} triangles",
                  ["flat-shaded data triangles" + (" with edges" if layer.edges else "")])
    return scene, dict(vertices=int(V.shape[0]), triangles=int(F.shape[0]))


def surface_scene(surface: "SplineSurface", mode: str, *, mesh: Any = None, view: View, backend: str,
                  resolution: int | None = None, curvature: str = "mean", stripes: float = 12.0,
                  stripe_angle: float = 45.0, patch_lines: bool | None = None, title: str | None = None
                  ) -> tuple[Scene, dict]:
    """The scene of ``surface`` in ``mode`` and the picture's statistics (see ``draw``)."""
    check_mode(mode)
    if curvature not in CURVATURES:
        raise RenderError(f"unknown curvature {curvature!r}: use one of {', '.join(CURVATURES)}")
    nf = surface.n_faces
    r = auto_resolution(nf, backend) if resolution is None else int(resolution)
    data = _deviation_mesh(surface, mesh) if mode == "deviation" else None
    s = sample_surface(surface, r, curvature=(mode == "curvature"))
    stats: dict[str, Any] = dict(patches=nf, resolution=r, samples=int(s.points.shape[0]),
                                 triangles=int(s.triangles.shape[0]))
    frame = s.points[np.isfinite(s.points).all(1)]
    scene = Scene([Layer("surface", s.points, s.triangles, normals=s.normals)], frame, view,
                  title or f"{mode}: {nf} quintic patches", [])
    if mode in ("shaded", "controlnet"):
        head = "shaded (analytic normals)" if mode == "shaded" else "control net over the shaded surface"
        scene.legend.append(f"{head}; {r}x{r} samples per patch")
    elif mode == "zebra":
        _zebra(scene, s, float(stripes), float(stripe_angle), stats)
    elif mode == "curvature":
        _curvature(scene, s, curvature, stats)
    else:
        _deviation(scene, s, data, stats)
    if mode == "controlnet":
        _control_net(scene, surface, stats)
    elif (nf <= PATCH_LINES_MAX) if patch_lines is None else bool(patch_lines):
        cp, cs = patch_curves(surface, max(r, 2))
        scene.layers.append(Layer("lines", cp, cs, color=(0.15, 0.15, 0.25), lit=False, width=0.6))
        scene.legend.append("thin lines: patch boundaries")
    return scene, stats


def _deviation_mesh(surface: "SplineSurface", mesh: Any) -> tuple[np.ndarray, np.ndarray]:
    """The data mesh to measure against: ``mesh``, else the one stored with the fit."""
    data = as_mesh(mesh) if mesh is not None else stored_data_mesh(surface)
    if data is None:
        raise RenderError("deviation needs a data mesh (--mesh DATA_MESH, or mesh=(V, F)); this surface "
                          "file stores no data vertices")
    return data


def _zebra(scene: Scene, s: SurfaceSample, stripes: float, angle: float, stats: dict) -> None:
    """Colour by highlight lines, unlit (the stripes are the shading)."""
    light = zebra_light(s.points, scene.view, stripes=stripes, angle=angle)
    layer = scene.layers[0]
    layer.stripes, layer.lit = stripe_function(s.points, s.normals, light), False
    stats.update(stripe_spacing=light.spacing, stripes=stripes, stripe_angle=angle,
                 panel_distance=float(light.height - (s.points @ light.facing).max()))
    scene.legend += [f"zebra: highlight lines of the analytic normals, {stripes:g} tube spacings per "
                     f"bounding-box diagonal (spacing {_fmt(light.spacing)}), tubes at {angle:g} deg",
                     "continuous stripes = C1; broken stripes = a kink"]


def _curvature(scene: Scene, s: SurfaceSample, kind: str, stats: dict) -> None:
    """Colour by mean or Gaussian curvature, range symmetric at :data:`CURVATURE_PERCENTILE`."""
    vals = s.mean_curvature if kind == "mean" else s.gaussian_curvature
    c = _symmetric_clim(vals, CURVATURE_PERCENTILE)
    layer = scene.layers[0]
    layer.scalars, layer.clim, layer.cmap = vals, (-c, c), "RdBu_r"
    finite = vals[np.isfinite(vals)]
    label = "mean curvature H" if kind == "mean" else "Gaussian curvature K"
    scene.bar = ("RdBu_r", (-c, c), "H, 1/length" if kind == "mean" else "K, 1/length^2")
    stats.update(curvature=kind, clim=c, min=float(finite.min()) if finite.size else None,
                 max=float(finite.max()) if finite.size else None)
    scene.legend += [f"{label} from the analytic 1st and 2nd derivatives ({'(k1+k2)/2' if kind == 'mean' else 'k1 k2'})",
                     f"colour range +-{_fmt(c)} ({CURVATURE_PERCENTILE:g}th percentile of the absolute value); "
                     f"min {_fmt(stats['min'])}, max {_fmt(stats['max'])}"]


def _deviation(scene: Scene, s: SurfaceSample, data: tuple[np.ndarray, np.ndarray], stats: dict) -> None:
    """Colour by the signed distance to the data mesh, range symmetric at the largest |distance|."""
    d = deviation(s.points, *data)
    finite = d[np.isfinite(d)]
    m = float(np.abs(finite).max()) if finite.size else 0.0
    rms = float(np.sqrt(np.mean(finite**2))) if finite.size else 0.0
    diag = float(np.linalg.norm(data[0].max(0) - data[0].min(0)))
    c = m if m > 0 else 1.0
    layer = scene.layers[0]
    layer.scalars, layer.clim, layer.cmap = d, (-c, c), "PuOr_r"
    scene.bar = ("PuOr_r", (-c, c), "deviation")
    stats.update(max_abs=m, rms=rms, data_vertices=int(data[0].shape[0]), data_triangles=int(data[1].shape[0]),
                 relative_max=m / diag if diag > 0 else None)
    scene.legend += ["deviation: signed distance surface -> data mesh (+ along the data face normal)",
                     f"max abs {_fmt(m)} ({_fmt(100 * m / diag) if diag > 0 else '?'}% of the diagonal), "
                     f"RMS {_fmt(rms)}"]


def _control_net(scene: Scene, surface: "SplineSurface", stats: dict) -> None:
    """The control points and net lines of every patch over a pale surface.

    Shared boundary points are drawn once per patch (no global de-duplication).
    """
    nf = surface.n_faces
    pts = np.asarray(surface.ctrl, np.float64).reshape(-1, 3)
    seg = (lattice_edges(DEGREE)[None] + NCTRL * np.arange(nf)[:, None, None]).reshape(-1, 2)
    tri = surface.triangulation
    n_points = tri.n_vertices + 4 * tri.n_edges + 6 * tri.n_faces
    scene.layers[0].color = (0.85, 0.88, 0.92)
    scene.layers += [Layer("lines", pts, seg, color=NET_RGB, lit=False, width=1.0),
                     Layer("points", pts, color=(0.1, 0.1, 0.1), lit=False, width=3.0)]
    stats.update(control_points=int(n_points))
    scene.legend.append(f"{n_points} control points (V + 4E + 6F), {lattice_edges(DEGREE).shape[0]} net "
                        f"segments per patch")
