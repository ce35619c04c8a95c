"""Draw scenes with matplotlib (Agg, off-screen): the fallback when VTK is missing or fails.

    image = draw(scenes, (800, 600))        # (h, w, 3) uint8, the scenes side by side

A painter's-algorithm parallel projection: triangles sorted far to near, each in
one flat colour (the mean of its corners' scalars, stripes or normals; a layer's
``back`` colour where the triangle is seen from behind), lit by a key light from
the viewer's upper right.
"""
from __future__ import annotations

from typing import TYPE_CHECKING, Sequence

import numpy as np

from trispline.spline.tolerances import TINY

from ..scene import BACKGROUND, CAPTION_RGB, NAN_RGB, STRIPE_RGB, Layer, Scene, centred, wrap_legend
from ..view import frame
from ..zebra import stripe_pattern

if TYPE_CHECKING:  # pragma: no cover
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

__all__ = ["draw"]

_DPI = 100.0
#: Key light in screen coordinates (right, up, toward the camera).
_KEY = np.array([0.3, 0.4, 1.0])


def draw(scenes: Sequence[Scene], size: tuple[int, int], caption: str | None = None) -> np.ndarray:
    """The ``scenes`` side by side in one ``(h, w, 3)`` uint8 picture of ``size = (w, h)``,
    ``caption`` (if any) in its bottom right corner."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    w, h = size
    fig = Figure(figsize=(w / _DPI, h / _DPI), dpi=_DPI, facecolor=BACKGROUND)
    FigureCanvasAgg(fig)
    n = len(scenes)
    for col, sc in enumerate(scenes):
        _draw_scene(fig, sc, col, n, (w / n, h), caption is not None)
    if caption:
        fig.text(0.995, 0.01, caption, ha="right", va="bottom", fontsize=_font((w / n, h)) * 0.62, color=CAPTION_RGB,
                 parse_math=False)  # a user's text as written: a "$" starts no formula
    fig.canvas.draw()
    img = np.asarray(fig.canvas.buffer_rgba())[..., :3]
    return np.ascontiguousarray(img, dtype=np.uint8)


def _font(sub: tuple[float, float]) -> float:
    """Title font size (points) of a panel ``sub = (w, h)`` pixels large."""
    return float(np.clip(sub[1] / 38, 7, 28)) * 0.75


def _draw_scene(fig: "Figure", sc: Scene, col: int, n: int, sub: tuple[float, float], captioned: bool) -> None:
    """Panel ``col`` of ``n``: its layers projected on screen, title, legend (a row higher when
    ``captioned``, leaving the bottom row to the caption) and colour bar."""
    font = _font(sub)
    sc = centred(sc)
    ax = fig.add_axes((col / n, 0.0, 1.0 / n, 1.0))
    ax.set_axis_off()
    focal, ps = frame(sc.frame, sc.view, (int(sub[0]), int(sub[1])), bar=sc.bar is not None)
    screen = np.stack([sc.view.right, sc.view.up, sc.view.toward])  # (3, 3): rows R, U, W
    aspect = sub[0] / sub[1]
    fx, fy = focal @ screen[0], focal @ screen[1]
    ax.set_xlim(fx - ps * aspect, fx + ps * aspect)
    ax.set_ylim(fy - ps, fy + ps)
    key = _KEY @ screen
    key /= np.linalg.norm(key)
    for layer in sc.layers:
        P = layer.points
        _draw_layer(ax, layer, np.column_stack([P @ screen[0], P @ screen[1], P @ screen[2]]), key)
    ax.text(0.5, 0.985, sc.title, transform=ax.transAxes, ha="center", va="top", fontsize=font, parse_math=False)
    if sc.legend:
        legend = sc.legend if sub[1] >= 300 else sc.legend[:1]
        rise = captioned * 1.5 * font * 0.62 / 72 * _DPI / sub[1]  # one text row, as a fraction of the height
        ax.text(0.01, 0.01 + rise, wrap_legend(legend, sub[0] / (0.6 * font * 0.62 * 1.39)), transform=ax.transAxes,
                ha="left", va="bottom", fontsize=font * 0.62, parse_math=False)
    if sc.bar is not None:
        _colour_bar(fig, sc.bar, col, n, font)


def _draw_layer(ax: "Axes", layer: Layer, xyz: np.ndarray, key: np.ndarray) -> None:
    """One layer, its points ``xyz (m, 3)`` already in screen coordinates (x, y, depth)."""
    from matplotlib.collections import LineCollection, PolyCollection

    xy = xyz[:, :2]
    if layer.kind == "points":
        ax.scatter(xy[:, 0], xy[:, 1], s=layer.width, c=[layer.color], linewidths=0, zorder=3)
        return
    if layer.kind == "lines":
        seg = np.stack([xy[layer.cells[:, 0]], xy[layer.cells[:, 1]]], 1)
        ax.add_collection(LineCollection(seg, colors=[layer.color], linewidths=layer.width * 0.7, zorder=2))
        return
    T = layer.cells[np.isfinite(layer.points).all(1)[layer.cells].all(1)]
    T = T[np.argsort(xyz[:, 2][T].mean(1), kind="stable")]  # far (small depth) first
    colors = _triangle_colours(layer, T, key, _front(xy, T))
    ec = (0.3, 0.3, 0.3) if layer.edges else colors
    ax.add_collection(PolyCollection(xy[T], facecolors=colors, edgecolors=ec,
                                     linewidths=0.3 if layer.edges else 0.15, zorder=1))


def _front(xy: np.ndarray, T: np.ndarray) -> np.ndarray:
    """``(t,)`` True where the triangle ``T (t, 3)`` of the screen points ``xy (m, 2)`` is
    counter-clockwise, i.e. seen from the side its normal points to."""
    a, b, c = xy[T[:, 0]], xy[T[:, 1]], xy[T[:, 2]]
    return (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0]) > 0


def _triangle_colours(layer: Layer, T: np.ndarray, key: np.ndarray, front: np.ndarray) -> np.ndarray:
    """``(t, 3)`` RGB of the triangles ``T (t, 3)``: stripes, colour-mapped scalars or flat (the
    layer's ``back`` colour where not ``front (t,)``), then lit."""
    from matplotlib import colormaps
    from matplotlib.colors import Normalize

    if layer.stripes is not None:
        pat = stripe_pattern(np.nanmean(layer.stripes[T], axis=1) if T.size else np.zeros(0))
        colors = np.where((pat == 0)[:, None], STRIPE_RGB[0], STRIPE_RGB[1])
        colors[pat < 0] = NAN_RGB
        return colors
    if layer.scalars is not None:
        sm = np.nanmean(layer.scalars[T], axis=1) if T.size else np.zeros(0)
        colors = colormaps[layer.cmap](Normalize(*layer.clim)(sm))[:, :3]
        colors[~np.isfinite(sm)] = NAN_RGB
    else:
        colors = np.tile(np.asarray(layer.color, float), (T.shape[0], 1))
        if layer.back is not None:
            colors[~front] = layer.back
    if not layer.lit:
        return colors
    if layer.normals is not None:
        fn = np.nanmean(layer.normals[T], axis=1)
    else:
        Q = layer.points[T]
        fn = np.cross(Q[:, 1] - Q[:, 0], Q[:, 2] - Q[:, 0])
    fn /= np.maximum(np.linalg.norm(fn, axis=1, keepdims=True), TINY)
    lam = np.abs(np.nan_to_num(fn @ key))
    return np.clip(colors * (0.3 + 0.7 * lam)[:, None] + 0.15 * lam[:, None] ** 20, 0, 1)


def _colour_bar(fig: "Figure", bar: tuple[str, tuple[float, float], str], col: int, n: int, font: float) -> None:
    """The colour bar ``(cmap, clim, label)`` at the right of panel ``col`` of ``n``."""
    from matplotlib import colormaps
    from matplotlib.cm import ScalarMappable
    from matplotlib.colors import Normalize

    cmap, clim, label = bar
    cax = fig.add_axes(((col + 0.86) / n, 0.22, 0.03 / n, 0.6))
    cb = fig.colorbar(ScalarMappable(Normalize(*clim), colormaps[cmap]), cax=cax)
    cb.set_label(label, fontsize=font * 0.7)
    cb.ax.tick_params(labelsize=font * 0.6)
