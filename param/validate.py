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

from trispline.spline.checks import as_array
from trispline.spline.errors import InputError, first_few
from trispline.spline.tolerances import MAX_DOMAIN_ASPECT, MAX_MAGNITUDE, MIN_EXTENT, MIN_RELATIVE_AREA_3D

from .errors import MeshError
from .tables import boundary_loops, edge_pairs, fan_counts, orientation_classes, undirected_edges, vertex_components


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


def face_aspects(V: np.ndarray, F: np.ndarray) -> np.ndarray:
    """Aspect ``(nf,)`` of each face in 2D or 3D: its longest edge over its height on that edge
    (``2 / sqrt(3)`` for an equilateral triangle; inf for a zero-area face)."""
    V = np.column_stack([V, np.zeros(len(V))]) if V.shape[1] == 2 else V
    P = V[F]  # (nf, 3, 3)
    longest = (np.diff(P[:, [0, 1, 2, 0]], axis=1) ** 2).sum(2).max(1)  # squared
    with np.errstate(divide="ignore", invalid="ignore"):
        aspect = longest / (2.0 * face_areas_3d(V, F))
    return np.where(np.isnan(aspect), np.inf, aspect)  # 0 / 0: a face collapsed to a point


def sliver_message(points: np.ndarray, faces: np.ndarray) -> str | None:
    """Why a fit refuses the triangles ``faces (nf, 3)`` over ``points (n, 2 or 3)`` as slivers
    (aspect above :data:`~trispline.spline.tolerances.MAX_DOMAIN_ASPECT`), or None."""
    aspect = face_aspects(points, faces)
    bad = np.flatnonzero(aspect > MAX_DOMAIN_ASPECT)
    if not bad.size:
        return None
    return (f"{bad.size} triangles are slivers too thin to fit (longest edge / height up to {aspect.max():.3g}, "
            f"at most {MAX_DOMAIN_ASPECT:g}): faces {first_few(bad)}; collapse or remove them")


def map_slivers(V: np.ndarray, uv: np.ndarray, F: np.ndarray) -> np.ndarray:
    """Mask ``(nf,)`` of the faces ``F`` that the map ``uv (nv, 2)`` of ``V (nv, 3)`` made slivers: aspect
    above :data:`~trispline.spline.tolerances.MAX_DOMAIN_ASPECT` in uv, not on the mesh."""
    bad = face_aspects(uv, F) > MAX_DOMAIN_ASPECT
    if bad.any():
        bad[bad] = face_aspects(V, F[bad]) <= MAX_DOMAIN_ASPECT
    return bad


def refuse_slivers(points: np.ndarray, faces: np.ndarray, *, V: np.ndarray | None = None,
                   method: str = "given") -> None:
    """:class:`MeshError` (kind ``"slivers"``) when :func:`sliver_message` finds triangles too thin
    to fit (their normal matrix is not positive definite in float64).

    ``points`` a domain ``(n, 2)`` of the mesh ``V (n, 3)``, made by the parameterization ``method``:
    where the mesh's own triangles are not slivers, the message says that the map made them so, and
    to choose another (LSCM collapsed an open cylinder's tall triangles to aspect 6e12; ``auto`` fits it).
    """
    aspect = face_aspects(points, faces)
    bad = np.flatnonzero(aspect > MAX_DOMAIN_ASPECT)
    if not bad.size:
        return
    on_mesh = None if V is None else face_aspects(V, faces[bad])
    if on_mesh is not None and (on_mesh <= MAX_DOMAIN_ASPECT).all():  # the map made them all
        raise MeshError(f"the {method} parameterization squeezed {bad.size} triangles into slivers too thin to fit "
                        f"(longest edge / height up to {aspect.max():.3g}, at most {MAX_DOMAIN_ASPECT:g}; on the mesh "
                        f"at most {on_mesh.max():.3g}): faces {first_few(bad)}; choose another parameterization "
                        "(--param auto, slim or harmonic; param= in Python)", ["slivers"])
    raise MeshError(sliver_message(points, faces), ["slivers"])


def zero_area_faces(V: np.ndarray, F: np.ndarray) -> np.ndarray:
    """Mask ``(nf,)`` of faces whose 3D area is below ``MIN_RELATIVE_AREA_3D`` times the mean."""
    area = face_areas_3d(V, F)
    return area <= MIN_RELATIVE_AREA_3D * max(area.mean(), np.finfo(float).tiny)


def folded_edges(V: np.ndarray, F: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The folds of a mesh: ``(pairs (n, 2) int64, cos (n,) float64)``, the two faces of every
    edge with exactly two faces whose normals, taken in the orientation the edge induces on both
    (so a mesh need not be consistently oriented), point apart: dihedral angle above 90 degrees,
    ``cos`` the cosine of the angle between the normals (negative). Zero-area faces fold nothing."""
    he, _, he_edge, count = undirected_edges(F, V.shape[0])
    h0, h1 = edge_pairs(he_edge)
    inner = count[he_edge[h0]] == 2
    h0, h1 = h0[inner], h1[inner]
    n = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])
    length = np.linalg.norm(n, axis=1)
    n = n / np.where(length > 0, length, 1.0)[:, None]
    same = np.where(he[h0, 0] == he[h1, 1], 1.0, -1.0)  # -1: the faces run the edge the same way
    cos = (n[h0 // 3] * n[h1 // 3]).sum(1) * same
    fold = cos < 0
    return np.column_stack([h0[fold] // 3, h1[fold] // 3]).astype(np.int64), cos[fold]


def repeated_vertex_faces(F: np.ndarray) -> np.ndarray:
    """Mask ``(nf,)`` of faces that name a vertex twice."""
    return (F[:, 0] == F[:, 1]) | (F[:, 1] == F[:, 2]) | (F[:, 0] == F[:, 2])


def duplicate_faces(F: np.ndarray) -> np.ndarray:
    """Mask ``(nf,)`` of faces with the vertex set of an earlier face (in either orientation)."""
    dup = np.ones(F.shape[0], bool)
    if F.shape[0]:
        dup[np.unique(np.sort(F, axis=1), axis=0, return_index=True)[1]] = False
    return dup


def as_mesh_arrays(V, F) -> tuple[np.ndarray, np.ndarray]:
    """``(V (nv, 3) float64, F (nf, 3) int64)``, contiguous; a planar ``(nv, 2)`` V is lifted to z = 0.

    Raises :class:`MeshError` (kind ``"shape"``, or ``"empty"`` without faces); face ids
    are not checked here.
    """
    V, F = np.asarray(V), np.asarray(F)
    if V.ndim != 2 or V.shape[1] not in (2, 3):
        raise MeshError(f"V must have shape (nv, 3) (or (nv, 2)), got {V.shape}", ["shape"])
    if F.ndim != 2 or F.shape[1] != 3:
        raise MeshError(f"F must have shape (nf, 3) (triangles), got {F.shape}", ["shape"])
    if F.size and not np.issubdtype(F.dtype, np.integer):  # as_array would round whole floats
        raise MeshError(f"F must hold integer vertex ids, got dtype {F.dtype}", ["shape"])
    try:
        V = np.ascontiguousarray(as_array(V, "V", (None, V.shape[1])))
        F = np.ascontiguousarray(as_array(F, "F", (None, 3), integer=True))
    except InputError as exc:
        raise MeshError(str(exc), ["shape"]) from None
    if V.shape[1] == 2:
        V = np.column_stack([V, np.zeros(len(V))])
    if F.shape[0] == 0:
        raise MeshError("the mesh has no faces", ["empty"])
    return V, F


def validate_mesh(V: np.ndarray, F: np.ndarray, *, keep_largest: bool = False,
                  vertex_ids: np.ndarray | None = None) -> ValidatedMesh:
    """Check that ``(V, F)`` is a single open genus-0 manifold surface; repair orientation.

    Parameters
    ----------
    V : (nv, 3) float64 (a (nv, 2) array is lifted to z = 0)
    F : (nf, 3) int
    keep_largest : bool
        Keep the connected component with the most faces instead of rejecting a
        mesh with several components (vertices are then renumbered; ``kept`` maps back).
    vertex_ids : (nv,) int, optional
        The number of each vertex in the user's file, for the messages (a reader that dropped
        unreferenced vertices renumbered the others); default: their index in ``V``.

    Raises
    ------
    MeshError
        With one line per problem found, and ``kinds`` naming them.
    """
    V, F = as_mesh_arrays(V, F)
    nv_in, nf_in = V.shape[0], F.shape[0]
    ids = np.arange(nv_in) if vertex_ids is None else np.asarray(vertex_ids, np.int64)
    _check_ids(V, F, ids)
    messages: list[str] = []
    problems: list[tuple[str, str]] = []
    # -- components (optionally keep the largest)
    ncomp, vlab = vertex_components(F, nv_in)
    kept = kept_faces = None
    if ncomp > 1:
        if keep_largest:
            V, F, kept, kept_faces, message = _largest_component(V, F, vlab, ncomp)
            messages.append(message)
        else:
            problems.append(_components_problem(V, F, vlab, ncomp))
    # -- stage 2: independent local problems, reported together
    he, edges, he_edge, edge_count = undirected_edges(F, V.shape[0])
    problems += _local_problems(V, F, edges, he_edge, edge_count, ids if kept is None else ids[kept])
    if problems:
        _raise(problems)
    # -- orientation, then the topology of the oriented surface
    F, flip = _orient(F, he, he_edge)
    if flip.any():
        messages.append(f"repaired orientation of {int(flip.sum())} faces (rows reversed, face order kept)")
    he_edge = he_edge.reshape(-1, 3).copy()
    he_edge[np.ix_(flip, [1, 2])] = he_edge[np.ix_(flip, [2, 1])]  # a reversed row swaps half-edges 1, 2
    loops = boundary_loops(V, F, he_edge.ravel(), edge_count)
    report = _topology_report(V.shape[0], edges.shape[0], F.shape[0], len(loops))
    report.update(components=ncomp, reoriented_faces=int(flip.sum()),
                  dropped_vertices=0 if kept is None else int(nv_in - kept.size),
                  dropped_faces=0 if kept_faces is None else int(nf_in - kept_faces.size))
    return ValidatedMesh(V=V, F=F, report=report, messages=messages, boundary_loops=loops,
                         kept=kept, kept_faces=kept_faces)


#: The problems :func:`~trispline.param.repair_mesh` removes (the error names it).
REPAIRABLE = frozenset({"repeated_vertex_id", "zero_area", "duplicate_faces", "non_manifold_edges",
                        "bowtie_vertices"})


def scale_problem(V: np.ndarray, ids: np.ndarray | None = None) -> str | None:
    """Why finite coordinates ``V (nv, 3)`` are beyond what double precision computes with (their squares
    overflow past :data:`MAX_MAGNITUDE`, underflow below :data:`MIN_EXTENT`), or None; ``ids``: the vertices'
    numbers in the message."""
    if not V.size:
        return None
    big = np.abs(V).max(1)
    if big.max() > MAX_MAGNITUDE:
        at = int(np.argmax(big))
        return (f"vertex coordinates reach {big[at]:.3g} (vertex {at if ids is None else ids[at]}): beyond "
                f"{MAX_MAGNITUDE:g} their squares overflow double precision; rescale the mesh (other units)")
    extent = float((V.max(0) - V.min(0)).max())  # not the diagonal: its squares may underflow
    if 0 < extent < MIN_EXTENT:
        return (f"the mesh spans only {extent:.3g} (its bounding box's longest side): below {MIN_EXTENT:g} its "
                "squared areas underflow double precision; rescale the mesh (other units)")
    return None


def _check_ids(V: np.ndarray, F: np.ndarray, ids: np.ndarray) -> None:
    """Stage 1: problems that make everything else meaningless (raised at once); ``ids (nv,)``: the
    vertices' numbers in messages."""
    nv = V.shape[0]
    bad_v = np.flatnonzero(~np.isfinite(V).all(1))
    if bad_v.size:
        raise MeshError(f"non-finite vertex coordinates (NaN or inf): vertices {first_few(ids[bad_v])}",
                        ["non_finite"])
    if (why := scale_problem(V, ids)) is not None:
        raise MeshError(why, ["scale"])
    problems: list[tuple[str, str]] = []
    out = np.flatnonzero(((F < 0) | (F >= nv)).any(1))
    if out.size:
        wrong = F[out][(F[out] < 0) | (F[out] >= nv)][:5]
        problems.append(("vertex_id_range", f"faces with vertex ids outside [0, {nv}): {first_few(out)}; the ids "
                         + ", ".join(str(int(v)) for v in wrong) + (", ..." if wrong.size < ((F < 0) | (F >= nv)).sum()
                                                                     else "")))
    rep = np.flatnonzero(repeated_vertex_faces(F))
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


def _largest_component(V: np.ndarray, F: np.ndarray, vlab: np.ndarray, ncomp: int):
    """``(V, F, kept (nv',), kept_faces (nf',), message)`` of the component with the most faces."""
    nv, nf = V.shape[0], F.shape[0]
    big = int(np.argmax(np.bincount(vlab[F[:, 0]], minlength=ncomp)))
    kept_faces = np.flatnonzero(vlab[F[:, 0]] == big)
    kept = np.flatnonzero(vlab == big)
    remap = np.full(nv, -1, np.int64)
    remap[kept] = np.arange(kept.size)
    message = (f"kept the largest of {ncomp} connected components ({kept_faces.size} of {nf} faces, "
               f"{kept.size} of {nv} vertices)")
    return V[kept], remap[F[kept_faces]], kept, kept_faces, message


def _components_problem(V: np.ndarray, F: np.ndarray, vlab: np.ndarray, ncomp: int) -> tuple[str, str]:
    """The several components' problem; where they touch at vertices of equal coordinates (a seam of
    duplicated vertices, as some exporters write at texture seams), it says how many and how to merge."""
    sizes = np.sort(np.bincount(vlab[F[:, 0]], minlength=ncomp))[::-1]
    shown = ", ".join(str(int(s)) for s in sizes[:8]) + (", ..." if sizes.size > 8 else "")
    seam = _seam_vertices(V, vlab)
    hint = (f"; {seam} vertices lie exactly on a vertex of another component (a seam of duplicated "
            "vertices?): merge them first, e.g. trimesh.Trimesh(V, F).merge_vertices()" if seam else "")
    return ("components",
            f"the mesh has {ncomp} connected components (faces per component: {shown}); "
            f"trispline needs one surface: use keep_largest=True (--keep-largest) or split the mesh{hint}")


def _seam_vertices(V: np.ndarray, vlab: np.ndarray) -> int:
    """Vertices ``V (nv, 3)`` sharing their exact coordinates with a vertex of another component (``vlab``)."""
    order = np.lexsort(V.T[::-1])
    Vs, ls = V[order], vlab[order]
    same = (Vs[1:] == Vs[:-1]).all(1) & (ls[1:] != ls[:-1])
    touching = np.zeros(V.shape[0], bool)
    touching[order[1:][same]] = touching[order[:-1][same]] = True
    return int(touching.sum())


def _local_problems(V: np.ndarray, F: np.ndarray, edges: np.ndarray, he_edge: np.ndarray,
                    edge_count: np.ndarray, ids: np.ndarray) -> list[tuple[str, str]]:
    """Zero-area faces, non-manifold edges, bowtie vertices (``ids (nv,)``: the vertices' numbers in messages)."""
    problems = []
    tiny = np.flatnonzero(zero_area_faces(V, F))
    if tiny.size:
        problems.append(("zero_area", f"zero-area faces (area < {MIN_RELATIVE_AREA_3D:g} x mean): "
                                      f"{first_few(tiny)}"))
    dup = np.flatnonzero(duplicate_faces(F))
    if dup.size:
        problems.append(("duplicate_faces", f"duplicate faces (the three vertices of an earlier face): {first_few(dup)}"))
    nm = np.flatnonzero(edge_count > 2)
    if nm.size:
        nm_faces = np.unique(np.flatnonzero(np.isin(he_edge, nm)) // 3)
        problems.append((
            "non_manifold_edges",
            f"non-manifold edges (shared by more than 2 faces): {nm.size} edges, first "
            f"{', '.join(f'({a}, {b})' for a, b in ids[edges[nm[:5]]])}; faces {first_few(nm_faces)}",
        ))
    bow = np.flatnonzero(fan_counts(F, he_edge, V.shape[0]) > 1)
    if bow.size:
        problems.append(("bowtie_vertices",
                         f"non-manifold (bowtie) vertices, where separate fans of faces meet: "
                         f"{first_few(ids[bow])}"))
    return problems


def _orient(F: np.ndarray, he: np.ndarray, he_edge: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Consistently orient an edge-manifold mesh with one component.

    Returns the oriented faces and the mask ``(nf,)`` of reversed rows (the smaller side).
    Raises MeshError for a non-orientable surface.
    """
    nf = F.shape[0]
    lab = orientation_classes(F, he, he_edge)
    bad = np.flatnonzero(lab[:nf] == lab[nf:])
    if bad.size:
        raise MeshError(
            f"the surface is not orientable (Moebius-like): faces {first_few(bad)} cannot be "
            "oriented consistently",
            ["non_orientable"],
        )
    flip = lab[:nf] != lab[0]
    if flip.sum() * 2 > nf:
        flip = ~flip
    F = F.copy()
    F[flip] = F[flip][:, [0, 2, 1]]
    return F, flip


def _topology_report(nv: int, ne: int, nf: int, nb: int) -> dict:
    """Counts of an oriented surface with ``nb`` boundary loops; raises unless it is a disk
    with ``nb - 1`` holes."""
    chi = nv - ne + nf
    if nb == 0:
        genus = (2 - chi) // 2
        raise MeshError(
            f"the mesh is closed (no boundary; genus {genus}): trispline fits open surfaces; "
            "cut the mesh open (e.g. remove a strip of faces) first",
            ["closed"],
        )
    genus2 = 2 - chi - nb
    if genus2 != 0:
        gtxt = f"{genus2 / 2:g}"
        raise MeshError(
            f"the surface is not a disk or a disk with holes: genus {gtxt} with {nb} boundary loops "
            f"(Euler characteristic {chi} = V {nv} - E {ne} + F {nf}; a disk with h holes has "
            f"1 - h); cut handles open first",
            ["not_disk"],
        )
    return dict(vertices=nv, faces=nf, edges=ne, boundary_loops=nb, holes=nb - 1, genus=0,
                euler_characteristic=chi)


def _raise(problems: list[tuple[str, str]]) -> None:
    kinds = [k for k, _ in problems]
    hint = ("; repair_mesh (--repair of trispline fit and info) drops such faces and splits such vertices"
            if REPAIRABLE.intersection(kinds) else "")
    if len(problems) == 1:
        raise MeshError(f"invalid mesh: {problems[0][1]}{hint}", kinds)
    lines = "\n".join(f"  - {m}" for _, m in problems)
    raise MeshError(f"invalid mesh ({len(problems)} problems):\n{lines}{hint}", kinds)
