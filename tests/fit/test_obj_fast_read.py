"""The OBJ reader's whole-array path reads exactly what the line-by-line path reads, on every form of file;
files it does not take (polygons, relative indices, mixed forms) go line by line."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, strategies as st

from trispline.param import MeshError

from trispline.fit.io import mesh_parse as mp


@st.composite
def obj_files(draw) -> bytes:
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    nv = draw(st.integers(4, 30))
    V = np.round(rng.normal(size=(nv, 3)), draw(st.integers(1, 17)))
    extra = draw(st.sampled_from([0, 1, 3]))  # w, or vertex colours
    nt = draw(st.sampled_from([0, nv, nv + 5]))
    form = draw(st.sampled_from(["v", "v/t", "v/t/n", "v//n", "poly", "relative", "mixed"]))
    eol = draw(st.sampled_from([b"\n", b"\r\n"]))
    out = [b"# generated", b"o part"]
    out += [b"v " + b" ".join(b"%r" % float(x) for x in np.r_[v, rng.random(extra)]) for v in V]
    out += [b"vt %r %r" % (float(a), float(b)) for a, b in rng.random((nt, 2))]
    out += [b"vn 0 0 1"]
    for _ in range(draw(st.integers(1, 20))):
        f = rng.choice(nv, 4 if form == "poly" else 3, replace=False) + 1
        t = rng.integers(1, max(nt, 1) + 1, f.size)
        if form == "relative":
            out.append(b"f " + b" ".join(b"%d" % (i - nv - 1) for i in f))
        elif form in ("v/t", "v/t/n", "mixed") and nt:
            tail = b"/1" if form == "v/t/n" else b""
            tokens = [b"%d/%d%s" % (i, j, tail) for i, j in zip(f, t)]
            if form == "mixed" and rng.random() < 0.5:
                tokens = [b"%d" % i for i in f]
            out.append(b"f " + b" ".join(tokens))
        elif form == "v//n":
            out.append(b"f " + b" ".join(b"%d//1" % i for i in f))
        else:
            out.append(b"f " + b" ".join(b"%d" % i for i in f))
    return eol.join(out) + eol


@given(obj_files())
def test_whole_array_reading_equals_line_by_line(tmp_path_factory, data):
    path = Path(tmp_path_factory.mktemp("obj")) / "m.obj"
    path.write_bytes(data)
    fast, lines = mp.read_obj(path), mp._read_obj_lines(path)
    np.testing.assert_array_equal(fast[0], lines[0])
    np.testing.assert_array_equal(fast[1], lines[1])
    assert (fast.uv is None) == (lines.uv is None)
    assert (fast.uv_note is None) == (lines.uv_note is None)
    if fast.uv is not None:
        np.testing.assert_array_equal(fast.uv, lines.uv)


def _decorated(data: bytes, rng: np.random.Generator) -> bytes:
    """The same OBJ with a byte order mark, tabs, indents and comments after data on some lines."""
    out = []
    for ln in data.split(b"\n"):
        r = rng.random()
        if ln[:2] in (b"v ", b"f ") and r < 0.2:
            ln = ln[:1] + b"\t" + ln[2:].replace(b" ", b"\t")
        elif ln[:2] in (b"v ", b"f ", b"vt") and r < 0.4:
            ln = b"  " + ln
        if ln.strip() and not ln.startswith(b"#") and rng.random() < 0.2:
            ln = ln.rstrip(b"\r") + b" # note" + (b"\r" if ln.endswith(b"\r") else b"")
        out.append(ln)
    return b"\xef\xbb\xbf" + b"\n".join(out)


@given(obj_files(), st.integers(0, 2**32 - 1))
def test_tabs_indents_comments_and_a_byte_order_mark_read_as_the_plain_file(tmp_path_factory, data, seed):
    folder = Path(tmp_path_factory.mktemp("obj"))
    (folder / "plain.obj").write_bytes(data)
    (folder / "decorated.obj").write_bytes(_decorated(data, np.random.default_rng(seed)))
    plain, decorated = mp.read_obj(folder / "plain.obj"), mp.read_obj(folder / "decorated.obj")
    for a, b in zip(plain, decorated):
        if isinstance(a, np.ndarray):
            np.testing.assert_array_equal(a, b)
        else:
            assert a == b


def test_a_polygon_without_slashes_beside_slashed_triangles_is_not_read_as_triangles(tmp_path):
    path = tmp_path / "mixed.obj"
    path.write_bytes(b"".join(b"v %d %d 0\nvt 0 0\n" % (i % 3, i // 3) for i in range(7))
                     + b"f 1 2 3 4 5 6\nf 2/2 7/7 3/3\n")
    m = mp.read_obj(path)
    np.testing.assert_array_equal(m.F, [[0, 1, 2], [0, 2, 3], [0, 3, 4], [0, 4, 5], [1, 6, 2]])
    assert m.uv is None and "face 1 has no texture coordinates" in m.uv_note


@pytest.mark.parametrize("faces, note", [
    (b"f 1/1 2/2 3/3\nf 2/2 4/9 3/3\n", "outside 1..4"),
    (b"f 1/1 2/2 3/3\nf 2/4 4/4 3/3\n", "several texture coordinates"),
    (b"f 1 2 3\nf 2 4 3\n", "name no texture coordinates"),
])
def test_why_texture_coordinates_give_no_uv_is_said(tmp_path, faces, note):
    path = tmp_path / "m.obj"
    path.write_bytes(b"v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nvt 1 1\n" + faces)
    m = mp.read_obj(path)
    assert m.uv is None and note in m.uv_note


def test_face_index_zero_is_refused_by_its_line(tmp_path):
    path = tmp_path / "zero.obj"
    path.write_bytes(b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 0\nv 1 1 0\n")
    with pytest.raises(MeshError, match="line 4: face index 0"):
        mp.read_obj(path)


def test_the_common_file_takes_the_whole_array_path_and_the_others_do_not():
    common = b"v 0 0 0\nv 1 0 0\nv 0 1 0.5\nf 1 2 3\n"
    with_uv = b"v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nf 1/1 2/2 3/3\n"
    assert mp._obj_arrays(common) is not None and mp._obj_arrays(with_uv)[3] is not None
    for other in (b"v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nf 1 2 4 3\n",  # a quad
                  b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf -3 -2 -1\n",  # relative indices
                  b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1//1 2//1 3//1\n",  # normals, no texture
                  b"v 0 0 0 # a\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",  # a comment after a number
                  b"v 0 0 0\nv 1 0 0\n  v 0 1 0\nf 1 2 3\n",  # an indented line
                  b"v\t0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"):  # a tab
        assert mp._obj_arrays(other) is None
