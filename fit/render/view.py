"""Where the camera looks from and how big the picture is: views, sizes, framing.

    parse_view("iso"); parse_view("-60,30"); parse_view((-60, 30))   # View(azimuth, elevation)
    check_view("auto")                                                # "auto" or a View
    facing_view(V, F)                                                 # along a mesh's mean normal
    resolve_view("auto", V, F)                                        # the default view: facing_view
    mean_normal_view(V, F)                                            # the normal's azimuth, 30 deg up
    parse_size("800x600")                                             # (width, height)

Pictures are parallel projections (no perspective), so a view is a direction
(and a roll about it) only; :func:`frame` places and scales the camera so that the
object fills its box. The default view, ``"auto"``, looks along the area-weighted
mean normal of what is drawn, from the side the normal points to, so that a scan
shows its front whichever way it was rotated.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np

from trispline.spline.tolerances import TINY

from ..errors import RenderError

__all__ = [
    "AUTO", "VIEWS", "MAX_SIDE", "WRAPPED_SHARE", "View", "parse_view", "check_view", "resolve_view", "parse_size", "mean_normal",
    "facing_view", "mean_normal_view", "frame",
]

#: Named views: (azimuth, elevation) in degrees; the camera looks at the surface from
#: direction (cos el cos az, cos el sin az, sin el), z up.
VIEWS = {"iso": (-60.0, 30.0), "top": (-90.0, 90.0), "front": (-90.0, 0.0), "side": (0.0, 0.0)}
#: The default view: along the mean normal of what is drawn (:func:`facing_view`).
AUTO = "auto"
#: :func:`facing_view` keeps world z up on screen unless the normal is within this many
#: degrees of vertical; there it keeps world y up (as the ``top`` view does).
STEEP_DEGREES = 30.0
#: :func:`facing_view` takes the ``iso`` view where the mean normal's length (the area-weighted normals summed)
#: is below this share of the total area: a surface that wraps around (an open tube: 0; a half sphere 0.5, a
#: 240-degree barrel strip 0.41), whose mean normal is round-off or its axis (a tube seen end-on: a circle).
WRAPPED_SHARE = 0.2
#: Largest picture side (pixels).
MAX_SIDE = 8192
#: Normalised picture box the object is fitted into (left, right, bottom, top), with and
#: without a colour bar on the right.
_BOX = {False: (0.03, 0.97, 0.17, 0.90), True: (0.03, 0.80, 0.17, 0.90)}


@dataclass(frozen=True)
class View:
    """A camera direction: ``azimuth`` and ``elevation`` in degrees (z up), turned by ``roll``
    degrees about the viewing direction (counter-clockwise on screen)."""

    azimuth: float
    elevation: float
    roll: float = 0.0

    @property
    def toward(self) -> np.ndarray:
        """(3,) unit vector from the surface toward the camera."""
        a, e = np.radians(self.azimuth), np.radians(self.elevation)
        return np.array([np.cos(e) * np.cos(a), np.cos(e) * np.sin(a), np.sin(e)])

    @property
    def up(self) -> np.ndarray:
        """(3,) screen up: the derivative of :attr:`toward` by elevation (y at the top view), rolled."""
        a, e = np.radians(self.azimuth), np.radians(self.elevation)
        up = np.array([-np.sin(e) * np.cos(a), -np.sin(e) * np.sin(a), np.cos(e)])
        if self.roll == 0:
            return up
        r = np.radians(self.roll)
        return np.cos(r) * up - np.sin(r) * np.cross(up, self.toward)

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
            raise RenderError(f"unknown view {view!r}: use {AUTO}, one of {', '.join(VIEWS)} or "
                              f"'azimuth,elevation' in degrees, e.g. '-60,30'")
        return pair
    try:
        pair = [float(p) for p in view]
    except (TypeError, ValueError):
        raise RenderError(f"a view must be a name, 'azimuth,elevation' or a pair of numbers, got {view!r}") from None
    if len(pair) != 2:
        raise RenderError(f"a view needs two angles (azimuth, elevation), got {len(pair)}")
    return pair


def parse_view(view: "str | View | Sequence[float]") -> View:
    """A :class:`View` from a name in :data:`VIEWS`, ``"azimuth,elevation"`` or a pair.

    :data:`AUTO` needs the geometry: :func:`resolve_view` turns it into a View.
    """
    if isinstance(view, View):
        return view
    if isinstance(view, str) and view.strip().lower() == AUTO:
        raise RenderError(f"the view {AUTO!r} depends on the surface: resolve it with resolve_view(view, V, F)")
    if isinstance(view, str) and view.strip().lower() in VIEWS:
        return View(*VIEWS[view.strip().lower()])
    az, el = _angle_pair(view)
    if not (np.isfinite(az) and np.isfinite(el)) or abs(el) > 90:
        raise RenderError(f"view angles must be finite with |elevation| <= 90, got azimuth {az}, elevation {el}")
    return View(az, el)


def check_view(view: "str | View | Sequence[float]") -> "View | str":
    """:data:`AUTO` or the :class:`View` of :func:`parse_view`; raises on anything else."""
    if isinstance(view, str) and view.strip().lower() == AUTO:
        return AUTO
    return parse_view(view)


def resolve_view(view: "str | View | Sequence[float]", V: np.ndarray, F: np.ndarray) -> View:
    """The :class:`View` ``view`` names; :data:`AUTO` is :func:`facing_view` of ``V (nv, 3)``, ``F (nf, 3)``."""
    v = check_view(view)
    return facing_view(V, F) if isinstance(v, str) else v


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


def mean_normal(V: np.ndarray, F: np.ndarray) -> np.ndarray:
    """(3,) unit area-weighted mean normal of the triangles ``F (nf, 3)`` of ``V (nv, 3)``.

    Zeros where the sum vanishes (no area); on a closed surface, where the normals
    cancel, the direction is round-off. Triangles with non-finite corners are left out.
    """
    return _normal_sum(V, F)[0]


def _normal_sum(V: np.ndarray, F: np.ndarray) -> tuple[np.ndarray, float]:
    """``(unit mean normal (3,), its length over the total area)``: see :func:`mean_normal`."""
    V = np.asarray(V, np.float64)
    F = np.asarray(F, np.int64)
    c = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])
    c = c[np.isfinite(c).all(1)]
    n = c.sum(0)
    norm = float(np.linalg.norm(n))
    total = float(np.linalg.norm(c, axis=1).sum())
    return (n / norm if norm > TINY else np.zeros(3)), (norm / total if total > 0 else 0.0)


def facing_view(V: np.ndarray, F: np.ndarray) -> View:
    """The default view of the mesh ``V (nv, 3)``, ``F (nf, 3)``: looking along its mean normal.

    The camera sits on the side the area-weighted mean normal points to, so it sees
    the front of a scan in any orientation (a height field from above, a face scan
    from the front, an upside-down one from below). World z stays up on screen, or
    world y where the normal is within :data:`STEEP_DEGREES` of vertical (so a
    height field is seen as in the ``top`` view). The ``iso`` view where the mesh has
    no area or wraps around (:data:`WRAPPED_SHARE`).
    """
    n, share = _normal_sum(V, F)
    if not n.any() or share < WRAPPED_SHARE:
        return parse_view("iso")
    horizontal = float(np.hypot(n[0], n[1]))
    azimuth = float(np.degrees(np.arctan2(n[1], n[0]))) if horizontal > 0 else -90.0
    base = View(azimuth, float(np.degrees(np.arctan2(n[2], horizontal))))
    if horizontal >= np.sin(np.radians(STEEP_DEGREES)):
        return base  # z up: the elevation's own screen up
    want = np.array([0.0, 1.0, 0.0]) - n[1] * n  # world y, projected onto the screen
    want /= np.linalg.norm(want)
    roll = float(np.degrees(np.arctan2(-(want @ base.right), want @ base.up)))
    return View(base.azimuth, base.elevation, round(roll, 9) + 0.0)  # round-off of an exact view: none


def mean_normal_view(V: np.ndarray, F: np.ndarray, elevation: float = 30.0) -> View:
    """Look from the azimuth of the mean normal of ``V (nv, 3)``, ``F (nf, 3)``, ``elevation`` degrees up.

    Unlike :func:`facing_view` the elevation is fixed (the ``iso`` view's by
    default, low enough for the relief to show), so it suits surfaces whose
    normal points up; one facing down is seen from behind.
    """
    n = mean_normal(V, F)
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
