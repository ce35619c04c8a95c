"""Exact CAD export: every STEP, IGES and 3dm file is read back and checked against trispline.

Read back with Open CASCADE (STEP, IGES) and rhino3dm (3dm): surface points at random
parameters of every face, the number of faces, one shell with shared edges (gaps and normal
jumps along them), ``BRepCheck_Analyzer`` validity and the free edges against the surface's
boundary loops (holes included).
"""
from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial import cKDTree

from trispline.fit.errors import CommandFailed, ExportFormatError
from trispline.fit.io import cad
from trispline.spline.errors import InputError
from trispline.spline.tensor import quad_bary
from trispline.spline.util.atomic import AtomicOutputs
from trispline.spline.testing import random_c1_surface

pytest.importorskip("OCP")
pytest.importorskip("rhino3dm")

from OCP.BRep import BRep_Tool  # noqa: E402
from OCP.BRepAdaptor import BRepAdaptor_Curve, BRepAdaptor_Curve2d, BRepAdaptor_Surface  # noqa: E402
from OCP.BRepCheck import BRepCheck_Analyzer  # noqa: E402
from OCP.collections import (  # noqa: E402
    IndexedDataMap_TopoDS_Shape_List_TopoDS_Shape_TopTools_ShapeMapHasher as EdgeFaces)
from OCP.GCPnts import GCPnts_AbscissaPoint  # noqa: E402
from OCP.gp import gp_Pnt, gp_Vec  # noqa: E402
from OCP.ShapeAnalysis import ShapeAnalysis_FreeBounds  # noqa: E402
from OCP.TopAbs import (  # noqa: E402
    TopAbs_EDGE, TopAbs_FACE, TopAbs_FORWARD, TopAbs_SHELL, TopAbs_VERTEX, TopAbs_WIRE)
from OCP.TopExp import TopExp, TopExp_Explorer  # noqa: E402
from OCP.TopoDS import TopoDS  # noqa: E402

SAMPLES = 7  # per shared edge
# shape casts: TopoDS.Face (OCP 8) or Face (OCP 7)
Face, Edge, Shell, Vertex, Wire = (getattr(TopoDS, n, None) or getattr(TopoDS, n + "_s")
                                   for n in ("Face", "Edge", "Shell", "Vertex", "Wire"))


@pytest.fixture(scope="module")
def surface():
    s = random_c1_surface(30, holes=1, seed=5)
    assert s.triangulation.n_holes == 1
    return s


@pytest.fixture(scope="module")
def diagonal(surface):
    pts = surface.ctrl.reshape(-1, 3)
    return float(np.linalg.norm(pts.max(0) - pts.min(0)))


def _all(shape, kind, cast):
    out, ex = [], TopExp_Explorer(shape, kind)
    while ex.More():
        out.append(cast(ex.Current()))
        ex.Next()
    return out


def _xyz(p) -> np.ndarray:
    return np.array([p.X(), p.Y(), p.Z()])


def _face_param_map(surface, merge: bool):
    """Per written face: ``(triangle, (u, v) -> barycentric)``, the layout of :mod:`cad`'s docstring."""
    nf = surface.n_faces
    if not merge:
        return [(n // 3, lambda uv, k=n % 3: quad_bary(uv)[k]) for n in range(3 * nf)]

    def joined(uv):
        first = uv[:, 0] <= 1
        st = np.where(first[:, None], uv, np.column_stack([uv[:, 1], 2 - uv[:, 0]]))
        q = quad_bary(st)
        return np.where(first[:, None], q[1], q[2])

    return [(f, lambda uv: quad_bary(uv)[0]) for f in range(nf)] + [(f, joined) for f in range(nf)]


def _check_points(surface, faces, merge, read_point, spans, diagonal, rng):
    """Read-back surface points equal trispline's at random parameters of every face."""
    worst = 0.0
    for n, ((tri_face, to_bary), read) in enumerate(zip(_face_param_map(surface, merge), faces)):
        umax = spans(n)
        uv = rng.random((4, 2)) * [umax, 1.0]
        ref = surface.evaluate(np.full(4, tri_face), to_bary(uv))
        got = np.array([read_point(read, u, v) for u, v in uv])
        worst = max(worst, np.abs(got - ref).max())
    assert worst < 1e-9 * diagonal


def _boundary_loop_lengths(surface, nodes: int = 24) -> list[float]:
    """Length of every boundary loop of the spline (Gauss--Legendre along each half edge)."""
    tri = surface.triangulation
    x, w = np.polynomial.legendre.leggauss(nodes)
    t, w = np.concatenate([(x + 1) / 4, (x + 3) / 4]), np.concatenate([w, w]) / 4
    out = []
    for loop in tri.boundary_loops:
        a, b = loop, np.roll(loop, -1)
        fi, bary = [], []
        for va, vb in zip(a, b):
            f = np.flatnonzero((tri.faces == va).any(1) & (tri.faces == vb).any(1))[0]
            la, lb = np.argmax(tri.faces[f] == va), np.argmax(tri.faces[f] == vb)
            bb = np.zeros((t.size, 3))
            bb[:, la], bb[:, lb] = 1 - t, t
            fi.append(np.full(t.size, f))
            bary.append(bb)
        r = surface.evaluate_derivatives(np.concatenate(fi), np.concatenate(bary))
        d = (tri.uv[b] - tri.uv[a]).repeat(t.size, axis=0)
        speed = np.linalg.norm(r.du * d[:, :1] + r.dv * d[:, 1:], axis=1)
        out.append(float((speed.reshape(len(a), -1) * w).sum()))
    return out


def _check_shell(shape, surface, n_faces, diagonal):
    """One valid shell with shared edges; free edges exactly the boundary loops."""
    tri = surface.triangulation
    assert len(_all(shape, TopAbs_SHELL, Shell)) == 1
    faces = _all(shape, TopAbs_FACE, Face)
    assert len(faces) == n_faces
    assert BRepCheck_Analyzer(shape).IsValid()
    emap = EdgeFaces()
    TopExp.MapShapesAndAncestors_s(shape, TopAbs_EDGE, TopAbs_FACE, emap)
    w = np.linspace(0.0, 1.0, SAMPLES)
    gap, angle, n_free = 0.0, 0.0, 0
    for i in range(1, emap.Extent() + 1):
        edge = Edge(emap.FindKey(i))
        owners = [Face(f) for f in emap.FindFromIndex(i)]
        n_free += len(owners) == 1
        assert len(owners) in (1, 2)
        curve = BRepAdaptor_Curve(edge)
        ws = curve.FirstParameter() + w * (curve.LastParameter() - curve.FirstParameter())
        normals = []
        for face in owners:
            pc, srf = BRepAdaptor_Curve2d(edge, face), BRepAdaptor_Surface(face)
            ns = []
            for x in ws:
                p2, p, du, dv = pc.Value(x), gp_Pnt(), gp_Vec(), gp_Vec()
                srf.D1(p2.X(), p2.Y(), p, du, dv)
                gap = max(gap, p.Distance(curve.Value(x)))
                n = np.cross(_xyz(du), _xyz(dv))
                ns.append(n / np.linalg.norm(n) * (1 if face.Orientation() == TopAbs_FORWARD else -1))
            normals.append(np.array(ns))
        if len(owners) == 2:
            sin = np.linalg.norm(np.cross(normals[0], normals[1]), axis=1)  # arccos loses ~1e-8 near 0
            angle = max(angle, float(np.arctan2(sin, np.sum(normals[0] * normals[1], axis=1)).max()))
    assert gap < 1e-9 * diagonal
    assert angle < 1e-7
    assert n_free == 2 * tri.boundary_edges.size  # each boundary edge in two halves
    _check_free_edges(shape, surface, diagonal)


def _check_free_edges(shape, surface, diagonal):
    """Free wires: as many as boundary loops, same lengths, through the corner and midpoints."""
    tri = surface.triangulation
    bounds = ShapeAnalysis_FreeBounds(shape)
    assert len(_all(bounds.GetOpenWires(), TopAbs_EDGE, Edge)) == 0
    wires = _all(bounds.GetClosedWires(), TopAbs_WIRE, Wire)
    assert len(wires) == len(tri.boundary_loops) == 1 + tri.n_holes
    got = []
    for wire in wires:
        edges = _all(wire, TopAbs_EDGE, Edge)
        length = sum(GCPnts_AbscissaPoint.Length_s(BRepAdaptor_Curve(e), 1e-13) for e in edges)
        verts = np.unique(np.array([_xyz(BRep_Tool.Pnt_s(Vertex(v)))
                                    for v in _all(wire, TopAbs_VERTEX, lambda s: s)]), axis=0)
        got.append((length, verts))
    expected_lengths = _boundary_loop_lengths(surface)
    for loop, length in zip(tri.boundary_loops, expected_lengths):
        match = [g for g in got if abs(g[0] - length) < 1e-9 * length]
        assert len(match) == 1
        # its vertices: the loop's corner points and the midpoints of its edges
        a, b = loop, np.roll(loop, -1)
        fi = [np.flatnonzero((tri.faces == x).any(1) & (tri.faces == y).any(1))[0] for x, y in zip(a, b)]
        bary = np.zeros((len(a), 3))
        for n, (f, x, y) in enumerate(zip(fi, a, b)):
            bary[n, np.argmax(tri.faces[f] == x)] = bary[n, np.argmax(tri.faces[f] == y)] = 0.5
        expected = np.concatenate([surface.evaluate(np.array(fi), np.eye(3)[[np.argmax(tri.faces[f] == x)
                                                                              for f, x in zip(fi, a)]]),
                                   surface.evaluate(np.array(fi), bary)])
        verts = match[0][1]
        assert verts.shape == expected.shape
        assert cKDTree(expected).query(verts)[0].max() < 1e-9 * diagonal


# ------------------------------------------------------------------ STEP and IGES
@pytest.mark.parametrize("merge", [False, True], ids=["quads", "merged"])
@pytest.mark.parametrize("suffix", [".step", ".igs"])
def test_step_and_iges_round_trip(tmp_path, surface, diagonal, suffix, merge):
    path = cad.export_cad(surface, tmp_path / f"s{suffix}", merge=merge)
    assert path.is_file() and [p.name for p in tmp_path.iterdir()] == [path.name]
    text = path.read_text(errors="replace")
    if suffix == ".step":
        assert "AUTOMOTIVE_DESIGN" in text and "OPEN_SHELL" in text
        assert text.count("B_SPLINE_SURFACE_WITH_KNOTS") == (2 if merge else 3) * surface.n_faces
    shape = cad.read_cad(path)
    n_faces = (2 if merge else 3) * surface.n_faces
    faces = _all(shape, TopAbs_FACE, Face)

    def point(face, u, v):
        return _xyz(BRep_Tool.Surface_s(face).Value(u, v))

    spans = (lambda n: 2.0 if merge and n >= surface.n_faces else 1.0)
    _check_points(surface, faces, merge, point, spans, diagonal, np.random.default_rng(1))
    _check_shell(shape, surface, n_faces, diagonal)


def test_merge_is_smaller(tmp_path, surface):
    sizes = {m: cad.export_cad(surface, tmp_path / f"{m}.step", merge=m).stat().st_size for m in (False, True)}
    assert sizes[True] < 0.95 * sizes[False]


# ------------------------------------------------------------------ 3dm
@pytest.mark.parametrize("merge", [False, True], ids=["quads", "merged"])
def test_3dm_round_trip(tmp_path, surface, diagonal, merge):
    import rhino3dm

    path = cad.export_cad(surface, tmp_path / "s.3dm", merge=merge)
    model = rhino3dm.File3dm.Read(str(path))
    objects = list(model.Objects)
    assert len(objects) == (2 if merge else 3) * surface.n_faces
    assert len(model.Groups) == 1 and all(o.Attributes.GetGroupList() == (0,) for o in objects)
    surfaces = [o.Geometry for o in objects]
    assert all(isinstance(s, rhino3dm.NurbsSurface) and s.IsValid for s in surfaces)

    def point(s, u, v):
        p = s.PointAt(u, v)
        return np.array([p.X, p.Y, p.Z])

    spans = (lambda n: 2.0 if merge and n >= surface.n_faces else 1.0)
    assert [s.Domain(0).T1 for s in surfaces] == [spans(n) for n in range(len(surfaces))]
    _check_points(surface, surfaces, merge, point, spans, diagonal, np.random.default_rng(2))


# ------------------------------------------------------------------ refusals and atomicity
def test_unknown_suffix_and_bad_tolerance(tmp_path, surface):
    with pytest.raises(ExportFormatError, match="unknown output format '.obj'"):
        cad.export_cad(surface, tmp_path / "s.obj")
    with pytest.raises(InputError, match="tolerance must be a positive number"):
        cad.export_cad(surface, tmp_path / "s.step", tolerance=0.0)
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("suffix, module", [(".step", "OCP.STEPControl"), (".iges", "OCP.IGESControl"),
                                            (".3dm", "rhino3dm")])
def test_missing_extra_names_it(tmp_path, surface, monkeypatch, suffix, module):
    monkeypatch.setitem(sys.modules, module, None)  # import fails as if not installed
    with pytest.raises(ExportFormatError, match=r"trispline\[cad\]") as err:
        cad.export_cad(surface, tmp_path / f"s{suffix}")
    assert isinstance(err.value, InputError)  # the CLI's exit 2
    assert list(tmp_path.iterdir()) == []


def test_read_cad_refusals(tmp_path, surface):
    with pytest.raises(InputError, match="read_cad reads .step"):
        cad.read_cad(tmp_path / "s.3dm")
    with pytest.raises(InputError, match="no such file"):
        cad.read_cad(tmp_path / "s.step")
    (tmp_path / "bad.step").write_text("not a STEP file")
    with pytest.raises(CommandFailed, match="cannot read"):
        cad.read_cad(tmp_path / "bad.step")


def test_failed_writer_leaves_nothing(tmp_path, surface, monkeypatch):
    def broken(shell, tmp: Path, name):
        tmp.write_text("half a file")
        return False

    monkeypatch.setattr(cad, "_write_step", broken)
    with pytest.raises(CommandFailed, match="STEP writer"):
        cad.export_cad(surface, tmp_path / "s.step")
    assert list(tmp_path.iterdir()) == []


def test_joins_an_output_group(tmp_path, surface):
    target = tmp_path / "s.igs"
    with AtomicOutputs() as out:
        cad.export_cad(surface, target, outputs=out)
        assert not target.exists()
    assert target.is_file() and target.stat().st_size > 0


# ------------------------------------------------------------------ command line
def test_cli_export_step_reads_back(tmp_path, surface, diagonal, capsys):
    """``trispline export s.npz -o s.step`` writes the exact shell (merge: 2 faces per patch)."""
    from trispline.fit.cli import main

    src = tmp_path / "s.npz"
    surface.save(src)
    for merge, per_patch in ((False, 3), (True, 2)):
        out = tmp_path / f"s{int(merge)}.step"
        assert main(["export", str(src), "-o", str(out), "--json", *(["--merge"] if merge else [])]) == 0
        rep = json.loads(capsys.readouterr().out)
        assert rep["cad_faces"] == per_patch * surface.n_faces and rep["outputs"] == [str(out)]
        assert rep["estimated_bytes"] == pytest.approx(out.stat().st_size, rel=0.1)
        _check_shell(cad.read_cad(out), surface, per_patch * surface.n_faces, diagonal)


def test_cli_merge_needs_a_cad_output(tmp_path, surface, capsys):
    from trispline.fit.cli import main

    src = tmp_path / "s.npz"
    surface.save(src)
    assert main(["export", str(src), "-o", str(tmp_path / "s.obj"), "--merge"]) == 2
    assert "--merge is for CAD outputs" in capsys.readouterr().err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["s.npz"]


def test_export_surface_dispatches_cad(tmp_path, surface):
    from trispline.fit.io import export_surface

    path = export_surface(surface, tmp_path / "s.igs")
    assert len(_all(cad.read_cad(path), TopAbs_FACE, Face)) == 3 * surface.n_faces


@pytest.mark.parametrize("merge", [False, True], ids=["quads", "merged"])
@pytest.mark.parametrize("suffix", [".step", ".iges", ".3dm"])
def test_the_size_is_known_before_the_file_is_written(tmp_path, surface, suffix, merge):
    from trispline.fit.io.sizes import estimate_export_bytes

    path = cad.export_cad(surface, tmp_path / f"s{suffix}", merge=merge)
    assert estimate_export_bytes(surface, path, merge=merge) == pytest.approx(path.stat().st_size, rel=0.1)


def test_a_large_cad_export_is_announced_before_it_is_written(tmp_path, surface, monkeypatch):
    from trispline.fit.errors import LargeExportWarning
    from trispline.fit.io import export

    monkeypatch.setattr(export, "LARGE_EXPORT_BYTES", 1000)
    with pytest.warns(LargeExportWarning, match=rf"about \d+ MB \({surface.n_faces} patches as "
                                                 rf"{3 * surface.n_faces} B-spline faces\).*fit --tolerance"):
        export.export_surface(surface, tmp_path / "s.step")
