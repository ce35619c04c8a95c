"""Which scan vertices of each boundary loop the coarse domain keeps.

    kept, corners = thin_loop(loop, uv, V, spacing, scale, roughness)   # scan ids, in loop order

Along a loop (scan vertex ids, the domain on the left) the kept vertices are:

1. **corners**: where the outline turns by more than ``corner_angle``, measured in
   uv and in 3D between the directions of the arcs one local spacing behind and
   ahead (each between the centroids of its halves, so a jagged scan edge does
   not count as a corner), on the loop without its spikes (roughness above
   :data:`~.analysis.SPIKE_LEVELS`: never a corner), the largest turn within
   half a spacing;
2. **spacing**: between consecutive corners, vertices about one local spacing
   apart (the spacing field in uv, integrated along the loop), each nudged to
   the neighbour with the smallest roughness (a spike always; the others where
   the loop has at least :data:`NUDGE_STEPS` vertices per kept one): straight
   runs are thinned to the spacing;
3. **sagitta**: where a chord between kept vertices lies farther than
   :data:`SAGITTA` local spacings from a loop vertex it cuts off, the loop vertex
   halfway along that run too, repeated until none is left: curved runs and
   small holes keep their shape.
"""
from __future__ import annotations

import numpy as np
from scipy import ndimage

from trispline.param import polygon_area

from .analysis import SPIKE_LEVELS
from .locate import segment_foot

__all__ = ["thin_loop", "CORNER_ANGLE", "SAGITTA"]

#: Default turn (degrees) of the outline that makes a corner.
CORNER_ANGLE = 35.0
#: The arcs a turn is measured over are at most this share of the loop's length (:func:`_turn`).
REACH_SHARE = 0.2
#: Where the spacing reaches past that on the outer loop, a corner must also stand this share of
#: ``corner_angle`` above the lowest turn within the arcs' reach: on a round loop every turn is alike and
#: none is a corner, while a square's four stand 44 degrees above its sides' (:func:`_corners`).
PROMINENCE = 0.5
#: A corner's turn is also measured over arcs of this share of the spacing, and of its powers
#: (:func:`_split_merged`) ...
FINE = 0.25
#: ... down to arcs of this many of the loop's shorter segments (its 10th percentile).
FINEST_STEPS = 2.0
#: A chord may cut off loop vertices by at most this many local spacings.
SAGITTA = 0.25
#: Loop vertices per kept vertex at least, for the spaced ones to be nudged to a smoother neighbour.
NUDGE_STEPS = 6
#: Rounds of the sagitta refinement at most (each splits every bad chord at its run's middle).
SAGITTA_ROUNDS = 64


def _arc_centroids(p: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """Centroids ``(L, d)`` of the closed polyline ``p (L, d)`` between arc lengths ``lo`` and ``hi`` (``(L,)``,
    any reals: the loop repeats), from the cumulative first moment of its segments."""
    L = p.shape[0]
    q = np.roll(p, -1, axis=0)
    seg = np.linalg.norm(q - p, axis=1)
    s = np.concatenate([[0.0], np.cumsum(seg)])
    total = s[-1]
    mom = np.concatenate([np.zeros((1, p.shape[1])), np.cumsum(0.5 * (p + q) * seg[:, None], axis=0)])

    def moment(x: np.ndarray) -> np.ndarray:  # first moment of the arc [0, x], x any real
        lap, r = np.divmod(x, total)
        i = np.clip(np.searchsorted(s, r, side="right") - 1, 0, L - 1)
        f = r - s[i]
        part = f[:, None] * (p[i] + 0.5 * f[:, None] * (q[i] - p[i]) / np.maximum(seg[i], 1e-300)[:, None])
        return lap[:, None] * mom[-1] + mom[i] + part

    return (moment(hi) - moment(lo)) / np.maximum(hi - lo, 1e-300)[:, None]


def _turn(p: np.ndarray, reach: np.ndarray) -> np.ndarray:
    """Turn angle (radians) ``(L,)`` of the closed polyline ``p (L, d)`` at each vertex: between the
    direction of the arc ``reach`` behind it and that of the arc ``reach`` ahead, each taken between
    the centroids of its two halves (a lone spike or a jagged edge moves them little)."""
    seg = np.linalg.norm(np.roll(p, -1, axis=0) - p, axis=1)
    s = np.concatenate([[0.0], np.cumsum(seg)])[:-1]
    r = np.minimum(reach, REACH_SHARE * seg.sum())
    back = _arc_centroids(p, s - 0.5 * r, s) - _arc_centroids(p, s - r, s - 0.5 * r)
    ahead = _arc_centroids(p, s + 0.5 * r, s + r) - _arc_centroids(p, s, s + 0.5 * r)
    na, nb = np.linalg.norm(back, axis=1), np.linalg.norm(ahead, axis=1)
    cos = np.einsum("nd,nd->n", back, ahead) / np.maximum(na * nb, 1e-300)
    return np.where((na > 0) & (nb > 0), np.arccos(np.clip(cos, -1.0, 1.0)), 0.0)


def _corners(loop: np.ndarray, uv: np.ndarray, V: np.ndarray, spacing: np.ndarray, scale: np.ndarray,
             smooth: np.ndarray, corner_angle: float) -> tuple[np.ndarray, np.ndarray]:
    """Positions in the loop of its corners (sorted), and the turn at every loop vertex; the turn is
    measured on the loop without its spikes (``smooth (L,)`` False), which get turn 0.

    A corner is a turn above ``corner_angle`` that is the largest within half the spacing along the loop;
    on the outer loop, where the spacing reaches past the turn's arcs (:data:`REACH_SHARE`), within a tenth
    of the loop, and it must also stand out (:data:`PROMINENCE`): a hole's outline keeps its one largest
    turn there, as its coverage does not depend on it (applied to holes too, this lost beetle's and
    halftunnel's targets at equal size: model-to-scan RMS 0.31 -> 0.36 and 0.21 -> 0.51 of qslim's). Then,
    on the outer loop, the uv turn over ever shorter arcs splits a corner that merged two, and moves one that
    peaked beside a sharp turn onto it (:func:`_split_merged`; on a small round hole, jagged at the scan's
    spacing, it found up to 9 corners and a coarse face reached over the hole)."""
    keep = np.flatnonzero(smooth) if smooth.sum() >= 3 else np.arange(loop.size)
    p, x, h = uv[loop[keep]], V[loop[keep]], spacing[keep]
    t = np.maximum(_turn(p, h), _turn(x, h * scale[keep]))
    seg = np.linalg.norm(np.roll(p, -1, axis=0) - p, axis=1)
    span = float(seg.sum())
    arc = np.concatenate([[0.0], np.cumsum(seg)[:-1]])
    hm = float(np.median(h))
    window = 0.5 * hm  # arc length about a corner that holds no other
    corner = t > np.radians(corner_angle)
    outer = polygon_area(p) > 0  # the domain on the left: the outer loop runs counter-clockwise
    if outer and window > 0.5 * REACH_SHARE * span:  # a spacing beyond the loop's size: every turn is measured over the same arcs
        window = 0.5 * REACH_SHARE * span
        corner &= t - _arc_filter(t, arc, span, 2 * window, np.minimum) > np.radians(PROMINENCE * corner_angle)
    found = np.flatnonzero(corner & (t >= _arc_filter(t, arc, span, window, np.maximum)))
    share, short = FINE, float(np.percentile(seg, 10))
    arcs = min(hm, REACH_SHARE * span)  # a merged turn's corners lie within its arcs
    while outer and share * hm >= FINEST_STEPS * short:  # ever finer arcs, down to a few short segments
        fine = _turn(p, share * h)  # in uv: a boundary wavy in 3D has no corners to split out
        radius = 0.5 * min(share * hm, REACH_SHARE * span)  # half the arcs' length
        found = _split_merged(found, fine, arc, span, arcs, radius, corner_angle)
        share *= FINE
    turn = np.zeros(loop.size)
    turn[keep] = t
    return keep[found], turn


def _arc_filter(values: np.ndarray, arc: np.ndarray, span: float, radius: float, reduce: np.ufunc) -> np.ndarray:
    """``(L,)`` the largest (``reduce=np.maximum``) or least (``np.minimum``) of ``values (L,)`` within
    ``radius`` along a loop of length ``span`` (``arc (L,)``: the vertices' arc lengths; segments of any
    lengths, so a filter over a count of loop vertices would not do): a filter on a uniform resampling."""
    if not 2.0 * radius < span:  # the window holds the whole loop (a loop of (nearly) no length too)
        return np.full(values.size, reduce.reduce(values))
    m = 4 * values.size
    at = np.minimum((arc / max(span, 1e-300) * m).astype(np.int64), m - 1)  # each vertex's cell
    cells = np.full(m, -np.inf if reduce is np.maximum else np.inf)
    reduce.at(cells, at, values)
    filled = np.zeros(m, bool)
    filled[at] = True
    last = np.maximum.accumulate(np.where(filled, np.arange(m), -1))
    cells = cells[np.where(last >= 0, last, at.max())]  # an empty cell: the vertex before it
    f = ndimage.maximum_filter1d if reduce is np.maximum else ndimage.minimum_filter1d
    return f(cells, 2 * int(np.ceil(radius / max(span, 1e-300) * m)) + 1, mode="wrap")[at]


def _split_merged(found: np.ndarray, fine: np.ndarray, arc: np.ndarray, span: float, reach: float, peak: float,
                  corner_angle: float) -> np.ndarray:
    """``found`` sharpened by the ``fine (L,)`` turn, measured over arcs of length ``2 peak`` (``arc (L,)``: arc
    length along the loop, ``span``: its length). A corner blunt there that holds two or more sharp peaks of
    it (each the largest within ``peak``) within ``reach`` is replaced by those peaks: two corners closer
    than the spacing (a strip's short side, an L's arm end) merge into one turn of their sum halfway
    between them, where the outline runs straight. A corner with one sharp peak within ``reach`` moves to
    it if it lies within ``2 peak`` (the longer arcs' turn, in 3D too, can peak a few loop vertices off a
    corner). A sharp peak also stands :data:`PROMINENCE` above the turns within ``2 peak``: over such arcs
    a small round hole turns 50 degrees everywhere, and split into all its vertices."""
    sharp_ok = fine > np.radians(corner_angle)
    stands = fine - _arc_filter(fine, arc, span, 2 * peak, np.minimum) > np.radians(PROMINENCE * corner_angle)
    sharp = np.flatnonzero(sharp_ok & stands & (fine >= _arc_filter(fine, arc, span, peak, np.maximum)))
    if found.size == 0 or sharp.size == 0:
        return found
    d = np.abs(arc[sharp][:, None] - arc[found][None])
    d = np.minimum(d, span - d)  # (S, C)
    several = (d <= reach).sum(0) >= 2
    merged = ~sharp_ok[found] & several
    close = d <= 2 * peak
    best = np.where(close, fine[sharp][:, None], -np.inf).argmax(0)
    moved = np.where(close.any(0) & ~several, sharp[best], found)  # two peaks near: a finer level splits it
    return np.union1d(moved[~merged], sharp[(d[:, merged] <= reach).any(1)])


def _spaced(tau: np.ndarray, anchors: np.ndarray, L: int) -> np.ndarray:
    """Loop positions about one unit of ``tau`` apart between consecutive ``anchors`` (cyclic)."""
    total = tau[-1]
    a0 = anchors
    t0 = tau[a0]
    t1 = np.concatenate([tau[a0[1:]], [tau[a0[0]] + total]])
    m = np.maximum(np.round(t1 - t0).astype(np.int64), 1)
    run = np.repeat(np.arange(a0.size), m - 1)
    j = np.arange(run.size) - np.repeat(np.cumsum(m - 1) - (m - 1), m - 1) + 1
    target = t0[run] + j * (t1 - t0)[run] / m[run]
    tau2 = np.concatenate([tau[:-1], tau[:-1] + total])
    pos = np.clip(np.searchsorted(tau2, target), 1, 2 * L - 1)
    pos = np.where(target - tau2[pos - 1] < tau2[pos] - target, pos - 1, pos)
    return pos % L


def _sagitta(p: np.ndarray, keep: np.ndarray, limit: np.ndarray) -> np.ndarray:
    """Sorted loop positions: ``keep`` plus, per chord that cuts off a loop vertex farther than
    ``limit`` (per vertex), the loop vertex halfway along its run, until every chord is within the limit
    (halving keeps the spacing even; a smooth run's sagitta falls four times a round)."""
    L = p.shape[0]
    for _ in range(SAGITTA_ROUNDS):
        nxt = np.concatenate([keep[1:], [keep[0] + L]])
        cnt = nxt - keep - 1  # loop vertices strictly between consecutive kept ones
        if cnt.max(initial=0) <= 0:
            return keep
        run = np.repeat(np.arange(keep.size), cnt)
        idx = (np.arange(run.size) - np.repeat(np.cumsum(cnt) - cnt, cnt) + 1 + keep[run]) % L
        _, foot = segment_foot(p[idx], p[keep[run]], p[nxt[run] % L])
        excess = np.linalg.norm(p[idx] - foot, axis=1) - limit[idx]
        worst = np.full(keep.size, -np.inf)
        np.maximum.at(worst, run, excess)
        bad = np.flatnonzero(worst > 0)
        if bad.size == 0:
            return keep
        keep = np.unique(np.concatenate([keep, (keep[bad] + 1 + cnt[bad] // 2) % L]))
    return keep


def thin_loop(loop: np.ndarray, uv: np.ndarray, V: np.ndarray, spacing: np.ndarray, scale: np.ndarray,
              roughness: np.ndarray, *, corner_angle: float = CORNER_ANGLE) -> tuple[np.ndarray, np.ndarray]:
    """The kept vertices of one boundary loop.

    Parameters
    ----------
    loop : (L,) scan vertex ids, the domain on the left
    uv : (n, 2), V : (n, 3) the scan's domain points and vertices
    spacing : (L,) the local target spacing in uv at each loop vertex
    scale : (L,) 3D length per uv length there (for the 3D turn)
    roughness : (n,) every scan vertex's residual against its local level (``ScanAnalysis.roughness``)

    Returns
    -------
    kept : (k,) scan ids in loop order (``k >= 3``); corners : (c,) the scan ids among them that are corners
    """
    L = loop.size
    corners, turn = _corners(loop, uv, V, spacing, scale, roughness[loop] <= SPIKE_LEVELS, corner_angle)
    anchors = corners if corners.size else np.array([int(np.argmax(turn))])
    p = uv[loop]
    seg = np.linalg.norm(np.roll(p, -1, axis=0) - p, axis=1)
    tau = np.concatenate([[0.0], np.cumsum(seg / np.maximum(0.5 * (spacing + np.roll(spacing, -1)), 1e-300))])
    spaced = _spaced(tau, anchors, L)
    # nudge each spaced vertex to the smoothest of its two loop neighbours and itself: every spike, and
    # the others where a step of one loop vertex is small against the spacing (no short boundary edges)
    nudge = roughness[loop[spaced]] > SPIKE_LEVELS
    nudge |= L >= NUDGE_STEPS * max(spaced.size + anchors.size, 1)
    cand = (spaced[nudge, None] + np.array([-1, 0, 1])) % L
    spaced[nudge] = cand[np.arange(cand.shape[0]), np.argmin(roughness[loop[cand]], axis=1)]
    keep = np.unique(np.concatenate([anchors, spaced]))
    if keep.size < 3:
        keep = np.unique(np.concatenate([keep, (keep[0] + np.array([L // 3, (2 * L) // 3])) % L]))
    keep = _sagitta(p, keep, SAGITTA * spacing)
    # a spike that the sagitta or the minimum of three brought in gives way to a smoother neighbour
    spike = np.flatnonzero((roughness[loop[keep]] > SPIKE_LEVELS) & ~np.isin(keep, anchors))
    if spike.size:
        cand = (keep[spike, None] + np.array([-1, 1])) % L
        alt = cand[np.arange(spike.size), np.argmin(roughness[loop[cand]], axis=1)]
        free = ~np.isin(alt, keep)
        keep[spike[free]] = alt[free]
        keep = np.unique(keep)
    return loop[keep], loop[corners]
