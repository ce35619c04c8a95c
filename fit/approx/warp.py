"""The scan's uv warped so that its outline follows the coarse domain's boundary chords.

    uv = outline_warp(dom)                    # (n, 2): the scan's parameters in the coarse domain
    ids, target = outline_targets(dom)        # where each scan boundary vertex goes

A coarse domain's boundary is a polygon of chords between kept scan boundary vertices. Where
the scan's outline bulges out of a chord, its points lie outside the domain (the fit can only
clamp or extrapolate them); where it dents in, the patches over the dent have no data under
them and the surface there swings out into space (beetle at 2%: 12% of the surface's samples,
55% of its surface-to-scan sum of squares). The warp moves the outline onto the chords and
carries the interior along by the cotangent-harmonic extension of that displacement
(``igl.harmonic`` on the scan in uv) over the boundary patches' band, zero at every coarse
vertex and beyond the band.

How an outline run (the scan boundary vertices between two kept ones) goes onto its chord
depends on its shape:

* a **smooth** run (it turns back and forth by at most :data:`JAGGED_TURN` in all) goes onto the
  chord whole, each vertex at its fraction of the run's uv arc length: the spline's boundary
  curve is then fitted to the scan's own outline, and every point of it lies in the domain;
* a **jagged** run (a staircase, as a mask cut from a range image leaves) loses only its smooth
  bulge, the cubic ``s (1 - s) (c1 + c2 (2 s - 1))`` fitted to its offsets along the chord's
  normal: its teeth stay on both sides of the chord. Put on the chord whole, a staircase's arc
  length would misplace its points along it by up to a step, and the surface would wiggle to
  follow (generated-100k-clean at 2%: the surface-to-scan maximum 2.6x that of the cubic's).

The coarse vertices keep their uv exactly (a corner point still sits at its data vertex's
parameter). Around a scan triangle the warp would fold, it is halved, a few times at most
(:func:`_unfolded_scale`).
"""
from __future__ import annotations

from typing import TYPE_CHECKING

import igl
import numpy as np

from trispline.spline.topology import signed_areas

if TYPE_CHECKING:
    from .domain import CoarseDomain

__all__ = ["outline_warp", "outline_targets", "OUTLINE_WARP", "JAGGED_TURN", "SHRINK_ROUNDS"]

#: Whether the scan's parameters follow the warp (:attr:`~.domain.CoarseDomain.warped_uv`; off: the scan's
#: own uv, clamped or extrapolated outside the domain).
OUTLINE_WARP = True
#: A run whose turns add up to more than this (degrees) beyond its net turn is jagged (a smooth arc turns
#: one way only: the shared scans' smooth runs turn back by at most 12 degrees but for a few, a staircase
#: by 400-800).
JAGGED_TURN = 90.0
#: Rounds of halving the warp around folded scan triangles (the last one sets it to zero there).
SHRINK_ROUNDS = 6


def outline_targets(dom: "CoarseDomain") -> tuple[np.ndarray, np.ndarray]:
    """``(ids (b,), target (b, 2))``: every scan boundary vertex and where the warp puts it (see the module
    docstring; kept vertices stay)."""
    uv = dom.scan_uv
    ids, target = [], []
    for kept, loop in zip(dom.boundary, dom.loops):
        p = uv[loop]
        start = np.flatnonzero(np.isin(loop, kept))  # kept positions in loop order
        run = np.searchsorted(start, np.arange(loop.size), side="right") - 1  # the run each position starts
        run[run < 0] = start.size - 1  # before the first kept vertex: the last run (wraps)
        a, b = p[start[run]], p[start[(run + 1) % start.size]]
        s = _arc_fraction(p, start, run)
        chord = a + s[:, None] * (b - a)
        jagged = _jagged(p, start, run)
        bump = p - _run_bumps(p, a, b, s, run, start.size)
        ids.append(loop)
        target.append(np.where(jagged[run][:, None], bump, chord))
    return np.concatenate(ids), np.concatenate(target)


def _arc_fraction(p: np.ndarray, start: np.ndarray, run: np.ndarray) -> np.ndarray:
    """``(L,)`` each loop point's fraction of its run's uv arc length (``p (L, 2)`` the loop, ``start`` the kept
    positions, ``run (L,)`` each point's run)."""
    arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.roll(p, -1, axis=0) - p, axis=1))])
    total = arc[-1]
    a_pos, b_pos = start[run], start[(run + 1) % start.size]
    length = (arc[b_pos] - arc[a_pos]) % total
    length = np.where(length <= 0, total, length)  # one kept vertex: the run is the whole loop
    return ((arc[:-1] - arc[a_pos]) % total) / length


def _jagged(p: np.ndarray, start: np.ndarray, run: np.ndarray) -> np.ndarray:
    """``(runs,)`` bool: the run turns back and forth by more than :data:`JAGGED_TURN` in all (the sum of
    its inner vertices' absolute turns less the absolute sum)."""
    d = np.roll(p, -1, axis=0) - p  # edge i: from point i to i + 1
    heading = np.arctan2(d[:, 1], d[:, 0])
    turn = np.angle(np.exp(1j * (heading - np.roll(heading, 1))))  # at point i, from edge i - 1 to edge i
    inner = np.ones(p.shape[0], bool)
    inner[start] = False
    total = np.bincount(run[inner], np.abs(turn[inner]), start.size)
    net = np.bincount(run[inner], turn[inner], start.size)
    return total - np.abs(net) > np.radians(JAGGED_TURN)


def _run_bumps(p: np.ndarray, a: np.ndarray, b: np.ndarray, s: np.ndarray, run: np.ndarray, runs: int
               ) -> np.ndarray:
    """``(L, 2)`` each point's share of its run's smooth bulge off the chord ``a b`` (rows per point): the
    signed offsets along the chord's normal fitted per run by ``s (1 - s) (c1 + c2 (2 s - 1))`` (zero at
    the kept ends) in least squares, times the normal."""
    e = b - a
    n = np.column_stack([-e[:, 1], e[:, 0]]) / np.maximum(np.linalg.norm(e, axis=1), 1e-300)[:, None]
    o = np.einsum("md,md->m", p - a, n)
    phi = np.column_stack([s * (1 - s), s * (1 - s) * (2 * s - 1)])
    G = np.stack([np.bincount(run, phi[:, i] * phi[:, j], runs) for i in range(2) for j in range(2)], 1)
    trace = G[:, 0] + G[:, 3]
    fit = trace > 0  # a run with inner points (its kept ends have phi = 0)
    c = np.zeros((runs, 2))
    if fit.any():
        Gf = G[fit].reshape(-1, 2, 2) + 1e-12 * np.eye(2) * trace[fit][:, None, None]  # rank one with one point
        r = np.stack([np.bincount(run, phi[:, i] * o, runs) for i in range(2)], 1)[fit]
        c[fit] = np.linalg.solve(Gf, r[..., None])[..., 0]
    return np.einsum("mk,mk->m", phi, c[run])[:, None] * n


def _band(dom: "CoarseDomain") -> np.ndarray:
    """``(n,)`` bool: scan vertices outside the domain or in a face with a boundary vertex."""
    hit = dom.locate_scan()
    on = np.zeros(dom.uv.shape[0], bool)
    on[: dom.stats.n_boundary] = True  # CoarseDomain.vertices: the boundary loops' first
    return hit.clamped | on[dom.faces[hit.face]].any(1)


def outline_warp(dom: "CoarseDomain") -> np.ndarray:
    """``(n, 2)`` the scan's uv with its outline on the coarse boundary chords (see the module docstring),
    over the scan's faces ``dom.scan_faces`` (counter-clockwise in ``dom.scan_uv``)."""
    uv, F = dom.scan_uv, dom.scan_faces
    ids, target = outline_targets(dom)
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
