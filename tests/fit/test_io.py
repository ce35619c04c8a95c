"""Mesh loading: order-preserving round trips, polygons, vt, unreferenced vertices, errors."""
from __future__ import annotations

import warnings

import numpy as np
import pytest
import trimesh

from trispline.fit.datasets.cache import MISSING_DATA, find_data
from trispline.fit.io import MeshData, load_mesh, read_mesh
from trispline.param import CoordinatePrecisionWarning, MeshError, UnreferencedVerticesWarning
from trispline.param.testing import lift
from trispline.spline.testing.domains import random_delaunay
from trispline.spline.errors import InputError


def test_generated_scan_round_trips(tmp_path, real_mesh):
    """The generated real-world-like scan (every clone has it) through a file and back, order kept."""
    V, F = real_mesh
    path = tmp_path / "face.obj"
    trimesh.Trimesh(V, F, process=False).export(path)
    m = read_mesh(path)
    np.testing.assert_array_equal(m.F, F)
    np.testing.assert_allclose(m.V, V, rtol=0, atol=1e-6)
    assert m.dropped == 0


@pytest.fixture(scope="module")
def mesh():
    V, F = lift(*random_delaunay(60, holes=1, seed=3))
    # shuffle vertex ids so that "same order" is a real check (file order != face order)
    perm = np.random.default_rng(0).permutation(len(V))
    inv = np.argsort(perm)
    return V[perm], inv[F]


@pytest.mark.parametrize("ext", ["obj", "ply", "off", "glb"])
def test_round_trip_keeps_vertex_and_face_order(tmp_path, mesh, ext):
    V, F = mesh
    path = tmp_path / f"m.{ext}"
    trimesh.Trimesh(V, F, process=False).export(path)
    m = read_mesh(path)
    assert isinstance(m, MeshData)
    np.testing.assert_array_equal(m.F, F)
    # trimesh writes text with ~8 digits and PLY/GLB as float32
    np.testing.assert_allclose(m.V, V, rtol=0, atol=1e-6)
    assert m.dropped == 0
    np.testing.assert_array_equal(m.kept, np.arange(len(V)))
    assert m.V.dtype == np.float64 and m.F.dtype == np.int64


def write_double_ply(path, V, F) -> None:
    """A binary PLY whose vertices are ``double`` (trimesh writes ``float``)."""
    head = (f"ply\nformat binary_little_endian 1.0\nelement vertex {len(V)}\nproperty double x\n"
            f"property double y\nproperty double z\nelement face {len(F)}\n"
            "property list uchar int vertex_indices\nend_header\n")
    faces = np.zeros(len(F), dtype=[("n", "u1"), ("v", "<i4", 3)])
    faces["n"], faces["v"] = 3, F
    path.write_bytes(head.encode() + np.asarray(V, "<f8").tobytes() + faces.tobytes())


@pytest.mark.parametrize("ext", ["ply", "stl", "glb"])
def test_single_precision_far_from_the_origin_is_warned_about(tmp_path, mesh, ext):
    V, F = mesh  # spacing ~0.1: a northing of 4.2e6 in float32 rounds by 0.25, far more than 1% of an edge
    path = tmp_path / f"far.{ext}"
    trimesh.Trimesh(V + [512_300.0, 4_231_800.0, 0.0], F, process=False).export(path)
    with pytest.warns(CoordinatePrecisionWarning, match=r"single precision.*rounds them by up to 0\.25"):
        read_mesh(path)


def test_single_precision_near_the_origin_and_double_precision_are_quiet(tmp_path, mesh):
    V, F = mesh
    near, far = tmp_path / "near.ply", tmp_path / "far.ply"
    trimesh.Trimesh(V, F, process=False).export(near)  # float32, rounding ~1e-8 of an edge
    write_double_ply(far, V + [512_300.0, 4_231_800.0, 0.0], F)  # the same far-off mesh in double precision
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        read_mesh(near)
        np.testing.assert_array_equal(read_mesh(far).V, V + [512_300.0, 4_231_800.0, 0.0])


def test_stl_round_trip_merges_exactly_equal_corners(tmp_path, mesh):
    V, F = mesh
    path = tmp_path / "m.stl"
    trimesh.Trimesh(V, F, process=False).export(path)
    m = read_mesh(path)
    # STL has no shared vertices: same triangles in the same order, vertices renumbered
    assert m.F.shape == F.shape and m.V.shape == V.shape
    np.testing.assert_allclose(m.V[m.F], V[F], rtol=0, atol=1e-6)  # float32 storage


def test_load_mesh_convenience(tmp_path, mesh):
    V, F = mesh
    path = tmp_path / "m.ply"
    trimesh.Trimesh(V, F, process=False).export(path)
    V2, F2 = load_mesh(path)
    np.testing.assert_array_equal(F2, F)
    np.testing.assert_allclose(V2, V, rtol=0, atol=1e-6)  # float32 in PLY


def test_coincident_vertices_are_not_merged(tmp_path):
    V = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 0], [1, 0, 0], [0, -1, 0]], float)
    F = np.array([[0, 1, 2], [3, 5, 4]])
    for ext in ("obj", "off", "ply", "glb"):
        path = tmp_path / f"c.{ext}"
        trimesh.Trimesh(V, F, process=False).export(path)
        m = read_mesh(path)
        assert m.V.shape == (6, 3), ext
        np.testing.assert_array_equal(m.F, F)


def test_obj_polygons_triangulated_and_vt_as_uv(tmp_path):
    path = tmp_path / "q.obj"
    path.write_text(
        "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 2 0.5 0\n"
        "vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nvt 2 0.5\n"
        "f 1/1 2/2 3/3 4/4\nf -4/-4 -1/-1 -3/-3\n"
    )
    m = read_mesh(path)
    np.testing.assert_array_equal(m.F, [[0, 1, 2], [0, 2, 3], [1, 4, 2]])
    np.testing.assert_array_equal(m.uv, [[0, 0], [1, 0], [1, 1], [0, 1], [2, 0.5]])


def test_obj_seam_uv_is_not_per_vertex(tmp_path):
    path = tmp_path / "s.obj"
    path.write_text("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nvt 9 9\n"
                    "f 1/1 2/2 3/3\nf 1/5 3/3 4/4\n")
    m = read_mesh(path)
    assert m.uv is None
    assert m.V.shape == (4, 3)  # not split at the seam


def test_off_mixed_polygons(tmp_path):
    path = tmp_path / "p.off"
    path.write_text("OFF\n# comment\n6 2 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n0.5 1.5 0\n-0.5 0.5 0\n"
                    "5 0 1 2 4 3\n3 0 3 5\n")
    m = read_mesh(path)
    np.testing.assert_array_equal(m.F, [[0, 1, 2], [0, 2, 4], [0, 4, 3], [0, 3, 5]])


def test_unreferenced_vertices_dropped_with_warning(tmp_path):
    path = tmp_path / "u.obj"
    path.write_text("v 9 9 9\nv 0 0 0\nv 1 0 0\nv 7 7 7\nv 0 1 0\nf 2 3 5\n")
    with pytest.warns(UnreferencedVerticesWarning, match="dropped 2 vertices"):
        m = read_mesh(path)
    assert m.dropped == 2
    np.testing.assert_array_equal(m.kept, [1, 2, 4])
    np.testing.assert_array_equal(m.V, [[0, 0, 0], [1, 0, 0], [0, 1, 0]])
    np.testing.assert_array_equal(m.F, [[0, 1, 2]])


def test_errors(tmp_path):
    assert issubclass(MeshError, InputError)
    with pytest.raises(MeshError, match="not found"):
        read_mesh(tmp_path / "nope.obj")
    (tmp_path / "m.xyz").write_text("1 2 3\n")
    with pytest.raises(MeshError, match="unknown mesh format '.xyz'"):
        read_mesh(tmp_path / "m.xyz")
    (tmp_path / "e.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\n")
    with pytest.raises(MeshError, match="no faces"):
        read_mesh(tmp_path / "e.obj")
    (tmp_path / "bad.ply").write_bytes(b"this is not a ply file at all\n")
    with pytest.raises(MeshError, match="cannot read"):
        read_mesh(tmp_path / "bad.ply")
    (tmp_path / "bad.off").write_text("OFF\n3 1 0\n0 0 0\n1 0 0\n")
    with pytest.raises(MeshError, match="header announces"):
        read_mesh(tmp_path / "bad.off")
    (tmp_path / "range.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 7\n")
    with pytest.raises(MeshError, match="outside"):
        read_mesh(tmp_path / "range.obj")
    (tmp_path / "line.obj").write_text("v 0 0 0\nv 1 0 0\nf 1 2\n")
    with pytest.raises(MeshError, match="fewer than 3"):
        read_mesh(tmp_path / "line.obj")


@pytest.mark.skipif(find_data("beetle.off") is None, reason=f"beetle.off: {MISSING_DATA}")
def test_beetle_keeps_coincident_vertices():
    path = find_data("beetle.off")
    header = [ln.split() for ln in path.read_text().splitlines()[:3] if ln.strip() and not ln.startswith("#")]
    nv_file = int(header[1][0]) if header[0] == ["OFF"] else int(header[0][1])
    m = read_mesh(path)
    assert m.V.shape[0] == nv_file == 19887
    assert np.unique(m.V, axis=0).shape[0] < m.V.shape[0]  # coincident vertices exist and stay apart


def _ply(path, V, F, *, order="<", vertex_extra=(), face_extra=(), count="u1", index="i4", coord="f4",
         sizes=None, ascii_=False) -> None:
    """A PLY written here field by field: ``vertex_extra`` / ``face_extra`` scalar properties
    ``(type, name)`` after the coordinates / the list, ``sizes`` polygon sizes (default all 3; a face
    of size k takes the first k of ``F``'s row, padded by repeating its last corner)."""
    tn = {"u1": "uchar", "i1": "char", "u2": "ushort", "i2": "short", "u4": "uint", "i4": "int", "f4": "float",
          "f8": "double"}
    sizes = np.full(len(F), 3) if sizes is None else np.asarray(sizes)
    head = ["ply", f"format {'ascii' if ascii_ else {'<': 'binary_little_endian', '>': 'binary_big_endian'}[order]} 1.0",
            "comment written by the test", f"element vertex {len(V)}", *(f"property {tn[coord]} {c}" for c in "xyz"),
            *(f"property {tn[t]} {n}" for t, n in vertex_extra), f"element face {len(F)}",
            f"property list {tn[count]} {tn[index]} vertex_indices", *(f"property {tn[t]} {n}" for t, n in face_extra),
            "end_header"]
    rows = np.concatenate([F, np.repeat(F[:, -1:], 1, axis=1)], axis=1)
    if ascii_:
        body = "".join(" ".join(f"{x:.17g}" for x in v) + " 0" * len(vertex_extra) + "\n" for v in V)
        body += "".join(" ".join(map(str, [k, *r[:k]])) + " 0" * len(face_extra) + "\n" for k, r in zip(sizes, rows))
        path.write_bytes(("\n".join(head) + "\n" + body).encode())
        return
    vt = np.dtype([(c, order + coord) for c in "xyz"] + [(n, order + t) for t, n in vertex_extra])
    verts = np.zeros(len(V), vt)
    for i, c in enumerate("xyz"):
        verts[c] = V[:, i]
    body = verts.tobytes()
    for k, r in zip(sizes, rows):  # the faces one record each: their sizes differ
        ft = np.dtype([("n", order + count), ("v", order + index, (int(k),))] + [(n, order + t) for t, n in face_extra])
        rec = np.zeros(1, ft)
        rec["n"], rec["v"] = k, r[:k]
        body += rec.tobytes()
    path.write_bytes(("\n".join(head) + "\n").encode() + body)


PLY_VARIANTS = {  # name: options of _ply
    "float": {}, "double": {"coord": "f8"}, "big endian": {"order": ">"},
    "colours and normals": {"vertex_extra": (("u1", "red"), ("u1", "green"), ("u1", "blue"), ("f4", "nx"))},
    "face flags": {"face_extra": (("i4", "flags"),)}, "uint indices, ushort counts": {"count": "u2", "index": "u4"},
    "ascii": {"ascii_": True}, "a quad": {"sizes": "quad"},
}


@pytest.mark.parametrize("name", list(PLY_VARIANTS))
def test_ply_variants_read_as_trimesh_reads_them(tmp_path, mesh, name):
    """Binary triangle PLYs are read straight into numpy (no trimesh import), every other PLY by trimesh:
    either way the same vertices, faces and precision flag as ``trimesh.load``."""
    from trispline.fit.io.mesh_parse import read_binary_ply, read_trimesh

    V, F = mesh
    opts = dict(PLY_VARIANTS[name])
    if opts.get("sizes") == "quad":
        opts["sizes"] = np.r_[4, np.full(len(F) - 1, 3)]
    path = tmp_path / "m.ply"
    _ply(path, V, F, **opts)
    fast = read_binary_ply(path)
    assert (fast is None) == (name in ("ascii", "a quad"))
    if name == "a quad":  # mixed polygon sizes: left to trimesh (whose binary reader refuses this one)
        return
    got_V, got_F, single = read_trimesh(path, ".ply")
    ref = trimesh.load(path, process=False, force="mesh", maintain_order=True)
    np.testing.assert_array_equal(got_V, np.asarray(ref.vertices, np.float64))
    np.testing.assert_array_equal(got_F, np.asarray(ref.faces, np.int64))
    assert single == (opts.get("coord", "f4") == "f4")  # the header's type, as check_ply_header reads it
    if fast is None:
        return
    assert fast[0].dtype == np.float64 and fast[1].dtype == np.int64
    tol = 0 if opts.get("coord") == "f8" else 1e-6
    np.testing.assert_allclose(fast[0], V, rtol=0, atol=tol)
    np.testing.assert_array_equal(fast[1], F)


def test_a_truncated_binary_ply_is_refused_by_its_header(tmp_path, mesh):
    V, F = mesh
    path = tmp_path / "m.ply"
    _ply(path, V, F)
    path.write_bytes(path.read_bytes()[:-40])
    with pytest.raises(MeshError, match="truncated"):
        read_mesh(path)
