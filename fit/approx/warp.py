"""The scan's uv warped so that its outline runs along the coarse domain's boundary chords.

    uv = outline_warp(dom, F)        # (n, 2): the scan's parameters in the coarse domain

A coarse domain's boundary is a polygon of chords between kept scan boundary vertices. Where
the scan's outline bulges out of a chord, its points lie outside the domain (the fit can only
clamp or extrapolate them); where it dents in, the patches over the dent have no data under
them and the surface there swings out into space (beetle at 2%: 12% of the surface's samples,
55% of its surface-to-scan sum of squares). The warp moves each scan boundary vertex onto its
run's chord (at its fraction of the run's uv arc length) and carries the interior along by the
cotangent-harmonic extension of that displacement (``igl.harmonic`` on the scan in uv) over the
boundary patches' band, zero at every coarse vertex and beyond the band. The spline's boundary
curve is then fitted to the scan's own outline, and every scan point lies in the domain.

The coarse vertices keep their uv exactly (a corner point still sits at its data vertex's
parameter). Where the warp would fold a scan triangle (a coarse vertex pinned in the squeezed
strip of a bulge), it is scaled down until none folds; :data:`MIN_WARP` of it or less: no warp.
"""
from __future__ import annotations

from typing import TYPE_CHECKING

import igl
import numpy as np

from trispline.spline.topology import signed_areas

if TYPE_CHECKING:
    from .domain import CoarseDomain

__all__ = ["outline_warp", "chord_targets", "OUTLINE_WARP", "SHRINK_ROUNDS"]

#: Whether the scan's parameters follow the warp (:attr:`~.domain.CoarseDomain.warped_uv`; off: the scan's
#: own uv, clamped or extrapolated outside the domain).
OUTLINE_WARP = True
#: Rounds of halving the warp around folded scan triangles (the last one sets it to zero there).
SHRINK_ROUNDS = 6


def chord_targets(dom: "CoarseDomain") -> tuple[np.ndarray, np.ndarray]:
    """``(ids (b,), target (b, 2))``: every scan boundary vertex and its point on its run's chord, at its
    fraction of the run's uv arc length (kept vertices: their own uv)."""
    uv = dom.scan_uv
    ids, target = [], []
    for kept, loop in zip(dom.boundary, dom.loops):
        pos = np.full(uv.shape[0], -1, np.int64)
        pos[loop] = np.arange(loop.size)
        start = np.sort(pos[kept])  # kept positions in loop order
        seg = np.linalg.norm(uv[np.roll(loop, -1)] - uv[loop], axis=1)  # loop edge i -> i+1
        arc = np.concatenate([[0.0], np.cumsum(seg)])  # arc[i]: length from loop[0] to loop[i]
        total = arc[-1]
        run = np.searchsorted(start, np.arange(loop.size), side="right") - 1  # the run each position is in
        run[run < 0] = start.size - 1  # before the first kept vertex: the last run (wraps)
        a_pos = start[run]
        b_pos = start[(run + 1) % start.size]
        s_a = arc[a_pos]
        length = (arc[b_pos] - s_a) % total
        length = np.where(length <= 0, total, length)
        frac = ((arc[:-1] - s_a) % total) / length
        a, b = uv[loop[a_pos]], uv[loop[b_pos]]
        ids.append(loop)
        target.append(a + frac[:, None] * (b - a))
    return np.concatenate(ids), np.concatenate(target)


def _band(dom: "CoarseDomain") -> np.ndarray:
    """``(n,)`` bool: scan vertices outside the domain or in a face with a boundary vertex."""
    hit = dom.locate(dom.scan_uv)
    on = np.zeros(dom.uv.shape[0], bool)
    nb = sum(b.size for b in dom.boundary)
    on[:nb] = True  # CoarseDomain.vertices: the boundary loops' first
    return hit.clamped | on[dom.faces[hit.face]].any(1)


def outline_warp(dom: "CoarseDomain", F: np.ndarray) -> np.ndarray:
    """``(n, 2)`` the scan's uv with its outline on the coarse boundary chords (see the module docstring);
    ``F (m, 3)`` the scan's faces."""
    uv = dom.scan_uv
    ids, target = chord_targets(dom)
    shift = np.zeros_like(uv)
    shift[ids] = target - uv[ids]
    if not np.any(shift):
        return uv
    free = _band(dom)
    free[ids] = False
    free[dom.vertices] = False
    if free.any():
        shift = _harmonic_band(uv, F, shift, free)
    return uv + _unfolded_scale(uv, F, shift, ids)[:, None] * shift


def _harmonic_band(uv: np.ndarray, F: np.ndarray, shift: np.ndarray, free: np.ndarray) -> np.ndarray:
    """``shift (n, 2)`` with its ``free (n,)`` rows replaced by the cotangent-harmonic extension
    (``igl.harmonic`` over the faces that hold a free vertex) of the other rows' values."""
    band = F[free[F].any(1)]
    used, local = np.unique(band, return_inverse=True)
    fixed = np.flatnonzero(~free[used])
    uv3 = np.column_stack([uv[used], np.zeros(used.size)])
    out = shift.copy()
    out[used] = igl.harmonic(uv3, local.reshape(-1, 3).astype(np.int64), fixed.astype(np.int64),
                             np.ascontiguousarray(shift[used[fixed]]), 1)
    return out


def _unfolded_scale(uv: np.ndarray, F: np.ndarray, shift: np.ndarray, outline: np.ndarray) -> np.ndarray:
    """``(n,)`` per-vertex fractions of ``shift`` that fold no scan triangle: 1, halved around every fold
    (its vertices and their neighbours) until none is left, at most :data:`SHRINK_ROUNDS` times (then 0
    there). A triangle with all three vertices on the outline (an ear) is not judged: put on its chord it
    is flat, and the outline's order along the chord is kept."""
    judged = ~np.isin(F, outline).all(1) & (signed_areas(uv, F) > 0)
    Fj = F[judged]
    scale = np.ones(uv.shape[0])
    for r in range(SHRINK_ROUNDS + 1):
        bad = signed_areas(uv + scale[:, None] * shift, Fj) <= 0
        if not bad.any():
            return scale
        around = np.isin(Fj, Fj[bad]).any(1)  # the folded faces' vertices and their neighbours
        scale[Fj[around].ravel()] *= 0.0 if r == SHRINK_ROUNDS - 1 else 0.5
    return np.zeros(uv.shape[0]) if (signed_areas(uv + scale[:, None] * shift, Fj) <= 0).any() else scale
