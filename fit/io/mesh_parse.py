"""Parsers of the mesh formats :func:`~trispline.fit.io.mesh.read_mesh` reads, and size checks
of the binary ones, each raising :class:`~trispline.param.MeshError` with the file and the problem.

OBJ and OFF are parsed here (trimesh's OBJ reader drops unreferenced vertices silently when
``vt`` lines are present and keeps only one ``vt`` per vertex without saying so; its OFF
reader fails on mixed polygon sizes), and so is a binary PLY (:func:`read_binary_ply` for triangles:
the scanners' format, without trimesh's ~1 s import; :func:`read_ply_polygons` for any other, whose
mixed polygon sizes trimesh refuses). ASCII PLY, STL and GLB/GLTF go through
``trimesh.load(..., process=False)`` after their headers are checked against the file
(:func:`check_ply_header`, :func:`check_ply_ascii_rows`, :func:`check_stl_size`): a header that
claims more elements than the file can hold is refused before anything is allocated.
"""
from __future__ import annotations

import io
import struct
from itertools import islice
from pathlib import Path
from typing import Iterable, Iterator, NamedTuple

import numpy as np

from trispline.param.errors import MeshError
from trispline.spline.errors import first_few

__all__ = ["ObjMesh", "fan_triangulate", "read_obj", "read_off", "check_ply_header", "check_stl_size",
           "check_ply_ascii_rows", "read_binary_ply", "read_ply_polygons", "read_trimesh"]

#: Why a file's ``vt`` give no uv when no face names one.
_NO_FACE_VT = "its faces name no texture coordinates (f a/t b/t c/t)"
#: UTF-8's byte order mark, which some writers put first.
_BOM = b"\xef\xbb\xbf"
#: Bytes of the shortest OFF vertex line (``"0 0 0\n"``) and face line (``"3 0 1 2\n"``).
_OFF_MIN_VERTEX, _OFF_MIN_FACE = 6, 8
#: Bytes at the end of an ASCII STL searched for its ``endsolid`` line (trimesh reads nothing without one).
_STL_TAIL = 4096
#: Longest PLY header read (real headers have a few hundred bytes).
_PLY_MAX_HEADER = 1 << 16
#: numpy's type of each PLY scalar type (byte order added by the file's format).
_PLY_TYPES = {"char": "i1", "uchar": "u1", "int8": "i1", "uint8": "u1", "short": "i2", "ushort": "u2", "int16": "i2",
              "uint16": "u2", "int": "i4", "uint": "u4", "int32": "i4", "uint32": "u4", "float": "f4", "float32": "f4",
              "double": "f8", "float64": "f8"}
#: Bytes of each PLY scalar type.
_PLY_SIZES = {name: np.dtype(code).itemsize for name, code in _PLY_TYPES.items()}
#: PLY formats read by :func:`read_binary_ply` and their byte order.
_PLY_ORDER = {"binary_little_endian": "<", "binary_big_endian": ">"}


def _unreadable(path: Path, what: str) -> MeshError:
    return MeshError(f"{path}: {what}", ["unreadable"])


def fan_triangulate(polys: list[list[int]], where: Path) -> np.ndarray:
    """Fan-triangulate polygons ``(p0, p_i, p_i+1)`` given as index lists; returns ``(nf, 3)`` int64."""
    if not polys:
        return np.zeros((0, 3), np.int64)
    sizes = np.fromiter((len(p) for p in polys), np.int64, len(polys))
    try:
        flat = np.fromiter((i for p in polys for i in p), np.int64, int(sizes.sum()))
    except OverflowError:
        raise _unreadable(where, "face vertex indices beyond the int64 range") from None
    return _fan(flat, sizes, where)


def _fan(flat: np.ndarray, sizes: np.ndarray, where: Path) -> np.ndarray:
    """:func:`fan_triangulate` of the polygons of ``sizes`` whose indices ``flat`` lists one after another."""
    if (sizes < 3).any():
        raise _unreadable(where, f"polygons with fewer than 3 vertices: {first_few(np.flatnonzero(sizes < 3))}")
    if (sizes == 3).all():
        return flat.reshape(-1, 3)
    start = np.concatenate([[0], np.cumsum(sizes)[:-1]])
    ntri = sizes - 2
    poly_of = np.repeat(np.arange(len(sizes)), ntri)
    k = np.arange(ntri.sum()) - np.repeat(np.cumsum(ntri) - ntri, ntri)  # 0..n-3 within polygon
    s = start[poly_of]
    return np.column_stack([flat[s], flat[s + 1 + k], flat[s + 2 + k]])


def _coordinates(rows: list[str] | list[list[str]], width: int, what: str, where: Path) -> np.ndarray:
    """``(n, width)`` float64 of the first ``width`` numbers of each row (a line or its tokens);
    the first bad row is named."""
    split = (lambda r: r.split()) if rows and isinstance(rows[0], str) else (lambda r: r)
    try:
        return np.array([split(r)[:width] for r in rows], dtype=np.float64).reshape(-1, width)
    except ValueError:
        for i, r in enumerate(map(split, rows)):
            if len(r) < width:
                raise _unreadable(where, f"{what} {i + 1} has {len(r)} coordinates, expected {width}") from None
            try:
                [float(x) for x in r[:width]]
            except ValueError:
                raise _unreadable(where, f"{what} {i + 1} has a coordinate that is not a number: "
                                         f"{' '.join(r[:width])[:60]!r}") from None
        raise  # pragma: no cover - every row converts alone


class ObjMesh(NamedTuple):
    """An OBJ's arrays: ``V (nv, 3)``, ``F (nf, 3)``, ``uv (nv, 2)`` when every vertex has exactly one ``vt``
    (else None), and ``uv_note``: why the file's ``vt`` lines give no ``uv`` (None: it has none, or they do)."""

    V: np.ndarray
    F: np.ndarray
    uv: np.ndarray | None
    uv_note: str | None = None


def read_obj(path: Path) -> ObjMesh:
    """The OBJ at ``path`` (:class:`ObjMesh`; a UTF-8 byte order mark is skipped).

    The common file (triangles ``f a b c``, or ``f a/t b/t c/t``, positive indices, one width of ``v`` and
    ``vt`` lines, no tabs, indents or comments after data) is parsed by whole arrays (:func:`_obj_arrays`: a
    1M-face scan 4.5 -> 1.2 s); any other, or any error, line by line (:func:`_read_obj_lines`, from the
    same bytes), which names the bad line."""
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise _unreadable(path, str(exc)) from None
    data = data.removeprefix(_BOM)
    fast = _obj_arrays(data)
    if fast is not None:
        return _with_uv(*fast, path)
    return _read_obj_lines(path, data)


def _obj_arrays(data: bytes) -> tuple[np.ndarray, np.ndarray, np.ndarray | None, np.ndarray | None] | None:
    """``(V, F, T, FT)`` of the common OBJ by whole-array conversions (``T``, ``FT``: the texture coordinates
    and the faces' indices into them, or None), or None where the file is not of that form."""
    if _irregular(data):  # keywords are found by their first bytes only where lines are plain
        return None
    lines = data.split(b"\n")
    verts = [ln[2:] for ln in lines if ln[:2] == b"v "]
    faces = [ln[2:] for ln in lines if ln[:2] == b"f "]
    texs = [ln[3:] for ln in lines if ln[:3] == b"vt "]
    if not verts or not faces:
        return None
    try:
        V = _table(verts, np.float64)
        T = _table(texs, np.float64) if texs else None
        block = b"\n".join(faces)
        slashed = b"/" in block
        if slashed and (T is None or b"//" in block):
            return None
        I = _table(block.replace(b"/", b" ").split(b"\n") if slashed else faces, np.int64)
    except (ValueError, OverflowError):  # an index beyond int64 too: the line-by-line reader names it
        return None
    per = I.shape[1] // 3  # numbers per corner: v, or v/t (v/t/n)
    if V.shape[1] < 3 or (T is not None and T.shape[1] < 2) or I.shape[1] % 3 or per not in ((2, 3) if slashed else (1,)):
        return None
    if slashed and block.count(b"/") != I.shape[0] * 3 * (per - 1):  # a face without slashes among them
        return None
    I = I.reshape(-1, 3, per) - 1
    F, FT = I[:, :, 0], (I[:, :, 1] if slashed else None)
    if F.min() < 0 or (FT is not None and FT.min() < 0):  # relative indices: the line-by-line reader
        return None
    return V[:, :3].copy(), F, None if T is None else T[:, :2].copy(), FT


def _irregular(data: bytes) -> bool:
    """Whether an OBJ has what the whole-array path does not read: tabs, indented lines, a backslash (a line
    continued on the next), or a comment after data on a line (found by ``#``'s few positions, not a scan
    per byte)."""
    if b"\t" in data or b"\n " in data or data[:1] == b" " or b"\\" in data:  # tabs, indents, continuations
        return True
    at = data.find(b"#")
    while at >= 0:
        if data[data.rfind(b"\n", 0, at) + 1: at].strip():
            return True
        end = data.find(b"\n", at)
        if end < 0:
            return False
        at = data.find(b"#", end)
    return False


def _table(rows: list[bytes], dtype: type) -> np.ndarray:
    """``(n, k)`` of rows that all hold ``k`` numbers (ValueError otherwise: the caller falls back to the
    line-by-line reader, which names the bad line)."""
    counts = np.fromiter(map(len, map(bytes.split, rows)), np.int64, len(rows))
    if (counts != counts[0]).any():
        raise ValueError("rows of different widths")
    return np.array(b" ".join(rows).split(), dtype=dtype).reshape(len(rows), int(counts[0]))


def _read_obj_lines(path: Path, data: bytes | None = None) -> ObjMesh:
    """:func:`read_obj` line by line: every OBJ it reads (polygons, relative indices, mixed forms, tabs,
    indents, comments after data, lines continued by a final backslash); ``data``: the file's bytes when
    already read (as UTF-8, a byte order mark skipped, bad bytes replaced, universal newlines, as ``open``
    reads)."""
    verts: list[str] = []  # lines, split later: lists would keep the garbage collector busy
    texs: list[str] = []
    fv: list[list[int]] = []
    ft: list[list[int]] = []
    no_vt = 0  # the first face without texture coordinates (1-based; 0: none)
    source = (open(path, encoding="utf-8-sig", errors="replace") if data is None
              else io.StringIO(data.decode("utf-8-sig", errors="replace"), newline=None))
    with source as fh:
        for number, text in _continued(fh):
            key, rest = (text.split("#", 1)[0].split(None, 1) + ["", ""])[:2]  # any whitespace, any indent
            if key == "v":
                verts.append(rest)
            elif key == "vt":
                texs.append(rest)
            elif key == "f":
                vi, ti = _face_indices(rest, len(verts), len(texs), path, number)
                fv.append(vi)
                ft.append(ti)
                if len(ti) < len(vi) and not no_vt:
                    no_vt = len(fv)
    if not verts:
        raise MeshError(f"{path} has no vertices ('v' lines)", ["empty"])
    V = _coordinates(verts, 3, "vertex", path)
    F = fan_triangulate(fv, path)
    if not texs or not fv:
        return ObjMesh(V, F, None)
    if not any(ft):
        return ObjMesh(V, F, None, _NO_FACE_VT)
    if no_vt:
        return ObjMesh(V, F, None, f"face {no_vt} has no texture coordinates (f a/t b/t c/t)")
    return _with_uv(V, F, _coordinates(texs, 2, "texture coordinate", path), fan_triangulate(ft, path), path)


def _continued(lines: Iterable[str]) -> Iterator[tuple[int, str]]:
    """``(number, line)`` of an OBJ's lines, a line ending in a backslash joined with the next (the format's
    line continuation), numbered by its first."""
    held: list[str] = []
    for number, text in enumerate(lines, 1):
        end = text.rstrip()
        if end.endswith("\\"):
            held.append(end[:-1])
            continue
        if held:
            yield number - len(held), " ".join(held + [text])
            held = []
        else:
            yield number, text
    if held:
        yield number + 1 - len(held), " ".join(held)


def _face_indices(rest: str, nv: int, nt: int, path: Path, number: int) -> tuple[list[int], list[int]]:
    """``(vertex ids, texture ids)`` (0-based) of an ``f`` line's corners ``rest``, with ``nv`` vertices and
    ``nt`` texture coordinates read before it (negative indices count back from there)."""
    vi, ti = [], []
    for token in rest.split():
        parts = token.split("/")
        for ids, count, index in ((vi, nv, parts[0]), (ti, nt, parts[1] if len(parts) > 1 else "")):
            if not index:
                continue
            try:
                i = int(index)
            except ValueError:
                raise _unreadable(path, f"line {number}: a face index is not an integer in "
                                        f"{('f ' + rest.strip())[:60]!r}") from None
            if i == 0:
                raise _unreadable(path, f"line {number}: face index 0 in {('f ' + rest.strip())[:60]!r} (OBJ "
                                        "indices start at 1; negative ones count back)")
            ids.append(i - 1 if i > 0 else count + i)
    return vi, ti


def _with_uv(V: np.ndarray, F: np.ndarray, T: np.ndarray | None, FT: np.ndarray | None, path: Path) -> ObjMesh:
    """The mesh with ``uv (nv, 2)`` when the faces' texture indices ``FT`` give every vertex one texture
    coordinate of ``T``, else with the reason it has none."""
    if T is None:
        return ObjMesh(V, F, None)
    if FT is None or not FT.size:
        return ObjMesh(V, F, None, _NO_FACE_VT)
    if FT.min() < 0 or FT.max() >= T.shape[0]:
        bad = np.flatnonzero(((FT < 0) | (FT >= T.shape[0])).any(1))
        return ObjMesh(V, F, None, f"faces refer to texture coordinates outside 1..{T.shape[0]}: {first_few(bad)}")
    ok = (F.ravel() >= 0) & (F.ravel() < V.shape[0])
    if not ok.all():  # read_mesh names the faces
        return ObjMesh(V, F, None)
    per_v = np.full(V.shape[0], -1, np.int64)
    per_v[F.ravel()] = FT.ravel()
    a, b = T[per_v[F.ravel()]], T[FT.ravel()]
    differ = ((a != b) & ~(np.isnan(a) & np.isnan(b))).any(1)  # one texture coordinate per vertex?
    if differ.any():
        seam = np.unique(F.ravel()[differ])
        return ObjMesh(V, F, None, f"{seam.size} vertices have several texture coordinates (a seam; first: "
                                   f"{', '.join(str(int(i) + 1) for i in seam[:5])}), one each is needed")
    return ObjMesh(V, F, np.where((per_v >= 0)[:, None], T[np.maximum(per_v, 0)], np.nan))


def _off_counts(head: list[str], path: Path) -> tuple[int, int]:
    """``(nv, nf)`` of an OFF header line, refused when negative or more than the file can hold."""
    try:
        nv, nf = int(head[0]), int(head[1])
    except (ValueError, IndexError):
        raise _unreadable(path, f"the OFF header's counts {' '.join(head)[:60]!r} are not two integers") from None
    if nv < 0 or nf < 0:
        raise _unreadable(path, f"header announces negative counts ({nv} vertices, {nf} faces)")
    size = path.stat().st_size
    need = _OFF_MIN_VERTEX * nv + _OFF_MIN_FACE * nf
    if need > size:
        raise _unreadable(path, f"header announces {nv} vertices and {nf} faces, which need at least "
                                f"{need} bytes, but the file has {size}")
    return nv, nf


def read_off(path: Path) -> tuple[np.ndarray, np.ndarray]:
    """``(V (nv, 3), F (nf, 3))`` of an OFF file (COFF/NOFF columns beyond x, y, z ignored)."""
    with open(path, encoding="utf-8-sig", errors="replace") as fh:
        lines = (t for t in (ln.split("#", 1)[0].split() for ln in fh) if t)
        first = next(lines, None)
        if first is None or not first[0].upper().endswith("OFF"):
            raise _unreadable(path, "not an OFF file (no OFF header)")
        if first[1:2] == ["BINARY"]:
            raise _unreadable(path, "binary OFF ('OFF BINARY') is not read; write it as ASCII OFF")
        head = first[1:] if len(first) >= 3 else next(lines, [])
        nv, nf = _off_counts(head, path)
        rest = list(islice(lines, nv + nf))
        more = sum(1 for _ in lines)  # data after the last face: the header announces too few
    if len(rest) < nv + nf or more:
        raise _unreadable(path, f"header announces {nv} vertices and {nf} faces but the file has "
                                f"{len(rest) + more} data lines")
    V = _coordinates(rest[:nv], 3, "vertex", path)
    polys = []
    for i, r in enumerate(rest[nv:], 1):
        try:
            k = int(r[0])
            polys.append([int(x) for x in r[1: k + 1]])
        except ValueError:
            raise _unreadable(path, f"face {i} is not a list of integers: {' '.join(r)[:60]!r}") from None
        if len(polys[-1]) < k:
            raise _unreadable(path, f"face line {r} lists fewer than {k} indices")
    return V, fan_triangulate(polys, path)


def _ply_min_bytes(header: list[str], ascii_: bool) -> tuple[int, dict[str, int]]:
    """Fewest bytes the body of a PLY with this header can have, and its element counts.

    Per value: a digit and a separator in ASCII, the type's size in binary; a list counts
    its length, and in a ``face`` element three entries (a polygon has at least three).
    """
    need, counts, row = 0, {}, 0
    name = None
    for tok in [ln.split() for ln in header] + [["element", "", "0"]]:
        if tok[:1] == ["element"] and len(tok) >= 3:
            if name is not None:
                need += counts[name] * max(row, 1)
            name, row = tok[1], 0
            counts[name] = int(tok[2])
            if counts[name] < 0:
                raise ValueError(f"negative count for element {name!r}")
        elif tok[:1] == ["property"] and len(tok) >= 3:
            if tok[1] == "list" and len(tok) >= 4:
                items = 3 if name == "face" else 0
                row += 2 * (1 + items) if ascii_ else _PLY_SIZES.get(tok[2], 1) + items * _PLY_SIZES.get(tok[3], 1)
            else:
                row += 2 if ascii_ else _PLY_SIZES.get(tok[1], 1)
    counts.pop("", None)
    return need, counts


def check_ply_header(path: Path) -> bool:
    """Refuse a PLY whose header claims more elements than the rest of the file can hold; True where its
    vertices' ``x, y, z`` are stored in single precision (``float`` / ``float32``)."""
    with open(path, "rb") as fh:
        blob = fh.read(_PLY_MAX_HEADER)
    end = blob.find(b"end_header")
    if not blob.startswith(b"ply") or end < 0:
        raise _unreadable(path, "cannot read as PLY: not a PLY file (no 'ply ... end_header' header)")
    header = blob[:end].decode("ascii", "replace").splitlines()
    fmt = next((ln.split()[1] for ln in header if ln.startswith("format") and len(ln.split()) > 1), "")
    problem = _ply_header_problem(header, fmt)
    if problem:
        raise _unreadable(path, f"cannot read as PLY: {problem}")
    try:
        need, counts = _ply_min_bytes(header, fmt == "ascii")
    except ValueError as exc:
        raise _unreadable(path, f"cannot read as PLY: bad header ({exc})") from None
    body = path.stat().st_size - (end + len(b"end_header") + 1)
    if need > body:
        claims = ", ".join(f"{n} {k}" for k, n in counts.items())
        raise _unreadable(path, f"header announces {claims}, which need at least {need} bytes, "
                                f"but the file has {max(body, 0)} after its header (truncated?)")
    return _ply_single(header)


def _ply_header_problem(header: list[str], fmt: str) -> str | None:
    """What makes a PLY header unreadable (an unknown format or property type, no ``vertex`` element with
    ``x, y, z``), else None; trimesh's own words for these were ``KeyError: 'x'`` and the like."""
    if fmt not in ("ascii", *_PLY_ORDER):
        return f"unknown format {fmt or '(none)'!r}; PLY is ascii, binary_little_endian or binary_big_endian"
    element, xyz = None, set()
    for tok in (ln.split() for ln in header):
        if tok[:1] == ["element"] and len(tok) >= 2:
            element = tok[1]
        elif tok[:1] == ["property"] and len(tok) >= 3:
            types = tok[2:4] if tok[1] == "list" else tok[1:2]
            unknown = [t for t in types if t not in _PLY_TYPES]
            if unknown:
                return f"property {tok[-1]!r} of element {element!r} has the unknown type {unknown[0]!r}"
            if element == "vertex" and tok[1] != "list":
                xyz.add(tok[2])
    if not {"x", "y", "z"} <= xyz:
        return "no 'vertex' element with properties x, y and z"
    return None


def _ply_single(header: list[str]) -> bool:
    """Whether the ``vertex`` element of a PLY header stores ``x``, ``y`` or ``z`` as 4-byte floats."""
    element = None
    for tok in (ln.split() for ln in header):
        if tok[:1] == ["element"] and len(tok) >= 2:
            element = tok[1]
        elif element == "vertex" and len(tok) == 3 and tok[0] == "property" and tok[2] in ("x", "y", "z"):
            if tok[1] in ("float", "float32"):
                return True
    return False


def _ply_layout(header: list[str]) -> tuple[str, list[tuple[str, int, list[tuple[str, ...]]]]] | None:
    """``(format, [(element, count, properties)])`` of a PLY header; each property ``(type, name)`` or
    ``("list", count type, item type, name)``; None where a line is not one of these."""
    fmt, elements = "", []
    for tok in (ln.split() for ln in header[1:]):
        if not tok or tok[0] in ("comment", "obj_info"):
            continue
        if tok[0] == "format" and len(tok) == 3:
            fmt = tok[1]
        elif tok[0] == "element" and len(tok) == 3 and tok[2].isdigit():
            elements.append((tok[1], int(tok[2]), []))
        elif tok[0] == "property" and elements and (len(tok) == 3 or (len(tok) == 5 and tok[1] == "list")):
            elements[-1][2].append(tuple(tok[1:]))
        else:
            return None
    return fmt, elements


def _ply_dtype(props: list[tuple[str, ...]], order: str, face: bool) -> np.dtype | None:
    """The record type of a binary PLY element of ``props``: scalars, and for a ``face`` its one list
    read as a triangle (count then three indices); None for any other list or type."""
    fields = []
    for i, prop in enumerate(props):
        if prop[0] == "list":
            if not face or prop[3] not in ("vertex_indices", "vertex_index") or prop[1] not in _PLY_TYPES \
                    or _PLY_TYPES.get(prop[2], "f")[0] == "f" or _PLY_TYPES[prop[1]][0] == "f":
                return None
            fields += [("n", order + _PLY_TYPES[prop[1]]), ("corners", order + _PLY_TYPES[prop[2]], (3,))]
        elif prop[0] in _PLY_TYPES:
            fields.append((f"p{i}_{prop[1]}", order + _PLY_TYPES[prop[0]]))
        else:
            return None
    return np.dtype(fields)


def read_binary_ply(path: Path) -> tuple[np.ndarray, np.ndarray, bool] | None:
    """``(V, F, single)`` of a binary PLY triangle mesh read straight into numpy, or None for any other
    PLY (ASCII, polygons of other sizes, other elements or lists), which trimesh reads instead.

    Why: the scanners' own format, and ``import trimesh`` alone costs ~1 s of a command line that
    reads nothing else with it (issue 15's 100k-face scan: 18 s end to end). The header is checked
    first (:func:`check_ply_header`); ``single``: ``x, y, z`` stored as 4-byte floats."""
    single = check_ply_header(path)
    start, header = _ply_head(path)
    layout = _ply_layout(header)
    if layout is None or layout[0] not in _PLY_ORDER or [e[0] for e in layout[1]] != ["vertex", "face"]:
        return None
    order = _PLY_ORDER[layout[0]]
    (_, nv, vprops), (_, nf, fprops) = layout[1]
    vtype, ftype = _ply_dtype(vprops, order, False), _ply_dtype(fprops, order, True)
    names = [p[1] for p in vprops]
    if vtype is None or ftype is None or "n" not in ftype.names or not {"x", "y", "z"} <= set(names):
        return None
    if path.stat().st_size != start + nv * vtype.itemsize + nf * ftype.itemsize:
        return None  # polygons of other sizes (or bytes after the data): trimesh's general reader
    with open(path, "rb") as fh:
        fh.seek(start)
        verts = np.fromfile(fh, vtype, nv)
        faces = np.fromfile(fh, ftype, nf)
    if len(verts) != nv or len(faces) != nf or (faces["n"] != 3).any():
        return None
    V = np.stack([verts[f"p{names.index(c)}_{c}"].astype(np.float64) for c in "xyz"], axis=1)
    return V, faces["corners"].astype(np.int64), single


def _ply_head(path: Path) -> tuple[int, list[str]]:
    """The byte where a PLY's body starts and its header's lines (a checked header: :func:`check_ply_header`)."""
    with open(path, "rb") as fh:
        blob = fh.read(_PLY_MAX_HEADER)
    end = blob.find(b"end_header")
    start = end + len(b"end_header")
    start += 2 if blob[start:start + 2] == b"\r\n" else 1
    return start, blob[:end].decode("ascii", "replace").splitlines()


def read_ply_polygons(path: Path) -> tuple[np.ndarray, np.ndarray, bool] | None:
    """``(V, F, single)`` of any binary PLY whose vertices hold no lists, or None for an ASCII one (trimesh
    reads it) or a header :func:`_ply_layout` does not parse.

    For the binary PLYs :func:`read_binary_ply` leaves: polygons of any sizes, fan-triangulated in file
    order as OBJ and OFF are (trimesh's binary reader refuses polygons of mixed sizes: "PLY is unexpected
    length!"), elements other than ``vertex`` and ``face`` skipped. A body shorter or longer than its
    header's elements is refused, naming both sizes."""
    single = check_ply_header(path)
    start, header = _ply_head(path)
    layout = _ply_layout(header)
    if layout is None or layout[0] not in _PLY_ORDER:
        return None
    order = _PLY_ORDER[layout[0]]
    data = path.read_bytes()
    pos, V, F = start, np.zeros((0, 3)), np.zeros((0, 3), np.int64)
    for name, n, props in layout[1]:
        if any(p[0] == "list" for p in props):
            if name == "vertex":
                return None
            flat, sizes, pos = _ply_lists(data, pos, n, props, order, path, name)
            if name == "face" and flat is not None:
                F = _fan(flat, sizes, path)
            continue
        rtype = _ply_dtype(props, order, False)
        if pos + n * rtype.itemsize > len(data):
            raise _unreadable(path, f"the PLY's element {name!r} ends past the end of the file (truncated?)")
        rows = np.frombuffer(data, rtype, n, pos)
        pos += n * rtype.itemsize
        if name == "vertex":
            names = [p[1] for p in props]
            V = np.stack([rows[f"p{names.index(c)}_{c}"].astype(np.float64) for c in "xyz"], axis=1)
    if pos != len(data):
        raise _unreadable(path, f"the PLY's header announces elements of {pos - start} bytes but the file has "
                                f"{len(data) - start} after its header (does it announce too few?)")
    return V, F, single


def _ply_lists(data: bytes, pos: int, n: int, props: list[tuple[str, ...]], order: str, path: Path,
               element: str) -> tuple[np.ndarray | None, np.ndarray | None, int]:
    """Walk the ``n`` rows of a binary PLY element with list properties from byte ``pos``: the items of its
    ``vertex_indices`` (``vertex_index``) lists one after another as int64, each row's item count (both None
    where it has no such list), and the byte after the element."""
    segments = []  # (bytes of scalars before the list, its count's struct, bytes per item)
    skip, keep, item = 0, None, None
    for p in props:
        if p[0] != "list":
            skip += _PLY_SIZES[p[0]]
            continue
        if p[3] in ("vertex_indices", "vertex_index") and keep is None:
            keep, item = len(segments), np.dtype(order + _PLY_TYPES[p[2]])
        segments.append((skip, struct.Struct(order + np.dtype(_PLY_TYPES[p[1]]).char), _PLY_SIZES[p[2]]))
        skip = 0
    if item is not None and item.kind == "f":
        raise _unreadable(path, f"the PLY's {element} indices are stored as floating-point numbers")
    counts, items = np.zeros(n, np.int64), np.zeros(n, np.int64)
    try:
        for row in range(n):
            for k, (before, count, size) in enumerate(segments):
                m = count.unpack_from(data, pos + before)[0]
                pos += before + count.size
                if m < 0:
                    raise _unreadable(path, f"{element} {row} of the PLY has a list of negative length {m}")
                if k == keep:
                    counts[row], items[row] = m, pos
                pos += m * size
            pos += skip
    except struct.error:
        pos = len(data) + 1
    if pos > len(data):
        raise _unreadable(path, f"the PLY's element {element!r} ends past the end of the file (truncated?)")
    if keep is None:
        return None, None, pos
    first = np.repeat(items, counts)
    within = np.arange(first.size) - np.repeat(np.cumsum(counts) - counts, counts)
    raw = np.frombuffer(data, np.uint8)[(first + within * item.itemsize)[:, None] + np.arange(item.itemsize)]
    return raw.reshape(-1).view(item).astype(np.int64), counts, pos


def check_ply_ascii_rows(path: Path) -> None:
    """Refuse an ASCII PLY whose body is not one line per element its header announces, each with as many
    values as its properties take, and polygons of at least 3 vertices.

    trimesh reads the lines it finds: a truncated file, or a header announcing more faces than the file
    holds, was read as a smaller mesh (or its face lines as vertices) without a word."""
    start, header = _ply_head(path)
    layout = _ply_layout(header)
    if layout is None or layout[0] != "ascii":
        return
    with open(path, "rb") as fh:
        fh.seek(start)
        lines = fh.read().splitlines()
    need = sum(n for _, n, _ in layout[1])
    extra = sum(1 for ln in lines[need:] if ln.strip())
    if len(lines) < need or extra:
        claims = ", ".join(f"{n} {name}" for name, n, _ in layout[1])
        raise _unreadable(path, f"the PLY's header announces {claims}: {need} lines, but its body has "
                                f"{min(len(lines), need) + extra}" + (" (truncated?)" if len(lines) < need else ""))
    row = 0
    for name, n, props in layout[1]:
        bad = _ply_ascii_bad_row(lines[row:row + n], props, name)
        if bad is not None:
            raise _unreadable(path, f"line {len(header) + 2 + row + bad[0]} ({name} {bad[0]}) {bad[1]}")
        row += n


def _ply_ascii_bad_row(rows: list[bytes], props: list[tuple[str, ...]], element: str) -> tuple[int, str] | None:
    """The first of ``rows`` (an ASCII PLY element of ``props``) whose values do not fit them, and what is
    wrong with it; None when all fit."""
    if not any(p[0] == "list" for p in props):
        widths = np.fromiter(map(len, map(bytes.split, rows)), np.int64, len(rows))
        wrong = np.flatnonzero(widths != len(props))
        return None if not wrong.size else (int(wrong[0]), f"has {widths[wrong[0]]} values, expected {len(props)}")
    for i, ln in enumerate(rows):
        values, at = ln.split(), 0
        for p in props:
            if p[0] != "list":
                at += 1
                continue
            try:
                k = int(values[at])
            except (IndexError, ValueError):
                return i, f"has no list length where property {p[3]!r} starts"
            if element == "face" and p[3] in ("vertex_indices", "vertex_index") and k < 3:
                return i, f"is a polygon of {k} vertices (at least 3 needed)"
            at += 1 + k
        if at != len(values):
            return i, f"has {len(values)} values, its properties take {at}"
    return None


def check_stl_size(path: Path) -> None:
    """Refuse a file that is neither ASCII STL nor a binary STL of the size its header claims."""
    size = path.stat().st_size
    with open(path, "rb") as fh:
        head = fh.read(84)
    if size >= 84:
        n = int.from_bytes(head[80:84], "little")
        if 84 + 50 * n == size:
            return
    solid = head.lstrip().lower().startswith(b"solid")
    if solid:
        with open(path, "rb") as fh:
            fh.seek(max(size - _STL_TAIL, 0))
            if b"endsolid" in fh.read().lower():
                return
    as_ascii = ("as ASCII STL it has no 'endsolid' line (truncated?)" if solid
                else "it does not start with 'solid' (ASCII STL)")
    if size < 84:
        raise _unreadable(path, f"not an STL file ({size} bytes: too short for binary STL, and {as_ascii})")
    raise _unreadable(path, f"not an STL file: as binary STL its header announces {n} triangles "
                            f"({84 + 50 * n} bytes) but the file has {size} bytes, and {as_ascii}")


def read_trimesh(path: Path, ext: str) -> tuple[np.ndarray, np.ndarray, bool]:
    """``(V, F, single)`` through ``trimesh.load(process=False)``; an STL's exactly equal corners merged
    (first occurrence first), because STL has no other notion of shared vertices. ``single``: the file
    stores the coordinates in single precision (binary PLY of ``float`` vertices, STL, GLB/GLTF)."""
    if ext == ".ply":
        fast = read_binary_ply(path)
        if fast is None:
            fast = read_ply_polygons(path)
        if fast is not None:
            return fast
    import trimesh

    single = ext in (".stl", ".glb", ".gltf")
    if ext == ".ply":
        single = check_ply_header(path)
        check_ply_ascii_rows(path)
    elif ext == ".stl":
        check_stl_size(path)
    mesh = trimesh.load(path, process=False, force="mesh", maintain_order=True)
    if not isinstance(mesh, trimesh.Trimesh):
        raise _unreadable(path, f"holds no triangle mesh (got {type(mesh).__name__})")
    V = np.asarray(mesh.vertices, dtype=np.float64)
    F = np.asarray(mesh.faces, dtype=np.int64)
    if not F.size and ext in (".glb", ".gltf") and (kinds := _gltf_other_primitives(path)):
        raise _unreadable(path, f"its primitives are {kinds}: only triangle lists and strips (glTF modes 4 and 5) "
                                "are read; trispline fits triangle meshes")
    if ext == ".stl" and F.size:
        corners = V[F.ravel()]
        _, first, inv = np.unique(corners, axis=0, return_index=True, return_inverse=True)
        order = np.argsort(first, kind="stable")
        rank = np.empty_like(order)
        rank[order] = np.arange(order.size)
        V = corners[first[order]]
        F = rank[inv.ravel()].reshape(-1, 3)
    return V, F, single


#: glTF primitive modes other than triangle lists (4) and strips (5), by name.
_GLTF_MODES = {0: "points", 1: "lines", 2: "line loops", 3: "line strips", 6: "triangle fans"}


def _gltf_other_primitives(path: Path) -> str:
    """The kinds of a glTF / GLB file's primitives that trimesh reads no faces from (points, lines, fans), as
    ``"points (mode 0)"``; "" when there are none or the file's JSON cannot be read."""
    import json

    try:
        data = path.read_bytes()
        if data[:4] == b"glTF":  # binary: 12-byte header, then the JSON chunk's length and type
            length, kind = struct.unpack_from("<I4s", data, 12)
            text = data[20:20 + length] if kind == b"JSON" else b"{}"
        else:
            text = data
        meshes = json.loads(text).get("meshes", [])
        modes = sorted({int(p.get("mode", 4)) for m in meshes for p in m.get("primitives", [])} - {4, 5})
    except (OSError, ValueError, TypeError, AttributeError, struct.error):
        return ""
    return ", ".join(f"{_GLTF_MODES.get(m, 'unknown')} (mode {m})" for m in modes)
