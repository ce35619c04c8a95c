"""Draw surfaces into pictures and write them as PNG files.

    pic = draw(surface, "zebra", size=(800, 600))      # Picture: image (h, w, 3) uint8, stats
    render(surface, "zebra.png", "zebra")              # the same, written to a file
    render_panels([Panel(mesh=(V, F)), Panel(surface)], "pair.png")
    write_png(pic.image, "zebra.png")

The defaults explain themselves: the view looks along the surface's mean normal
(``view="auto"``), the zebra stripe count follows the picture's scale
(``stripes=None``), and a dated caption (:mod:`.caption`) sits in the bottom
right corner (``caption=True``; a string replaces it, ``False`` leaves it out).
Every file is written atomically (:mod:`trispline.spline.util.atomic`); the output
name is checked before anything is drawn.
"""
from __future__ import annotations

import io
import os
from pathlib import Path
from typing import TYPE_CHECKING, Any, Sequence

import numpy as np

from trispline.spline.checks import whole_number
from trispline.spline.util.atomic import write_bytes

from ..errors import RenderError
from ..io.formats import IMAGE_FORMATS, check_export_path
from .backends import choose, draw_scenes
from .caption import caption_text
from .scene import Panel, Picture, check_mode, panel_scene, panel_view
from .view import AUTO, View, check_view, parse_size

if TYPE_CHECKING:  # pragma: no cover
    from trispline.spline.surface import SplineSurface

__all__ = ["draw", "draw_panels", "render", "render_panels", "write_png"]


def _caption(caption: "str | bool") -> str | None:
    """The caption to draw: the dated default for True, none for False or an empty string."""
    if caption is True:
        return caption_text()
    return str(caption) if caption else None


#: A panel draws at most this many triangles a pixel: more show nothing more (a picture of 800 x 600 px: 30.7M
#: triangles; 152 patches at resolution 1000, 152M, ran out of 23 GB of memory before this was checked).
MAX_TRIANGLES_PER_PIXEL = 64


def _check_resolution(panel: Panel, panel_size: tuple[int, int]) -> None:
    """Refuse, before any work, a ``resolution`` whose triangles could not all show in the panel."""
    r = panel.options.get("resolution")
    if r is None or panel.surface is None:
        return
    r = whole_number(r, "resolution", least=1, error=RenderError)
    nf = int(panel.surface.n_faces)
    room = MAX_TRIANGLES_PER_PIXEL * panel_size[0] * panel_size[1]
    if nf * r * r > room:
        top = max(1, int(np.sqrt(room / nf)))
        raise RenderError(f"resolution {r} draws {nf * r * r:,} triangles on a picture of {panel_size[0]} x "
                          f"{panel_size[1]} pixels (more than {MAX_TRIANGLES_PER_PIXEL} a pixel show nothing more): "
                          f"use a resolution of at most {top}")


def draw_panels(panels: Sequence[Panel], *, view: "str | View | Sequence[float]" = AUTO,
                size: "str | Sequence[int]" = (800, 600), backend: str | None = None,
                caption: "str | bool" = True) -> Picture:
    """Draw several panels side by side into one picture of ``size`` (width, height).

    ``view="auto"`` is resolved once, on the first panel, and the automatic zebra stripe
    count on the first zebra panel, so that panels side by side compare alike (a panel's
    own ``view`` or ``stripes`` option wins). Returns a :class:`Picture`; its ``stats``
    has one dict per panel under ``"panels"``.
    """
    if not panels:
        raise RenderError("nothing to draw: no panels")
    size = parse_size(size)
    panel_size = (size[0] // len(panels), size[1])
    for p in panels:
        _check_resolution(p, panel_size)
    plan = choose(backend)
    v = check_view(view)
    shared = panel_view(panels[0], v)
    built: list[tuple[Any, dict]] = []
    stripes = None  # the first automatic stripe count, for the zebra panels after it
    for p in panels:
        built.append(panel_scene(p, shared, plan.use, panel_size, auto=v == AUTO, stripes=stripes))
        if stripes is None and built[-1][1].get("stripes_auto"):
            stripes = built[-1][1]["stripes"]
    scenes = [sc for sc, _ in built]
    image, used = draw_scenes(scenes, size, plan, _caption(caption))
    legend = tuple(line for sc in scenes for line in sc.legend)
    return Picture(image, used, legend, dict(panels=[st for _, st in built]))


def draw(surface: "SplineSurface", mode: str = "shaded", *, mesh: Any = None,
         view: "str | View | Sequence[float]" = AUTO, size: "str | Sequence[int]" = (800, 600),
         resolution: int | None = None, curvature: str = "mean", stripes: float | None = None,
         stripe_angle: float = 45.0, patch_lines: bool | None = None, title: str | None = None,
         backend: str | None = None, caption: "str | bool" = True) -> Picture:
    """Draw one picture of ``surface`` (see :func:`render`); returns a :class:`Picture`."""
    check_mode(mode)
    pic = draw_panels([Panel(surface, mode, mesh, title, dict(
        resolution=resolution, curvature=curvature, stripes=stripes, stripe_angle=stripe_angle,
        patch_lines=patch_lines))], view=view, size=size, backend=backend, caption=caption)
    return Picture(pic.image, pic.backend, pic.legend, pic.stats["panels"][0])


def write_png(image: np.ndarray, path: str | os.PathLike) -> Path:
    """Write ``image (h, w, 3) uint8`` to a PNG file atomically."""
    from PIL import Image

    check_export_path(path, IMAGE_FORMATS)
    buf = io.BytesIO()
    Image.fromarray(np.asarray(image, np.uint8)).save(buf, format="PNG")
    return write_bytes(path, buf.getvalue())


def render(surface: "SplineSurface", path: str | os.PathLike, mode: str = "shaded", *, mesh: Any = None,
           view: "str | View | Sequence[float]" = AUTO, size: "str | Sequence[int]" = (800, 600),
           resolution: int | None = None, curvature: str = "mean", stripes: float | None = None,
           stripe_angle: float = 45.0, patch_lines: bool | None = None, title: str | None = None,
           backend: str | None = None, caption: "str | bool" = True) -> Path:
    """Render ``surface`` to the PNG file ``path`` (written atomically); returns the path.

    Parameters
    ----------
    mode : one of :data:`~trispline.fit.render.MODES`
    mesh : data mesh for ``deviation``: ``(V, F)``, a trimesh or a file path
        (default: the fit's data vertices stored in the surface file)
    view : ``"auto"`` (default: along the surface's mean normal, from the side it points to),
        ``"iso" | "top" | "front" | "side"``, ``"azimuth,elevation"`` or a pair (degrees)
    size : ``(width, height)`` or ``"WxH"`` in pixels
    resolution : samples per patch edge (default: about 1.7M triangles, at most 8)
    curvature : ``"mean"`` or ``"gaussian"`` (mode ``curvature``)
    stripes : zebra tube spacings per bounding-box diagonal (default None: the most, up to
        12, that keep stripe pairs 8 px wide on 75% of the surface: no aliasing into noise)
    stripe_angle : direction of the zebra tubes on screen (degrees)
    patch_lines : draw patch boundaries (default: up to ``PATCH_LINES_MAX`` patches)
    backend : ``"auto"`` (PyVista, else matplotlib), ``"pyvista"`` or ``"matplotlib"``
    caption : True (default: date and trispline version in the bottom right corner),
        a string to write there instead, or False for none
    """
    check_export_path(path, IMAGE_FORMATS)
    pic = draw(surface, mode, mesh=mesh, view=view, size=size, resolution=resolution, curvature=curvature,
               stripes=stripes, stripe_angle=stripe_angle, patch_lines=patch_lines, title=title, backend=backend,
               caption=caption)
    return write_png(pic.image, path)


def render_panels(panels: Sequence[Panel], path: str | os.PathLike, *,
                  view: "str | View | Sequence[float]" = AUTO, size: "str | Sequence[int]" = (1200, 500),
                  backend: str | None = None, caption: "str | bool" = True) -> Path:
    """Render several :class:`Panel` side by side to the PNG file ``path`` (atomically)."""
    check_export_path(path, IMAGE_FORMATS)
    return write_png(draw_panels(panels, view=view, size=size, backend=backend, caption=caption).image, path)
