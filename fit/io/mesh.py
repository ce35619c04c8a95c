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

OBJ, OFF and binary PLY are parsed by :mod:`.mesh_parse`; ASCII PLY, STL and GLB/GLTF go
through ``trimesh.load(..., process=False)`` once their headers are checked against the
file (an ASCII PLY's lines against its header's elements). OBJ, OFF and binary PLY polygons
are triangulated as fans ``(p0, p_i, p_i+1)`` in file order; trimesh triangulates ASCII PLY
polygons itself and, when one mixes triangles with larger polygons, lists the triangles
first (vertex order is still kept; all-triangle files keep face order). Every problem, from
a missing, empty, unreadable or truncated file to a header announcing more or fewer
elements than the file holds or faces naming missing vertices, is one
:class:`~trispline.param.MeshError` naming the file and what is wrong.
"""
from __future__ import annotations

import os
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from trispline.param.errors import CoordinatePrecisionWarning, MeshError, UnreferencedVerticesWarning
from trispline.spline.errors import first_few

from .mesh_parse import read_obj, read_off, read_trimesh

#: File extensions :func:`read_mesh` understands.
SUPPORTED = (".obj", ".off", ".ply", ".stl", ".glb", ".gltf")
#: A single-precision file whose rounding reaches this share of the median edge is warned about.
ROUNDING_SHARE = 0.01
#: Faces whose edges set the median edge length (the first ones: a cheap, representative sample).
EDGE_SAMPLE = 100_000


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
    uv_note : str or None
        Why an OBJ's ``vt`` lines give no ``uv`` (a face without them, a seam, indices out of
        range); None when the file has none or they give ``uv``.
    """

    V: np.ndarray
    F: np.ndarray
    uv: np.ndarray | None
    path: Path
    dropped: int
    kept: np.ndarray
    uv_note: str | None = None


def read_mesh(path: str | Path) -> MeshData:
    """Read a triangle (or polygon) mesh without merging or reordering vertices.

    Raises
    ------
    MeshError
        Missing, unreadable or empty file, unknown extension, unreadable content (naming the
        line or element at fault where known), no faces, faces naming missing vertices.
    """
    path = _readable_file(path)
    ext = path.suffix.lower()
    try:
        uv, uv_note, single = None, None, False
        if ext == ".obj":
            V, F, uv, uv_note = read_obj(path)
        elif ext == ".off":
            V, F = read_off(path)
        else:
            V, F, single = read_trimesh(path, ext)
    except MeshError:
        raise
    except Exception as exc:  # noqa: BLE001 - any parser failure is a user-facing format error
        raise MeshError(f"cannot read {path} as {ext[1:].upper()} (damaged, truncated or not such a file): "
                        f"{type(exc).__name__}: {exc}", ["unreadable"]) from None
    V = np.ascontiguousarray(V, dtype=np.float64).reshape(-1, 3)
    F = np.ascontiguousarray(F, dtype=np.int64).reshape(-1, 3)
    if F.shape[0] == 0:
        raise MeshError(f"{path} has no faces ({V.shape[0]} vertices)"
                        + (": trispline fits triangle meshes; points of a height field z(x, y) can be "
                           "triangulated in (x, y) first (e.g. scipy.spatial.Delaunay) and fitted with --param uv"
                           if V.shape[0] >= 3 else ""), ["empty"])
    if F.min() < 0 or F.max() >= V.shape[0]:
        bad = np.flatnonzero((F < 0).any(1) | (F >= V.shape[0]).any(1))
        raise MeshError(
            f"{path}: faces refer to vertices outside [0, {V.shape[0]}): {first_few(bad)}", ["unreadable"]
        )
    if single:
        _warn_rounding(path, V, F)
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
    return MeshData(V=V, F=F, uv=uv, path=path, dropped=dropped, kept=kept, uv_note=uv_note)


def single_rounding(V: np.ndarray) -> float:
    """The largest rounding error of coordinates ``V (nv, 3)`` stored in single precision: half the
    float32 spacing at the largest magnitude (0.25 at 4.2e6, a map projection's northing)."""
    return float(0.5 * np.spacing(np.float32(np.abs(V).max()))) if V.size else 0.0


def _warn_rounding(path: Path, V: np.ndarray, F: np.ndarray) -> None:
    """A :class:`CoordinatePrecisionWarning` where single-precision rounding reaches :data:`ROUNDING_SHARE`
    of the median edge length of ``F``'s first :data:`EDGE_SAMPLE` faces."""
    rounding = single_rounding(V)
    f = F[:EDGE_SAMPLE]
    edges = np.linalg.norm(V[f] - V[np.roll(f, 1, axis=1)], axis=2)
    edge = float(np.median(edges)) if edges.size else 0.0
    if edge > 0 and rounding > ROUNDING_SHARE * edge:
        warnings.warn(
            f"{path} stores its coordinates in single precision (float32), which at magnitudes up to "
            f"{np.abs(V).max():.3g} rounds them by up to {rounding:.3g}: {100 * rounding / edge:.2g}% of the "
            f"median edge length {edge:.3g}; folds and roughness at that scale are the rounding's, and a "
            "tolerance near it cannot be met. Write the mesh in double precision, or subtract an offset (e.g. "
            "the bounding box's corner) before writing it",
            CoordinatePrecisionWarning, stacklevel=3)


def _readable_file(path: str | Path) -> Path:
    """``Path(path)`` of an existing, readable, non-empty file with a supported suffix, else MeshError."""
    if not isinstance(path, (str, os.PathLike)):
        raise MeshError(f"a mesh path must be a str or os.PathLike, got {type(path).__name__}", ["missing_file"])
    path = Path(path)
    if not path.exists():
        raise MeshError(f"mesh file not found: {path}", ["missing_file"])
    if not path.is_file():
        raise MeshError(f"not a file: {path}" + (" (a folder)" if path.is_dir() else ""), ["missing_file"])
    ext = path.suffix.lower()
    if ext not in SUPPORTED:
        raise MeshError(
            f"unknown mesh format {ext or '(no extension)'!r} for {path}; supported: {', '.join(SUPPORTED)}",
            ["unknown_format"],
        )
    try:
        with open(path, "rb") as fh:
            empty = not fh.read(1)
    except OSError as exc:
        raise MeshError(f"cannot read {path}: {exc.strerror or exc}", ["unreadable"]) from None
    if empty:
        raise MeshError(f"{path} is empty (0 bytes)", ["empty"])
    return path


def load_mesh(path: str | Path) -> tuple[np.ndarray, np.ndarray]:
    """``(V (nv, 3) float64, F (nf, 3) int64)`` of :func:`read_mesh`."""
    m = read_mesh(path)
    return m.V, m.F
