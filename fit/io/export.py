"""Export a :class:`SplineSurface`: meshes, control nets, surface files, pictures.

    from trispline.fit.io.export import export_surface, export_control_net, render_image
    export_surface(surface, "scan.ply", resolution=8)   # OBJ / PLY / STL / GLB / NPZ / JSON / PNG
    export_control_net(surface, "net.obj")              # control net as a triangle mesh
    export_control_net(surface, "net.obj", lines=True)  # ... or as line segments (OBJ 'l')
    render_image(surface, "scan.png")                    # off-screen matplotlib picture

Meshes are the watertight tessellation of :func:`trispline.spline.tessellate.tessellate`
(neighbouring patches share their boundary samples, so there are no cracks along
patch boundaries; vertex ``v`` of the mesh is the corner point of domain vertex
``v``) with its analytic unit normals, written through trimesh with
``process=False`` so nothing is merged or reordered (PLY is written here, binary
in double precision; trimesh would store float32). GLB and STL store float32 by
specification; STL stores face normals only and one copy of each corner per
triangle. Every file is
written atomically (:mod:`trispline.spline.util.atomic`).
"""
from __future__ import annotations

import os
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from trispline.spline.index import DEGREE, EXPONENTS, NCTRL, index_of
from trispline.spline.tessellate import Tessellation

from trispline.spline.util.atomic import AtomicOutputs
from ..errors import ExportFormatError

if TYPE_CHECKING:  # pragma: no cover
    import trimesh

    from trispline.spline.surface import SplineSurface

__all__ = [
    "MESH_FORMATS", "SURFACE_FORMATS", "IMAGE_FORMATS", "EXPORT_FORMATS",
    "ExportFormatError", "check_export_path", "surface_mesh", "control_net",
    "control_net_mesh", "export_mesh", "export_surface", "export_control_net", "render_image",
]

#: Tessellated-mesh formats (through trimesh).
MESH_FORMATS = (".obj", ".ply", ".stl", ".glb")
#: Surface file formats (DESIGN.md §6).
SURFACE_FORMATS = (".npz", ".json")
#: Pictures (matplotlib, off-screen).
IMAGE_FORMATS = (".png",)
EXPORT_FORMATS = MESH_FORMATS + SURFACE_FORMATS + IMAGE_FORMATS



def check_export_path(path: str | os.PathLike, formats: tuple[str, ...] = EXPORT_FORMATS) -> str:
    """Return the lower-case suffix of ``path`` if it is one of ``formats``; else raise."""
    suffix = Path(path).suffix.lower()
    if suffix not in formats:
        raise ExportFormatError(
            f"cannot write {path}: unknown output format {suffix or '(no extension)'!r}; "
            f"use one of {', '.join(formats)}"
        )
    return suffix


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


def _lattice_triangles() -> np.ndarray:
    """(25, 3) storage indices of the control-net triangles of one patch (CCW like the face)."""
    tris = []
    n = DEGREE
    for i in range(n, 0, -1):
        for j in range(n - i + 1):
            k = n - i - j
            tris.append((index_of(i, j, k), index_of(i - 1, j + 1, k), index_of(i - 1, j, k + 1)))
            if i >= 2:
                tris.append((index_of(i - 1, j + 1, k), index_of(i - 2, j + 1, k + 1), index_of(i - 1, j, k + 1)))
    return np.array(tris, np.int64)


_LATTICE = _lattice_triangles()


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
    triangles = gid[:, _LATTICE].reshape(-1, 3)
    seg = np.concatenate([triangles[:, [0, 1]], triangles[:, [1, 2]], triangles[:, [2, 0]]])
    segments = np.unique(np.sort(seg, axis=1), axis=0)
    return points, triangles, segments


def control_net_mesh(surface: "SplineSurface") -> "trimesh.Trimesh":
    """The control net as a triangle mesh (25 triangles per patch) for viewing."""
    points, triangles, _ = control_net(surface)
    return _trimesh(points, triangles)


# ------------------------------------------------------------------------ writers
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


def _run(path: str | os.PathLike, outputs: AtomicOutputs | None, write) -> Path:
    if outputs is not None:
        write(outputs.path(path))
    else:
        with AtomicOutputs() as out:
            write(out.path(path))
    return Path(path)


def export_mesh(
    V: np.ndarray, F: np.ndarray, path: str | os.PathLike, *, normals: np.ndarray | None = None,
    outputs: AtomicOutputs | None = None,
) -> Path:
    """Write a plain triangle mesh ``V (nv, 3)``, ``F (nf, 3)`` (optional ``normals (nv, 3)``)
    to OBJ/PLY/STL/GLB atomically, vertex order kept."""
    suffix = check_export_path(path, MESH_FORMATS)
    mesh = _trimesh(np.asarray(V, float), np.asarray(F, np.int64), normals)
    return _run(path, outputs, lambda tmp: _write_mesh(mesh, tmp, suffix, normals is not None))


def export_surface(
    surface: "SplineSurface", path: str | os.PathLike, *, resolution: int = 8,
    outputs: AtomicOutputs | None = None, **image_options: Any,
) -> Path:
    """Write ``surface`` to ``path``; the format follows the suffix.

    ``.obj .ply .stl .glb``: the tessellated mesh (``resolution`` steps per patch
    edge) with analytic normals; ``.npz .json``: the surface file; ``.png``: a
    picture (:func:`render_image`, ``image_options`` passed on).
    With ``outputs`` the file joins that group (committed by the caller), otherwise
    it is written atomically on its own.
    """
    suffix = check_export_path(path)
    if suffix in MESH_FORMATS:
        mesh = surface_mesh(surface, resolution)
        return _run(path, outputs, lambda tmp: _write_mesh(mesh, tmp, suffix, True))
    if suffix in SURFACE_FORMATS:
        return _run(path, outputs, lambda tmp: surface.save(tmp))
    return _run(path, outputs, lambda tmp: render_image(surface, tmp, resolution=resolution, **image_options))


def export_control_net(
    surface: "SplineSurface", path: str | os.PathLike, *, lines: bool = False,
    outputs: AtomicOutputs | None = None,
) -> Path:
    """Write the control net: a triangle mesh (OBJ/PLY/STL/GLB) or, with ``lines=True``,
    its points and line segments as an OBJ file (``v`` and ``l`` records)."""
    suffix = check_export_path(path, (".obj",) if lines else MESH_FORMATS)
    if lines:
        points, _, segments = control_net(surface)
        return _run(path, outputs, lambda tmp: _write_obj_lines(points, segments, tmp))
    mesh = control_net_mesh(surface)
    return _run(path, outputs, lambda tmp: _write_mesh(mesh, tmp, suffix, False))


# ------------------------------------------------------------------------ pictures
def _auto_view(V: np.ndarray, T: np.ndarray, tilt: float, elev: float | None, azim: float | None
               ) -> tuple[float, float]:
    """Camera (elev, azim) in degrees: ``tilt`` degrees off the mean normal of the mesh."""
    n = np.cross(V[T[:, 1]] - V[T[:, 0]], V[T[:, 2]] - V[T[:, 0]]).sum(0)
    n = n / (np.linalg.norm(n) or 1.0)
    if n[2] < 0:
        n = -n
    side = np.cross(n, [0.0, 0.0, 1.0])
    side = side / np.linalg.norm(side) if np.linalg.norm(side) > 1e-6 else np.array([0.0, -1.0, 0.0])
    down = np.cross(n, side)  # in the surface, pointing away from +z
    if down[2] > 0:
        down = -down
    t = np.radians(tilt)
    eye = np.cos(t) * n + np.sin(t) * (0.8 * down + 0.6 * side)
    e = float(np.degrees(np.arcsin(np.clip(eye[2], -1, 1))))
    a = float(np.degrees(np.arctan2(eye[1], eye[0])))
    return (e if elev is None else elev), (a if azim is None else azim)


def render_image(
    surface: "SplineSurface", path: str | os.PathLike, *, resolution: int = 6,
    data_points: np.ndarray | None = None, patch_lines: bool = True, title: str | None = None,
    elev: float | None = None, azim: float | None = None, view_tilt: float = 50.0, zoom: float = 1.35, size: tuple[float, float] = (6.4, 4.8), dpi: int = 120,
) -> Path:
    """Render the surface off-screen (matplotlib Agg) to a PNG file at ``path``.

    Shading is Lambertian from the tessellation's analytic normals (two-sided);
    ``patch_lines`` draws the patch boundaries (the images of the domain edges);
    ``data_points (n, 3)`` are drawn as dots (e.g. the fitted mesh's vertices).
    Unless ``elev`` and ``azim`` (degrees) are given, the camera looks at the surface
    ``view_tilt`` degrees off its mean normal, so the relief shows.
    The file is written as given (wrap it in :mod:`trispline.spline.util.atomic` yourself,
    or use :func:`export_surface`, which does).
    """
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure
    from mpl_toolkits.mplot3d.art3d import Line3DCollection, Poly3DCollection

    tess = surface.tessellate(resolution)
    V, T, N = tess.vertices, tess.triangles, tess.normals
    fig = Figure(figsize=size, dpi=dpi)
    FigureCanvasAgg(fig)
    ax = fig.add_subplot(projection="3d")
    if elev is None or azim is None:
        elev, azim = _auto_view(V, T, view_tilt, elev, azim)
    ax.view_init(elev=elev, azim=azim)
    # light from the viewer's upper left, in data coordinates
    e, a = np.radians(elev + 25.0), np.radians(azim - 35.0)
    light = np.array([np.cos(e) * np.cos(a), np.cos(e) * np.sin(a), np.sin(e)])
    fn = N[T].mean(1)
    fn /= np.maximum(np.linalg.norm(fn, axis=1, keepdims=True), 1e-300)
    diffuse = np.abs(fn @ light)
    shade = 0.18 + 0.72 * diffuse + 0.25 * diffuse**24  # ambient + diffuse + a soft highlight
    base = np.array([0.42, 0.62, 0.92])
    colors = np.clip(shade[:, None] * base[None, :], 0, 1)
    # edges in the face colour hide the anti-aliasing seams between the small triangles
    ax.add_collection3d(Poly3DCollection(V[T], facecolors=colors, edgecolors=colors, linewidths=0.25))
    if patch_lines:
        tri = surface.triangulation
        t = np.linspace(0.0, 1.0, max(resolution, 2) + 1)
        f = np.where(tri.edge_faces[:, 0] >= 0, tri.edge_faces[:, 0], tri.edge_faces[:, 1])
        k = np.where(tri.edge_faces[:, 0] >= 0, tri.edge_opposite[:, 0], tri.edge_opposite[:, 1])
        ne, m = f.size, t.size
        bary = np.zeros((ne, m, 3))
        rows = np.arange(ne)[:, None]
        bary[rows, np.arange(m)[None, :], ((k + 1) % 3)[:, None]] = 1.0 - t
        bary[rows, np.arange(m)[None, :], ((k + 2) % 3)[:, None]] = t
        curve = surface.evaluate(np.repeat(f, m), bary.reshape(-1, 3)).reshape(ne, m, 3)
        segs = np.stack([curve[:, :-1], curve[:, 1:]], axis=2).reshape(-1, 2, 3)
        ax.add_collection3d(Line3DCollection(segs, colors=[(0.1, 0.1, 0.2, 0.35)], linewidths=0.4))
    if data_points is not None and len(data_points):
        P = np.asarray(data_points, float)
        ax.scatter(P[:, 0], P[:, 1], P[:, 2], s=1.5, c="k", depthshade=False)
    lo, hi = V.min(0), V.max(0)
    ctr, half = 0.5 * (lo + hi), 0.5 * (hi - lo)
    ax.set_xlim(ctr[0] - half[0], ctr[0] + half[0])
    ax.set_ylim(ctr[1] - half[1], ctr[1] + half[1])
    ax.set_zlim(ctr[2] - half[2], ctr[2] + half[2])
    ax.set_box_aspect(np.maximum(hi - lo, 1e-3 * float((hi - lo).max())), zoom=zoom)
    ax.set_axis_off()
    if title:
        ax.set_title(title)
    fig.subplots_adjust(left=0, right=1, bottom=0, top=0.95 if title else 1)
    fig.savefig(str(path), format="png")
    return Path(path)
