"""Combinatorial tables of a triangle mesh in 3D: edges, components, face fans, orientation.

One home for each table that :func:`~trispline.param.validate_mesh` and
:func:`~trispline.param.inspect_mesh` both need. Nothing here judges the mesh or raises:
the tables are defined for any ``faces (nf, 3)`` with ids in ``[0, nv)``, non-manifold,
unoriented and multi-component meshes included. The half-edge and edge tables are
:mod:`trispline.spline.topology`'s, which the planar
:class:`~trispline.spline.topology.Triangulation` builds its stricter tables on.

Half-edge ``3 f + k`` of face ``f`` is opposite local vertex ``k``: it runs from
``faces[f, k + 1]`` to ``faces[f, k + 2]`` (indices mod 3).
"""
from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components

from trispline.spline.topology import halfedges, undirected_edges

__all__ = ["ring_step", "loop_successors", "halfedges", "undirected_edges", "edge_pairs", "vertex_components", "corner_fans", "fan_counts",
           "orientation_classes", "boundary_loop_count", "boundary_loops", "SMALL_HOLE", "small_holes"]

#: Holes with at most this many vertices around are small (scanner dropouts: a few missing triangles):
#: ``trispline info`` counts them, and an approximation can span them (``fill_holes``).
SMALL_HOLE = 8


def ring_step(edges: np.ndarray, nv: int) -> sp.csr_matrix:
    """``(nv, nv)`` CSR of ones: the undirected ``edges (ne, 2)`` both ways and the diagonal, so that a
    product with it grows a set of vertices (its rows' patterns) by one ring."""
    A = sp.csr_matrix((np.ones(2 * len(edges)), (edges.ravel(), edges[:, ::-1].ravel())), shape=(nv, nv))
    return A + sp.identity(nv, format="csr")


def loop_successors(sizes: list[int]) -> np.ndarray:
    """``(sum(sizes),)``: the position of each vertex's successor in loops of ``sizes`` stacked in one list
    (the last of a loop is followed by its first)."""
    sizes = np.asarray(sizes, np.int64)
    start = np.repeat(np.cumsum(sizes) - sizes, sizes)
    return start + (np.arange(int(sizes.sum())) - start + 1) % np.repeat(sizes, sizes)


def edge_pairs(he_edge: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Pairs ``(h0 (n,), h1 (n,))`` of half-edges on the same edge, consecutive in half-edge
    order (on a non-manifold edge the pairs form a chain, which keeps every face connected)."""
    order = np.argsort(he_edge, kind="stable")
    e_sorted = he_edge[order]
    same = e_sorted[1:] == e_sorted[:-1]
    return order[:-1][same], order[1:][same]


def vertex_components(F: np.ndarray, nv: int) -> tuple[int, np.ndarray]:
    """Vertex-connected components: ``(count, label per vertex (nv,))``; a vertex no face
    uses is a component of its own."""
    r = np.concatenate([F[:, 0], F[:, 1], F[:, 2]])
    c = np.concatenate([F[:, 1], F[:, 2], F[:, 0]])
    A = sp.coo_matrix((np.ones(r.size, np.int8), (r, c)), shape=(nv, nv)).tocsr()
    return connected_components(A, directed=False)


def corner_fans(F: np.ndarray, h0: np.ndarray, h1: np.ndarray) -> np.ndarray:
    """Fan label ``(3 nf,)`` of every corner (corner ``3 f + k`` sits at ``F[f, k]``).

    Two corners at one vertex are in the same fan when they are joined through faces glued
    along the half-edge pairs ``(h0, h1)`` (e.g. :func:`edge_pairs`); labels are global
    (distinct fans at one vertex have distinct labels). Needs no repeated vertex ids.
    """
    nf = F.shape[0]
    he_face = np.repeat(np.arange(nf), 3)
    he_k = np.tile(np.arange(3), nf)
    rows, cols = [], []
    for off in (1, 2):  # both endpoints of the edge (half-edge 3f+k joins local k+1, k+2)
        c0 = 3 * he_face[h0] + (he_k[h0] + off) % 3
        v = F.ravel()[c0]
        f1 = he_face[h1]
        k1 = np.argmax(F[f1] == v[:, None], axis=1)
        rows.append(c0)
        cols.append(3 * f1 + k1)
    r = np.concatenate(rows)
    c = np.concatenate(cols)
    A = sp.coo_matrix((np.ones(r.size, np.int8), (r, c)), shape=(3 * nf, 3 * nf)).tocsr()
    return connected_components(A, directed=False)[1]


def fan_counts(F: np.ndarray, he_edge: np.ndarray, nv: int) -> np.ndarray:
    """Number of face fans (edge-connected groups of the faces at a vertex) per vertex ``(nv,)``.

    A manifold vertex has one fan; more than one is a bowtie. Needs no repeated vertex ids.
    """
    lab = corner_fans(F, *edge_pairs(he_edge))
    key = np.unique(F.ravel() * np.int64(3 * F.shape[0]) + lab)  # distinct (vertex, fan label)
    return np.bincount(key // (3 * F.shape[0]), minlength=nv)


def orientation_classes(F: np.ndarray, he: np.ndarray, he_edge: np.ndarray) -> np.ndarray:
    """Labels ``(2 nf,)`` of the orientation double cover of an edge-manifold mesh.

    Node ``f`` is face ``f`` as given, node ``nf + f`` the face reversed; two nodes share a
    label when their orientations must agree across the edges between them. The surface
    is orientable iff ``labels[f] != labels[nf + f]`` for every ``f``.
    """
    nf = F.shape[0]
    h0, h1 = edge_pairs(he_edge)
    f0, f1 = h0 // 3, h1 // 3
    consistent = he[h0, 0] == he[h1, 1]  # opposite traversal
    a = np.where(consistent, f1, nf + f1)
    b = np.where(consistent, nf + f1, f1)
    r = np.concatenate([f0, nf + f0])
    c = np.concatenate([a, b])
    A = sp.coo_matrix((np.ones(r.size, np.int8), (r, c)), shape=(2 * nf, 2 * nf)).tocsr()
    return connected_components(A, directed=False)[1]


def boundary_loop_count(edges: np.ndarray, edge_count: np.ndarray, nv: int) -> int:
    """Number of boundary loops of a manifold mesh, oriented or not: the connected
    components of the graph of its boundary edges (``edge_count == 1``)."""
    bnd = edges[edge_count == 1]
    if not bnd.size:
        return 0
    B = sp.coo_matrix((np.ones(bnd.shape[0]), (bnd[:, 0], bnd[:, 1])), shape=(nv, nv))
    _, lab = connected_components(B, directed=False)
    return int(np.unique(lab[np.unique(bnd)]).size)


def boundary_loops(V: np.ndarray, F: np.ndarray, he_edge: np.ndarray,
                   edge_count: np.ndarray) -> list[np.ndarray]:
    """Boundary loops ``[(n_i,) int64]`` of an oriented manifold mesh, longest (3D length)
    first (equal lengths: the lower vertex id first), each with the surface on its left and
    starting at its lowest vertex id, so that the loops do not depend on the order of ``F``'s rows.

    ``he_edge`` and ``edge_count`` are :func:`undirected_edges` of ``F`` itself.
    """
    nv, nf = V.shape[0], F.shape[0]
    # corner order: half-edge 3f+2 (F0 -> F1) first, then 3f (F1 -> F2), then 3f+1 (F2 -> F0)
    corner = (3 * np.arange(nf)[:, None] + np.array([2, 0, 1])).ravel()
    corner = corner[edge_count[he_edge[corner]] == 1]
    if corner.size == 0:
        return []
    bnd = halfedges(F)[corner]
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
        loop = np.asarray(loop, np.int64)
        loops.append(np.roll(loop, -int(np.argmin(loop))))
    length = np.array([np.linalg.norm(V[l] - V[np.roll(l, -1)], axis=1).sum() for l in loops])
    return [loops[i] for i in np.lexsort(([l[0] for l in loops], -length))]


def small_holes(loops: list[np.ndarray], max_vertices: int = SMALL_HOLE) -> list[np.ndarray]:
    """The holes among ``loops`` (:func:`boundary_loops`' order: the longest in 3D first, the outline, which is
    never one of them) with at most ``max_vertices`` vertices around."""
    return [h for h in loops[1:] if h.size <= max_vertices] if max_vertices >= 3 else []
