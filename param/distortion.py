"""How much a map from a 3D mesh to the plane distorts: per-face measures, folds, summaries.

    rep = distortion_report(V, F, uv)     # angle/area percentiles, folds, score, warning
    rep["score"], rep["warning"]

The **score** of a map is its worst angle distortion ``angle_max`` (1 for a conformal map):
the C1 conditions and the fairing work on the uv triangles, and a single strongly sheared
or folded one ends as a spike in the fit, while area distortion alone does not (measured
on the shared meshes; see :data:`~trispline.spline.tolerances.ANGLE_DISTORTION_WARN`).
``parameterize(..., method="auto")`` ranks maps by it; :func:`warning` also names area
distortion above :data:`~trispline.spline.tolerances.AREA_DISTORTION_WARN`.
"""
from __future__ import annotations

from typing import Any

import numpy as np

from trispline.spline.checks import as_array, check_ids
from trispline.spline.tolerances import ANGLE_DISTORTION_WARN, AREA_DISTORTION_WARN, MIN_RELATIVE_AREA
from trispline.spline.topology import signed_areas

from .tables import loop_successors

#: Percentiles reported for each distortion measure.
PERCENTILES = (50, 90, 99)


def fold_mask(uv: np.ndarray, F: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(flipped (nf,), degenerate (nf,))`` masks, with Triangulation's relative area test."""
    a = signed_areas(uv, F)
    scale = max(np.abs(a).mean(), np.finfo(float).tiny)
    flipped = a < 0
    degenerate = ~flipped & (a <= MIN_RELATIVE_AREA * scale)
    return flipped, degenerate


def outline_crossings(uv: np.ndarray, loops: list[np.ndarray], *, tangle: int = 0) -> int:
    """How many pairs of the boundary ``loops``' segments (vertex ids into ``uv (nv, 2)``) cross or touch
    (0: the map is one-to-one where it is fold-free). A fold-free map can still cover part of the plane
    twice -- LSCM winds a three-turn helicoid strip three times around its centre -- which a fit over
    its triangles does not mind but anything that locates points in uv does (the approximation's coarse
    triangulation). Segments sharing a vertex id are not compared (:func:`segment_crossings`), nor, with
    ``tangle`` (e.g. :data:`TANGLE_SEGMENTS`), segments of one loop at most that many steps apart along it:
    a local tangle of a noisy outline (LSCM of a noisy 50k-vertex scan: 3 crossings among 4 consecutive
    segments of a hole), which thinning the outline removes, not a second cover of the plane.
    """
    ids = np.concatenate([np.asarray(l, np.int64) for l in loops]) if loops else np.zeros(0, np.int64)
    if ids.size < 3:
        return 0
    sizes = [len(l) for l in loops]
    nxt = ids[loop_successors(sizes)]
    a, b = np.asarray(uv, float)[ids], np.asarray(uv, float)[nxt]
    i, j = segment_crossings(a, b)
    keep = (ids[i] != ids[j]) & (ids[i] != nxt[j]) & (nxt[i] != ids[j]) & (nxt[i] != nxt[j])
    if tangle:
        loop = np.repeat(np.arange(len(sizes)), sizes)
        n = np.asarray(sizes)[loop[i]]
        step = np.abs(i - j)
        keep &= (loop[i] != loop[j]) | (np.minimum(step, n - step) > tangle)
    return int(np.count_nonzero(keep))


#: Crossings among segments of one loop at most this many steps apart are a local tangle of a noisy outline,
#: not an overlap of the map (:func:`outline_crossings`).
TANGLE_SEGMENTS = 8


def segment_crossings(a: np.ndarray, b: np.ndarray, c: np.ndarray | None = None, d: np.ndarray | None = None
                      ) -> tuple[np.ndarray, np.ndarray]:
    """Pairs ``(i, j)`` of segments ``a[i] -> b[i]`` and ``c[j] -> d[j]`` (all ``(n, 2)`` / ``(m, 2)``) that
    cross or touch, within :data:`TOUCH_RTOL` of their extent; without ``c, d`` the pairs ``i < j`` of the
    first set among themselves (then the caller drops pairs sharing an end, which always touch). Linear in
    the segments (a grid of half the median length finds the candidates) where Triangle, asked the same,
    crashes or fails on the outlines that need asking: segments between duplicated points, nearly
    collinear overlaps."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    one = c is None
    c, d = (a, b) if one else (np.asarray(c, float), np.asarray(d, float))
    i, j = _near_segment_pairs(np.r_[a, c] if not one else a, np.r_[b, d] if not one else b)
    if not one:  # pairs across the two sets only, renumbered
        n = a.shape[0]
        cross = (i < n) != (j < n)
        i, j = np.where(i[cross] < n, i[cross], j[cross]), np.where(i[cross] < n, j[cross], i[cross]) - n
    if not i.size:
        return i, j
    pa, pb, qa, qb = a[i], b[i], c[j], d[j]
    eps = TOUCH_RTOL * max(float(np.ptp(np.r_[a, b, c, d], axis=0).max()), np.finfo(float).tiny)

    def side(p, q, r):  # signed distance of r from the line p -> q (the segment's length in the unit)
        e = q - p
        return (e[:, 0] * (r[:, 1] - p[:, 1]) - e[:, 1] * (r[:, 0] - p[:, 0])) / np.maximum(
            np.hypot(e[:, 0], e[:, 1]), np.finfo(float).tiny)

    s1, s2 = side(pa, pb, qa), side(pa, pb, qb)
    s3, s4 = side(qa, qb, pa), side(qa, qb, pb)
    crossing = (s1 * s2 <= 0) & (s3 * s4 <= 0)
    # collinear pairs (all four within eps of each other's lines) cross only where their extents overlap
    flat = (np.abs(s1) <= eps) & (np.abs(s2) <= eps)
    if flat.any():
        e = pb - pa
        ta, tb = ((qa - pa) * e).sum(1), ((qb - pa) * e).sum(1)  # positions along segment i
        lo, hi = np.minimum(ta, tb), np.maximum(ta, tb)
        crossing &= ~flat | ((hi >= -eps * np.hypot(*e.T)) & (lo <= (e * e).sum(1) + eps * np.hypot(*e.T)))
    near = (np.minimum.reduce([np.abs(s1), np.abs(s2), np.abs(s3), np.abs(s4)]) <= eps)
    hit = crossing | (near & _endpoint_touches(pa, pb, qa, qb, eps))
    return i[hit], j[hit]


#: Segments closer than this fraction of their extent touch (:func:`segment_crossings`).
TOUCH_RTOL = 1e-12


def _endpoint_touches(a1: np.ndarray, b1: np.ndarray, a2: np.ndarray, b2: np.ndarray, eps: float) -> np.ndarray:
    """``(m,)``: an end of one segment lies within ``eps`` of the other segment (a T-touch)."""
    def dist(p, a, b):
        d = b - a
        t = np.clip(((p - a) * d).sum(1) / np.maximum((d * d).sum(1), np.finfo(float).tiny), 0.0, 1.0)
        return np.hypot(*(a + t[:, None] * d - p).T)

    return np.minimum.reduce([dist(a2, a1, b1), dist(b2, a1, b1), dist(a1, a2, b2), dist(b1, a2, b2)]) <= eps


def _near_segment_pairs(a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Pairs ``(i, j)``, ``i < j``, of segments ``a -> b (n, 2)`` that may meet: each is sampled at half a
    cell (the median segment length) and two segments are a pair where their samples fall in neighbouring
    cells (any common point is within a quarter cell of a sample on each)."""
    length = np.hypot(*(b - a).T)
    h = max(float(np.median(length)), float(np.ptp(np.r_[a, b], axis=0).max()) * 1e-9, np.finfo(float).tiny)
    count = np.ceil(length / (0.5 * h)).astype(np.int64) + 1
    seg = np.repeat(np.arange(a.shape[0]), count)
    t = (np.arange(seg.size) - np.repeat(np.cumsum(count) - count, count)) / np.repeat(count - 1, count)
    cell = np.floor((a[seg] + t[:, None] * (b - a)[seg]) / h).astype(np.int64)
    cell -= cell.min(0)
    width = int(cell[:, 1].max()) + 3
    key = (cell[:, 0] + 1) * width + cell[:, 1] + 1
    order = np.lexsort((seg, key))  # the distinct (cell, segment) pairs, by cell: two flat keys sort ~10x
    key, seg = key[order], seg[order]  # faster than np.unique(..., axis=0) on their rows
    first = np.r_[True, (key[1:] != key[:-1]) | (seg[1:] != seg[:-1])]
    cells, segs = key[first], seg[first]
    shifts = np.array([dx * width + dy for dx in (-1, 0, 1) for dy in (-1, 0, 1)])
    probe = (cells[:, None] + shifts).ravel()
    lo = np.searchsorted(cells, probe, "left")
    n = np.searchsorted(cells, probe, "right") - lo
    i = np.repeat(np.repeat(segs, shifts.size), n)
    j = segs[np.repeat(lo, n) + np.arange(n.sum()) - np.repeat(np.cumsum(n) - n, n)]
    m = a.shape[0]
    pairs = np.unique((np.minimum(i, j) * m + np.maximum(i, j))[i != j])  # i < j < m: no overflow below 3e9
    return pairs // m, pairs % m


def face_jacobians(V: np.ndarray, F: np.ndarray, uv: np.ndarray) -> np.ndarray:
    """Jacobians ``(nf, 2, 2)`` of the affine map from each 3D face (in a local
    orthonormal frame of its plane) to its uv triangle."""
    a, b, c = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
    e1, e2 = b - a, c - a
    x = e1 / np.linalg.norm(e1, axis=1, keepdims=True)
    n = np.cross(e1, e2)
    y = np.cross(n, x)
    y /= np.linalg.norm(y, axis=1, keepdims=True)
    P = np.stack([np.stack([(e1 * x).sum(1), (e2 * x).sum(1)], -1),
                  np.stack([(e1 * y).sum(1), (e2 * y).sum(1)], -1)], axis=1)  # (nf, 2, 2) columns = edges
    q0 = uv[F[:, 0]]
    Q = np.stack([uv[F[:, 1]] - q0, uv[F[:, 2]] - q0], axis=-1)  # (nf, 2, 2)
    det = P[:, 0, 0] * P[:, 1, 1] - P[:, 0, 1] * P[:, 1, 0]
    Pinv = np.stack([np.stack([P[:, 1, 1], -P[:, 0, 1]], -1),
                     np.stack([-P[:, 1, 0], P[:, 0, 0]], -1)], axis=1) / det[:, None, None]
    return Q @ Pinv


def face_distortion(V: np.ndarray, F: np.ndarray, uv: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(angle, area)``, each ``(nf,)`` and >= 1 (1 = no distortion).

    ``angle`` is the ratio of singular values ``s1 / s2`` of each face's Jacobian
    (1 for a conformal map: a similarity on every face); ``area`` is ``max(r, 1/r)`` of the face's share of
    the total uv area over its share of the total 3D area.
    """
    J = face_jacobians(V, F, uv)
    a, b, c, d = J[:, 0, 0], J[:, 0, 1], J[:, 1, 0], J[:, 1, 1]
    q = np.hypot(0.5 * (a + d), 0.5 * (c - b))  # closed-form 2x2 singular values
    r_ = np.hypot(0.5 * (a - d), 0.5 * (c + b))
    with np.errstate(divide="ignore", invalid="ignore"):
        angle = (q + r_) / np.abs(q - r_)
        det = np.abs(a * d - b * c)
        a3 = 0.5 * np.linalg.norm(np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]]), axis=1)
        r = det * (a3.sum() / (a3 * det).sum())  # (uv area / total uv) / (3D area / total 3D)
        area = np.maximum(r, 1.0 / r)
    return angle, area


def summarize(angle: np.ndarray, area: np.ndarray) -> dict:
    """Flat dict ``angle_p50 ... angle_max, area_p50 ... area_max`` (floats)."""
    out: dict = {}
    for name, x in (("angle", angle), ("area", area)):
        x = np.where(np.isfinite(x), x, np.inf)
        for p, val in zip(PERCENTILES, np.percentile(x, PERCENTILES)):
            out[f"{name}_p{p}"] = float(val)
        out[f"{name}_max"] = float(x.max())
    return out


def score(summary: dict[str, Any]) -> float:
    """The distortion score of a :func:`summarize` dict: its worst angle distortion ``angle_max`` (>= 1)."""
    return float(summary["angle_max"])


def warning(summary: dict[str, Any], folds: int = 0, method: str | None = None, repaired: str | None = None
            ) -> str | None:
    """Why a map with this summary (and ``folds`` folded faces) deserves a warning, or None.

    ``method`` (the map's) words the advice: another method only where one could help; ``repaired`` names the
    map that replaced a folded one (SLIM's: suggesting it again would say nothing).
    """
    why = []
    if folds:
        why.append(f"{folds} folded triangles (repaired)")
    if summary["angle_max"] > ANGLE_DISTORTION_WARN:
        why.append(f"angle distortion max {summary['angle_max']:.3g} (p99 {summary['angle_p99']:.3g}) "
                   f"above {ANGLE_DISTORTION_WARN:g}")
    sheared = bool(why)
    if summary["area_p99"] > AREA_DISTORTION_WARN:
        why.append(f"area distortion p99 {summary['area_p99']:.3g} (max {summary['area_max']:.3g}) "
                   f"above {AREA_DISTORTION_WARN:g}")
    if not why:
        return None
    if folds and method == "uv":  # the user's parameters folded: the repaired map replaced them
        advice = ("; the given uv folded, so the fit uses the repaired map, not that uv (or --param auto maps the "
                  "mesh itself)")
    elif sheared and method == "uv":  # the user's own parameters: another map would change what is fitted
        advice = ("; the fit may spike there: the given uv is used as is (thin triangles: trispline info --repair; "
                  "or --param auto maps the mesh itself)")
    elif sheared and method not in ("slim", "auto") and repaired != "slim":
        advice = "; the fit may spike there: try --param auto or --param slim"
    elif sheared:
        advice = "; the fit may spike there: check the mesh for slivers and folds (trispline info --repair)"
    else:
        advice = " (the uv resolution of the fit varies as much between regions)"
    return f"the parameterization is strongly distorted: {'; '.join(why)}{advice}"


def distortion_report(V: np.ndarray, F: np.ndarray, uv: np.ndarray) -> dict[str, Any]:
    """Distortion of the map ``uv`` of the mesh ``(V, F)``.

    Parameters
    ----------
    V : (nv, 3) float64, F : (nf, 3) int, uv : (nv, 2) float64

    Returns
    -------
    dict
        ``angle_p50/p90/p99/max`` (singular value ratio, 1 = conformal), ``area_p50/p90/p99/max``
        (area share ratio, 1 = equiareal), ``flipped`` and ``degenerate`` (face counts),
        ``score`` (:func:`score`) and ``warning`` (:func:`warning`: text or None).

    Raises
    ------
    InputError
        Arrays of the wrong shape or dtype, non-finite values, face ids out of range.
    """
    V = as_array(V, "V", (None, 3), finite=True)
    F = check_ids(as_array(F, "F", (None, 3), integer=True, min_rows=1), "F", V.shape[0])
    uv = as_array(uv, "uv", (V.shape[0], 2), finite=True)
    out = summarize(*face_distortion(V, F, uv))
    flipped, degenerate = fold_mask(uv, F)
    out.update(flipped=int(flipped.sum()), degenerate=int(degenerate.sum()), score=score(out))
    out["warning"] = warning(out, out["flipped"] + out["degenerate"])
    return out


def conformal_energy(V: np.ndarray, F: np.ndarray, uv: np.ndarray) -> float:
    """Area-weighted conformal (MIPS) energy ``sum A_f (s1 / s2 + s2 / s1)`` of the map (2 x area for
    a conformal map; infinite for a fold or a non-finite map), the energy :func:`~trispline.param.methods.slim_uv` lowers."""
    J = face_jacobians(V, F, uv)
    if not np.isfinite(J).all() or (np.linalg.det(J) <= 0).any():
        return float(np.inf)
    s = np.linalg.svd(J, compute_uv=False)
    a3 = 0.5 * np.linalg.norm(np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]]), axis=1)
    return float((a3 * (s[:, 0] / s[:, 1] + s[:, 1] / s[:, 0])).sum())
