"""Mesh loading: OBJ, OFF, PLY, STL, GLB/GLTF into plain ``V, F`` arrays.

Vertex order and count are kept exactly as in the file: coincident vertices are
never merged (``process=False``), so vertex ``i`` of the file is vertex ``i`` of
the result. The only exceptions are

* vertices used by no face, which are dropped (order of the others kept) with an
  :class:`~trispline.param.UnreferencedVerticesWarning`; ``MeshData.kept`` maps
  back to the file's indices;
* STL, which stores every triangle with its own three corners: exactly equal
  corners are merged (first occurrence first), because STL has no other notion
  of shared vertices.

OBJ and OFF are parsed here (trimesh's OBJ reader drops unreferenced vertices
silently when ``vt`` lines are present and keeps only one ``vt`` per vertex
without saying so; its OFF reader fails on mixed polygon sizes). PLY, STL and
GLB/GLTF go through ``trimesh.load(..., process=False)``. OBJ and OFF polygons are
triangulated as fans ``(p0, p_i, p_i+1)`` in file order; trimesh triangulates PLY
polygons itself and, when a PLY mixes triangles with larger polygons, lists the
triangles first (vertex order is still kept; all-triangle files keep face order).
"""
from __future__ import annotations

import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from trispline.param.errors import MeshError, UnreferencedVerticesWarning
from trispline.spline.errors import first_few

#: File extensions :func:`read_mesh` understands.
SUPPORTED = (".obj", ".off", ".ply", ".stl", ".glb", ".gltf")


@dataclass(frozen=True, eq=False)
class MeshData:
    """A loaded triangle mesh.

    Attributes
    ----------
    V : (nv, 3) float64
    F : (nf, 3) int64
    uv : (nv, 2) float64 or None
        OBJ texture coordinates when every vertex has exactly one ``vt``.
    path : Path
    dropped : int
        Number of unreferenced vertices removed.
    kept : (nv,) int64
        Index in the file of each vertex of ``V``.
    """

    V: np.ndarray
    F: np.ndarray
    uv: np.ndarray | None
    path: Path
    dropped: int
    kept: np.ndarray


def read_mesh(path: str | Path) -> MeshData:
    """Read a triangle (or polygon) mesh without merging or reordering vertices.

    Raises
    ------
    MeshError
        Missing file, unknown extension, unreadable content, no faces.
    """
    path = Path(path)
    if not path.exists():
        raise MeshError(f"mesh file not found: {path}", ["missing_file"])
    if not path.is_file():
        raise MeshError(f"not a file: {path}", ["missing_file"])
    ext = path.suffix.lower()
    if ext not in SUPPORTED:
        raise MeshError(
            f"unknown mesh format {ext or '(no extension)'!r} for {path}; "
            f"supported: {', '.join(SUPPORTED)}",
            ["unknown_format"],
        )
    try:
        if ext == ".obj":
            V, F, uv = _read_obj(path)
        elif ext == ".off":
            V, F = _read_off(path)
            uv = None
        else:
            V, F = _read_trimesh(path, ext)
            uv = None
    except MeshError:
        raise
    except Exception as exc:  # noqa: BLE001 - any parser failure is a user-facing format error
        raise MeshError(f"cannot read {path} as {ext[1:].upper()}: {exc}", ["unreadable"]) from exc
    V = np.ascontiguousarray(V, dtype=np.float64).reshape(-1, 3)
    F = np.ascontiguousarray(F, dtype=np.int64).reshape(-1, 3)
    if F.shape[0] == 0:
        raise MeshError(f"{path} has no faces ({V.shape[0]} vertices)", ["empty"])
    if F.min() < 0 or F.max() >= V.shape[0]:
        bad = np.flatnonzero((F < 0).any(1) | (F >= V.shape[0]).any(1))
        raise MeshError(
            f"{path}: faces refer to vertices outside [0, {V.shape[0]}): {first_few(bad)}", ["unreadable"]
        )
    used = np.zeros(V.shape[0], bool)
    used[F.ravel()] = True
    kept = np.flatnonzero(used).astype(np.int64)
    dropped = int(V.shape[0] - kept.size)
    if dropped:
        warnings.warn(
            f"{path}: dropped {dropped} vertices used by no face "
            f"(first: {', '.join(str(int(i)) for i in np.flatnonzero(~used)[:5])}); "
            "the other vertices keep their order",
            UnreferencedVerticesWarning,
            stacklevel=2,
        )
        remap = np.cumsum(used) - 1
        V, F = V[used], remap[F]
        uv = None if uv is None else uv[used]
    return MeshData(V=V, F=F, uv=uv, path=path, dropped=dropped, kept=kept)


def load_mesh(path: str | Path) -> tuple[np.ndarray, np.ndarray]:
    """``(V (nv, 3) float64, F (nf, 3) int64)`` of :func:`read_mesh`."""
    m = read_mesh(path)
    return m.V, m.F


# --------------------------------------------------------------------- helpers
def _fan_triangulate(polys: list[list[int]]) -> np.ndarray:
    """Fan-triangulate polygons given as index lists; returns (nf, 3) int64."""
    if not polys:
        return np.zeros((0, 3), np.int64)
    sizes = np.fromiter((len(p) for p in polys), np.int64, len(polys))
    if (sizes < 3).any():
        bad = np.flatnonzero(sizes < 3)
        raise MeshError(f"polygons with fewer than 3 vertices: {first_few(bad)}", ["unreadable"])
    flat = np.fromiter((i for p in polys for i in p), np.int64, int(sizes.sum()))
    if (sizes == 3).all():
        return flat.reshape(-1, 3)
    start = np.concatenate([[0], np.cumsum(sizes)[:-1]])
    ntri = sizes - 2
    poly_of = np.repeat(np.arange(len(polys)), ntri)
    k = np.arange(ntri.sum()) - np.repeat(np.cumsum(ntri) - ntri, ntri)  # 0..n-3 within polygon
    s = start[poly_of]
    return np.column_stack([flat[s], flat[s + 1 + k], flat[s + 2 + k]])


def _read_obj(path: Path) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    verts: list[str] = []
    texs: list[str] = []
    fv: list[list[int]] = []
    ft: list[list[int]] = []
    has_all_vt = True
    with open(path, encoding="utf-8", errors="replace") as fh:
        for line in fh:
            if line.startswith("v "):
                verts.append(line[2:])
            elif line.startswith("vt "):
                texs.append(line[3:])
            elif line.startswith("f "):
                toks = line[2:].split()
                nv_now, nt_now = len(verts), len(texs)
                vi, ti = [], []
                for t in toks:
                    parts = t.split("/")
                    i = int(parts[0])
                    vi.append(i - 1 if i > 0 else nv_now + i)
                    if len(parts) > 1 and parts[1]:
                        j = int(parts[1])
                        ti.append(j - 1 if j > 0 else nt_now + j)
                    else:
                        has_all_vt = False
                fv.append(vi)
                ft.append(ti)
    if not verts:
        raise MeshError(f"{path} has no vertices ('v' lines)", ["empty"])
    V = np.array([row.split()[:3] for row in verts], dtype=np.float64)
    F = _fan_triangulate(fv)
    uv = None
    if texs and has_all_vt and fv:
        T = np.array([row.split()[:2] for row in texs], dtype=np.float64)
        FT = _fan_triangulate(ft)
        if FT.min() >= 0 and FT.max() < T.shape[0]:
            # one texture coordinate per vertex: every (v, vt) pair agrees per v
            per_v = np.full(V.shape[0], -1, np.int64)
            per_v[F.ravel()] = FT.ravel()
            same = np.allclose(T[per_v[F.ravel()]], T[FT.ravel()], rtol=0, atol=0)
            if same:
                uv = np.where((per_v >= 0)[:, None], T[np.maximum(per_v, 0)], np.nan)
    return V, F, uv


def _read_off(path: Path) -> tuple[np.ndarray, np.ndarray]:
    with open(path, encoding="utf-8", errors="replace") as fh:
        tokens_lines = [ln.split("#", 1)[0].split() for ln in fh]
    lines = [t for t in tokens_lines if t]
    if not lines or not lines[0][0].upper().endswith("OFF"):
        raise MeshError(f"{path} is not an OFF file (no OFF header)", ["unreadable"])
    head = lines[0][1:]
    rest = lines[1:]
    if len(head) < 2:
        head, rest = rest[0], rest[1:]
    nv, nf = int(head[0]), int(head[1])
    if len(rest) < nv + nf:
        raise MeshError(
            f"{path}: header announces {nv} vertices and {nf} faces but the file has {len(rest)} data lines",
            ["unreadable"],
        )
    V = np.array([r[:3] for r in rest[:nv]], dtype=np.float64).reshape(-1, 3)
    polys = []
    for r in rest[nv : nv + nf]:
        k = int(r[0])
        if len(r) < k + 1:
            raise MeshError(f"{path}: face line {r} lists fewer than {k} indices", ["unreadable"])
        polys.append([int(x) for x in r[1 : k + 1]])
    return V, _fan_triangulate(polys)


def _read_trimesh(path: Path, ext: str) -> tuple[np.ndarray, np.ndarray]:
    import trimesh

    mesh = trimesh.load(path, process=False, force="mesh", maintain_order=True)
    if not isinstance(mesh, trimesh.Trimesh):
        raise MeshError(f"{path} holds no triangle mesh (got {type(mesh).__name__})", ["unreadable"])
    V = np.asarray(mesh.vertices, dtype=np.float64)
    F = np.asarray(mesh.faces, dtype=np.int64)
    if ext == ".stl" and F.size:
        # STL has no shared vertices: merge exactly equal corners, first occurrence first.
        corners = V[F.ravel()]
        _, first, inv = np.unique(corners, axis=0, return_index=True, return_inverse=True)
        order = np.argsort(first, kind="stable")
        rank = np.empty_like(order)
        rank[order] = np.arange(order.size)
        V = corners[first[order]]
        F = rank[inv.ravel()].reshape(-1, 3)
    return V, F
