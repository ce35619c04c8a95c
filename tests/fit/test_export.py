"""Export (trimesh formats, control net, surface files, pictures), atomic writes, generated scans.

Surfaces here are built without a fit (random free points through the C1
propagation map), so these tests need no JAX.
"""
from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest
import trimesh

from trispline.fit.io import export as ex
from trispline.spline.util.atomic import AtomicOutputs, OutputError, atomic_path, write_text
from trispline.fit.datasets.face import EYE_AXES, EYE_CENTRE, ROTATION, face_depth, face_scan
from trispline.fit.datasets.synthetic import HOLE_RADIUS, synthetic_scan
from trispline.param import validate_mesh
from trispline.spline.index import CORNER, DEGREE, EXPONENTS, lattice_triangles
from trispline.spline.continuity import continuity_report
from trispline.spline.errors import InputError
from trispline.spline.surface import SplineSurface
from trispline.spline.testing import random_c1_surface
from trispline.spline.tessellate import tessellation_counts



@pytest.fixture(scope="module")
def surface() -> SplineSurface:
    s = random_c1_surface()
    assert continuity_report(s.triangulation, s.ctrl)["c1_relative"] < 1e-12
    return s


def _no_temp_files(folder: Path) -> list[str]:
    return [p.name for p in folder.iterdir() if ".tmp" in p.name]


# ----------------------------------------------------------------------- control net
def test_control_net_shares_points_and_reproduces_every_patch(surface):
    tri = surface.triangulation
    points, triangles, segments = ex.control_net(surface)
    assert points.shape == (tri.n_vertices + 4 * tri.n_edges + 6 * tri.n_faces, 3)
    assert triangles.shape == (25 * tri.n_faces, 3)
    # every lattice triangle's corners are the patch's own control points
    lattice = lattice_triangles(DEGREE)
    np.testing.assert_array_equal(points[triangles].reshape(tri.n_faces, 25, 3, 3), surface.ctrl[:, lattice])
    # point v is the corner point of domain vertex v
    np.testing.assert_array_equal(points[tri.faces.ravel()], surface.ctrl[:, CORNER].reshape(-1, 3))
    # the net is crack-free: its boundary edges are exactly 5 per domain boundary edge
    e = np.sort(np.concatenate([triangles[:, [0, 1]], triangles[:, [1, 2]], triangles[:, [2, 0]]]), axis=1)
    _, count = np.unique(e, axis=0, return_counts=True)
    assert set(count.tolist()) <= {1, 2}
    assert (count == 1).sum() == 5 * tri.boundary_edges.size
    assert segments.shape[0] == count.size
    # lattice triangles are counter-clockwise over the domain, like the faces
    dom = np.einsum("nk,fkd->fnd", EXPONENTS / 5.0, tri.uv[tri.faces])  # (F, 21, 2)
    a, b, c = (dom[:, lattice[:, i]] for i in range(3))
    cross = (b - a)[..., 0] * (c - a)[..., 1] - (b - a)[..., 1] * (c - a)[..., 0]
    assert (cross > 0).all()


def test_lattice_has_25_distinct_triangles():
    lat = lattice_triangles(DEGREE)
    assert lat.shape == (25, 3)
    assert np.unique(np.sort(lat, axis=1), axis=0).shape[0] == 25
    assert set(lat.ravel().tolist()) == set(range(21))


# ----------------------------------------------------------------------------- meshes
@pytest.mark.parametrize("resolution", [1, 2, 5])
def test_surface_mesh_is_watertight_along_patch_boundaries(surface, resolution):
    tri = surface.triangulation
    mesh = ex.surface_mesh(surface, resolution)
    nverts, ntris = tessellation_counts(tri.n_vertices, tri.n_edges, tri.n_faces, resolution)
    assert mesh.vertices.shape == (nverts, 3) and mesh.faces.shape == (ntris, 3)
    # vertex v is the corner point of domain vertex v
    corners = np.empty((tri.n_vertices, 3))
    corners[tri.faces.ravel()] = surface.ctrl[:, CORNER].reshape(-1, 3)
    np.testing.assert_array_equal(mesh.vertices[: tri.n_vertices], corners)
    # no cracks: only the domain boundary is open, r mesh edges per boundary edge
    e = np.sort(mesh.edges, axis=1)
    _, count = np.unique(e, axis=0, return_counts=True)
    assert set(count.tolist()) <= {1, 2}
    assert (count == 1).sum() == resolution * tri.boundary_edges.size
    assert np.allclose(np.linalg.norm(mesh.vertex_normals, axis=1), 1.0)


def test_surface_mesh_cracks_would_be_seen():
    """Negative control for the crack count: unsharing one patch's vertices opens edges."""
    s = random_c1_surface(20, holes=0, seed=3)
    mesh = ex.surface_mesh(s, 3)
    faces = mesh.faces.copy()
    first = faces[:9]  # the 9 triangles of one patch at r = 3
    new_ids = {v: len(mesh.vertices) + i for i, v in enumerate(np.unique(first))}
    faces[:9] = np.vectorize(new_ids.get)(first)
    _, count = np.unique(np.sort(np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]]), axis=1),
                         axis=0, return_counts=True)
    assert (count == 1).sum() > 3 * s.triangulation.boundary_edges.size


@pytest.mark.parametrize("suffix", [".obj", ".ply", ".glb", ".stl", ".off"])
def test_export_mesh_formats_reload(surface, tmp_path, suffix):
    r = 4
    ref = ex.surface_mesh(surface, r)
    out = ex.export_surface(surface, tmp_path / f"s{suffix}", resolution=r)
    assert out.is_file() and _no_temp_files(tmp_path) == []
    got = trimesh.load(out, process=False, force="mesh")
    assert got.faces.shape == ref.faces.shape
    if suffix == ".stl":  # one copy of each corner per triangle: compare triangle by triangle
        np.testing.assert_allclose(got.vertices[got.faces], ref.vertices[ref.faces], rtol=0, atol=1e-6)
        return
    tol = 1e-6 if suffix == ".glb" else 1e-14  # glTF stores float32
    np.testing.assert_allclose(got.vertices, ref.vertices, rtol=0, atol=tol)
    np.testing.assert_array_equal(got.faces, ref.faces)
    if suffix == ".off":  # positions and triangles only
        return
    # the analytic normals are in the file (trimesh.load recomputes its own, so read them raw)
    with open(out, "rb") as fh:
        raw = {".obj": lambda: next(iter(trimesh.exchange.obj.load_obj(fh)["geometry"].values())),
               ".ply": lambda: trimesh.exchange.ply.load_ply(fh),
               ".glb": lambda: next(iter(trimesh.exchange.gltf.load_glb(fh)["geometry"].values()))}[suffix]()
    np.testing.assert_allclose(raw["vertex_normals"], surface.tessellate(r).normals, rtol=0, atol=tol)


def test_exported_normals_are_analytic():
    """On a polynomial graph z = p(u, v) (reproduced exactly) the mesh normals are
    (-p_u, -p_v, 1) normalised, at every tessellation vertex."""
    s = random_c1_surface(30, holes=1, seed=4, wiggle=0.0)
    mesh = ex.surface_mesh(s, 5)
    u, v = mesh.vertices[:, 0], mesh.vertices[:, 1]
    n = np.column_stack([-(0.6 * u - 0.2 * v), -(-0.2 * u + 0.3 * v**2), np.ones_like(u)])
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    np.testing.assert_allclose(mesh.vertex_normals, n, atol=1e-12)
    np.testing.assert_allclose(mesh.vertices[:, 2], 0.3 * u**2 - 0.2 * u * v + 0.1 * v**3, atol=1e-13)


def test_export_control_net_mesh_and_lines(surface, tmp_path):
    points, triangles, segments = ex.control_net(surface)
    p = ex.export_control_net(surface, tmp_path / "net.ply")
    got = trimesh.load(p, process=False, force="mesh")
    np.testing.assert_allclose(got.vertices, points, atol=1e-12)
    np.testing.assert_array_equal(got.faces, triangles)
    p = ex.export_control_net(surface, tmp_path / "net_lines.obj", lines=True)
    text = p.read_text().splitlines()
    assert sum(ln.startswith("v ") for ln in text) == points.shape[0]
    assert sum(ln.startswith("l ") for ln in text) == segments.shape[0]
    v = np.array([ln.split()[1:] for ln in text if ln.startswith("v ")], float)
    np.testing.assert_array_equal(v, points)  # %.17g round-trips exactly
    with pytest.raises(ex.ExportFormatError, match="unknown output format"):
        ex.export_control_net(surface, tmp_path / "net.ply", lines=True)


@pytest.mark.parametrize("suffix", [".npz", ".json"])
def test_export_surface_files_round_trip(surface, tmp_path, suffix):
    p = ex.export_surface(surface, tmp_path / f"s{suffix}")
    back = SplineSurface.load(p)
    np.testing.assert_array_equal(back.ctrl, surface.ctrl)
    np.testing.assert_array_equal(back.faces, surface.faces)
    np.testing.assert_array_equal(back.uv, surface.uv)


def test_render_png(surface, tmp_path):
    p = ex.export_surface(surface, tmp_path / "s.png", resolution=3, title="test")
    data = p.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) > 5000
    assert _no_temp_files(tmp_path) == []


def test_png_is_drawn_by_render_facing_the_mean_normal(surface, tmp_path):
    """One renderer: the exported picture is trispline.fit.render's shaded picture with its
    defaults (seen along the surface's mean normal), with the options passed on."""
    from PIL import Image

    from trispline.fit import render as rd

    p = ex.export_surface(surface, tmp_path / "s.png", resolution=2, size=(240, 160), backend="matplotlib")
    pic = rd.draw(surface, "shaded", resolution=2, size=(240, 160), backend="matplotlib")
    ref = rd.reference_sample(surface, curvature=False)
    assert pic.stats["view"]["auto"]
    np.testing.assert_allclose(rd.parse_view((pic.stats["view"]["azimuth"], pic.stats["view"]["elevation"])).toward,
                               rd.mean_normal(ref.points, ref.triangles), atol=1e-12)
    with Image.open(p) as im:
        np.testing.assert_array_equal(np.asarray(im.convert("RGB")), pic.image)
    p = ex.export_surface(surface, tmp_path / "z.png", resolution=2, size=(240, 160), backend="matplotlib",
                          mode="zebra", view="top")
    with Image.open(p) as im:
        np.testing.assert_array_equal(np.asarray(im.convert("RGB")), rd.draw(
            surface, "zebra", view="top", resolution=2, size=(240, 160), backend="matplotlib").image)
    assert _no_temp_files(tmp_path) == []


def test_export_rejects_unknown_suffix_and_missing_folder(surface, tmp_path):
    with pytest.raises(ex.ExportFormatError, match=r"unknown output format '\.xyz'"):
        ex.export_surface(surface, tmp_path / "s.xyz")
    with pytest.raises(InputError, match="no extension"):
        ex.export_surface(surface, tmp_path / "s")
    with pytest.raises(OutputError, match="does not exist"):
        ex.export_surface(surface, tmp_path / "missing" / "s.obj")
    assert list(tmp_path.iterdir()) == []


def test_export_mesh_keeps_vertex_order(tmp_path):
    V, F = synthetic_scan(100, seed=2)
    p = ex.export_mesh(V, F, tmp_path / "scan.obj")
    got = trimesh.load(p, process=False, force="mesh")
    np.testing.assert_allclose(got.vertices, V, atol=1e-14)
    np.testing.assert_array_equal(got.faces, F)


# ----------------------------------------------------------------------------- atomic
def test_failed_writer_leaves_nothing(surface, tmp_path, monkeypatch):
    def broken(self, file_obj=None, file_type=None, **kw):
        Path(file_obj).write_bytes(b"partial")
        raise RuntimeError("disk full")

    monkeypatch.setattr(trimesh.Trimesh, "export", broken)
    with pytest.raises(RuntimeError, match="disk full"):
        ex.export_surface(surface, tmp_path / "s.obj")
    assert list(tmp_path.iterdir()) == []


def test_failed_ply_writer_leaves_nothing(surface, tmp_path, monkeypatch):
    real = ex._write_ply

    def half(vertices, triangles, normals, tmp):
        real(vertices[:3], triangles[:1], None, tmp)
        raise OSError("no space left on device")

    monkeypatch.setattr(ex, "_write_ply", half)
    with pytest.raises(OSError, match="no space"):
        ex.export_surface(surface, tmp_path / "s.ply")
    assert list(tmp_path.iterdir()) == []


def test_existing_file_survives_failed_overwrite(surface, tmp_path, monkeypatch):
    target = tmp_path / "s.glb"
    target.write_bytes(b"old")
    monkeypatch.setattr(trimesh.Trimesh, "export", lambda *a, **k: (_ for _ in ()).throw(KeyboardInterrupt()))
    with pytest.raises(KeyboardInterrupt):
        ex.export_surface(surface, target)
    assert target.read_bytes() == b"old"
    assert [p.name for p in tmp_path.iterdir()] == ["s.glb"]


def test_atomic_outputs_all_or_nothing(tmp_path):
    with pytest.raises(ValueError):
        with AtomicOutputs() as out:
            out.path(tmp_path / "a.txt").write_text("complete")
            out.path(tmp_path / "b.txt").write_text("half")
            raise ValueError("second writer failed")
    assert list(tmp_path.iterdir()) == []
    with AtomicOutputs() as out:
        out.path(tmp_path / "a.txt").write_text("A")
        out.path(tmp_path / "b.txt").write_text("B")
        assert not (tmp_path / "a.txt").exists()  # nothing visible before the commit
    assert (tmp_path / "a.txt").read_text() == "A" and (tmp_path / "b.txt").read_text() == "B"
    with pytest.raises(OutputError, match="more than one output"):
        with AtomicOutputs() as out:
            out.path(tmp_path / "c.txt")
            out.path(tmp_path / "c.txt")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.txt", "b.txt"]


def test_atomic_path_keeps_suffix_and_sets_normal_permissions(tmp_path):
    with atomic_path(tmp_path / "x.npz") as tmp:
        assert tmp.parent == tmp_path and tmp.suffix == ".npz" and tmp.name.startswith(".x.npz.")
        np.savez(tmp, a=np.arange(3))
    assert (tmp_path / "x.npz").is_file()
    mask = os.umask(0)
    os.umask(mask)
    assert (tmp_path / "x.npz").stat().st_mode & 0o777 == 0o666 & ~mask
    write_text(tmp_path / "t.txt", "hello")
    assert (tmp_path / "t.txt").read_text() == "hello"
    with pytest.raises(OutputError, match="is a folder"):
        write_text(tmp_path, "x")


# ------------------------------------------------------------ synthetic and face scans
#: The generated scans: (generator, faces asked for, allowed relative miss of the face count).
SCANS = [pytest.param(synthetic_scan, n, 0.3, id=f"synthetic-{n}") for n in (60, 300, 1500)] + [
    pytest.param(face_scan, n, 0.15, id=f"face-{n}") for n in (300, 4000)]


@pytest.mark.parametrize("seed", [0, 1, 2])
@pytest.mark.parametrize("make,n,slack", SCANS)
def test_generated_scans_are_open_disks_with_one_hole(make, n, slack, seed):
    V, F = make(n, seed=seed)
    vm = validate_mesh(V, F)
    assert vm.report["holes"] == 1 and vm.report["components"] == 1 and vm.messages == []
    assert (1 - slack) * n < F.shape[0] < (1 + slack) * n
    assert V.dtype == np.float64 and F.dtype == np.int64
    assert validate_mesh(*make(n, seed=seed, hole=False)).report["holes"] == 0


def test_synthetic_scan_properties():
    a = synthetic_scan(300, seed=5)
    b = synthetic_scan(300, seed=5)
    np.testing.assert_array_equal(a[0], b[0])
    np.testing.assert_array_equal(a[1], b[1])
    V0, F0 = synthetic_scan(300, seed=5, noise=0.0, rotate=False)
    Vn, Fn = synthetic_scan(300, seed=5, noise=0.01, rotate=False)
    np.testing.assert_array_equal(F0, Fn)
    np.testing.assert_array_equal(V0[:, :2], Vn[:, :2])
    dz = Vn[:, 2] - V0[:, 2]
    assert 0.005 < dz.std() < 0.02  # the requested noise level
    assert validate_mesh(*synthetic_scan(300, hole=False)).report["holes"] == 0
    # the hole is round and empty: no vertex strictly inside it
    from trispline.fit.datasets.synthetic import HOLE_CENTRE

    assert (np.linalg.norm(V0[:, :2] - HOLE_CENTRE, axis=1) > HOLE_RADIUS - 1e-12).all()
    with pytest.raises(ValueError, match="n_faces"):
        synthetic_scan(10)
    with pytest.raises(ValueError, match="noise"):
        synthetic_scan(100, noise=-1)


def test_face_scan_is_irregular_noisy_and_faces_its_own_way():
    from trispline.fit.render import mean_normal

    a, b = face_scan(2000, seed=5), face_scan(2000, seed=5)
    np.testing.assert_array_equal(a[0], b[0])
    np.testing.assert_array_equal(a[1], b[1])
    V0, F0 = face_scan(2000, seed=5, noise=0.0)
    Vn, Fn = face_scan(2000, seed=5, noise=0.002)
    np.testing.assert_array_equal(F0, Fn)
    P = V0 @ ROTATION  # back to the face plane (x, y, depth)
    np.testing.assert_allclose(P[:, 2], face_depth(P[:, :2]), atol=1e-12)
    dz = (Vn - V0) @ ROTATION[:, 2]
    assert 0.0015 < dz.std() < 0.0025 and np.abs((Vn - V0) @ ROTATION[:, :2]).max() < 1e-12  # along the view
    # irregular sampling: edge lengths vary several times, denser in the middle
    E = np.concatenate([F0[:, [0, 1]], F0[:, [1, 2]], F0[:, [2, 0]]])
    length = np.linalg.norm(V0[E[:, 0]] - V0[E[:, 1]], axis=1)
    assert np.percentile(length, 95) > 3 * np.percentile(length, 5)
    mid = np.linalg.norm(P[E[:, 0], :2], axis=1) < 0.3
    assert np.median(length[mid]) < 0.7 * np.median(length[~mid])
    # the hole is the eye, empty; the face looks along ROTATION's depth axis (-y, turned)
    e = np.hypot((P[:, 0] - EYE_CENTRE[0]) / EYE_AXES[0], (P[:, 1] - EYE_CENTRE[1]) / EYE_AXES[1])
    assert (e > 1 - 1e-12).all()
    n = mean_normal(V0, F0)
    assert n @ ROTATION[:, 2] > 0.9 and n @ [0, -1, 0] > 0.85
    with pytest.raises(ValueError, match="n_faces"):
        face_scan(100)
    with pytest.raises(ValueError, match="noise"):
        face_scan(1000, noise=-1)


def test_large_export_warning_lives_in_fit_errors():
    """One class, defined in fit.errors (every exception and warning type of the fit layer), re-exported by io.export."""
    from trispline.fit import errors
    from trispline.fit.io import export

    assert export.LargeExportWarning is errors.LargeExportWarning
    assert errors.LargeExportWarning.__module__ == "trispline.fit.errors"


def test_cli_version_is_the_captions():
    from trispline.fit.cli.common import version
    from trispline.fit.render.caption import package_version

    assert version() == package_version()
