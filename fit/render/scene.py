"""What a picture shows, independent of the backend that draws it: layers, panels, legends.

    scene, stats = panel_scene(Panel(surface, "zebra"), "auto", backend="pyvista", size=(800, 600))

A :class:`Scene` is a list of :class:`Layer` (shaded triangles, line segments or
points, each with its colouring) plus the view, the title, the legend lines and the
colour bar; :mod:`.backends` turn scenes into pixels. One builder per mode adds
its colouring and its statistics (stripe count and spacing, curvature range,
deviation). Lengths are in the surface's own coordinates, called "model units".
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Any

import numpy as np

from trispline.spline.index import DEGREE, NCTRL, lattice_edges

from ..errors import RenderError
from .deviation import as_mesh, deviation, stored_data_mesh
from .geometry import CURVATURES
from .sampling import SurfaceSample, auto_resolution, patch_curves, reference_sample, sample_surface
from .view import AUTO, View, check_view, frame, resolve_view
from .zebra import MIN_STRIPE_PIXELS, STRIPE_AREA_FRACTION, auto_stripes, stripe_function, zebra_light

if TYPE_CHECKING:  # pragma: no cover
    from trispline.spline.surface import SplineSurface

__all__ = [
    "MODES", "PATCH_LINES_MAX", "CURVATURE_PERCENTILE", "UNIT", "SURFACE_RGB", "BACK_RGB", "DATA_RGB", "NET_RGB",
    "BACKGROUND", "NAN_RGB", "STRIPE_RGB", "CAPTION_RGB", "Layer", "Scene", "Panel", "Picture", "check_mode",
    "panel_view", "panel_scene", "surface_scene", "centred", "wrap_legend",
]

MODES = ("shaded", "zebra", "curvature", "deviation", "controlnet")
#: Patch boundaries are drawn by default up to this many patches.
PATCH_LINES_MAX = 2000
#: Robust colour range of curvature maps: this percentile of |value| on the reference sample.
CURVATURE_PERCENTILE = 98.0
#: How legends name the surface's length unit (whatever its coordinates are in).
UNIT = "model unit"

#: Colours (RGB in [0, 1]) of the surface's front (the side its normal points to) and
#: back (shaded mode), a data mesh, the control net, the background, undefined values,
#: the white and black zebra stripes and the caption; both backends draw with them.
SURFACE_RGB = (0.55, 0.70, 0.95)
BACK_RGB = (0.85, 0.62, 0.42)
DATA_RGB = (0.80, 0.78, 0.72)
NET_RGB = (0.75, 0.12, 0.10)
BACKGROUND = (1.0, 1.0, 1.0)
NAN_RGB = (0.6, 0.6, 0.6)
STRIPE_RGB = ((0.97, 0.97, 0.97), (0.08, 0.08, 0.08))
CAPTION_RGB = (0.35, 0.35, 0.35)


@dataclass
class Layer:
    """One thing to draw: ``points (m, 3)`` and ``cells`` (``(t, 3)`` triangles or ``(s, 2)`` segments).

    A ``"surface"`` is coloured by ``scalars (m,)`` through ``cmap``/``clim``, by
    ``stripes (m,)`` (the highlight coordinate) or in ``color`` (``back``, if given, on
    triangles seen from behind); ``normals (m, 3)`` smooth its shading. ``width`` is
    the line width or point size.
    """

    kind: str                      # "surface" | "lines" | "points"
    points: np.ndarray
    cells: np.ndarray | None = None
    normals: np.ndarray | None = None
    color: tuple = SURFACE_RGB
    back: tuple | None = None
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
    ``resolution``, ``patch_lines``, ``view``: this panel's own view).
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


def centred(sc: Scene) -> Scene:
    """``sc`` moved to its frame's centre: what a backend draws in (VTK's 32-bit floats kept 0.25 m of a tile at
    UTM's 4e6 m, and none of its zebra stripes); a parallel camera fitted to the frame does not see the move."""
    centre = 0.5 * (sc.frame.min(0) + sc.frame.max(0)) if sc.frame.size else np.zeros(3)
    return replace(sc, frame=sc.frame - centre, layers=[replace(layer, points=layer.points - centre) for layer in sc.layers])


def wrap_legend(lines: list[str] | tuple[str, ...], chars: float) -> str:
    """Legend lines wrapped to about ``chars`` characters."""
    import textwrap

    width = max(int(chars), 20)
    return "\n".join(w for line in lines for w in textwrap.wrap(line, width, subsequent_indent="  "))


def _fmt(x: float | None) -> str:
    """``x`` to 3 digits; ``n/a`` where there is no finite value (a surface with no defined curvature)."""
    return f"{x:.3g}" if x is not None and np.isfinite(x) else "n/a"


def _symmetric_clim(values: np.ndarray, percentile: float) -> float:
    """Half-width of a colour range symmetric about 0: the ``percentile`` of ``|values (n,)|``."""
    v = np.abs(values[np.isfinite(values)])
    if v.size == 0:
        return 1.0
    c = float(np.percentile(v, percentile))
    if not c > 0:
        c = float(v.max())
    return c if c > 0 else 1.0


def panel_view(panel: Panel, view: "str | View") -> View:
    """``view`` as a :class:`View`; ``"auto"`` faces the panel's surface (its reference sample) or mesh."""
    v = check_view(view)
    if not isinstance(v, str):
        return v
    if panel.surface is None:
        return resolve_view(AUTO, *as_mesh(panel.mesh))
    ref = reference_sample(panel.surface, curvature=False)
    return resolve_view(AUTO, ref.points, ref.triangles)


def panel_scene(panel: Panel, view: "str | View", backend: str, size: tuple[int, int], *,
                auto: bool = False, stripes: float | None = None) -> tuple[Scene, dict]:
    """The scene and statistics of ``panel`` drawn ``size = (width, height)`` pixels large.

    Seen from ``view`` (a :class:`View` or ``"auto"``) unless the panel's options name
    one; ``auto`` says that ``view`` was chosen automatically (reported in the stats).
    ``stripes``: the automatic zebra stripe count another panel chose, used instead of
    this panel's own (so that side-by-side panels compare alike).
    """
    opts = dict(panel.options)
    unknown = sorted(set(opts) - set(_PANEL_OPTIONS))
    if unknown:
        raise RenderError(f"unknown render options: {', '.join(unknown)}")
    spec = check_view(opts.pop("view", view))
    own = panel_view(panel, spec)
    auto = spec == AUTO or (auto and "view" not in panel.options)
    if panel.surface is None:
        scene, stats = _mesh_scene(panel.mesh, own, panel.title)
    else:
        scene, stats = surface_scene(panel.surface, panel.mode, mesh=panel.mesh, view=own, backend=backend,
                                     size=size, title=panel.title, auto_stripes=stripes, **opts)
    stats["view"] = dict(azimuth=own.azimuth, elevation=own.elevation, roll=own.roll, auto=auto)
    return scene, stats


def _mesh_scene(mesh: Any, view: View, title: str | None) -> tuple[Scene, dict]:
    """A data mesh alone, flat-shaded with its edges (up to 60k triangles)."""
    V, F = as_mesh(mesh)
    layer = Layer("surface", V, F, color=DATA_RGB, edges=F.shape[0] <= 60_000)
    scene = Scene([layer], V, view, title or f"data mesh: {V.shape[0]} vertices, {F.shape[0]} triangles",
                  ["flat-shaded data triangles" + (" with edges" if layer.edges else "")])
    return scene, dict(vertices=int(V.shape[0]), triangles=int(F.shape[0]))


def surface_scene(surface: "SplineSurface", mode: str, *, mesh: Any = None, view: View, backend: str,
                  size: tuple[int, int], resolution: int | None = None, curvature: str = "mean",
                  stripes: float | None = None, stripe_angle: float = 45.0, patch_lines: bool | None = None,
                  title: str | None = None, auto_stripes: float | None = None) -> tuple[Scene, dict]:
    """The scene of ``surface`` in ``mode`` seen from ``view``, ``size`` pixels large, and its statistics.

    The options are those of :func:`~trispline.fit.render.draw`; ``auto_stripes`` is the
    count to use when ``stripes`` is None (None: this picture's own, :func:`.zebra.auto_stripes`).
    """
    check_mode(mode)
    if curvature not in CURVATURES:
        raise RenderError(f"unknown curvature {curvature!r}: use one of {', '.join(CURVATURES)}")
    nf = surface.n_faces
    r = auto_resolution(nf, backend) if resolution is None else int(resolution)
    data = _deviation_mesh(surface, mesh) if mode == "deviation" else None
    s = sample_surface(surface, r, curvature=(mode == "curvature"))
    stats: dict[str, Any] = dict(patches=nf, resolution=r, samples=int(s.points.shape[0]),
                                 triangles=int(s.triangles.shape[0]))
    frame_points = s.points[np.isfinite(s.points).all(1)]
    scene = Scene([Layer("surface", s.points, s.triangles, normals=s.normals)], frame_points, view,
                  title or f"{mode}: {nf} quintic patches", [])
    if mode in ("shaded", "controlnet"):
        head = "shaded (analytic normals)" if mode == "shaded" else "control net over the shaded surface"
        if mode == "shaded":
            scene.layers[0].back = BACK_RGB
            head += ", blue front, tan back"
        scene.legend.append(f"{head}; {r}x{r} samples per patch")
    elif mode == "zebra":
        _zebra(scene, s, size, stripes, auto_stripes, float(stripe_angle), stats)
    elif mode == "curvature":
        _curvature(scene, s, reference_sample(surface), curvature, stats)
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
        why = ("it approximates a scan: give that scan" if "approx_scan_vertices" in surface.extras
               else "this surface file stores no usable data vertices (none, or malformed)")
        raise RenderError(f"deviation needs a data mesh (--mesh DATA_MESH, or mesh=(V, F)); {why}")
    return data


def _zebra(scene: Scene, s: SurfaceSample, size: tuple[int, int], stripes: float | None, shared: float | None,
           angle: float, stats: dict) -> None:
    """Colour by highlight lines, unlit (the stripes are the shading); ``stripes`` None: automatic
    (``shared``, if given, else this picture's :func:`.zebra.auto_stripes`)."""
    _, half_height = frame(scene.frame, scene.view, size)
    count, width_one = auto_stripes(s.points, s.normals, s.triangles, scene.view, size[1] / (2 * half_height), angle)
    auto = stripes is None
    stripes = float(stripes) if not auto else count if shared is None else float(shared)
    light = zebra_light(s.points, scene.view, stripes=stripes, angle=angle)
    layer = scene.layers[0]
    layer.stripes, layer.lit = stripe_function(s.points, s.normals, light), False
    pixels = width_one / stripes
    stats.update(stripe_spacing=light.spacing, stripes=stripes, stripes_auto=auto, stripe_pixels=pixels,
                 stripe_angle=angle, panel_distance=float(light.height - (s.points @ light.facing).max()))
    how = "automatic" if auto else "set"
    scene.legend += ["zebra (highlight lines of the normals): broken stripes = a kink",
                     f"{stripes:g} stripe pairs per diagonal ({how}), >= {pixels:.3g} px on "
                     f"{100 * STRIPE_AREA_FRACTION:g}% of the area"]
    if pixels < MIN_STRIPE_PIXELS:
        scene.legend.append(f"narrower than {MIN_STRIPE_PIXELS:g} px: stripes alias (fewer stripes, larger picture)")


def _curvature(scene: Scene, s: SurfaceSample, ref: SurfaceSample, kind: str, stats: dict) -> None:
    """Colour by mean or Gaussian curvature, range symmetric at :data:`CURVATURE_PERCENTILE` of
    the reference sample ``ref`` (so that it does not change with the picture's resolution)."""
    vals = s.mean_curvature if kind == "mean" else s.gaussian_curvature
    ref_vals = ref.mean_curvature if kind == "mean" else ref.gaussian_curvature
    c = _symmetric_clim(ref_vals, CURVATURE_PERCENTILE)
    layer = scene.layers[0]
    layer.scalars, layer.clim, layer.cmap = vals, (-c, c), "RdBu_r"
    finite = ref_vals[np.isfinite(ref_vals)]
    symbol, unit = ("H", f"1/{UNIT}") if kind == "mean" else ("K", f"1/{UNIT}^2")
    label = "mean curvature H" if kind == "mean" else "Gaussian curvature K"
    scene.bar = ("RdBu_r", (-c, c), f"{symbol} [{unit}]")
    per_patch = (ref.resolution + 1) * (ref.resolution + 2) // 2
    stats.update(curvature=kind, clim=c, unit=unit, percentile=CURVATURE_PERCENTILE,
                 min=float(finite.min()) if finite.size else None, max=float(finite.max()) if finite.size else None,
                 reference_samples=int(ref_vals.size))
    scene.legend += [f"{label} = {'(k1+k2)/2' if kind == 'mean' else 'k1 k2'} in {unit} (the surface's unit)",
                     f"colour range +-{_fmt(c)}: {CURVATURE_PERCENTILE:g}th percentile of abs({symbol}) at "
                     f"{per_patch} fixed points per patch",
                     f"(the same at any resolution); min {_fmt(stats['min'])}, max {_fmt(stats['max'])}"]


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
    scene.bar = ("PuOr_r", (-c, c), f"deviation [{UNIT}s]")
    stats.update(max_abs=m, rms=rms, data_vertices=int(data[0].shape[0]), data_triangles=int(data[1].shape[0]),
                 relative_max=m / diag if diag > 0 else None)
    scene.legend += [f"deviation in {UNIT}s: signed distance surface -> data (+ along its normals)",
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
