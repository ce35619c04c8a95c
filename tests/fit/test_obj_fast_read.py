"""The OBJ reader's whole-array path reads exactly what the line-by-line path reads, on every form of file;
files it does not take (polygons, relative indices, mixed forms) go line by line."""
from __future__ import annotations

from pathlib import Path

import numpy as np
from hypothesis import given, strategies as st

from trispline.fit.io import mesh_parse as mp


@st.composite
def obj_files(draw) -> bytes:
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    nv = draw(st.integers(3, 30))
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
    assert (fast[2] is None) == (lines[2] is None)
    if fast[2] is not None:
        np.testing.assert_array_equal(fast[2], lines[2])


def test_the_common_file_takes_the_whole_array_path_and_the_others_do_not():
    common = b"v 0 0 0\nv 1 0 0\nv 0 1 0.5\nf 1 2 3\n"
    with_uv = b"v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nf 1/1 2/2 3/3\n"
    assert mp._obj_arrays(common) is not None and mp._obj_arrays(with_uv)[3] is not None
    for other in (b"v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nf 1 2 4 3\n",  # a quad
                  b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf -3 -2 -1\n",  # relative indices
                  b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1//1 2//1 3//1\n",  # normals, no texture
                  b"v 0 0 0 # a\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"):  # a comment after a number
        assert mp._obj_arrays(other) is None
