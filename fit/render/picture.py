"""Draw surfaces into pictures and write them as PNG files.

    pic = draw(surface, "zebra", view="iso", size=(800, 600))      # Picture: image (h, w, 3) uint8, stats
    render(surface, "zebra.png", "zebra")                          # the same, written to a file
    render_panels([Panel(mesh=(V, F)), Panel(surface)], "pair.png")
    write_png(pic.image, "zebra.png")

Every file is written atomically (:mod:`trispline.spline.util.atomic`); the output
name is checked before anything is drawn.
"""
from __future__ import annotations

import io
import os
from pathlib import Path
from typing import TYPE_CHECKING, Any, Sequence

import numpy as np

from trispline.spline.util.atomic import write_bytes

from ..errors import RenderError
from ..io.formats import IMAGE_FORMATS, check_export_path
from .backends import choose, draw_scenes
from .scene import Panel, Picture, check_mode, panel_scene
from .view import View, parse_size, parse_view

if TYPE_CHECKING:  # pragma: no cover
    from trispline.spline.surface import SplineSurface

__all__ = ["draw", "draw_panels", "render", "render_panels", "write_png"]


def draw_panels(panels: Sequence[Panel], *, view: "str | View | Sequence[float]" = "iso",
                size: "str | Sequence[int]" = (800, 600), backend: str | None = None) -> Picture:
    """Draw several panels side by side into one picture of ``size`` (width, height).

    Returns a :class:`Picture`; its ``stats`` has one dict per panel under ``"panels"``.
    """
    if not panels:
        raise RenderError("nothing to draw: no panels")
    size = parse_size(size)
    plan = choose(backend)
    v = parse_view(view)
    built = [panel_scene(p, v, plan.use) for p in panels]
    scenes = [sc for sc, _ in built]
    image, used = draw_scenes(scenes, size, plan)
    legend = tuple(line for sc in scenes for line in sc.legend)
    return Picture(image, used, legend, dict(panels=[st for _, st in built]))


def draw(surface: "SplineSurface", mode: str = "shaded", *, mesh: Any = None,
         view: "str | View | Sequence[float]" = "iso", size: "str | Sequence[int]" = (800, 600),
         resolution: int | None = None, curvature: str = "mean", stripes: float = 12.0,
         stripe_angle: float = 45.0, patch_lines: bool | None = None, title: str | None = None,
         backend: str | None = None) -> Picture:
    """Draw one picture of ``surface`` (see :func:`render`); returns a :class:`Picture`."""
    check_mode(mode)
    pic = draw_panels([Panel(surface, mode, mesh, title, dict(
        resolution=resolution, curvature=curvature, stripes=stripes, stripe_angle=stripe_angle,
        patch_lines=patch_lines))], view=view, size=size, backend=backend)
    return Picture(pic.image, pic.backend, pic.legend, pic.stats["panels"][0])


def write_png(image: np.ndarray, path: str | os.PathLike) -> Path:
    """Write ``image (h, w, 3) uint8`` to a PNG file atomically."""
    from PIL import Image

    check_export_path(path, IMAGE_FORMATS)
    buf = io.BytesIO()
    Image.fromarray(np.asarray(image, np.uint8)).save(buf, format="PNG")
    return write_bytes(path, buf.getvalue())


def render(surface: "SplineSurface", path: str | os.PathLike, mode: str = "shaded", *, mesh: Any = None,
           view: "str | View | Sequence[float]" = "iso", size: "str | Sequence[int]" = (800, 600),
           resolution: int | None = None, curvature: str = "mean", stripes: float = 12.0,
           stripe_angle: float = 45.0, patch_lines: bool | None = None, title: str | None = None,
           backend: str | None = None) -> Path:
    """Render ``surface`` to the PNG file ``path`` (written atomically); returns the path.

    Parameters
    ----------
    mode : one of :data:`~trispline.fit.render.MODES`
    mesh : data mesh for ``deviation``: ``(V, F)``, a trimesh or a file path
        (default: the fit's data vertices stored in the surface file)
    view : ``"iso" | "top" | "front" | "side"``, ``"azimuth,elevation"`` or a pair (degrees)
    size : ``(width, height)`` or ``"WxH"`` in pixels
    resolution : samples per patch edge (default: about 1.7M triangles, at most 8)
    curvature : ``"mean"`` or ``"gaussian"`` (mode ``curvature``)
    stripes, stripe_angle : zebra tube count per bounding-box diagonal and direction (degrees)
    patch_lines : draw patch boundaries (default: up to ``PATCH_LINES_MAX`` patches)
    backend : ``"auto"`` (PyVista, else matplotlib), ``"pyvista"`` or ``"matplotlib"``
    """
    check_export_path(path, IMAGE_FORMATS)
    pic = draw(surface, mode, mesh=mesh, view=view, size=size, resolution=resolution, curvature=curvature,
               stripes=stripes, stripe_angle=stripe_angle, patch_lines=patch_lines, title=title, backend=backend)
    return write_png(pic.image, path)


def render_panels(panels: Sequence[Panel], path: str | os.PathLike, *,
                  view: "str | View | Sequence[float]" = "iso", size: "str | Sequence[int]" = (1200, 500),
                  backend: str | None = None) -> Path:
    """Render several :class:`Panel` side by side to the PNG file ``path`` (atomically)."""
    check_export_path(path, IMAGE_FORMATS)
    return write_png(draw_panels(panels, view=view, size=size, backend=backend).image, path)
