"""Export a :class:`SplineSurface`: meshes, control nets, surface files, pictures.

    from trispline.fit.io.export import export_surface, export_control_net
    export_surface(surface, "scan.ply")                 # OBJ / PLY / STL / GLB / NPZ / JSON / PNG
    export_surface(surface, "scan.ply", resolution=8)   # ... 8 steps per patch edge
    export_control_net(surface, "net.obj")              # control net as a triangle mesh
    export_control_net(surface, "net.obj", lines=True)  # ... or as line segments (OBJ 'l')
    export_surface(surface, "scan.png", size=(800, 600))  # a shaded picture (trispline.fit.render)

Meshes are the watertight tessellation of :func:`trispline.spline.tessellate.tessellate`
(neighbouring patches share their boundary samples, so there are no cracks along
patch boundaries; vertex ``v`` of the mesh is the corner point of domain vertex
``v``) with its analytic unit normals, written through trimesh with
``process=False`` so nothing is merged or reordered (PLY is written here, binary
in double precision; trimesh would store float32). GLB and STL store float32 by
specification; STL stores face normals only and one copy of each corner per
triangle. Pictures are drawn by :mod:`trispline.fit.render`. Every file is
written atomically (:mod:`trispline.spline.util.atomic`).

Mesh exports have a sensible size by default: the resolution follows the patch
count (:func:`.sizes.export_resolution`), and a file estimated
(:func:`.sizes.estimate_export_bytes`) above :data:`LARGE_EXPORT_BYTES` is announced
with a :class:`LargeExportWarning` before it is written. So is exact CAD of that size (an
interpolating fit of a dense scan is one patch per triangle: about 21 kB each as STEP).
"""
from __future__ import annotations

import os
import warnings
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from trispline.spline.checks import as_array, check_ids, flag, whole_number
from trispline.spline.errors import InputError
from trispline.spline.index import DEGREE, EXPONENTS, NCTRL, lattice_triangles
from trispline.spline.tessellate import Tessellation, require_tessellation_memory
from trispline.spline.util.atomic import AtomicOutputs, write_with

from ..errors import ExportFormatError, LargeExportWarning
from .formats import (
    CAD_FORMATS, EXPORT_FORMATS, IMAGE_FORMATS, MESH_FORMATS, SURFACE_FORMATS, check_coordinate_range, check_export_path,
)
from .sizes import estimate_export_bytes, export_resolution, require_export_memory

if TYPE_CHECKING:  # pragma: no cover
    import trimesh

    from trispline.spline.surface import SplineSurface

__all__ = [
    "MESH_FORMATS", "SURFACE_FORMATS", "IMAGE_FORMATS", "EXPORT_FORMATS", "LARGE_EXPORT_BYTES",
    "ExportFormatError", "LargeExportWarning", "check_export_path", "surface_mesh", "control_net",
    "control_net_mesh", "export_mesh", "export_surface", "export_control_net",
]


#: Exports estimated above this many bytes are announced with a LargeExportWarning.
LARGE_EXPORT_BYTES = 200_000_000


# ------------------------------------------------------------------------- meshes
def _trimesh(vertices: np.ndarray, triangles: np.ndarray, normals: np.ndarray | None = None) -> "trimesh.Trimesh":
    import trimesh

    kw: dict[str, Any] = {}
    if normals is not None and normals.size:
        kw["vertex_normals"] = normals
    return trimesh.Trimesh(vertices=vertices, faces=triangles, process=False, validate=False, **kw)


def surface_mesh(surface: "SplineSurface", resolution: int = 8) -> "trimesh.Trimesh":
    """The tessellated surface as a ``trimesh.Trimesh`` with analytic vertex normals.

    ``resolution`` steps per patch edge: ``V + (r-1) E + (r-1)(r-2)/2 F`` vertices,
    ``r^2 F`` triangles; vertex ``v < V`` is the corner point of domain vertex ``v``.
    """
    tess: Tessellation = surface.tessellate(resolution)
    return _trimesh(tess.vertices, tess.triangles, tess.normals)


def control_net(surface: "SplineSurface") -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The global control net: shared points, lattice triangles and edges.

    Points shared by neighbouring patches (corner points, the boundary points of a
    common edge) appear once, so the net has ``V + 4E + 6F`` points.

    Returns
    -------
    points : (V + 4E + 6F, 3) float64; point ``v < V`` is the corner point of vertex ``v``
    triangles : (25 F, 3) int64 into ``points``, counter-clockwise like the faces
    segments : (n, 2) int64 unique edges of the lattice (for line drawings)
    """
    tri = surface.triangulation
    F, ctrl = tri.faces, np.asarray(surface.ctrl)
    nv, nf, ne = tri.n_vertices, tri.n_faces, tri.n_edges
    gid = np.empty((nf, NCTRL), np.int64)
    zeros = EXPONENTS == 0
    n_zero = zeros.sum(1)
    # corners
    for n in np.flatnonzero(n_zero == 2):
        gid[:, n] = F[:, int(np.argmax(EXPONENTS[n]))]
    # edge points: the edge opposite local k (the zero exponent), position counted
    # from the edge's first vertex tri.edges[e, 0]
    for n in np.flatnonzero(n_zero == 1):
        k = int(np.argmax(zeros[n]))
        e = tri.face_edges[:, k]
        first_local = np.where(F[:, (k + 1) % 3] == tri.edges[e, 0], (k + 1) % 3, (k + 2) % 3)
        steps_from_first = DEGREE - EXPONENTS[n][first_local]  # 1..4
        gid[:, n] = nv + 4 * e + steps_from_first - 1
    # the six inner points of each face
    inner = np.flatnonzero(n_zero == 0)
    gid[:, inner] = nv + 4 * ne + 6 * np.arange(nf)[:, None] + np.arange(inner.size)[None, :]
    points = np.empty((nv + 4 * ne + 6 * nf, 3))
    points[gid.ravel()] = ctrl.reshape(-1, 3)
    # the control points' exponents are lattice(5), so its 25 triangles index the storage order
    triangles = gid[:, lattice_triangles(DEGREE)].reshape(-1, 3)
    seg = np.concatenate([triangles[:, [0, 1]], triangles[:, [1, 2]], triangles[:, [2, 0]]])
    segments = np.unique(np.sort(seg, axis=1), axis=0)
    return points, triangles, segments


def control_net_mesh(surface: "SplineSurface") -> "trimesh.Trimesh":
    """The control net as a triangle mesh (25 triangles per patch) for viewing."""
    points, triangles, _ = control_net(surface)
    return _trimesh(points, triangles)


# ------------------------------------------------------------------------ writers
def _path(path: Any) -> str | os.PathLike:
    """``path`` if it is a str or an ``os.PathLike``, else InputError."""
    if not isinstance(path, (str, os.PathLike)):
        raise InputError(f"the output path must be a str or os.PathLike, got {type(path).__name__}")
    return path


def _check_picture_options(options: dict[str, Any]) -> None:
    """Refuse picture options :func:`trispline.fit.render.draw` does not take (named, not a TypeError)."""
    import inspect

    from .. import render

    params = inspect.signature(render.draw).parameters
    if any(p.kind is inspect.Parameter.VAR_KEYWORD for p in params.values()):
        return  # a wrapper that takes anything: draw itself names what it does not take
    known = set(params) - {"surface", "resolution"}
    unknown = sorted(set(options) - known)
    if unknown:
        raise InputError(f"unknown picture option{'s' if len(unknown) > 1 else ''} {', '.join(unknown)}; "
                         f"known: {', '.join(sorted(known))}")


def _write_ply(vertices: np.ndarray, triangles: np.ndarray, normals: np.ndarray | None, tmp: Path) -> None:
    """Binary little-endian PLY in double precision (trimesh's writer stores float32)."""
    fields = [("xyz", "<f8", (3,))] + ([("n", "<f8", (3,))] if normals is not None else [])
    vert = np.empty(vertices.shape[0], dtype=fields)
    vert["xyz"] = vertices
    if normals is not None:
        vert["n"] = normals
    face = np.empty(triangles.shape[0], dtype=[("count", "u1"), ("index", "<i4", (3,))])
    face["count"] = 3
    face["index"] = triangles
    header = ["ply", "format binary_little_endian 1.0", "comment trispline tessellation",
              f"element vertex {vertices.shape[0]}", "property double x", "property double y",
              "property double z"]
    if normals is not None:
        header += ["property double nx", "property double ny", "property double nz"]
    header += [f"element face {triangles.shape[0]}", "property list uchar int vertex_indices", "end_header"]
    with open(tmp, "wb") as fh:
        fh.write(("\n".join(header) + "\n").encode("ascii"))
        fh.write(vert.tobytes())
        fh.write(face.tobytes())


def _write_mesh(mesh: "trimesh.Trimesh", tmp: Path, suffix: str, normals: bool) -> None:
    kind = suffix[1:]
    if kind == "ply":
        _write_ply(np.asarray(mesh.vertices), np.asarray(mesh.faces),
                   np.asarray(mesh.vertex_normals) if normals else None, tmp)
        return
    if kind == "obj":
        kw: dict[str, Any] = dict(include_normals=normals, digits=15)
    elif kind == "off":  # positions and triangles only: the format has no normals
        kw = dict(digits=15)
    elif kind == "glb":
        kw = dict(include_normals=normals)
    else:
        kw = {}
    mesh.export(file_obj=str(tmp), file_type=kind, **kw)


def _write_obj_lines(points: np.ndarray, segments: np.ndarray, tmp: Path) -> None:
    with open(tmp, "w", encoding="utf-8") as fh:
        fh.write("# trispline control net: points and line segments\n")
        np.savetxt(fh, points, fmt="v %.17g %.17g %.17g")
        np.savetxt(fh, segments + 1, fmt="l %d %d")


def export_mesh(
    V: np.ndarray, F: np.ndarray, path: str | os.PathLike, *, normals: np.ndarray | None = None,
    outputs: AtomicOutputs | None = None,
) -> Path:
    """Write a plain triangle mesh ``V (nv, 3)``, ``F (nf, 3)`` (optional ``normals (nv, 3)``)
    to OBJ/PLY/STL/GLB/OFF atomically, vertex order kept."""
    suffix = check_export_path(_path(path), MESH_FORMATS)
    V = as_array(V, "V", (None, 3), finite=True)
    F = check_ids(as_array(F, "F", (None, 3), integer=True, whole_floats=False), "F", V.shape[0])
    if normals is not None:
        normals = as_array(normals, "normals", (V.shape[0], 3), finite=True)
    check_coordinate_range(path, V)
    mesh = _trimesh(V, F, normals)
    return write_with(path, lambda tmp: _write_mesh(mesh, tmp, suffix, normals is not None), outputs)


def export_surface(
    surface: "SplineSurface", path: str | os.PathLike, *, resolution: int | None = None,
    outputs: AtomicOutputs | None = None, merge: bool = False, **image_options: Any,
) -> Path:
    """Write ``surface`` to ``path``; the format follows the suffix.

    ``.obj .ply .stl .glb .off``: the tessellated mesh (``resolution`` steps per patch
    edge; None: :func:`.sizes.export_resolution` of the patch count) with analytic
    normals (OFF has none), announced with a :class:`LargeExportWarning` when estimated above
    :data:`LARGE_EXPORT_BYTES`; ``.npz .json``: the surface file; ``.png``: a
    picture drawn by :func:`trispline.fit.render.draw` (``resolution`` samples per
    patch edge; None: the renderer's own), shaded and with the renderer's defaults
    (seen along the surface's mean normal) unless ``image_options`` (``mode``,
    ``view``, ``size``, ``title``, ...) say otherwise;
    ``.step .stp .iges .igs .3dm``: the exact B-spline faces of :func:`.cad.export_cad`
    (``merge`` joins two of a triangle's three faces; needs the extra ``trispline[cad]``),
    announced like a large mesh.
    With ``outputs`` the file joins that group (committed by the caller), otherwise
    it is written atomically on its own.
    """
    from trispline.spline.surface import SplineSurface

    if not isinstance(surface, SplineSurface):
        raise InputError(f"surface must be a SplineSurface, got {type(surface).__name__}")
    suffix = check_export_path(_path(path))
    if resolution is not None:
        resolution = whole_number(resolution, "resolution", least=1)
    merge = flag(merge, "merge")
    if suffix in IMAGE_FORMATS:
        _check_picture_options(image_options)
    if suffix in MESH_FORMATS:
        check_coordinate_range(path, surface.ctrl)  # the surface lies in its control points' hull
        r = export_resolution(surface.n_faces) if resolution is None else int(resolution)
        tri = surface.triangulation  # a tessellation beyond the memory is refused before the size warning
        require_tessellation_memory(tri.n_vertices, tri.n_edges, tri.n_faces, r, np.asarray(surface.ctrl).shape[2])
        require_export_memory(tri.n_vertices, tri.n_edges, tri.n_faces, r, path)
        size = estimate_export_bytes(surface, path, r)
        if size > LARGE_EXPORT_BYTES:
            warnings.warn(f"{Path(path).name} will be about {size / 1e6:.0f} MB ({surface.n_faces} patches at "
                          f"resolution {r}); a lower --resolution makes it smaller", LargeExportWarning, stacklevel=2)
        mesh = surface_mesh(surface, r)
        return write_with(path, lambda tmp: _write_mesh(mesh, tmp, suffix, True), outputs)
    if suffix in SURFACE_FORMATS:
        return write_with(path, lambda tmp: surface.save(tmp), outputs)
    if suffix in CAD_FORMATS:
        from .cad import export_cad

        size = estimate_export_bytes(surface, path, merge=merge)
        if size > LARGE_EXPORT_BYTES:
            warnings.warn(f"{Path(path).name} will be about {size / 1e6:.0f} MB ({surface.n_faces} patches as "
                          f"{(2 if merge else 3) * surface.n_faces} B-spline faces); an approximating fit "
                          "(fit --tolerance) gives a compact surface", LargeExportWarning, stacklevel=2)
        return export_cad(surface, path, merge=merge, outputs=outputs)
    return write_with(path, lambda tmp: _write_picture(surface, tmp, resolution, image_options), outputs)


def export_control_net(
    surface: "SplineSurface", path: str | os.PathLike, *, lines: bool = False,
    outputs: AtomicOutputs | None = None,
) -> Path:
    """Write the control net: a triangle mesh (OBJ/PLY/STL/GLB/OFF) or, with ``lines=True``,
    its points and line segments as an OBJ file (``v`` and ``l`` records)."""
    suffix = check_export_path(_path(path), (".obj",) if lines else MESH_FORMATS)
    if lines:
        points, _, segments = control_net(surface)
        return write_with(path, lambda tmp: _write_obj_lines(points, segments, tmp), outputs)
    check_coordinate_range(path, surface.ctrl)
    mesh = control_net_mesh(surface)
    return write_with(path, lambda tmp: _write_mesh(mesh, tmp, suffix, False), outputs)


def _write_picture(surface: "SplineSurface", tmp: Path, resolution: int | None, options: dict[str, Any]) -> None:
    """Draw ``surface`` with :mod:`trispline.fit.render` into the PNG file ``tmp`` (see :func:`export_surface`)."""
    from .. import render  # imported when a picture is asked for: render builds on this package's formats

    opts: dict[str, Any] = dict(mode="shaded")
    opts.update(options)
    render.write_png(render.draw(surface, resolution=resolution, **opts).image, tmp)
