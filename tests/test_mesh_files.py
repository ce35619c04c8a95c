"""Mesh files as users get them: every valid variant reads as the same mesh as its plain OBJ, every broken
one ends in one line naming the problem (exit 2), with no output written and an existing one untouched.

A 6 x 6 grid (quads, or hexagons and quads) is written in each format's variants by hand; valid files
are compared with the plain OBJ through :func:`read_mesh`, broken ones go through ``info``, ``fit`` and
``fit --tolerance-rel`` (the approximation) with :func:`assert_cli_error` from the bad-input battery.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from test_bad_input import assert_cli_error, cli
from trispline.fit.io import read_mesh

N = 6
_X, _Y = np.meshgrid(np.linspace(0, 1, N), np.linspace(0, 1, N))
V = np.column_stack([_X.ravel(), _Y.ravel(), 0.1 * np.sin(3 * _X.ravel()) * np.cos(2 * _Y.ravel())])
QUADS = [[j * N + i, j * N + i + 1, (j + 1) * N + i + 1, (j + 1) * N + i] for j in range(N - 1) for i in range(N - 1)]
#: Hexagons (two quads each) on even rows, quads on odd ones: polygons of mixed sizes.
MIXED = [p for j in range(N - 1) for p in (
    [[j * N + i, j * N + i + 1, j * N + i + 2, (j + 1) * N + i + 2, (j + 1) * N + i + 1, (j + 1) * N + i]
     for i in range(0, N - 2, 2)] + [[j * N + N - 2, j * N + N - 1, (j + 1) * N + N - 1, (j + 1) * N + N - 2]]
    if j % 2 == 0 else QUADS[j * (N - 1): (j + 1) * (N - 1)])]
TRIANGLES = [[p[0], p[1], p[2]] for p in QUADS] + [[p[0], p[2], p[3]] for p in QUADS]
_PLY_TYPES = {"uchar": "u1", "char": "i1", "int": "i4", "double": "f8", "float": "f4"}


def obj_bytes(polys: list[list[int]], sep: str = " ") -> bytes:
    """The plain OBJ of ``V`` and ``polys``; ``sep`` between a face's corners."""
    return ("".join(f"v {x!r} {y!r} {z!r}\n" for x, y, z in V.tolist())
            + "".join("f " + sep.join(str(i + 1) for i in p) + "\n" for p in polys)).encode()


def ply_bytes(polys: list[list[int]], fmt: str = "ascii", faces: int | None = None, vertices: int | None = None,
              count: str = "uchar", extra: bytes = b"") -> bytes:
    """A PLY of ``V`` (doubles) and ``polys`` whose header announces ``faces`` / ``vertices`` (default: as
    many as there are) and stores list lengths as ``count``; ``extra``: header lines before ``end_header``."""
    head = (f"ply\nformat {fmt} 1.0\nelement vertex {len(V) if vertices is None else vertices}\nproperty double x\n"
            f"property double y\nproperty double z\nelement face {len(polys) if faces is None else faces}\n"
            f"property list {count} int vertex_indices\n").encode() + extra + b"end_header\n"
    if fmt == "ascii":
        return head + "".join(f"{x!r} {y!r} {z!r}\n" for x, y, z in V.tolist()).encode() + "".join(
            f"{len(p)} {' '.join(map(str, p))}\n" for p in polys).encode()
    o = "<" if fmt == "binary_little_endian" else ">"
    body = V.astype(o + "f8").tobytes()
    for p in polys:
        body += np.array([len(p)], o + _PLY_TYPES[count]).tobytes() + np.array(p, o + "i4").tobytes()
    return head + body


def stl_ascii(keyword_case=str.lower) -> bytes:
    """An ASCII STL of the grid's triangles, its keywords in ``keyword_case``."""
    k = keyword_case
    text = f"{k('solid')} grid\n"
    for t in TRIANGLES:
        text += f"{k('facet normal')} 0 0 0\n{k('outer loop')}\n"
        text += "".join(f"{k('vertex')} {' '.join('%.9g' % c for c in V[i])}\n" for i in t)
        text += f"{k('endloop')}\n{k('endfacet')}\n"
    return (text + f"{k('endsolid')} grid\n").encode()


def assert_same_mesh(tmp_path: Path, name: str, data: bytes, polys: list[list[int]]) -> None:
    """``name`` holding ``data`` reads as the same vertices and faces as the plain OBJ of ``polys``."""
    path, plain = tmp_path / name, tmp_path / "plain.obj"
    path.write_bytes(data)
    plain.write_bytes(obj_bytes(polys))
    got, want = read_mesh(path), read_mesh(plain)
    if name.endswith(".stl"):  # its corners welded in the order they come: the same triangles, corner by corner
        assert got.V.shape == want.V.shape
        np.testing.assert_allclose(got.V[got.F], want.V[want.F], rtol=0, atol=1e-7)
        return
    np.testing.assert_array_equal(got.V, want.V)
    np.testing.assert_array_equal(got.F, want.F)


def assert_refused(tmp_path: Path, capsys: pytest.CaptureFixture, name: str, data: bytes, match: str) -> None:
    """``info``, ``fit`` and ``fit --tolerance-rel`` of ``name`` holding ``data``: one line naming ``match``,
    exit 2; no output where none was, an existing one untouched."""
    tmp_path = tmp_path / "refused"
    tmp_path.mkdir()
    path = tmp_path / name
    path.write_bytes(data)
    assert_cli_error(cli(capsys, "info", path), match)
    existing = tmp_path / "existing.npz"
    existing.write_bytes(b"an earlier surface")
    for extra in ([], ["--tolerance-rel", "1e-3"]):
        assert_cli_error(cli(capsys, "fit", path, "-o", tmp_path / "new.npz", "-q", *extra), match)
        assert_cli_error(cli(capsys, "fit", path, "-o", existing, "-q", *extra), match)
    assert existing.read_bytes() == b"an earlier surface" and path.read_bytes() == data
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted([name, "existing.npz"])


# ================================================================================ PLY
@pytest.mark.parametrize("fmt", ["binary_little_endian", "binary_big_endian"])
def test_a_binary_ply_of_polygons_of_mixed_sizes_reads_as_its_obj(tmp_path, fmt):
    """trimesh's binary reader refused these ("PLY is unexpected length!"); like OBJ and OFF they are
    fan-triangulated in file order."""
    assert_same_mesh(tmp_path, "m.ply", ply_bytes(MIXED, fmt), MIXED)
    assert_same_mesh(tmp_path, "q.ply", ply_bytes(QUADS, fmt), QUADS)
    edges = b"element edge 1\nproperty int vertex1\nproperty int vertex2\n"
    o = "<" if fmt == "binary_little_endian" else ">"
    assert_same_mesh(tmp_path, "e.ply", ply_bytes(MIXED, fmt, extra=edges) + np.array([0, 1], o + "i4").tobytes(),
                     MIXED)


ASCII_PLY = ply_bytes(TRIANGLES)
BROKEN_PLY = {  # name: (content, message)
    "truncated.ply": (ASCII_PLY[:-40], "lines, but its body has"),
    "more faces announced.ply": (ply_bytes(TRIANGLES, faces=len(TRIANGLES) + 5), "(truncated?)"),
    "more vertices announced.ply": (ply_bytes(TRIANGLES, vertices=len(V) + 5), "(truncated?)"),
    "fewer faces announced.ply": (ply_bytes(TRIANGLES, faces=len(TRIANGLES) - 5), "lines, but its body has"),
    "cut mid-line.ply": (ASCII_PLY[:-3], "has 3 values, its properties take 4"),
    "a two-vertex face.ply": (ply_bytes([[0, 1]] + TRIANGLES), "is a polygon of 2 vertices"),
    "binary, fewer faces announced.ply": (ply_bytes(MIXED, "binary_little_endian", faces=len(MIXED) - 2),
                                          "does it announce too few?"),
    "unknown format.ply": (ASCII_PLY.replace(b"format ascii", b"format binary_middle_endian"),
                           "unknown format 'binary_middle_endian'"),
    "unknown type.ply": (ASCII_PLY.replace(b"property double x", b"property quad x"), "unknown type 'quad'"),
    "no x y z.ply": (ASCII_PLY.replace(b"double x\n", b"double u\n"), "no 'vertex' element with properties x, y and z"),
}


@pytest.mark.parametrize("name", list(BROKEN_PLY))
def test_a_broken_ply_is_refused_naming_the_problem(tmp_path, capsys, name):
    """An ASCII PLY was read line by line as far as it went: a truncated one, or one whose header announces
    other counts, gave a smaller mesh (face lines read as vertices) and exit 0."""
    assert_refused(tmp_path, capsys, name, *BROKEN_PLY[name])


def test_a_binary_ply_with_a_negative_list_length_is_refused(tmp_path, capsys):
    o = "<"
    head = ply_bytes([], "binary_little_endian", faces=len(QUADS), count="char")
    body = b"".join(np.array([-4 if k == 3 else 4], o + "i1").tobytes() + np.array(p, o + "i4").tobytes()
                    for k, p in enumerate(QUADS))
    assert_refused(tmp_path, capsys, "m.ply", head + body, "face 3 of the PLY has a list of negative length -4")


# ================================================================================ OBJ
def test_an_obj_line_continued_by_a_backslash_reads_as_one_line(tmp_path):
    """OBJ continues a line ending in ``\\`` on the next; read as a face index ``'\\'`` before."""
    assert_same_mesh(tmp_path, "m.obj", obj_bytes(QUADS, sep=" \\\n  "), QUADS)
    assert_same_mesh(tmp_path, "m.obj", obj_bytes(MIXED).replace(b"v 0.0 ", b"v 0.0 \\\r\n", 1), MIXED)


# ================================================================================ OFF
def off_bytes(polys: list[list[int]], faces: int | None = None) -> bytes:
    return (f"OFF\n{len(V)} {len(polys) if faces is None else faces} 0\n"
            + "".join(f"{x!r} {y!r} {z!r}\n" for x, y, z in V.tolist())
            + "".join(f"{len(p)} {' '.join(map(str, p))}\n" for p in polys)).encode()


def test_an_off_header_announcing_fewer_faces_than_the_file_holds_is_refused(tmp_path, capsys):
    """Read before as the announced faces only, the rest dropped without a word."""
    assert_same_mesh(tmp_path, "m.off", off_bytes(MIXED), MIXED)
    assert_refused(tmp_path, capsys, "fewer.off", off_bytes(MIXED, faces=len(MIXED) - 3),
                   f"header announces {len(V)} vertices and {len(MIXED) - 3} faces but the file has "
                   f"{len(V) + len(MIXED)} data lines")


def test_a_binary_off_is_refused_as_such(tmp_path, capsys):
    assert_refused(tmp_path, capsys, "b.off", b"OFF BINARY\n" + np.array([36, 50, 0], ">i4").tobytes(),
                   "binary OFF ('OFF BINARY') is not read")


# ================================================================================ STL
def test_an_ascii_stl_in_capitals_reads_as_its_obj(tmp_path):
    """``SOLID`` was taken for a binary STL's header, and refused by its size."""
    assert_same_mesh(tmp_path, "m.stl", stl_ascii(str.upper), TRIANGLES)


def test_a_truncated_ascii_stl_is_refused_as_truncated(tmp_path, capsys):
    """Read before as a file of no faces ("has no faces (0 vertices)")."""
    assert_same_mesh(tmp_path, "m.stl", stl_ascii(), TRIANGLES)
    assert_refused(tmp_path, capsys, "cut.stl", stl_ascii()[:-300], "as ASCII STL it has no 'endsolid' line")


# ================================================================================ GLB
def test_a_glb_of_points_or_lines_is_refused_naming_its_primitives(tmp_path, capsys):
    """A scanner app's point cloud as GLB read as "has no faces (0 vertices)": trimesh keeps no points or lines
    when asked for a mesh. Its primitives' kinds are named."""
    import trimesh

    for name, geometry, kind in (("points.glb", trimesh.PointCloud(V), "points (mode 0)"),
                                 ("lines.glb", trimesh.load_path(V[:8].reshape(4, 2, 3)), "lines (mode 1)")):
        folder = tmp_path / name.split(".")[0]
        folder.mkdir()
        assert_refused(folder, capsys, name, trimesh.Scene(geometry).export(file_type="glb"),
                       f"its primitives are {kind}: only triangle lists and strips")
