"""Where the camera looks from and how big the picture is: views, sizes, framing.

    parse_view("iso"); parse_view("-60,30"); parse_view((-60, 30))   # View(azimuth, elevation)
    mean_normal_view(V, F)                                            # facing a mesh's mean normal
    parse_size("800x600")                                             # (width, height)

Pictures are parallel projections (no perspective), so a view is a direction
only; :func:`frame` places and scales the camera so that the object fills its box.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np

from ..errors import RenderError

__all__ = ["VIEWS", "MAX_SIDE", "View", "parse_view", "parse_size", "mean_normal_view", "frame"]

#: Named views: (azimuth, elevation) in degrees; the camera looks at the surface from
#: direction (cos el cos az, cos el sin az, sin el), z up.
VIEWS = {"iso": (-60.0, 30.0), "top": (-90.0, 90.0), "front": (-90.0, 0.0), "side": (0.0, 0.0)}
#: Largest picture side (pixels).
MAX_SIDE = 8192
#: Normalised picture box the object is fitted into (left, right, bottom, top), with and
#: without a colour bar on the right.
_BOX = {False: (0.03, 0.97, 0.17, 0.90), True: (0.03, 0.80, 0.17, 0.90)}


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


def _angle_pair(view: "str | Sequence[float]") -> list[float]:
    """The two numbers of ``"azimuth,elevation"`` or of a pair; raises on anything else."""
    if isinstance(view, str):
        try:
            pair = [float(p) for p in view.split(",")]
        except ValueError:
            pair = []
        if len(pair) != 2:
            raise RenderError(f"unknown view {view!r}: use one of {', '.join(VIEWS)} or 'azimuth,elevation' "
                              f"in degrees, e.g. '-60,30'")
        return pair
    try:
        pair = [float(p) for p in view]
    except (TypeError, ValueError):
        raise RenderError(f"a view must be a name, 'azimuth,elevation' or a pair of numbers, got {view!r}") from None
    if len(pair) != 2:
        raise RenderError(f"a view needs two angles (azimuth, elevation), got {len(pair)}")
    return pair


def parse_view(view: "str | View | Sequence[float]") -> View:
    """A :class:`View` from a name in :data:`VIEWS`, ``"azimuth,elevation"`` or a pair."""
    if isinstance(view, View):
        return view
    if isinstance(view, str) and view.strip().lower() in VIEWS:
        return View(*VIEWS[view.strip().lower()])
    az, el = _angle_pair(view)
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


def mean_normal_view(V: np.ndarray, F: np.ndarray, elevation: float = 30.0) -> View:
    """Look along the mean normal of the mesh ``V (nv, 3)``, ``F (nf, 3)`` from ``elevation`` degrees.

    The azimuth is that of the area-weighted normal sum, so the camera faces the
    side the surface faces, whichever way a scan was rotated; the default elevation
    is that of the ``iso`` view, low enough for the relief to show.
    """
    V = np.asarray(V, np.float64)
    F = np.asarray(F, np.int64)
    n = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]]).sum(0)
    return parse_view((float(np.degrees(np.arctan2(n[1], n[0]))), float(elevation)))


def frame(points: np.ndarray, view: View, size: tuple[int, int], *, bar: bool = False
          ) -> tuple[np.ndarray, float]:
    """Camera focal point ``(3,)`` and parallel half-height that fit ``points (m, 3)`` into the box.

    ``size`` is the panel's ``(width, height)`` in pixels; with ``bar`` the box leaves
    room for a colour bar on the right.
    """
    R, U, W = view.right, view.up, view.toward
    P = points if points.size else np.zeros((1, 3))
    x, y, z = P @ R, P @ U, P @ W
    x0, x1, y0, y1 = _BOX[bar]
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
