"""Repair of a broken scan into a mesh :func:`~trispline.param.validate_mesh` can accept.

    r = repair_mesh(V, F)
    r.V, r.F                      # the repaired mesh
    r.source_vertex_index         # (nv',) input vertex of each output vertex
    r.changes, r.messages         # counts per kind of change, and the same in words

In this order, all vectorised: faces with non-finite corners, a repeated vertex id, zero
area (:func:`~trispline.param.validate.zero_area_faces`) or the vertex set of an earlier
face are dropped; every edge keeps at most two faces (the first, and the first after it
that runs the edge the other way, else the next one); then every vertex is split into one
copy per fan of faces that the kept edges join, which separates bowtie vertices and cuts
fins off along their non-manifold edge; then the hull slivers of a triangulation of scattered
points are peeled off the outline (:func:`~trispline.param.hull.hull_sliver_faces`); then folded
flaps are cut off (faces across an edge whose normals point apart: the side that disagrees with
the faces around it goes), where the cut leaves fans meeting at a vertex only the largest stays,
and what is still non-manifold is split again; last, only the largest connected component (by
faces) is kept. Orientation is left to :func:`validate_mesh`, which repairs it.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from trispline.spline.checks import check_ids
from trispline.spline.topology import outline_vertex_mask

from .errors import MeshError
from .hull import hull_sliver_faces
from .tables import corner_fans, edge_pairs, orientation_classes, undirected_edges, vertex_components
from .validate import as_mesh_arrays, duplicate_faces, folded_edges, repeated_vertex_faces, zero_area_faces

__all__ = ["RepairedMesh", "repair_mesh"]

#: Rounds of edge-cutting and vertex-splitting before giving up (one suffices unless a cut
#: face reaches the kept ones again around a vertex).
MAX_SPLIT_ROUNDS = 8
#: Rounds of flap cutting (each removes at least one face of every fold left).
MAX_FLAP_ROUNDS = 32


@dataclass(frozen=True, eq=False)
class RepairedMesh:
    """The result of :func:`repair_mesh`.

    Attributes
    ----------
    V : (nv', 3) float64
    F : (nf', 3) int64
    source_vertex_index : (nv',) int64
        Input vertex of each output vertex (a split vertex appears several times).
    source_face_index : (nf',) int64
        Input face of each output face (the kept faces, in input order).
    changes : dict of str -> int
        ``non_finite_faces``, ``repeated_vertex_faces``, ``zero_area_faces``,
        ``duplicate_faces``, ``non_manifold_edges``, ``hull_sliver_faces``, ``folded_flap_faces``,
        ``pinched_fan_faces``, ``split_vertices`` (input vertices that became several), ``added_vertices``,
        ``dropped_components``, ``dropped_component_faces``,
        ``dropped_vertices`` (input vertices in no output face).
    messages : list of str
        The non-zero changes in words.
    """

    V: np.ndarray
    F: np.ndarray
    source_vertex_index: np.ndarray
    source_face_index: np.ndarray
    changes: dict = field(default_factory=dict)
    messages: list = field(default_factory=list)

    @property
    def changed(self) -> bool:
        """Whether anything was changed."""
        return any(self.changes.values())


def _drop_bad_faces(V: np.ndarray, F: np.ndarray, changes: dict) -> np.ndarray:
    """Indices ``(nf',)`` of the faces to keep: finite, three distinct ids, non-zero area, first of their vertex set."""
    keep = np.isfinite(V[F]).all((1, 2))
    changes["non_finite_faces"] = int((~keep).sum())
    rep = repeated_vertex_faces(F) & keep
    changes["repeated_vertex_faces"] = int(rep.sum())
    keep &= ~rep
    zero = np.zeros_like(keep)
    if keep.any():
        zero[keep] = zero_area_faces(V, F[keep])
    changes["zero_area_faces"] = int(zero.sum())
    keep &= ~zero
    idx = np.flatnonzero(keep)
    dup = duplicate_faces(F[idx])
    changes["duplicate_faces"] = int(dup.sum())
    return idx[~dup]


def _manifold_pairs(F: np.ndarray, nv: int) -> tuple[np.ndarray, np.ndarray, int]:
    """``(h0, h1, n_cut)``: one half-edge pair per interior edge, at most two faces per edge.

    On an edge with more than two faces the first face (lowest index) is paired with the
    first later face that runs the edge the other way (else the next face); the others are cut.
    """
    he, _, he_edge, edge_count = undirected_edges(F, nv)
    order = np.argsort(he_edge, kind="stable")
    e_sorted = he_edge[order]
    start = np.flatnonzero(np.r_[True, e_sorted[1:] != e_sorted[:-1]])
    count = edge_count[e_sorted[start]]
    group = np.repeat(np.arange(start.size), count)
    first = order[start][group]
    later = np.arange(order.size) != start[group]
    opposite = later & (he[order, 0] == he[first, 1])
    # the partner: the first opposite half-edge of the group, else the one after the first
    cand = np.flatnonzero(opposite)
    partner = start + 1
    g, at = np.unique(group[cand], return_index=True)
    partner[g] = cand[at]
    inner = count >= 2
    return order[start[inner]], order[partner[inner]], int((count > 2).sum())


def _split_fans(F: np.ndarray, nv: int) -> tuple[np.ndarray, np.ndarray, int]:
    """``(F', source (nv',), n_cut)``: one vertex per (vertex, fan) over the manifold pairs."""
    h0, h1, n_cut = _manifold_pairs(F, nv)
    lab = corner_fans(F, h0, h1)
    key = F.ravel().astype(np.int64) * np.int64(3 * F.shape[0]) + lab
    uniq, inv = np.unique(key, return_inverse=True)
    return inv.reshape(-1, 3).astype(np.int64), uniq // (3 * F.shape[0]), n_cut


def _manifold(F: np.ndarray, source: np.ndarray) -> tuple[np.ndarray, np.ndarray, int]:
    """``(F', source', n_cut)``: edges cut to two faces and vertices split per fan until none is left."""
    cut = 0
    for _ in range(MAX_SPLIT_ROUNDS):
        F, src, n_cut = _split_fans(F, source.size)
        source = source[src]
        cut += n_cut
        if n_cut == 0:
            return F, source, cut
    raise MeshError(f"repair could not resolve the non-manifold edges in {MAX_SPLIT_ROUNDS} rounds",
                    ["non_manifold_edges"])


def _oriented(F: np.ndarray, nv: int) -> np.ndarray:
    """``F`` with the rows of each orientable component of an edge-manifold mesh oriented alike."""
    nf = F.shape[0]
    he, _, he_edge, _ = undirected_edges(F, nv)
    lab = orientation_classes(F, he, he_edge)
    flip = lab[:nf] > lab[nf:]  # one of the two classes of each orientable component
    return np.where(flip[:, None], F[:, [0, 2, 1]], F)


def _agreement(V: np.ndarray, F: np.ndarray) -> np.ndarray:
    """Cosine ``(nf,)`` between each face's normal and the area-weighted normal of the other faces
    at its corners, the faces oriented alike first (per orientable component; an edge-manifold F)."""
    Fo = _oriented(F, V.shape[0])
    n = np.cross(V[Fo[:, 1]] - V[Fo[:, 0]], V[Fo[:, 2]] - V[Fo[:, 0]])  # (nf, 3), twice the area
    vn = np.zeros_like(V)
    for k in range(3):
        np.add.at(vn, Fo[:, k], n)
    ring = vn[Fo].sum(1) - 3 * n
    norm = np.linalg.norm(n, axis=1) * np.linalg.norm(ring, axis=1)
    return (n * ring).sum(1) / np.where(norm > 0, norm, 1.0)


def _cut_flaps(V: np.ndarray, F: np.ndarray) -> np.ndarray:
    """Indices ``(nf',)`` of the faces left when folded flaps are cut off an edge-manifold ``F``.

    A fold (:func:`~trispline.param.validate.folded_edges`) joins two faces whose normals point
    apart; the flap is the side that disagrees with the faces around it (:func:`_agreement`):
    every face of a fold that disagrees (negative cosine) goes, else the one of the two that agrees
    less; repeated until no fold is left. A face that folds against all three of its neighbours away
    from the rim is no flap but a lone flipped face inside (a vertex pushed across the opposite
    edge): it is kept, as are its folds (cutting it opens a hole, whose rim the fit bends more than
    the fold; measured on camelhead.off in docs/fit.md). A mesh without folds keeps every face.
    """
    keep = np.arange(F.shape[0])
    for _ in range(MAX_FLAP_ROUNDS):
        pairs, _ = folded_edges(V, F[keep])
        alone = np.bincount(pairs.ravel(), minlength=keep.size) == 3  # folds against all three neighbours
        rim = outline_vertex_mask(F[keep], V.shape[0])
        alone &= ~rim[F[keep]].any(1)  # on the rim, cutting it opens no hole
        pairs = pairs[~alone[pairs].any(1)]
        if not pairs.size:
            break
        agree = _agreement(V, F[keep])
        bad = np.unique(pairs[agree[pairs] < 0])
        if not bad.size:
            lower = np.argmin(agree[pairs], axis=1)
            bad = np.unique(pairs[np.arange(pairs.shape[0]), lower])
        keep = np.delete(keep, bad)
        if not keep.size:
            break
    return keep


def _drop_pinched_fans(F: np.ndarray, nv: int) -> np.ndarray:
    """Indices ``(nf',)`` of the faces left when, at every vertex where fans of an edge-manifold ``F``
    meet (a bowtie the flap cut made), only its largest fan is kept; repeated until none is left.
    A split would leave two vertices at one point, where an interpolating surface pinches."""
    keep = np.arange(F.shape[0])
    for _ in range(MAX_SPLIT_ROUNDS):
        Fk = F[keep]
        _, _, he_edge, _ = undirected_edges(Fk, nv)
        lab = corner_fans(Fk, *edge_pairs(he_edge))
        minor = ~_largest_of(lab, Fk.ravel(), nv).reshape(-1, 3).all(1)
        if not minor.any():
            break
        keep = keep[~minor]
    return keep


def _largest_of(group: np.ndarray, owner: np.ndarray, n_owners: int) -> np.ndarray:
    """``(k,)`` bool: whether each item's ``group (k,)`` is the largest (most items; the lowest label
    on ties) of the groups of its ``owner (k,)`` (ids in ``[0, n_owners)``)."""
    size = np.bincount(group)[group]
    score = size * (group.size + 1) + (group.size - group)
    best = np.zeros(n_owners, np.int64)
    np.maximum.at(best, owner, score)
    return best[owner] == score


def _drop_pinches(F: np.ndarray, source: np.ndarray) -> np.ndarray:
    """Indices ``(nf',)`` of the faces of the split, edge-manifold ``F`` left when every pinch is undone.

    A pinch: copies of one input vertex (``source``) in one connected piece, where the split left
    the piece's own fans meeting at one point (holes that touch at a vertex, the flap cut's bowties):
    an interpolating surface passes through that point twice, and the fit spiked there (docs/fit.md,
    "Spikes on real meshes"). Only the copy with the most faces keeps its faces; copies in different
    pieces (separate sheets glued at a point) stay, and the largest piece is chosen later. Where
    dropping faces makes fans meet at one copy, the smaller go too (:func:`_drop_pinched_fans`).
    """
    keep = _drop_pinched_fans(F, source.size)
    for _ in range(MAX_SPLIT_ROUNDS):
        Fk = F[keep]
        _, piece = vertex_components(Fk, source.size)
        corner = Fk.ravel()
        _, pair = np.unique(source[corner] * np.int64(source.size) + piece[corner], return_inverse=True)
        minor = ~_largest_of(corner, pair.ravel(), int(pair.max()) + 1).reshape(-1, 3).all(1)
        if not minor.any():
            break
        keep = keep[~minor]
        keep = keep[_drop_pinched_fans(F[keep], source.size)]
    return keep


def _largest(F: np.ndarray, nv: int, changes: dict) -> np.ndarray:
    """Indices of the faces of the component with the most faces."""
    ncomp, vlab = vertex_components(F, nv)
    flab = vlab[F[:, 0]]
    sizes = np.bincount(flab, minlength=ncomp)
    big = int(np.argmax(sizes))
    kept = np.flatnonzero(flab == big)
    changes["dropped_components"] = int((sizes > 0).sum() - 1)
    changes["dropped_component_faces"] = int(F.shape[0] - kept.size)
    return kept


_WORDS = {
    "non_finite_faces": "dropped {} faces with non-finite (NaN or inf) corners",
    "repeated_vertex_faces": "dropped {} faces naming a vertex twice",
    "zero_area_faces": "dropped {} zero-area faces",
    "duplicate_faces": "dropped {} duplicate faces (same three vertices as an earlier face)",
    "non_manifold_edges": "cut {} non-manifold edges down to two faces each",
    "hull_sliver_faces": "peeled {} hull slivers off the outline (long thin faces along the convex hull of scattered points)",
    "folded_flap_faces": "cut off {} faces of folded flaps (adjacent faces whose normals point apart)",
    "pinched_fan_faces": "dropped {} faces of the smaller fans where one piece of the surface met itself at a vertex",
    "split_vertices": "split {} bowtie or non-manifold vertices into one copy per fan of faces ({} added)",
    "dropped_components": "dropped {} smaller connected components ({} faces)",
    "dropped_vertices": "{} input vertices are in no output face",
}
#: Counts told in the message of another (key -> the key whose message shows it).
_TOLD_WITH = {"added_vertices": "split_vertices", "dropped_component_faces": "dropped_components"}


def _messages(changes: dict[str, int]) -> list[str]:
    """The non-zero ``changes`` in words, in the order they were made."""
    extra = {host: changes[k] for k, host in _TOLD_WITH.items()}
    return [_WORDS[k].format(v, extra.get(k)) for k, v in changes.items() if v and k in _WORDS]


def repair_mesh(V: np.ndarray, F: np.ndarray, *, keep_largest: bool = True) -> RepairedMesh:
    """Drop bad and duplicate faces, split bowtie and non-manifold vertices, cut folded flaps, keep the largest component.

    Parameters
    ----------
    V : (nv, 3) float64 (a (nv, 2) array is lifted to z = 0); non-finite rows allowed
    F : (nf, 3) int, ids in ``[0, nv)``
    keep_largest : bool
        Keep only the connected component with the most faces (default), else all of them.

    Returns
    -------
    RepairedMesh
        A mesh without degenerate, duplicate or non-manifold elements, the map back to the
        input vertices and what changed. It may still be closed, of higher genus or
        non-orientable: :func:`validate_mesh` says so.

    Raises
    ------
    MeshError
        Arrays of the wrong shape or dtype, ids out of range, or no face left.
    """
    V, F = as_mesh_arrays(V, F)
    nv = V.shape[0]
    check_ids(F, "F", nv, error=MeshError)
    changes: dict[str, int] = {}
    faces = _drop_bad_faces(V, F, changes)
    if faces.size == 0:
        raise MeshError(f"repair left no faces ({', '.join(f'{k} {v}' for k, v in changes.items() if v)})",
                        ["empty"])
    Fw, source, changes["non_manifold_edges"] = _manifold(F[faces], np.arange(nv))
    hull = np.flatnonzero(~hull_sliver_faces(V[source], Fw))
    changes["hull_sliver_faces"] = int(Fw.shape[0] - hull.size)
    flaps = hull[_cut_flaps(V[source], Fw[hull])]
    changes["folded_flap_faces"] = int(hull.size - flaps.size)
    hidden = flaps.size
    flaps = flaps[~hull_sliver_faces(V[source], Fw[flaps])]  # those the cut flaps had hidden
    changes["hull_sliver_faces"] += int(hidden - flaps.size)
    if not flaps.size:
        raise MeshError("repair left no faces (every face was on a folded flap)", ["empty"])
    kept = flaps[_drop_pinches(Fw[flaps], source)]
    changes["pinched_fan_faces"] = int(flaps.size - kept.size)
    if kept.size < Fw.shape[0]:
        faces = faces[kept]
        Fw, source, cut = _manifold(Fw[kept], source)
        changes["non_manifold_edges"] += cut
    copies = np.bincount(source, minlength=nv)
    changes["split_vertices"] = int((copies > 1).sum())
    changes["added_vertices"] = int(source.size - (copies > 0).sum())
    if keep_largest:
        kept = _largest(Fw, source.size, changes)
    else:
        kept = np.arange(Fw.shape[0])
        changes.update(dropped_components=0, dropped_component_faces=0)
    used, Fk = np.unique(Fw[kept], return_inverse=True)
    source = source[used]
    changes["dropped_vertices"] = int(nv - np.unique(source).size)
    messages = _messages(changes)
    return RepairedMesh(V=V[source], F=Fk.reshape(-1, 3).astype(np.int64), source_vertex_index=source,
                        source_face_index=faces[kept], changes=changes, messages=messages)
