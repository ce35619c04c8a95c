"""Draw scenes with PyVista/VTK off-screen (no display, no GPU: EGL or OSMesa from the VTK wheels).

    image = draw(scenes, (800, 600))        # (h, w, 3) uint8, the scenes side by side

Surfaces are Phong-shaded with their analytic normals; zebra stripes are a
two-texel texture repeated along the highlight coordinate (sharp edges at any
resolution); lines are lifted toward the camera so that they are not half hidden
by the surface they lie on.
"""
from __future__ import annotations

from contextlib import contextmanager
from typing import TYPE_CHECKING, Any, Iterator, Sequence

import numpy as np

from ..scene import BACKGROUND, CAPTION_RGB, NAN_RGB, STRIPE_RGB, Layer, Scene, centred, wrap_legend
from ..view import frame

if TYPE_CHECKING:  # pragma: no cover
    import pyvista

__all__ = ["draw"]

_LIGHT = dict(ambient=0.25, diffuse=0.75, specular=0.15, specular_power=20.0)


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


def _polydata(layer: Layer, keep: np.ndarray | None = None) -> "pyvista.PolyData":
    """The layer (its cells ``keep`` only, a ``(t,)`` mask) as PolyData, normals attached."""
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
        poly.point_data["Normals"] = np.nan_to_num(layer.normals)
        poly.point_data.active_normals_name = "Normals"
    return poly


def draw(scenes: Sequence[Scene], size: tuple[int, int], caption: str | None = None) -> np.ndarray:
    """The ``scenes`` side by side in one ``(h, w, 3)`` uint8 picture of ``size = (w, h)``,
    ``caption`` (if any) in its bottom right corner."""
    with _quiet_vtk():
        import pyvista as pv

        pl = pv.Plotter(off_screen=True, window_size=list(size), shape=(1, len(scenes)), border=False)
        try:
            pl.set_background(BACKGROUND)
            sub_size = (size[0] / len(scenes), size[1])
            for col, sc in enumerate(scenes):
                pl.subplot(0, col)
                _add_scene(pl, sc, col, sub_size, caption is not None)
            if caption:
                pl.add_text(caption, position="lower_right", font_size=_small_font(sub_size), color=CAPTION_RGB)
            img = pl.screenshot(return_img=True)
        finally:
            pl.close()
    return np.ascontiguousarray(img[..., :3], dtype=np.uint8)


def _font(sub_size: tuple[float, float]) -> int:
    """Title font size of a panel ``sub_size = (w, h)`` pixels large."""
    return int(np.clip(sub_size[1] / 45, 8, 24))


def _small_font(sub_size: tuple[float, float]) -> int:
    """Legend and caption font size of a panel."""
    return max(7, int(_font(sub_size) * 0.7))


def _add_scene(pl: "pyvista.Plotter", sc: Scene, col: int, sub_size: tuple[float, float], captioned: bool) -> None:
    """One panel: its layers, title, legend (a row higher when ``captioned``, leaving the bottom
    row to the caption) and a parallel camera fitted to its frame, all moved to the frame's centre
    (:func:`~..scene.centred`: VTK draws in 32-bit floats)."""
    sc = centred(sc)
    for layer in sc.layers:
        _add_layer(pl, layer, sc, col)
    pl.add_text(sc.title, position="upper_edge", font_size=_font(sub_size), color="black")
    if sc.legend:
        small = _small_font(sub_size)
        legend = sc.legend if sub_size[1] >= 300 else sc.legend[:1]
        pl.add_text(wrap_legend(legend, (sub_size[0] - 12) / small),  # VTK: about 0.96 small px per character
                    position=(6, 6 + int(captioned * 1.6 * small)), font_size=small, color="black")
    focal, ps = frame(sc.frame, sc.view, (int(sub_size[0]), int(sub_size[1])), bar=sc.bar is not None)
    cam = pl.camera
    cam.parallel_projection = True
    cam.focal_point = focal
    cam.position = focal + sc.view.toward * float(10.0 * ps + 1.0)
    cam.up = sc.view.up
    cam.parallel_scale = ps
    pl.renderer.ResetCameraClippingRange()


def _add_layer(pl: "pyvista.Plotter", layer: Layer, sc: Scene, col: int) -> None:
    """Add one layer to the current subplot (``col``: its index, which keeps scalar-bar titles apart)."""
    if layer.kind == "points":
        pl.add_mesh(_polydata(layer), color=layer.color, point_size=layer.width, style="points",
                    lighting=False, render_points_as_spheres=False)
    elif layer.kind == "lines":
        # lift the lines toward the camera (parallel projection: no shift on screen) so
        # that curves lying on the surface are not half hidden by it (z-fighting)
        P = sc.frame
        lift = 2e-3 * float(np.linalg.norm(P.max(0) - P.min(0))) if P.size else 0.0
        moved = Layer("lines", layer.points + lift * sc.view.toward, layer.cells)
        pl.add_mesh(_polydata(moved), color=layer.color, line_width=layer.width, lighting=False)
    elif layer.stripes is not None:
        _add_stripes(pl, layer)
    else:
        _add_surface(pl, layer, sc, col)


def _add_stripes(pl: "pyvista.Plotter", layer: Layer) -> None:
    """Zebra stripes as a repeated black-and-white texture; triangles with undefined stripes grey."""
    import pyvista as pv

    t = layer.stripes
    finite = np.isfinite(t)
    if finite.any():  # whole stripes off: the same picture, with the texture coordinates' digits kept in float32
        t = t - np.floor(t[finite].min())
    badtri = (~finite)[layer.cells].any(1)
    good = ~badtri
    if good.any():
        poly = _polydata(layer, good)
        poly.active_texture_coordinates = np.column_stack([np.nan_to_num(t), np.zeros_like(t)])
        stripes = np.array([[STRIPE_RGB[0], STRIPE_RGB[1]]]) * 255
        tex = pv.Texture(stripes.astype(np.uint8))
        tex.repeat = True
        tex.interpolate = False
        pl.add_mesh(poly, texture=tex, lighting=False)
    if badtri.any():
        pl.add_mesh(_polydata(layer, badtri), color=NAN_RGB, lighting=False)


def _add_surface(pl: "pyvista.Plotter", layer: Layer, sc: Scene, col: int) -> None:
    """A shaded surface in one colour, or colour-mapped with a scalar bar."""
    poly = _polydata(layer)
    kw: dict[str, Any] = dict(lighting=layer.lit, show_edges=layer.edges, edge_color=(0.3, 0.3, 0.3),
                              line_width=0.5)
    if layer.lit:
        kw.update(_LIGHT)
    if layer.normals is not None:
        kw["smooth_shading"] = True
    if layer.scalars is None:
        if layer.back is not None:
            kw["backface_params"] = dict(color=layer.back)
        pl.add_mesh(poly, color=layer.color, **kw)
        return
    poly.point_data["values"] = layer.scalars
    bar_title = sc.bar[2] + " " * col if sc.bar else "values"
    pl.add_mesh(poly, scalars="values", cmap=layer.cmap, clim=list(layer.clim), nan_color=NAN_RGB,
                show_scalar_bar=False, **kw)
    pl.add_scalar_bar(title=bar_title, n_labels=5, fmt="%.3g", vertical=True, position_x=0.84,
                      position_y=0.2, width=0.1, height=0.62, color="black",
                      title_font_size=int(np.clip(pl.window_size[1] / 40, 8, 24)),
                      label_font_size=int(np.clip(pl.window_size[1] / 48, 7, 20)))
