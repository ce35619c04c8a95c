"""Highlight lines (Beier and Chen 1994): the zebra stripes of the analytic normals.

    light = zebra_light(points, "iso", stripes=12, angle=45)     # ZebraLight: the panel of tubes
    t = stripe_function(points, normals, light)                  # (n,) highlight coordinate
    stripe_pattern(t)                                            # (n,) 0 white, 1 black, -1 undefined
    stripes, width = auto_stripes(points, normals, triangles, view, pixels_per_unit)   # the default count

A panel of parallel light tubes hangs between the camera and the surface; the
stripe coordinate of a point ``P`` with unit normal ``N`` is where the normal line
``P + s N`` meets the panel, measured across the tubes. It depends on ``N``
itself, so a C1 surface has continuous stripes and a kink (a normal jump) breaks
them, and a plane has straight, parallel, equally spaced stripes. Stripes crowd
where the surface curves; :func:`auto_stripes` picks the count from the picture's
scale so that they stay wider than a few pixels (finer stripes alias into noise).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np

from trispline.spline.tolerances import ZEBRA_MIN_COS

from ..errors import RenderError
from .view import View, parse_view

__all__ = [
    "ZebraLight", "zebra_light", "stripe_function", "stripe_pattern", "stripe_pixels", "auto_stripes",
    "MIN_STRIPE_PIXELS", "STRIPE_AREA_FRACTION", "MIN_STRIPES", "MAX_STRIPES",
]

#: The automatic stripe count (:func:`auto_stripes`): stripe pairs at least this many pixels
#: wide on this fraction of the surface's area on screen, between these counts per diagonal.
MIN_STRIPE_PIXELS = 8.0
STRIPE_AREA_FRACTION = 0.75
MIN_STRIPES = 1.0
MAX_STRIPES = 12.0


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
    P = P[np.isfinite(P).all(1)]
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
    ``|N.W| <`` :data:`~trispline.spline.tolerances.ZEBRA_MIN_COS` or the normal is undefined.
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
    """``(n,)`` 0 (white) or 1 (black) stripes of the highlight coordinate ``t (n,)``; -1 where NaN."""
    t = np.asarray(t, np.float64)
    out = np.full(t.shape, -1, np.int64)
    ok = np.isfinite(t)
    out[ok] = np.floor(2.0 * t[ok]).astype(np.int64) % 2
    return out


def stripe_pixels(points: np.ndarray, normals: np.ndarray, triangles: np.ndarray, light: ZebraLight,
                  view: View, pixels_per_unit: float) -> tuple[np.ndarray, np.ndarray]:
    """Width on screen (pixels) of one stripe pair on each triangle, and the triangle's area (pixels^2).

    ``points (m, 3)``, ``normals (m, 3)``, ``triangles (t, 3)`` as drawn (the renderer
    interpolates the highlight coordinate linearly over each triangle, so its
    gradient there is what the screen shows); ``pixels_per_unit`` is the picture's
    scale. Both ``(t,)``; triangles with an undefined coordinate or no area are left out.
    """
    t = stripe_function(points, normals, light)
    x, y = pixels_per_unit * (points @ view.right), pixels_per_unit * (points @ view.up)
    a, b, c = triangles.T
    x1, y1, t1 = x[b] - x[a], y[b] - y[a], t[b] - t[a]
    x2, y2, t2 = x[c] - x[a], y[c] - y[a], t[c] - t[a]
    det = x1 * y2 - x2 * y1
    ok = np.isfinite(t1) & np.isfinite(t2) & (det != 0)
    det = det[ok]
    gx = (t1[ok] * y2[ok] - t2[ok] * y1[ok]) / det
    gy = (x1[ok] * t2[ok] - x2[ok] * t1[ok]) / det
    with np.errstate(divide="ignore"):
        return 1.0 / np.hypot(gx, gy), 0.5 * np.abs(det)


def auto_stripes(points: np.ndarray, normals: np.ndarray, triangles: np.ndarray, view: View,
                 pixels_per_unit: float, angle: float = 45.0) -> tuple[float, float]:
    """The stripe count that keeps stripes readable, and the stripe-pair width at one stripe (pixels).

    The most stripes per bounding-box diagonal (whole numbers, :data:`MIN_STRIPES`
    to :data:`MAX_STRIPES`) for which stripe pairs are at least
    :data:`MIN_STRIPE_PIXELS` wide on :data:`STRIPE_AREA_FRACTION` of the surface's
    area on screen (see :func:`stripe_pixels`). Stripes narrow where the surface
    curves, so a noisy scan gets fewer, wider stripes than a smooth one. With ``n``
    stripes, pairs are (the second value) / ``n`` pixels wide on that fraction.
    """
    light = zebra_light(points, view, stripes=1.0, angle=angle)
    width, area = stripe_pixels(points, normals, triangles, light, view, pixels_per_unit)
    if not area.sum() > 0:
        return MAX_STRIPES, float("inf")
    order = np.argsort(width)
    cum = np.cumsum(area[order])
    # the width that STRIPE_AREA_FRACTION of the area reaches or exceeds (at one stripe)
    w1 = float(width[order][np.searchsorted(cum, (1.0 - STRIPE_AREA_FRACTION) * cum[-1])])
    return float(np.clip(np.floor(w1 / MIN_STRIPE_PIXELS), MIN_STRIPES, MAX_STRIPES)), w1
