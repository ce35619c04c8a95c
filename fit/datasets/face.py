"""A real-world-like scan the project generates itself: a face mask, as a structured-light scanner sees it.

    from trispline.fit.datasets.face import face_scan
    V, F = face_scan(4000, seed=0)       # (nv, 3) float64, (nf, 3) int64: about 4000 triangles

What makes real scans harder than :func:`~trispline.fit.datasets.synthetic.synthetic_scan`,
in a mesh every clone can make (the real meshes of ``../shared/data`` are not in a
user's clone; see :mod:`.cache`):

* a ragged, non-convex outline (where the scanner lost the surface), and a hole
  where the left eye's glint dropped out;
* irregular sampling: random points, dense on the features in the middle and
  sparse toward the rim, so triangle sizes vary about 3 times and shapes vary;
* features of several scales: a head-sized dome, a nose ridge with a tip, eye
  sockets, brow, cheeks, lips and chin;
* noise along the viewing direction;
* an orientation of its own: the face looks along ``-y`` (z up), turned 20 degrees
  about z, so it is not a height field over xy and a camera above it sees its rim.

The outline and the hole are kept exactly (every boundary vertex is a loop point),
and the triangulation is Triangle's constrained Delaunay triangulation of the
points (:mod:`trispline.fit.approx.cdt`), so the mesh is one disk with one hole.
"""
from __future__ import annotations

import numpy as np

from ..approx.cdt import constrained, hole_seeds, loop_segments
from .checks import scan_arguments

__all__ = ["OUTLINE_AXES", "EYE_CENTRE", "EYE_AXES", "ROTATION", "face_depth", "face_scan"]

#: Half-axes of the elliptic outline before its raggedness (width, height), in the face plane.
OUTLINE_AXES = (0.8, 1.05)
#: Centre and half-axes of the hole (the left eye's dropout), in the face plane.
EYE_CENTRE = np.array([-0.3, 0.24])
EYE_AXES = (0.12, 0.065)
_TURN = np.radians(20.0)
#: The face plane (x right, y up, depth toward the viewer) to the world: the face looks along
#: ``-y`` with z up, then turned 20 degrees about z. ``V_world = V_face @ ROTATION.T``.
ROTATION = (np.array([[np.cos(_TURN), -np.sin(_TURN), 0.0], [np.sin(_TURN), np.cos(_TURN), 0.0], [0.0, 0.0, 1.0]])
            @ np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]]))
#: Features as (amplitude, x, y, sx, sy): Gaussian bumps exp(-((x-x0)/sx)^2 - ((y-y0)/sy)^2).
_FEATURES = (
    (0.16, 0.0, 0.02, 0.075, 0.22),     # nose ridge
    (0.05, 0.0, -0.17, 0.07, 0.05),     # nose tip
    (-0.07, -0.3, 0.24, 0.14, 0.08),    # eye sockets
    (-0.07, 0.3, 0.24, 0.14, 0.08),
    (0.04, 0.0, 0.42, 0.45, 0.06),      # brow
    (0.035, -0.38, -0.1, 0.15, 0.15),   # cheeks
    (0.035, 0.38, -0.1, 0.15, 0.15),
    (0.03, 0.0, -0.42, 0.17, 0.035),    # lips
    (0.03, 0.0, -0.52, 0.15, 0.035),
    (0.05, 0.0, -0.78, 0.16, 0.1),      # chin
)


def face_depth(xy: np.ndarray) -> np.ndarray:
    """The noise-free depth ``(n,)`` toward the viewer over ``xy (n, 2)`` in the face plane."""
    x, y = xy[:, 0], xy[:, 1]
    dome = 0.5 * np.sqrt(np.maximum(1.0 - (x / 1.0) ** 2 - (y / 1.35) ** 2, 0.0))
    return dome + sum(a * np.exp(-(((x - cx) / sx) ** 2) - ((y - cy) / sy) ** 2) for a, cx, cy, sx, sy in _FEATURES)


def _outline(rng: np.random.Generator, spacing: float) -> tuple[np.ndarray, np.ndarray]:
    """The ragged outline ``(k, 2)``, counter-clockwise, and its radius function's two phases."""
    phase = rng.uniform(0, 2 * np.pi, 2)
    a, b = OUTLINE_AXES
    k = int(np.ceil(2 * np.pi * np.sqrt(0.5 * (a * a + b * b)) / spacing))
    t = 2 * np.pi * (np.arange(k) + rng.uniform(-0.25, 0.25, k)) / k
    return _ragged(t, phase)[:, None] * np.column_stack([a * np.cos(t), b * np.sin(t)]), phase


def _ragged(t: np.ndarray, phase: np.ndarray) -> np.ndarray:
    """Radius factor ``(n,)`` of the outline at angles ``t (n,)``."""
    return 1.0 + 0.05 * np.sin(3 * t + phase[0]) + 0.03 * np.sin(7 * t + phase[1])


def _eye(spacing: float) -> np.ndarray:
    """The hole's loop ``(k, 2)``, clockwise (the domain on its left)."""
    a, b = EYE_AXES
    k = max(8, int(np.ceil(2 * np.pi * np.sqrt(0.5 * (a * a + b * b)) / spacing)))
    t = -2 * np.pi * np.arange(k) / k
    return EYE_CENTRE + np.column_stack([a * np.cos(t), b * np.sin(t)])


def _spacing(xy: np.ndarray, h: float) -> np.ndarray:
    """Wanted point spacing ``(n,)`` at ``xy (n, 2)``: ``h`` in the middle, 3 h at the rim."""
    a, b = OUTLINE_AXES
    rho2 = (xy[:, 0] / a) ** 2 + (xy[:, 1] / b) ** 2
    return h * (1.0 + 2.0 * np.clip(rho2, 0.0, 1.0))


def _inside(xy: np.ndarray, phase: np.ndarray, margin: np.ndarray, hole: bool) -> np.ndarray:
    """``(n,)`` True where ``xy (n, 2)`` is ``margin (n,)`` inside the outline and outside the hole."""
    a, b = OUTLINE_AXES
    t = np.arctan2(xy[:, 1] / b, xy[:, 0] / a)
    r = np.hypot(xy[:, 0] / a, xy[:, 1] / b)
    keep = r < _ragged(t, phase) - margin / min(a, b)
    if hole:
        e = np.hypot((xy[:, 0] - EYE_CENTRE[0]) / EYE_AXES[0], (xy[:, 1] - EYE_CENTRE[1]) / EYE_AXES[1])
        keep &= e > 1.0 + margin / min(EYE_AXES)
    return keep


def _points(rng: np.random.Generator, h: float, phase: np.ndarray, hole: bool) -> np.ndarray:
    """Irregular interior points: a jittered hexagonal grid of spacing ``h``, thinned at random to
    the spacing :func:`_spacing` wants, clear of the outline and the hole."""
    m = int(np.ceil(1.3 / h)) + 1
    i, j = np.meshgrid(np.arange(-m, m + 1), np.arange(-m, m + 1), indexing="ij")
    xy = np.column_stack([(i + 0.5 * (j % 2)).ravel() * h, j.ravel() * h * np.sqrt(3.0) / 2.0])
    xy = xy + rng.uniform(-0.3 * h, 0.3 * h, xy.shape)
    want = _spacing(xy, h)
    keep = (rng.uniform(size=xy.shape[0]) < (h / want) ** 2) & _inside(xy, phase, 0.6 * want, hole)
    return xy[keep]


def face_scan(n_faces: int = 4000, *, noise: float = 0.0008, hole: bool = True, seed: int = 0
              ) -> tuple[np.ndarray, np.ndarray]:
    """Generate the face scan (see the module's description).

    Parameters
    ----------
    n_faces : approximate number of triangles (at least 200)
    noise : standard deviation of the Gaussian noise along the viewing direction (the face is
        about 2 units tall)
    hole : leave out the left eye (one hole) or not (a disk)
    seed : random seed; the result is deterministic per seed

    Returns
    -------
    V : (nv, 3) float64
    F : (nf, 3) int64, counter-clockwise seen from the front (the normals point toward the viewer)
    """
    n_faces = scan_arguments(n_faces, noise, least=200)
    rng = np.random.default_rng(seed)
    # spacing in the middle for about n_faces triangles (2 per point): the mean of 1/spacing^2 over
    # the outline's area is 0.31 / h^2 (measured on the spacing 1 + 2 rho^2)
    area = np.pi * OUTLINE_AXES[0] * OUTLINE_AXES[1]
    h = float(np.sqrt(2 * 0.31 * area / (np.sqrt(3.0) / 2.0) / n_faces))
    outer, phase = _outline(rng, 3.0 * h)
    loops = [outer] + ([_eye(h)] if hole else [])
    inner = _points(rng, h, phase, hole)
    P = np.concatenate(loops + [inner])
    F, extra = constrained(P, loop_segments([len(p) for p in loops]), hole_seeds(loops))
    if extra.size:  # Triangle inserts points only where segments cross; these loops never do
        raise RuntimeError(f"face_scan: the outline and the hole crossed ({len(extra)} points inserted)")
    depth = face_depth(P) + (rng.normal(0.0, noise, P.shape[0]) if noise > 0 else 0.0)
    V = np.column_stack([P, depth]) @ ROTATION.T
    return np.ascontiguousarray(V), np.ascontiguousarray(F)
