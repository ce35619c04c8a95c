"""Exact CAD export of a :class:`SplineSurface`: STEP AP214, IGES and Rhino 3dm.

    from trispline.fit.io.cad import export_cad
    export_cad(surface, "scan.step")              # .step .stp .iges .igs .3dm
    export_cad(surface, "scan.step", merge=True)   # 2 instead of 3 faces per triangle

Every quintic triangle becomes three bi-quintic B-spline faces with no approximation
(:mod:`trispline.spline.tensor`). STEP and IGES hold them as one open shell built
through Open CASCADE: the faces share their edges and vertices (one B-spline edge curve
per quad side, a line as its parameter curve on each face), so the shell's free edges
are exactly the surface's boundary loops, holes included. STEP writes
``B_SPLINE_SURFACE_WITH_KNOTS`` faces in a ``SHELL_BASED_SURFACE_MODEL``; IGES writes
entity 128 surfaces in a 514 shell (its B-rep mode), which CAD imports as one body.
rhino3dm cannot build shared-edge B-reps, so a 3dm file holds the faces as NURBS
surfaces in one group; Rhino's ``Join`` turns them into one polysurface.

Face ``n`` of the shell (and object ``n`` of a 3dm file) is tensor patch ``n`` of
:func:`~trispline.spline.tensor.tensor_net`: quad ``n % 3`` of triangle ``n // 3``, with
the same ``(u, v) = (s, t)``. With ``merge=True`` faces ``f`` and ``F + f`` are triangle
``f``'s quad 0 and its quads 1 and 2 joined into one face with an interior knot at
``u = 1``: ``u`` in ``[0, 1]`` is quad 1's ``(s, t) = (u, v)``, ``u`` in ``[1, 2]`` quad 2's
``(s, t) = (v, 2 - u)``. Coordinates are written as they are (STEP and IGES label them
millimetres). Open CASCADE and rhino3dm come with the optional extra ``trispline[cad]``.
"""
from __future__ import annotations

import os
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, Iterator

import numpy as np

from trispline.spline.index import DEGREE
from trispline.spline.tensor import TensorNet, tensor_net
from trispline.spline.tolerances import CAD_TOLERANCE
from trispline.spline.util.atomic import AtomicOutputs, write_with

from trispline.spline.errors import InputError

from ..errors import CommandFailed, ExportFormatError
from .formats import CAD_FORMATS, check_export_path

if TYPE_CHECKING:  # pragma: no cover
    from trispline.spline.surface import SplineSurface

__all__ = [
    "CAD_FORMATS", "CAD_TOLERANCE", "CadLayout", "FaceKind", "cad_layout", "export_cad", "occ_mesh", "occ_shell",
    "read_cad",
]

_N = DEGREE + 1  # control points per row of a bi-quintic patch
#: IGES reals: 13 significant digits, the precision of Open CASCADE's STEP writer.
_IGES_REAL = "%.12E"
#: rhino3dm's 3dm archive version (Rhino 7 and later read it).
_3DM_VERSION = 7


# ------------------------------------------------------------------ B-rep tables
@dataclass(frozen=True)
class FaceKind:
    """Faces of one shape. ``poles (n, nu, 6)`` point ids (u then v), ``nu = 5 spans + 1``
    with knots ``0, 1, .., spans``; ``rows (n, m, 6)`` the point ids of the ``m`` boundary
    segments, counter-clockwise; ``uv (m, 2, 2)`` each segment's start and end on the face."""

    poles: np.ndarray
    rows: np.ndarray
    uv: np.ndarray

    @property
    def spans(self) -> int:
        return (self.poles.shape[1] - 1) // DEGREE


@dataclass(frozen=True)
class CadLayout:
    """The B-rep of a :class:`TensorNet`: faces, shared edges and vertices as index tables.

    Attributes
    ----------
    kinds : the faces, by shape (quads; with merge also the joined quad pairs)
    edge_rows : (ne, 6) point ids of every edge curve, from the lower id to the higher
    seg_edge, seg_forward : per kind ``(n, m)`` edge of each boundary segment and whether the
        segment runs it forward
    vertex_ids : (nvtx,) point ids of the B-rep vertices
    """

    kinds: tuple[FaceKind, ...]
    edge_rows: np.ndarray
    seg_edge: tuple[np.ndarray, ...]
    seg_forward: tuple[np.ndarray, ...]
    vertex_ids: np.ndarray

    @property
    def n_faces(self) -> int:
        return sum(k.poles.shape[0] for k in self.kinds)


def _sides(P: np.ndarray) -> np.ndarray:
    """``(n, 4, 6)`` boundary rows of quads ``P (n, 6, 6)``, counter-clockwise from ``(0, 0)``."""
    return np.stack([P[:, :, 0], P[:, -1, :], P[:, ::-1, -1], P[:, 0, ::-1]], axis=1)


_QUAD_UV = np.array([[(0, 0), (1, 0)], [(1, 0), (1, 1)], [(1, 1), (0, 1)], [(0, 1), (0, 0)]], float)
# quads 1 and 2 joined: quad 1's bottom, quad 2's left, bottom, right (its top is the shared
# spoke), quad 1's top and left; in face uv (quad 2's (s, t) is (v, 2 - u))
_PAIR_SIDES = ((1, 0), (2, 3), (2, 0), (2, 1), (1, 2), (1, 3))
_PAIR_UV = np.array([[(0, 0), (1, 0)], [(1, 0), (2, 0)], [(2, 0), (2, 1)], [(2, 1), (1, 1)],
                     [(1, 1), (0, 1)], [(0, 1), (0, 0)]], float)


def _kinds(net: TensorNet, merge: bool) -> tuple[FaceKind, ...]:
    """The faces of the B-rep: every quad, or with ``merge`` quad 0 and quads 1 + 2 of each triangle."""
    P = net.patches
    if not merge:
        return (FaceKind(P, _sides(P), _QUAD_UV),)
    q = P.reshape(net.n_faces, 3, _N, _N)
    joined = np.concatenate([q[:, 1], q[:, 2, :, ::-1].transpose(0, 2, 1)[:, 1:]], axis=1)  # (F, 11, 6)
    sides = {k: _sides(q[:, k]) for k in (1, 2)}
    rows = np.stack([sides[k][:, s] for k, s in _PAIR_SIDES], axis=1)
    return FaceKind(q[:, 0], _sides(q[:, 0]), _QUAD_UV), FaceKind(joined, rows, _PAIR_UV)


def cad_layout(net: TensorNet, *, merge: bool = False) -> CadLayout:
    """Faces, shared edges (identified by their end point ids) and vertices of ``net``'s B-rep."""
    kinds = _kinds(net, merge)
    rows = np.concatenate([k.rows.reshape(-1, _N) for k in kinds])
    start, end = rows[:, 0], rows[:, -1]
    key = np.minimum(start, end) * net.points.shape[0] + np.maximum(start, end)
    _, first, inv = np.unique(key, return_index=True, return_inverse=True)
    forward = start < end
    edge_rows = np.where(forward[first, None], rows[first], rows[first, ::-1])
    splits = np.cumsum([k.rows.shape[0] * k.rows.shape[1] for k in kinds])[:-1]
    shapes = [k.rows.shape[:2] for k in kinds]
    seg_edge = tuple(a.reshape(s) for a, s in zip(np.split(inv, splits), shapes))
    seg_forward = tuple(a.reshape(s) for a, s in zip(np.split(forward, splits), shapes))
    vertex_ids = np.unique(edge_rows[:, [0, -1]])
    return CadLayout(kinds, edge_rows, seg_edge, seg_forward, vertex_ids)


# ------------------------------------------------------------------ libraries
def _require(module: str, what: str, refusal: str) -> None:
    """Import ``module`` or refuse (``refusal``: "cannot write x.step") naming the extra to install."""
    import importlib

    try:
        importlib.import_module(module)
    except ImportError:
        raise ExportFormatError(
            f"{refusal}: {what} needs the optional extra trispline[cad] (pip install 'trispline[cad]'), "
            f"which provides {module.split('.')[0]}") from None


@contextmanager
def _occ_quiet() -> Iterator[None]:
    """Open CASCADE's messages (transfer statistics) off while writing; restored after."""
    from OCP.Message import Message, Message_Gravity

    printers = Message.DefaultMessenger_s().Printers()
    levels = [printers.Value(i).GetTraceLevel() for i in range(1, printers.Length() + 1)]
    for i in range(1, printers.Length() + 1):
        printers.Value(i).SetTraceLevel(Message_Gravity.Message_Fail)
    try:
        yield
    finally:
        for i, level in enumerate(levels, start=1):
            printers.Value(i).SetTraceLevel(level)


@contextmanager
def _occ_static(values: dict[str, str]) -> Iterator[None]:
    """Set Open CASCADE's global translator parameters for one write; restored after."""
    from OCP.Interface import Interface_Static

    old = {k: Interface_Static.CVal_s(k) for k in values if Interface_Static.IsPresent_s(k)}
    for k in old:
        Interface_Static.SetCVal_s(k, values[k])
    try:
        yield
    finally:
        for k, v in old.items():
            Interface_Static.SetCVal_s(k, v)


def _occ_arrays() -> tuple[type, type, type, type]:
    """``Array1_gp_Pnt, Array2_gp_Pnt, Array1_double, Array1_int`` of OCP 8, or OCP 7's TCol names."""
    try:
        from OCP.collections import Array1_double, Array1_gp_Pnt, Array1_int, Array2_gp_Pnt
    except ImportError:  # pragma: no cover - OCP 7.x
        from OCP.TColgp import TColgp_Array1OfPnt as Array1_gp_Pnt, TColgp_Array2OfPnt as Array2_gp_Pnt
        from OCP.TColStd import TColStd_Array1OfInteger as Array1_int, TColStd_Array1OfReal as Array1_double
    return Array1_gp_Pnt, Array2_gp_Pnt, Array1_double, Array1_int


# ------------------------------------------------------------------ Open CASCADE shell
def _occ_knots(spans: int) -> tuple[Any, Any]:
    """Knots ``0, 1, .., spans`` with end multiplicity 6 and interior multiplicity 5 (C0 joins)."""
    _, _, Array1_double, Array1_int = _occ_arrays()
    knots, mults = Array1_double(1, spans + 1), Array1_int(1, spans + 1)
    for i in range(spans + 1):
        knots.SetValue(i + 1, float(i))
        mults.SetValue(i + 1, _N if i in (0, spans) else DEGREE)
    return knots, mults


def _occ_edges(points: list, lay: CadLayout, tol: float) -> list:
    """One ``TopoDS_Edge`` per edge of ``lay``: a Bézier curve (as a B-spline) on shared vertices."""
    from OCP.BRep import BRep_Builder
    from OCP.Geom import Geom_BSplineCurve
    from OCP.gp import gp_Pnt
    from OCP.TopAbs import TopAbs_FORWARD, TopAbs_REVERSED
    from OCP.TopoDS import TopoDS_Edge, TopoDS_Vertex

    Array1_gp_Pnt = _occ_arrays()[0]
    build = BRep_Builder()
    vertex = {}
    for v in lay.vertex_ids.tolist():
        vertex[v] = TopoDS_Vertex()
        build.MakeVertex(vertex[v], gp_Pnt(*points[v]), tol)
    knots, mults = _occ_knots(1)
    edges = []
    for row in lay.edge_rows.tolist():
        poles = Array1_gp_Pnt(1, _N)
        for i, p in enumerate(row):
            poles.SetValue(i + 1, gp_Pnt(*points[p]))
        edge = TopoDS_Edge()
        build.MakeEdge(edge, Geom_BSplineCurve(poles, knots, mults, DEGREE), tol)
        build.Add(edge, vertex[row[0]].Oriented(TopAbs_FORWARD))
        build.Add(edge, vertex[row[-1]].Oriented(TopAbs_REVERSED))
        edges.append(edge)
    return edges


def _occ_pcurves(kind: FaceKind) -> list[dict[bool, Any]]:
    """Per boundary segment, its line on the face for either sense: parameter ``w`` in [0, 1]
    runs from the edge curve's start, so the edge's 3D curve and line share the parameter."""
    from OCP.Geom2d import Geom2d_Line
    from OCP.gp import gp_Dir2d, gp_Pnt2d

    out = []
    for a, b in kind.uv.tolist():
        d = np.subtract(b, a)
        out.append({True: Geom2d_Line(gp_Pnt2d(*a), gp_Dir2d(*d)), False: Geom2d_Line(gp_Pnt2d(*b), gp_Dir2d(*-d))})
    return out


def occ_shell(net: TensorNet, lay: CadLayout, tolerance: float = CAD_TOLERANCE) -> Any:
    """The B-rep of ``lay`` as an Open CASCADE ``TopoDS_Shell`` (open; shared edges and vertices)."""
    from OCP.BRep import BRep_Builder
    from OCP.Geom import Geom_BSplineSurface
    from OCP.gp import gp_Pnt
    from OCP.TopAbs import TopAbs_FORWARD, TopAbs_REVERSED
    from OCP.TopoDS import TopoDS_Face, TopoDS_Shell, TopoDS_Wire

    Array2_gp_Pnt = _occ_arrays()[1]
    points = net.points.tolist()
    edges = _occ_edges(points, lay, tolerance)
    build = BRep_Builder()
    shell = TopoDS_Shell()
    build.MakeShell(shell)
    vknots, vmults = _occ_knots(1)
    for kind, seg_edge, seg_forward in zip(lay.kinds, lay.seg_edge, lay.seg_forward):
        uknots, umults = _occ_knots(kind.spans)
        lines = _occ_pcurves(kind)
        nu = kind.poles.shape[1]
        for poles, segs, fwds in zip(kind.poles.tolist(), seg_edge.tolist(), seg_forward.tolist()):
            grid = Array2_gp_Pnt(1, nu, 1, _N)
            for i, row in enumerate(poles):
                for j, p in enumerate(row):
                    grid.SetValue(i + 1, j + 1, gp_Pnt(*points[p]))
            face, wire = TopoDS_Face(), TopoDS_Wire()
            surface = Geom_BSplineSurface(grid, uknots, vknots, umults, vmults, DEGREE, DEGREE)
            build.MakeFace(face, surface, tolerance)
            build.MakeWire(wire)
            for line, e, fwd in zip(lines, segs, fwds):
                build.UpdateEdge(edges[e], line[fwd], face, tolerance)
                build.Add(wire, edges[e].Oriented(TopAbs_FORWARD if fwd else TopAbs_REVERSED))
            wire.Closed(True)
            build.Add(face, wire)
            build.Add(shell, face)
    for edge in edges:  # after the pcurves, so every representation gets the range [0, 1]
        build.Range(edge, 0.0, 1.0)
    shell.Closed(False)
    return shell


def _write_step(shell: Any, tmp: Path, name: str) -> bool:
    from OCP.IFSelect import IFSelect_RetDone
    from OCP.STEPControl import STEPControl_AsIs, STEPControl_Writer

    with _occ_quiet():
        writer = STEPControl_Writer()  # defines the write.step.* parameters
        with _occ_static({"write.step.schema": "AP214IS", "write.step.product.name": name}):
            ok = writer.Transfer(shell, STEPControl_AsIs) == IFSelect_RetDone
            return ok and writer.Write(str(tmp)) == IFSelect_RetDone


def _write_iges(shell: Any, tmp: Path, name: str) -> bool:
    """IGES in B-rep mode, reals with 13 significant digits like STEP (OCCT's default, 10, turns
    normals by ~1e-6 rad across shared edges; its zero suppression reads 16 characters at most)."""
    from OCP.IGESControl import IGESControl_Writer
    from OCP.IGESData import IGESData_IGESWriter
    from OCP.IGESSelect import IGESSelect_WorkLibrary

    with _occ_quiet():
        writer = IGESControl_Writer("MM", 1)  # mode 1: B-rep (510 faces in a 514 shell)
        if not writer.AddShape(shell):
            return False
        writer.ComputeModel()
        out = IGESData_IGESWriter(writer.Model())
        out.FloatWriter().SetFormat(_IGES_REAL)
        out.FloatWriter().SetZeroSuppress(True)
        out.SendModel(IGESSelect_WorkLibrary.DefineProtocol_s())
        with open(tmp, "wb") as stream:
            return bool(out.Print(stream))


# ------------------------------------------------------------------ rhino3dm
def _write_3dm(net: TensorNet, lay: CadLayout, tmp: Path, name: str) -> bool:
    """The faces as non-rational NURBS surfaces, one group named ``name``."""
    import rhino3dm

    model = rhino3dm.File3dm()
    group = rhino3dm.Group()
    group.Name = name
    model.Groups.Add(group)
    attributes = rhino3dm.ObjectAttributes()
    attributes.AddToGroup(0)
    points = net.points.tolist()
    for kind in lay.kinds:
        nu, spans = kind.poles.shape[1], kind.spans
        uknots = [float(i) for i in range(spans + 1) for _ in range(DEGREE)]  # openNURBS: no end knot repeats
        vknots = [float(i >= DEGREE) for i in range(2 * DEGREE)]
        for poles in kind.poles.tolist():
            surface = rhino3dm.NurbsSurface.Create(3, False, _N, _N, nu, _N)
            ku, kv, cv = surface.KnotsU, surface.KnotsV, surface.Points  # each access makes a new view
            for i, u in enumerate(uknots):
                ku[i] = u
            for i, v in enumerate(vknots):
                kv[i] = v
            for i, row in enumerate(poles):
                for j, p in enumerate(row):
                    cv[i, j] = rhino3dm.Point4d(*points[p], 1.0)
            model.Objects.AddSurface(surface, attributes)
    return bool(model.Write(str(tmp), _3DM_VERSION))


# ------------------------------------------------------------------ export
_WRITERS: dict[str, tuple[str, str]] = {  # suffix: (module that must import, format name)
    ".step": ("OCP.STEPControl", "STEP"), ".stp": ("OCP.STEPControl", "STEP"),
    ".iges": ("OCP.IGESControl", "IGES"), ".igs": ("OCP.IGESControl", "IGES"),
    ".3dm": ("rhino3dm", "3dm"),
}


def export_cad(surface: "SplineSurface", path: str | os.PathLike, *, merge: bool = False,
               outputs: AtomicOutputs | None = None, tolerance: float = CAD_TOLERANCE) -> Path:
    """Write ``surface`` exactly as B-spline faces to STEP, IGES or 3dm (by the suffix of ``path``).

    Parameters
    ----------
    surface : the spline surface (``F`` quintic triangles become ``3 F`` bi-quintic faces)
    path : ``.step .stp .iges .igs .3dm``
    merge : join quads 1 and 2 of each triangle into one face with an interior knot
        (``2 F`` faces; exact as well)
    outputs : an :class:`AtomicOutputs` group to join (committed by the caller); otherwise
        the file is written atomically on its own
    tolerance : the B-rep tolerance of vertices, edges and faces (STEP, IGES), in the
        surface's units

    Raises
    ------
    ExportFormatError
        For another suffix, or when the extra ``trispline[cad]`` is not installed
        (checked before anything is written).
    CommandFailed
        When the library's writer reports a failure (nothing is left behind).
    """
    suffix = check_export_path(path, CAD_FORMATS)
    module, what = _WRITERS[suffix]
    _require(module, what, f"cannot write {path}")
    if not (np.isfinite(tolerance) and tolerance > 0):
        raise InputError(f"cannot write {path}: tolerance must be a positive number, got {tolerance}")
    net = tensor_net(surface.uv, surface.faces, surface.ctrl, triangulation=surface.triangulation)
    lay = cad_layout(net, merge=merge)
    name = Path(path).stem

    def write(tmp: Path) -> None:
        if suffix == ".3dm":
            ok = _write_3dm(net, lay, tmp, name)
        else:
            ok = (_write_step if what == "STEP" else _write_iges)(occ_shell(net, lay, tolerance), tmp, name)
        if not ok:
            raise CommandFailed(f"cannot write {path}: the {what} writer ({module.split('.')[0]}) failed")

    return write_with(path, write, outputs)


# ------------------------------------------------------------------ reading back
def read_cad(path: str | os.PathLike) -> Any:
    """Read a STEP or IGES file with Open CASCADE: its one ``TopoDS_Shape`` (checks, pictures)."""
    suffix = Path(path).suffix.lower()
    if suffix not in _WRITERS or suffix == ".3dm":
        raise InputError(f"cannot read {path}: read_cad reads {', '.join(CAD_FORMATS[:4])}")
    if not Path(path).is_file():
        raise InputError(f"cannot read {path}: no such file")
    module, what = _WRITERS[suffix]
    _require(module, what, f"cannot read {path}")
    from OCP.IFSelect import IFSelect_RetDone
    from OCP.IGESControl import IGESControl_Reader
    from OCP.STEPControl import STEPControl_Reader

    with _occ_quiet():
        reader = STEPControl_Reader() if what == "STEP" else IGESControl_Reader()
        if reader.ReadFile(str(path)) != IFSelect_RetDone or reader.TransferRoots() == 0:
            raise CommandFailed(f"cannot read {path} with Open CASCADE")
        return reader.OneShape()


def occ_mesh(shape: Any, deflection: float) -> tuple[np.ndarray, np.ndarray]:
    """Tessellate ``shape`` with ``BRepMesh`` (linear ``deflection``): ``V (n, 3)``, ``F (m, 3)``,
    one mesh per face (vertices on shared edges repeated), triangles oriented like the faces."""
    from OCP.BRep import BRep_Tool
    from OCP.BRepMesh import BRepMesh_IncrementalMesh
    from OCP.TopAbs import TopAbs_FACE, TopAbs_REVERSED
    from OCP.TopExp import TopExp_Explorer
    from OCP.TopLoc import TopLoc_Location
    from OCP.TopoDS import TopoDS

    as_face = getattr(TopoDS, "Face", None) or TopoDS.Face_s  # OCP 8 or 7
    BRepMesh_IncrementalMesh(shape, deflection, False, 0.5, False)
    V, F, offset = [], [], 0
    explorer = TopExp_Explorer(shape, TopAbs_FACE)
    while explorer.More():
        face = as_face(explorer.Current())
        tri = BRep_Tool.Triangulation_s(face, TopLoc_Location())
        nodes = [tri.Node(i) for i in range(1, tri.NbNodes() + 1)]
        V.append(np.array([(p.X(), p.Y(), p.Z()) for p in nodes]).reshape(-1, 3))
        t = np.array([tri.Triangle(i).Get() for i in range(1, tri.NbTriangles() + 1)], np.int64).reshape(-1, 3) - 1
        F.append((t[:, ::-1] if face.Orientation() == TopAbs_REVERSED else t) + offset)
        offset += len(nodes)
        explorer.Next()
    return np.concatenate(V), np.concatenate(F)
