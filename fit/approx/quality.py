"""Triangle quality of a coarse domain: face angles, and moving interior vertices off slivers.

    ang = face_angles(uv, faces)                                  # (f, 3) degrees
    ids = better_vertices(uv_scan, ids, faces, movable, allowed)  # ids (k,) with some interior ones moved

Snapping Triangle's points to scan vertices moves each by up to a fraction of the
local spacing, so two neighbours can end up close and make a thin triangle. A
vertex of a face with an angle below :data:`REPAIR_ANGLE` is moved to the nearby
scan vertex (among :data:`REPAIR_CANDIDATES`) that maximises the smallest angle
of its star, the other vertices held fixed, if that is better. No two neighbours
move in the same round (the lower id goes first); the caller re-triangulates
between rounds.
"""
from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

__all__ = ["face_angles", "triangle_angles", "better_vertices", "REPAIR_ANGLE", "REPAIR_ROUNDS"]

#: Faces with an angle below this (degrees) have their movable vertices repaired.
REPAIR_ANGLE = 20.0
#: Rounds of repair (each followed by a new triangulation).
REPAIR_ROUNDS = 8
#: Scan vertices considered for each vertex moved.
REPAIR_CANDIDATES = 48


def triangle_angles(T: np.ndarray) -> np.ndarray:
    """Interior angles ``(..., 3)`` in degrees of triangles ``T (..., 3, 2)``, at their three corners."""
    a, b = T[..., [1, 2, 0], :] - T, T[..., [2, 0, 1], :] - T
    cos = np.einsum("...d,...d->...", a, b) / np.maximum(np.linalg.norm(a, axis=-1) * np.linalg.norm(b, axis=-1),
                                                        1e-300)
    return np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))


def face_angles(uv: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Interior angles ``(f, 3)`` in degrees of the uv triangles ``faces (f, 3)``, at their three corners."""
    return triangle_angles(uv[faces])


def _star_min_angle(c: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Smallest angle (degrees) of the triangles ``(c, a, b)`` (arrays ``(..., 2)``); -1 where not CCW."""
    T = np.stack(np.broadcast_arrays(c, a, b), axis=-2)  # (..., 3, 2)
    e1, e2 = T[..., 1, :] - T[..., 0, :], T[..., 2, :] - T[..., 0, :]
    ccw = e1[..., 0] * e2[..., 1] - e1[..., 1] * e2[..., 0] > 0
    return np.where(ccw, triangle_angles(T).min(-1), -1.0)


def better_vertices(uv: np.ndarray, tree: cKDTree, ids: np.ndarray, faces: np.ndarray, movable: np.ndarray,
                    allowed: np.ndarray) -> np.ndarray:
    """One round of repair: ``ids (k,)`` (scan ids of the domain's vertices) with some movable ones replaced.

    Parameters
    ----------
    uv : (n, 2) the scan's uv; tree : a KD-tree over it
    ids : (k,) scan ids of the domain vertices; faces : (f, 3) into ``ids``
    movable : (k,) bool, the vertices that may move (interior, not asked for)
    allowed : (n,) bool, scan vertices that may take a moved vertex's place
    """
    ang = face_angles(uv[ids], faces)
    bad = faces[ang.min(1) < REPAIR_ANGLE]
    cand_v = np.unique(bad[movable[bad]])
    if cand_v.size == 0:
        return ids
    # no two neighbours in one round: a vertex waits for any movable neighbour with a lower id
    e = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
    mark = np.zeros(ids.size, bool)
    mark[cand_v] = True
    both = e[mark[e[:, 0]] & mark[e[:, 1]]]
    wait = np.zeros(ids.size, bool)
    wait[both.max(1)] = True
    move = cand_v[~wait[cand_v]]
    # the star of each moving vertex: (vertex, a, b) with the face (vertex, a, b) counter-clockwise
    f, k = np.nonzero(np.isin(faces, move))
    v = faces[f, k]
    order = np.argsort(v, kind="stable")
    f, k, v = f[order], k[order], v[order]
    a, b = faces[f, (k + 1) % 3], faces[f, (k + 2) % 3]
    q = min(REPAIR_CANDIDATES, uv.shape[0])
    _, near = tree.query(uv[ids[move]], k=q)
    near = np.concatenate([ids[move][:, None], near.reshape(move.size, q)], axis=1)  # (m, q + 1); 0: stay
    slot = np.searchsorted(move, v)
    score = _star_min_angle(uv[near[slot]], uv[ids[a]][:, None], uv[ids[b]][:, None])  # (pairs, q + 1)
    starts = np.flatnonzero(np.concatenate([[True], v[1:] != v[:-1]]))
    worst = np.minimum.reduceat(score, starts, axis=0)  # (m, q + 1): the star's smallest angle per candidate
    ok = allowed[near] | (np.arange(q + 1) == 0)
    ok &= ~np.isin(near, ids) | (np.arange(q + 1) == 0)
    worst = np.where(ok, worst, -np.inf)
    best = np.argmax(worst, axis=1)
    out = ids.copy()
    out[move] = near[np.arange(move.size), best]
    _, first = np.unique(out, return_index=True)  # two moved onto one scan vertex: the later one stays
    dup = np.setdiff1d(np.arange(out.size), first)
    out[dup] = ids[dup]
    return out
