"""Validation of an input mesh: can it be mapped to a planar triangulation?

A usable mesh is a single, edge- and vertex-manifold, orientable, open surface
of genus 0 (a disk, or a disk with holes) without zero-area faces. Problems that
can be detected independently are reported together in one :class:`MeshError`,
one line per problem, each naming counts and the first few indices.
Inconsistent face orientation is repaired (rows reversed in place, face order
kept) and reported in ``messages``.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components

from trispline.spline.errors import first_few

from .errors import MeshError

#: Faces with 3D area below this fraction of the mean face area count as zero-area.
MIN_RELATIVE_AREA_3D = 1e-12


@dataclass(frozen=True, eq=False)
class ValidatedMesh:
    """A mesh that passed :func:`validate_mesh`.

    Attributes
    ----------
    V : (nv, 3) float64
    F : (nf, 3) int64
        Consistently oriented; same rows as the input (restricted to the kept
        faces when ``keep_largest`` dropped components), a row reversed where its
        orientation was repaired.
    report : dict
        Counts: vertices, faces, edges, boundary_loops, holes, genus,
        euler_characteristic, components, reoriented_faces, dropped_vertices, dropped_faces.
    messages : list of str
        What was changed ("repaired orientation of 12 faces", ...).
    boundary_loops : list of (n_i,) int64
        Boundary loops, longest (3D length) first, each with the surface on its left.
    kept : (nv,) int64 or None
        Input index of each vertex when ``keep_largest`` dropped components, else None.
    kept_faces : (nf,) int64 or None
        Input index of each face when ``keep_largest`` dropped components, else None.
    """

    V: np.ndarray
    F: np.ndarray
    report: dict
    messages: list[str] = field(default_factory=list)
    boundary_loops: list[np.ndarray] = field(default_factory=list)
    kept: np.ndarray | None = None
    kept_faces: np.ndarray | None = None


def face_areas_3d(V: np.ndarray, F: np.ndarray) -> np.ndarray:
    """Unsigned face areas ``(nf,)`` of a mesh in 2D or 3D."""
    a, b, c = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
    return 0.5 * np.linalg.norm(np.cross(b - a, c - a), axis=1)


def _as_arrays(V, F) -> tuple[np.ndarray, np.ndarray]:
    V = np.asarray(V)
    F = np.asarray(F)
    if V.ndim != 2 or V.shape[1] not in (2, 3):
        raise MeshError(f"V must have shape (nv, 3) (or (nv, 2)), got {V.shape}", ["shape"])
    if F.ndim != 2 or F.shape[1] != 3:
        raise MeshError(f"F must have shape (nf, 3) (triangles), got {F.shape}", ["shape"])
    if not np.issubdtype(V.dtype, np.number):
        raise MeshError(f"V must be numeric, got dtype {V.dtype}", ["shape"])
    if F.size and not np.issubdtype(F.dtype, np.integer):
        raise MeshError(f"F must hold integer vertex ids, got dtype {F.dtype}", ["shape"])
    V = np.ascontiguousarray(V, dtype=np.float64)
    if V.shape[1] == 2:
        V = np.column_stack([V, np.zeros(len(V))])
    F = np.ascontiguousarray(F, dtype=np.int64)
    if F.shape[0] == 0:
        raise MeshError("the mesh has no faces", ["empty"])
    return V, F


def _undirected_edges(F: np.ndarray, nv: int):
    """Half-edges ``3f+k`` (opposite local k) -> undirected edge ids.

    Returns ``he (3nf, 2)``, ``edges (ne, 2)``, ``he_edge (3nf,)``, ``edge_count (ne,)``.
    """
    he = np.stack([F[:, [1, 2, 0]], F[:, [2, 0, 1]]], axis=-1).reshape(-1, 2)
    key = np.minimum(he[:, 0], he[:, 1]) * nv + np.maximum(he[:, 0], he[:, 1])
    uniq, inv, cnt = np.unique(key, return_inverse=True, return_counts=True)
    edges = np.column_stack([uniq // nv, uniq % nv])
    return he, edges, inv.ravel(), cnt


def _components(F: np.ndarray, nv: int) -> tuple[int, np.ndarray]:
    """Vertex-connected components: ``(n, label per vertex (nv,))``."""
    r = np.concatenate([F[:, 0], F[:, 1], F[:, 2]])
    c = np.concatenate([F[:, 1], F[:, 2], F[:, 0]])
    A = sp.coo_matrix((np.ones(r.size, np.int8), (r, c)), shape=(nv, nv)).tocsr()
    return connected_components(A, directed=False)


def _fan_counts(F: np.ndarray, he_edge: np.ndarray, edge_count: np.ndarray, nv: int) -> np.ndarray:
    """Number of face fans (edge-connected groups of incident faces) at each vertex ``(nv,)``."""
    nf = F.shape[0]
    # corner 3f+k sits at F[f, k]; half-edge 3f+k joins local (k+1, k+2)
    he_face = np.repeat(np.arange(nf), 3)
    he_k = np.tile(np.arange(3), nf)
    order = np.argsort(he_edge, kind="stable")
    e_sorted = he_edge[order]
    # pair consecutive half-edges of the same edge (for non-manifold edges: a chain)
    same = e_sorted[1:] == e_sorted[:-1]
    h0, h1 = order[:-1][same], order[1:][same]
    rows, cols = [], []
    for off in (1, 2):  # both endpoints of the edge
        c0 = 3 * he_face[h0] + (he_k[h0] + off) % 3
        v = F.ravel()[c0]
        f1 = he_face[h1]
        k1 = np.argmax(F[f1] == v[:, None], axis=1)
        rows.append(c0)
        cols.append(3 * f1 + k1)
    r = np.concatenate(rows)
    c = np.concatenate(cols)
    A = sp.coo_matrix((np.ones(r.size, np.int8), (r, c)), shape=(3 * nf, 3 * nf)).tocsr()
    _, lab = connected_components(A, directed=False)
    key = np.unique(F.ravel() * np.int64(3 * nf) + lab)  # distinct (vertex, fan label)
    return np.bincount(key // (3 * nf), minlength=nv)


def _orient(F: np.ndarray, he: np.ndarray, he_edge: np.ndarray) -> tuple[np.ndarray, int]:
    """Consistently orient an edge-manifold mesh with one component.

    Uses the orientation double cover: node ``f`` (kept) and ``nf + f`` (flipped).
    Returns the oriented faces and the number of reversed rows (the smaller side).
    Raises MeshError for a non-orientable surface.
    """
    nf = F.shape[0]
    order = np.argsort(he_edge, kind="stable")
    e_sorted = he_edge[order]
    same = e_sorted[1:] == e_sorted[:-1]
    h0, h1 = order[:-1][same], order[1:][same]
    f0, f1 = h0 // 3, h1 // 3
    consistent = he[h0, 0] == he[h1, 1]  # opposite traversal
    a = np.where(consistent, f1, nf + f1)
    b = np.where(consistent, nf + f1, f1)
    r = np.concatenate([f0, nf + f0])
    c = np.concatenate([a, b])
    A = sp.coo_matrix((np.ones(r.size, np.int8), (r, c)), shape=(2 * nf, 2 * nf)).tocsr()
    _, lab = connected_components(A, directed=False)
    bad = np.flatnonzero(lab[:nf] == lab[nf:])
    if bad.size:
        raise MeshError(
            f"the surface is not orientable (Moebius-like): faces {first_few(bad)} cannot be "
            "oriented consistently",
            ["non_orientable"],
        )
    keep_label = lab[0]
    flip = lab[:nf] != keep_label
    if flip.sum() * 2 > nf:
        flip = ~flip
    F = F.copy()
    F[flip] = F[flip][:, [0, 2, 1]]
    return F, int(flip.sum())


def _boundary_loops(V: np.ndarray, F: np.ndarray, bnd_edges: np.ndarray) -> list[np.ndarray]:
    """Boundary loops of an oriented manifold mesh, longest (3D length) first.

    ``bnd_edges (nb, 2)``: the undirected boundary edges (used by one face).
    """
    nv = V.shape[0]
    if bnd_edges.size == 0:
        return []
    he = np.stack([F[:, [0, 1, 2]], F[:, [1, 2, 0]]], axis=-1).reshape(-1, 2)
    key = np.minimum(he[:, 0], he[:, 1]) * nv + np.maximum(he[:, 0], he[:, 1])
    bkey = np.sort(bnd_edges[:, 0] * nv + bnd_edges[:, 1])
    pos = np.minimum(np.searchsorted(bkey, key), bkey.size - 1)
    bnd = he[bkey[pos] == key]
    if bnd.size == 0:
        return []
    succ = np.full(nv, -1, np.int64)
    succ[bnd[:, 0]] = bnd[:, 1]
    visited = np.zeros(nv, bool)
    loops = []
    for s in bnd[:, 0]:
        if visited[s]:
            continue
        loop = []
        v = s
        while v >= 0 and not visited[v]:
            visited[v] = True
            loop.append(v)
            v = succ[v]
        loops.append(np.asarray(loop, np.int64))
    length = [np.linalg.norm(V[l] - V[np.roll(l, -1)], axis=1).sum() for l in loops]
    return [loops[i] for i in np.argsort(length, kind="stable")[::-1]]


def validate_mesh(V: np.ndarray, F: np.ndarray, *, keep_largest: bool = False) -> ValidatedMesh:
    """Check that ``(V, F)`` is a single open genus-0 manifold surface; repair orientation.

    Parameters
    ----------
    V : (nv, 3) float64 (a (nv, 2) array is lifted to z = 0)
    F : (nf, 3) int
    keep_largest : bool
        Keep the connected component with the most faces instead of rejecting a
        mesh with several components (vertices are then renumbered; ``kept`` maps back).

    Raises
    ------
    MeshError
        With one line per problem found, and ``kinds`` naming them.
    """
    V, F = _as_arrays(V, F)
    nv, nf = V.shape[0], F.shape[0]
    messages: list[str] = []

    # -- stage 1: problems that make everything else meaningless
    bad_v = np.flatnonzero(~np.isfinite(V).all(1))
    if bad_v.size:
        raise MeshError(f"non-finite vertex coordinates (NaN or inf) at vertices {first_few(bad_v)}",
                        ["non_finite"])
    problems: list[tuple[str, str]] = []
    out = np.flatnonzero(((F < 0) | (F >= nv)).any(1))
    if out.size:
        problems.append(("vertex_id_range", f"faces with vertex ids outside [0, {nv}): {first_few(out)}"))
    rep = np.flatnonzero((F[:, 0] == F[:, 1]) | (F[:, 1] == F[:, 2]) | (F[:, 0] == F[:, 2]))
    if rep.size:
        problems.append(("repeated_vertex_id", f"faces with a repeated vertex id: {first_few(rep)}"))
    if problems:
        _raise(problems)
    used = np.zeros(nv, bool)
    used[F.ravel()] = True
    if not used.all():
        raise MeshError(
            f"vertices used by no face: {first_few(np.flatnonzero(~used))}; drop them first "
            "(trispline.fit.io.read_mesh does, keeping the order of the others)",
            ["unreferenced_vertices"],
        )

    # -- components (optionally keep the largest)
    ncomp, vlab = _components(F, nv)
    kept = kept_faces = None
    comp_sizes = np.bincount(vlab[F[:, 0]], minlength=ncomp)
    if ncomp > 1:
        if keep_largest:
            big = int(np.argmax(comp_sizes))
            kept_faces = np.flatnonzero(vlab[F[:, 0]] == big)
            kept = np.flatnonzero(vlab == big)
            remap = np.full(nv, -1, np.int64)
            remap[kept] = np.arange(kept.size)
            messages.append(
                f"kept the largest of {ncomp} connected components ({kept_faces.size} of {nf} faces, "
                f"{kept.size} of {nv} vertices)"
            )
            V, F = V[kept], remap[F[kept_faces]]
            nv, nf = V.shape[0], F.shape[0]
        else:
            sizes = np.sort(comp_sizes)[::-1]
            shown = ", ".join(str(int(s)) for s in sizes[:8]) + (", ..." if sizes.size > 8 else "")
            problems.append((
                "components",
                f"the mesh has {ncomp} connected components (faces per component: {shown}); "
                "trispline needs one surface: use keep_largest=True (--keep-largest) or split the mesh",
            ))

    # -- stage 2: independent local problems, reported together
    area = face_areas_3d(V, F)
    tiny = np.flatnonzero(area <= MIN_RELATIVE_AREA_3D * max(area.mean(), np.finfo(float).tiny))
    if tiny.size:
        problems.append(("zero_area", f"zero-area faces (area < {MIN_RELATIVE_AREA_3D:g} x mean): "
                                      f"{first_few(tiny)}"))
    he, edges, he_edge, edge_count = _undirected_edges(F, nv)
    nm = np.flatnonzero(edge_count > 2)
    if nm.size:
        nm_faces = np.unique(np.flatnonzero(np.isin(he_edge, nm)) // 3)
        problems.append((
            "non_manifold_edges",
            f"non-manifold edges (shared by more than 2 faces): {nm.size} edges, first "
            f"{', '.join(f'({a}, {b})' for a, b in edges[nm[:5]])}; faces {first_few(nm_faces)}",
        ))
    fans = _fan_counts(F, he_edge, edge_count, nv)
    bow = np.flatnonzero(fans > 1)
    if bow.size:
        problems.append(("bowtie_vertices",
                         f"non-manifold (bowtie) vertices, where separate fans of faces meet: "
                         f"{first_few(bow if kept is None else kept[bow])}"))
    if problems:
        _raise(problems)

    # -- orientation
    F, nflip = _orient(F, he, he_edge)
    if nflip:
        messages.append(f"repaired orientation of {nflip} faces (rows reversed, face order kept)")

    # -- topology
    loops = _boundary_loops(V, F, edges[edge_count == 1])
    ne = edges.shape[0]
    chi = nv - ne + nf
    nb = len(loops)
    if nb == 0:
        genus = (2 - chi) // 2
        raise MeshError(
            f"the mesh is closed (no boundary; genus {genus}): trispline fits open surfaces; "
            "cut the mesh open (e.g. remove a strip of faces) first",
            ["closed"],
        )
    genus2 = 2 - chi - nb
    if genus2 != 0:
        genus = genus2 / 2
        gtxt = f"{genus:g}"
        raise MeshError(
            f"the surface is not a disk or a disk with holes: genus {gtxt} with {nb} boundary loops "
            f"(Euler characteristic {chi} = V {nv} - E {ne} + F {nf}; a disk with h holes has "
            f"1 - h); cut handles open first",
            ["not_disk"],
        )
    report = dict(
        vertices=nv, faces=nf, edges=ne, boundary_loops=nb, holes=nb - 1, genus=0,
        euler_characteristic=chi, components=ncomp, reoriented_faces=nflip,
        dropped_vertices=0 if kept is None else int(used.size - kept.size),
        dropped_faces=0 if kept_faces is None else int(comp_sizes.sum() - kept_faces.size),
    )
    return ValidatedMesh(V=V, F=F, report=report, messages=messages, boundary_loops=loops,
                         kept=kept, kept_faces=kept_faces)


def _raise(problems: list[tuple[str, str]]) -> None:
    kinds = [k for k, _ in problems]
    if len(problems) == 1:
        raise MeshError(f"invalid mesh: {problems[0][1]}", kinds)
    lines = "\n".join(f"  - {m}" for _, m in problems)
    raise MeshError(f"invalid mesh ({len(problems)} problems):\n{lines}", kinds)
