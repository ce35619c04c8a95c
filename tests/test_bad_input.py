"""The bad-input battery (issue 18): every bad file, option, signal and API call ends the promised way.

Each case asserts, where it applies:

* CLI: exit 2 for bad input (1 only for a real internal failure), exactly one line
  ``trispline: error: ...`` on stderr, no traceback, nothing on stdout (:func:`assert_cli_error`);
* files: no partial or temporary output (:func:`assert_no_temporaries`), an existing output
  untouched and the input never destroyed (:class:`Snapshot`);
* API: trispline's own exception type with an expected-versus-actual message.

The CLI runs in-process (``trispline.fit.cli.main`` with ``capsys``: milliseconds, where a
subprocess costs about a second); subprocesses only where a signal must reach a process.
One section per kind of input; add a case to its section's parameter list, or a section of
your own below the last one with the same helpers.
"""
from __future__ import annotations

import io
import json
import os
import re
import signal
import subprocess
import sys
import tempfile
import time
import zipfile
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Iterator

import numpy as np
import pytest
import trimesh

from trispline.fit.cli import main
from trispline.fit.errors import LossyExportWarning
from trispline.fit.io import export_mesh, read_mesh
from trispline.param import MeshError, distortion_report, parameterize, repair_mesh, validate_mesh
from trispline.param.testing import bumpy_disk
from trispline.spline.errors import InputError, OutputError, ResourceError, SurfaceFileError
from trispline.spline.serialize import FORMAT
from trispline.spline.surface import SplineSurface
from trispline.spline.testing import random_c1_surface
from trispline.spline.util import atomic, npz

PY = sys.executable


# =============================================================================== helpers
@dataclass
class Result:
    """What one command printed and returned."""

    rc: int
    out: str
    err: str


def cli(capsys: pytest.CaptureFixture, *args: object) -> Result:
    """``trispline ARGS`` in-process: exit code, stdout, stderr."""
    capsys.readouterr()
    rc = main([str(a) for a in args])
    cap = capsys.readouterr()
    return Result(rc, cap.out, cap.err)


def assert_cli_error(r: Result, match: str, code: int = 2) -> None:
    """One line ``trispline: error: ...`` naming ``match``, exit ``code``, no traceback, empty stdout."""
    lines = r.err.strip().splitlines()
    assert r.rc == code, (r.rc, r.err)
    assert len(lines) == 1 and lines[0].startswith("trispline: error: "), r.err
    assert match in lines[0], (match, lines[0])
    assert "Traceback" not in r.err and r.out == ""


def assert_no_temporaries(folder: Path) -> None:
    """No half-written output: no ``.<name>.<random>.tmp<ext>`` file in ``folder``."""
    left = [p.name for p in folder.iterdir() if ".tmp" in p.name and p.name.startswith(".")]
    assert not left, left


class Snapshot:
    """The bytes and modes of every file in a folder, to assert later that none changed."""

    def __init__(self, folder: Path) -> None:
        self.folder = folder
        self.files = {p.name: (p.read_bytes(), p.stat().st_mode) for p in folder.iterdir() if p.is_file()}

    def assert_unchanged(self) -> None:
        now = {p.name: (p.read_bytes(), p.stat().st_mode) for p in self.folder.iterdir() if p.is_file()}
        assert now == self.files


@contextmanager
def unprivileged() -> Iterator[Path]:
    """A folder every user may enter, with this process running as ``nobody`` when it is root
    (root ignores file permissions); yields the folder."""
    root = Path(tempfile.mkdtemp(prefix="trispline-perm-"))
    root.chmod(0o777)
    uid, gid = os.geteuid(), os.getegid()
    try:
        if uid == 0:
            os.setegid(65534)
            os.seteuid(65534)
        yield root
    finally:
        if uid == 0:
            os.seteuid(0)
            os.setegid(gid)
        for p in sorted(root.rglob("*"), reverse=True):
            p.chmod(0o777) if p.is_dir() else None
        subprocess.run(["rm", "-rf", str(root)], check=False)


@pytest.fixture(scope="module")
def surface() -> SplineSurface:
    """A small exactly C1 surface."""
    return random_c1_surface(30, holes=0, seed=1)


def surface_arrays(surface: SplineSurface) -> dict[str, np.ndarray]:
    """The required keys of a surface file, as arrays."""
    return dict(format=np.array(FORMAT), version=np.array(1), degree=np.array(5), uv=surface.uv,
                faces=surface.faces, control_points=surface.ctrl)


def npy(array: np.ndarray | None = None, header: dict | None = None, data: bytes = b"") -> bytes:
    """An ``.npy`` member: ``array``, or a raw ``header`` followed by ``data``."""
    b = io.BytesIO()
    if header is None:
        np.lib.format.write_array(b, np.asarray(array), allow_pickle=False)
    else:
        np.lib.format.write_array_header_1_0(b, header)
        b.write(data)
    return b.getvalue()


def write_npz(path: Path, members: dict[str, bytes | np.ndarray]) -> Path:
    """An NPZ archive (deflated) with these members, ``.npy`` added to each name."""
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as z:
        for k, v in members.items():
            z.writestr(f"{k}.npy", v if isinstance(v, bytes) else npy(v))
    return path


# ======================================================================= surface files
def _npz_cases(s: SplineSurface) -> dict[str, tuple[dict, str]]:
    """name: (members replacing those of a good file (None: removed), message)."""
    F = s.faces.shape[0]
    return {
        "1e13 elements claimed": (dict(control_points=npy(header=dict(descr="<f8", fortran_order=False,
                                                                       shape=(10 ** 13 // 63, 21, 3)))),
                                  "header claims shape"),
        "truncated member": (dict(uv=npy(s.uv)[:-40]), "header claims shape"),
        "pickled array": (dict(uv=None, pickled=None), "pickled arrays are refused"),
        "negative shape": (dict(uv=npy(header=dict(descr="<f8", fortran_order=False, shape=(-3, 2)))),
                           "negative shape"),
        "complex control points": (dict(control_points=s.ctrl.astype(complex)), "must hold real numbers"),
        "float faces": (dict(faces=s.faces + 0.5), "faces must hold integers"),
        "control points for other faces": (dict(control_points=s.ctrl[:-1]), f"must have shape ({F}, 21, 3)"),
        "NaN control points": (dict(control_points=np.where(s.ctrl == s.ctrl.max(), np.nan, s.ctrl)),
                               "NaN or infinite control points"),
        "faces out of range": (dict(faces=s.faces + s.uv.shape[0]), "faces refer to ids outside"),
        "version 1.9": (dict(version=np.array(1.9)), "version must be an integer, got 1.9"),
        "version '1'": (dict(version=np.array("1")), "version must be an integer, got '1'"),
        "format array": (dict(format=np.array([FORMAT] * 3)), "format must be a single value"),
        "no control points": (dict(control_points=None), "missing required keys"),
    }


@pytest.mark.parametrize("case", list(_npz_cases(random_c1_surface(30, holes=0, seed=1))))
def test_bad_npz_surface(tmp_path, capsys, surface, case):
    change, message = _npz_cases(surface)[case]
    members = dict(surface_arrays(surface))
    for k, v in change.items():
        members.pop(k, None) if v is None else members.__setitem__(k, v)
    path = tmp_path / "bad.npz"
    if "pickled" in change:  # numpy itself writes the pickle
        np.savez(path, **members, uv=np.array([object()] * 3, dtype=object), allow_pickle=True)
    else:
        write_npz(path, members)
    before = Snapshot(tmp_path)
    with pytest.raises(SurfaceFileError, match=re.escape(message)):
        SplineSurface.load(path)
    assert_cli_error(cli(capsys, "check", path), message)
    before.assert_unchanged()


def test_zip_bomb_is_refused_before_inflating(tmp_path, capsys, surface):
    F = 200_000  # 106 MB of zeros in a 100 kB archive
    members = dict(surface_arrays(surface), faces=np.zeros((F, 3), np.int64), control_points=np.zeros((F, 21, 3)))
    path = write_npz(tmp_path / "bomb.npz", members)
    assert path.stat().st_size < 200_000
    t = time.perf_counter()
    with pytest.raises(SurfaceFileError, match="zip bomb"):
        SplineSurface.load(path)
    assert time.perf_counter() - t < 0.5  # refused from the directory, nothing inflated
    assert_cli_error(cli(capsys, "check", path), "zip bomb")


def test_npz_limits_are_relative_to_the_archive(tmp_path, surface):
    """A large member that compresses like real data passes; the same size of zeros does not."""
    rng = np.random.default_rng(0)
    members = dict(surface_arrays(surface), future=rng.normal(size=(npz.RATIO_FROM_BYTES // 8 + 10,)))
    SplineSurface.load(write_npz(tmp_path / "big.npz", members))
    members["future"] = np.zeros(npz.RATIO_FROM_BYTES // 8 + 10)
    with pytest.raises(SurfaceFileError, match=r"inflates from \d+ to \d+ bytes .* zip bomb"):
        SplineSurface.load(write_npz(tmp_path / "zeros.npz", members))


def _json_cases() -> dict[str, tuple[str, str]]:
    """name: (a regular expression in the JSON text of a good file, its replacement)."""
    return {
        "version 1.9": ('"version": 1', '"version": 1.9'), "version '1'": ('"version": 1', '"version": "1"'),
        "version true": ('"version": 1', '"version": true'), "version 1e400": ('"version": 1', '"version": 1e400'),
        "huge integer": ('"degree": 5', '"degree": ' + "9" * 5000),
        "int beyond int64": ('"degree": 5', '"degree": ' + "9" * 25),
        "NaN control point": (r'"control_points": \[\[\[[^,]+', '"control_points": [[[NaN'),
        "uv a string": (r'"uv": \[', '"uv": "x", "old_uv": ['),
        "uv a dict": (r'"uv": \[', '"uv": {"a": 1}, "old_uv": ['),
    }


JSON_MESSAGES = {
    "version 1.9": "version must be an integer, got 1.9", "version '1'": "version must be an integer, got '1'",
    "version true": "version must be an integer, got True", "version 1e400": "version must be an integer, got inf",
    "huge integer": "integer of 5000 digits", "int beyond int64": "integer of 25 digits",
    "NaN control point": "NaN or infinite control points in faces 1 (first: 0)",
    "uv a string": "uv must have shape (V, 2), got ()", "uv a dict": "uv must have shape (V, 2), got ()",
}


@pytest.mark.parametrize("case", list(_json_cases()))
def test_bad_json_surface(tmp_path, capsys, surface, case):
    good = tmp_path / "good.json"
    surface.save(good)
    old, new = _json_cases()[case]
    text, n = re.subn(old, lambda m: new, good.read_text(), count=1)
    assert n == 1
    path = tmp_path / "bad.json"
    path.write_text(text)
    with pytest.raises(SurfaceFileError, match=re.escape(JSON_MESSAGES[case])):
        SplineSurface.load(path)
    assert_cli_error(cli(capsys, "check", path), JSON_MESSAGES[case])


def test_deeply_nested_json(tmp_path, capsys):
    path = tmp_path / "deep.json"
    path.write_text('{"format": ' + "[" * 100_000 + "]" * 100_000 + "}")
    assert_cli_error(cli(capsys, "check", path), "JSON nested too deeply")


@pytest.mark.parametrize("content, match", [
    (b"", "not an NPZ archive"), (b"PK\x03\x04" + b"\0" * 40, "not an NPZ archive"),
    (os.urandom(2000), "not an NPZ archive"),
])
def test_garbage_npz(tmp_path, capsys, content, match):
    path = tmp_path / "g.npz"
    path.write_bytes(content)
    assert_cli_error(cli(capsys, "check", path), match)


def test_surface_paths(tmp_path, capsys):
    (tmp_path / "d.npz").mkdir()
    assert_cli_error(cli(capsys, "check", tmp_path / "d.npz"), "is a folder")
    with pytest.raises(SurfaceFileError, match="must be a str or os.PathLike, got int"):
        SplineSurface.load(3)


# ========================================================================== mesh files
V_GOOD, F_GOOD = bumpy_disk(60)


def _good_bytes(ext: str) -> bytes:
    b = io.BytesIO()
    trimesh.Trimesh(V_GOOD, F_GOOD, process=False).export(b, file_type=ext)
    return b.getvalue()


MESH_CASES = {  # file name: (content, message)
    **{f"empty.{e}": (b"", "is empty (0 bytes)") for e in ("obj", "off", "ply", "stl", "glb")},
    **{f"garbage.{e}": (bytes(range(256)) * 8, m) for e, m in (
        ("obj", "no vertices"), ("off", "not an OFF file"), ("ply", "not a PLY file"),
        ("stl", "not an STL file"), ("glb", "cannot read"))},
    "points.obj": (b"v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 1\n", "has no faces (4 vertices): trispline fits triangle meshes"),
    "truncated.ply": (_good_bytes("ply")[:-100], "(truncated?)"),
    "truncated.stl": (_good_bytes("stl")[:-100], "not an STL file"),
    "truncated.glb": (_good_bytes("glb")[:-100], "cannot read"),
    "truncated.off": (_good_bytes("off")[:-200], "header announces"),
    "truncated.obj": (b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2", "polygons with fewer than 3 vertices"),
    "huge.off": (b"OFF\n1000000000000 1000000000000 0\n0 0 0\n", "which need at least 14000000000000 bytes"),
    "negative.off": (b"OFF\n-3 -1 0\n", "negative counts"),
    "huge.ply": (b"ply\nformat binary_little_endian 1.0\nelement vertex 100000000000\nproperty float x\n"
                 b"property float y\nproperty float z\nend_header\n" + b"\0" * 64, "header announces"),
    "huge.stl": (b"\0" * 80 + (10 ** 9).to_bytes(4, "little") + b"\0" * 100, "announces 1000000000 triangles"),
    "missing_vertex.obj": (b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n", "faces refer to vertices outside [0, 3)"),
    "missing_vertex.off": (b"OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n", "faces refer to vertices outside"),
    "bad_number.obj": (b"v 0 0 zz\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", "vertex 1 has a coordinate that is not a number"),
    "bad_index.obj": (b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 x\n", "face index is not an integer"),
    "huge_index.obj": (b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 " + b"9" * 30 + b"\n", "beyond the int64 range"),
    "short_vertex.obj": (b"v 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", "vertex 1 has 2 coordinates, expected 3"),
}


@pytest.mark.parametrize("name", list(MESH_CASES))
def test_bad_mesh_file(tmp_path, capsys, name):
    content, message = MESH_CASES[name]
    path = tmp_path / name
    path.write_bytes(content)
    with pytest.raises(MeshError) as exc:
        read_mesh(path)
    assert str(path) in str(exc.value) and message in str(exc.value), str(exc.value)
    assert_cli_error(cli(capsys, "info", path), message)
    assert_cli_error(cli(capsys, "fit", path, "-o", tmp_path / "out.npz"), message)
    assert path.read_bytes() == content
    assert sorted(p.name for p in tmp_path.iterdir()) == [name]


def test_mesh_paths(tmp_path, capsys):
    (tmp_path / "d.obj").mkdir()
    assert_cli_error(cli(capsys, "info", tmp_path / "d.obj"), "not a file")
    assert_cli_error(cli(capsys, "info", tmp_path / "nope.obj"), "mesh file not found")
    with pytest.raises(MeshError, match="must be a str or os.PathLike, got NoneType"):
        read_mesh(None)


def test_unreadable_mesh(capsys):
    with unprivileged() as d:
        path = d / "secret.obj"
        path.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
        path.chmod(0)
        assert_cli_error(cli(capsys, "info", path), "Permission denied")


# ============================================================================= outputs
def test_long_output_names(tmp_path, capsys, surface):
    """The temporary name stays within NAME_MAX however long the output's name."""
    src = tmp_path / "s.npz"
    surface.save(src)
    for n in (200, 240, 251):
        target = tmp_path / ("n" * n + ".obj")
        r = cli(capsys, "export", src, "-o", target, "--resolution", 2)
        assert r.rc == 0, r.err
        assert target.exists()
        assert_no_temporaries(tmp_path)
    with pytest.raises(InputError, match="more than the 255 the file system allows"):
        surface.save(tmp_path / ("n" * 260 + ".npz"))
    with pytest.raises(OutputError, match="more than the 255 the file system allows"):
        atomic.check_writable(tmp_path / ("n" * 260 + ".npz"))
    assert_no_temporaries(tmp_path)


def test_output_name_past_name_max_is_bad_input(tmp_path, capsys, surface):
    src = tmp_path / "s.npz"
    surface.save(src)
    assert_cli_error(cli(capsys, "export", src, "-o", tmp_path / ("n" * 260 + ".obj")), "file system allows")


def test_existing_output_untouched_on_failure(tmp_path, capsys, surface, monkeypatch):
    out = tmp_path / "s.npz"
    surface.save(out)
    before = Snapshot(tmp_path)

    def fail(*args, **kwargs):
        raise OSError("disk full")

    monkeypatch.setattr(np, "savez", fail)
    with pytest.raises(OSError, match="disk full"):
        surface.save(out)
    before.assert_unchanged()
    assert_no_temporaries(tmp_path)


def test_read_only_folder(capsys, surface):
    with unprivileged() as d:
        src = d / "s.npz"
        surface.save(src)
        ro = d / "ro"
        ro.mkdir()
        ro.chmod(0o555)
        with pytest.raises(InputError, match="is not writable"):
            surface.save(ro / "s.npz")
        r = cli(capsys, "export", src, "-o", ro / "s.obj")
        assert_cli_error(r, "is not writable")
        assert list(ro.iterdir()) == []


def test_output_mode_is_the_clis(tmp_path, capsys, surface):
    mask = os.umask(0o022)
    try:
        surface.save(tmp_path / "api.npz")
        assert cli(capsys, "export", tmp_path / "api.npz", "-o", tmp_path / "cli.npz").rc == 0
        modes = {p.name: p.stat().st_mode & 0o777 for p in tmp_path.iterdir()}
        assert modes == {"api.npz": 0o644, "cli.npz": 0o644}
    finally:
        os.umask(mask)


def test_same_file(tmp_path):
    a = tmp_path / "a.obj"
    a.write_text("x")
    (tmp_path / "link.obj").symlink_to(a)
    os.link(a, tmp_path / "hard.obj")
    assert atomic.same_file(a, tmp_path / "link.obj") and atomic.same_file(a, tmp_path / "hard.obj")
    assert atomic.same_file(a, tmp_path / "." / "a.obj")
    assert not atomic.same_file(a, tmp_path / "b.obj") and not atomic.same_file(tmp_path / "b.obj", tmp_path / "b.obj")


def test_output_onto_the_input_is_refused(tmp_path, capsys):
    mesh = tmp_path / "m.obj"
    trimesh.Trimesh(V_GOOD, F_GOOD, process=False).export(mesh)
    before = Snapshot(tmp_path)
    assert_cli_error(cli(capsys, "fit", mesh, "-o", tmp_path / "s.npz", "--mesh-out", mesh), "input")
    before.assert_unchanged()


#: The writer waits in short sleeps: the kernel may hand the signal to one of the child's other threads (numpy's
#: BLAS pool), whose handler only flags it, and a main thread in one long ``sleep(60)`` then saw it after a minute
#: (about 1 run in 12 hung past the test's 30 s, for SIGINT and SIGTERM alike); a program at work checks the flag
#: between bytecodes, as this loop does every 20 ms.
_WRITER = """
import sys, time
from trispline.spline.util.atomic import AtomicOutputs
with AtomicOutputs() as out:
    out.path(sys.argv[1]).write_bytes(b"partial")
    print("ready", flush=True)
    for _ in range(3000):
        time.sleep(0.02)
"""


@pytest.fixture
def interruptible():
    """Children start with SIGINT and SIGTERM at their defaults, as at a terminal. A runner that
    starts the suite in the background (a non-interactive shell's ``cmd &``) passes SIGINT on
    ignored, and Python then never raises KeyboardInterrupt: right for a background job, not the
    case these tests are about. A handler set here is reset to the default by ``exec`` (no
    ``preexec_fn``: it can deadlock a child forked from a process with threads)."""
    caught = {s: signal.getsignal(s) for s in (signal.SIGINT, signal.SIGTERM)}
    for s in caught:
        if caught[s] is signal.SIG_IGN:
            signal.signal(s, signal.default_int_handler)
    yield
    for s, handler in caught.items():
        signal.signal(s, handler)


@pytest.mark.parametrize("sig, code", [
    (signal.SIGTERM, 128 + signal.SIGTERM),  # atomic's handler: Terminated, a SystemExit(143)
    (signal.SIGINT, -signal.SIGINT),  # KeyboardInterrupt; Python then dies by the signal itself
])
def test_signal_during_a_write_leaves_nothing(tmp_path, sig, code, interruptible):
    target = tmp_path / "out.npz"
    target.write_bytes(b"old")
    with subprocess.Popen([PY, "-c", _WRITER, str(target)], stdout=subprocess.PIPE, stderr=subprocess.DEVNULL,
                          text=True) as p:
        assert p.stdout.readline().strip() == "ready"
        assert any(".tmp" in q.name for q in tmp_path.iterdir())
        p.send_signal(sig)
        assert p.wait(timeout=30) == code
    assert target.read_bytes() == b"old"
    assert_no_temporaries(tmp_path)


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGINT])
def test_signal_during_a_fit_leaves_nothing(tmp_path, sig, interruptible):
    """Mid-fit: SIGTERM ends it, SIGINT exits 130 with one line; a complete output or none, never a
    temporary (the signal may land in the write, whose renames run with signals held back)."""
    # signalled once the progress bar shows (so inside the command, whatever the machine's
    # speed: a fixed sleep landed in the imports under load, or after the end on a fast machine)
    with subprocess.Popen([PY, "-m", "trispline.fit", "fit", "--example", "--example-faces", "20000", "-o",
                           str(tmp_path / "s.npz")], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True) as p:
        first = p.stderr.read(1)
        p.send_signal(sig)
        out, err = p.communicate(timeout=60)
        err = first + err
    if sig == signal.SIGINT:
        err = err.rstrip().rsplit("\r", 1)[-1].split("\n")[-1]  # the last line, after the bar
        assert p.returncode == 130 and err.strip() == "trispline: interrupted" and out == ""
    else:
        assert p.returncode in (-signal.SIGTERM, 128 + signal.SIGTERM) and "Traceback" not in err
    assert_no_temporaries(tmp_path)
    assert [q.name for q in tmp_path.iterdir()] in ([], ["s.npz"])
    if (tmp_path / "s.npz").exists():
        SplineSurface.load(tmp_path / "s.npz")


def test_sigterm_handler_only_while_a_group_is_open():
    assert signal.getsignal(signal.SIGTERM) is signal.SIG_DFL
    with atomic.AtomicOutputs():
        assert signal.getsignal(signal.SIGTERM) is not signal.SIG_DFL
        with atomic.AtomicOutputs():
            pass
        assert signal.getsignal(signal.SIGTERM) is not signal.SIG_DFL
    assert signal.getsignal(signal.SIGTERM) is signal.SIG_DFL


_RACER = """
import sys
from trispline.spline.testing import random_c1_surface
s = random_c1_surface(30, holes=0, seed=int(sys.argv[2]))
for _ in range(15):
    s.save(sys.argv[1])
"""


def test_two_writers_racing_for_one_path(tmp_path):
    target = tmp_path / "s.npz"
    procs = [subprocess.Popen([PY, "-c", _RACER, str(target), str(seed)]) for seed in (1, 2)]
    seen = 0
    while any(p.poll() is None for p in procs):
        if target.exists():
            SplineSurface.load(target)  # never a partial file
            seen += 1
    assert [p.wait() for p in procs] == [0, 0]
    final = SplineSurface.load(target)
    assert any(np.array_equal(final.ctrl, random_c1_surface(30, holes=0, seed=k).ctrl) for k in (1, 2))
    assert_no_temporaries(tmp_path)


# ===================================================================== API arguments
API_CASES = {  # name: (call, exception type, message)
    "validate V 2 columns of 4": (lambda: validate_mesh(np.zeros((3, 4)), [[0, 1, 2]]), MeshError,
                                 r"V must have shape \(nv, 3\)"),
    "validate F floats": (lambda: validate_mesh(V_GOOD, F_GOOD + 0.5), MeshError, "integer vertex ids"),
    "validate F out of range": (lambda: validate_mesh(V_GOOD, F_GOOD + 1000), MeshError, "outside"),
    "parameterize method": (lambda: parameterize(V_GOOD, F_GOOD, "conformal"), MeshError,
                            "unknown parameterization method 'conformal'"),
    "parameterize uv shape": (lambda: parameterize(V_GOOD, F_GOOD, "uv", uv=np.zeros((3, 2))), MeshError,
                              r"uv must have shape \(\d+, 2\)"),
    "parameterize uv NaN": (lambda: parameterize(V_GOOD, F_GOOD, "uv", uv=np.full((len(V_GOOD), 2), np.nan)),
                            MeshError, "non-finite uv"),
    "repair F 2 columns": (lambda: repair_mesh(V_GOOD, F_GOOD[:, :2]), MeshError, r"F must have shape \(nf, 3\)"),
    "distortion uv rows": (lambda: distortion_report(V_GOOD, F_GOOD, np.zeros((2, 2))), InputError,
                           r"uv must have shape \(\d+, 2\), got \(2, 2\)"),
    "surface extras not a mapping": (lambda: SplineSurface(*_c1_arrays(), extras=5), InputError,
                                     "extras must be a mapping"),
    "surface ctrl shape": (lambda: SplineSurface(_c1_arrays()[0], _c1_arrays()[1], np.zeros(5)), InputError,
                           r"control_points must have shape"),
    "evaluate bary shape": (lambda: _c1().evaluate(np.array([0]), np.ones((1, 2))), InputError,
                            r"bary must have shape \(1, 3\), got \(1, 2\)"),
    "evaluate float face ids": (lambda: _c1().evaluate(np.array([0.5]), np.ones((1, 3)) / 3), InputError,
                                "face_idx must hold integers"),
    "locate shape": (lambda: _c1().locate(np.ones((3, 3))), InputError, r"points must have shape \(n, 2\)"),
    "save path type": (lambda: _c1().save(3), SurfaceFileError, "must be a str or os.PathLike"),
}


def _c1() -> SplineSurface:
    return random_c1_surface(20, holes=0, seed=3)


def _c1_arrays() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    s = _c1()
    return s.uv, s.faces, s.ctrl


@pytest.mark.parametrize("case", list(API_CASES))
def test_bad_api_arguments(case):
    call, kind, message = API_CASES[case]
    with pytest.raises(kind, match=message):
        call()


# ==================================================================== resource limits
RESOURCE_CASES = {  # name: call that must be refused up front, naming the size it would need
    "tessellate resolution 1e6": lambda: _c1().tessellate(10**6),
    "sample_surface resolution 3e5": lambda: __import__("trispline.fit.render", fromlist=["x"]).sample_surface(
        _c1(), 300_000),
    "continuity 1e10 samples per edge": lambda: _c1().continuity(10**10),
    "synthetic scan of 1e9 faces": lambda: __import__(
        "trispline.fit.datasets.synthetic", fromlist=["x"]).synthetic_scan(10**9),
}


@pytest.mark.parametrize("case", list(RESOURCE_CASES))
def test_resource_limits_are_stated_before_the_work(case):
    """Absurd sizes end in one ResourceError (an InputError: exit 2) naming the memory needed, at once."""
    with pytest.raises(ResourceError, match=r"would need about [\d.]+ [kMGTP]?B of memory, but only"):
        RESOURCE_CASES[case]()


def test_nan_barycentric_coordinates_are_refused():
    with pytest.raises(InputError, match="bary has non-finite entries"):
        _c1().evaluate(np.array([0]), np.array([[np.nan, 0.5, 0.5]]))


# ============================================================= command-line options
@pytest.fixture()
def files(tmp_path, surface):
    """``(folder, surface file, mesh file)`` in a fresh folder."""
    src = tmp_path / "s.npz"
    surface.save(src)
    mesh = tmp_path / "m.obj"
    trimesh.Trimesh(V_GOOD, F_GOOD, process=False).export(mesh)
    return tmp_path, src, mesh


ABSURD_OPTIONS = {  # name: (arguments with {s} the surface file, {m} the mesh, {d} the folder; message)
    "fit --fit-rings 1000": ("fit {m} -o {d}/o.npz --fit-rings 1000", "at most 6, got 1000"),
    "fit --fit-rings 0": ("fit {m} -o {d}/o.npz --fit-rings 0", "at least 1"),
    "fit --blend-power 1e308": ("fit {m} -o {d}/o.npz --blend-power 1e308", "at most 16, got 1e308"),
    "fit --fit-degree 4": ("fit {m} -o {d}/o.npz --fit-degree 4", "at most 3"),
    "fit --bend nan": ("fit {m} -o {d}/o.npz --bend nan", "expected a finite number >= 0, got nan"),
    "fit --tilt -1": ("fit {m} -o {d}/o.npz --tilt -1", "expected a finite number >= 0, got -1"),
    "fit --local inf": ("fit {m} -o {d}/o.npz --local inf", "expected a finite number >= 0"),
    "fit bend and local 0": ("fit {m} -o {d}/o.npz --bend 0 --local 0", "bend and local weights must be positive"),
    "fit --example-faces 1e9": ("fit --example --example-faces 1000000000 -o {d}/o.npz", "needs about"),
    "fit --example-faces text": ("fit --example --example-faces 1e9 -o {d}/o.npz", "expected an integer >= 60"),
    "fit --mesh-out --resolution 1e6": ("fit {m} -o {d}/o.npz --mesh-out {d}/o.obj --resolution 1000000",
                                        "would need about"),
    "export --resolution 1e6": ("export {s} -o {d}/o.obj --resolution 1000000", "would need about"),
    "render --resolution 1e6": ("render {s} -o {d}/o.png --resolution 1000000", "use a resolution of at most"),
    "check --samples 1e9": ("check {s} --samples 1000000000", "would need about"),
    "fit -o the input": ("fit {m} -o {d}/o.npz --control-net {m}", "it is the input"),
    "export -o the input": ("export {s} -o {s}", "it is the input"),
    "export -o a link to the input": ("export {s} -o {d}/link.npz", "it is the input"),
    "render -o a link to the input": ("render {s} -o {d}/link.png", "it is the input"),
    "output name past NAME_MAX": ("export {s} -o {d}/" + "n" * 260 + ".obj", "file system allows"),
}


@pytest.mark.parametrize("case", list(ABSURD_OPTIONS))
def test_absurd_options_are_refused_before_any_work(files, capsys, case):
    """One line, exit 2, within a second or two (no fit, no allocation), nothing written."""
    folder, src, mesh = files
    (folder / "link.npz").symlink_to(src)
    (folder / "link.png").symlink_to(src)
    before = Snapshot(folder)
    args, message = ABSURD_OPTIONS[case]
    t0 = time.perf_counter()
    r = cli(capsys, *args.format(s=src, m=mesh, d=folder).split())
    assert_cli_error(r, message)
    assert time.perf_counter() - t0 < 10
    before.assert_unchanged()
    assert_no_temporaries(folder)


def test_a_sliver_is_bad_input(tmp_path, capsys):
    """A triangle of aspect 1e8 is refused as bad input (it made the factorisation fail: exit 1)."""
    V = np.array([[0, 0, 0], [1, 0, 0], [0.5, 1e-8, 0], [0.5, -1, 0]], float)
    path = tmp_path / "sliver.obj"
    trimesh.Trimesh(V, np.array([[0, 1, 2], [0, 3, 1]]), process=False).export(path)
    assert_cli_error(cli(capsys, "fit", path, "-o", tmp_path / "s.npz"), "slivers too thin to fit")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["sliver.obj"]
    r = cli(capsys, "info", path, "--json")  # info says so too
    assert r.rc == 3 and json.loads(r.out)["fit"]["problems"] == ["slivers"]
    from trispline.fit import fit_surface

    with pytest.raises(InputError, match="slivers too thin to fit"):  # and the Python API
        fit_surface(V, np.array([[0, 1, 2], [0, 3, 1]]), uv=V[:, :2])
    from trispline.param import face_aspects

    tri = np.array([[0, 0], [1, 0], [0.5, np.sqrt(3) / 2]])
    np.testing.assert_allclose(face_aspects(tri, np.array([[0, 1, 2]])), [2 / np.sqrt(3)])
    np.testing.assert_allclose(face_aspects(V, np.array([[0, 1, 2]])), [1e8], rtol=1e-6)


def test_a_reader_that_closes_stdout_is_no_internal_error(tmp_path, monkeypatch, capsys):
    """`trispline fit ... --json | head`: the pipe closed under the JSON was "internal error: BrokenPipeError"."""
    V, F = _random_square(seed=1, n=40)
    path = tmp_path / "scan.obj"
    trimesh.Trimesh(V, F, process=False).export(path)

    class Closed(io.StringIO):
        def write(self, text: str) -> int:
            raise BrokenPipeError(32, "Broken pipe")

    monkeypatch.setattr(sys, "stdout", Closed())
    rc = main(["info", str(path), "--json"])
    assert rc == 128 + 13 and capsys.readouterr().err == ""


def _random_square(seed: int = 5, n: int = 200) -> tuple[np.ndarray, np.ndarray]:
    """``n`` random points of the unit square and its corners, Delaunay, lifted to a smooth height field."""
    from scipy.spatial import Delaunay

    P = np.r_[np.random.default_rng(seed).random((n, 2)), [[0, 0], [1, 0], [0, 1], [1, 1]]]
    return np.c_[P, 0.2 * np.sin(3 * P[:, 0]) * np.cos(2 * P[:, 1])], Delaunay(P).simplices


def test_a_triangle_too_thin_for_float64_is_bad_input_naming_it(tmp_path, capfd):
    """A random point 1.4e-6 from the square's side leaves a triangle of aspect 7e5, below the sliver limit
    (1e6), whose C1 conditions still left the normal matrix indefinite in float64: exit 1, "internal error".
    Now bad input naming the triangle's vertices (a ridge that let it factor gave a surface 25x the scan);
    it is a hull sliver, which --repair peels (then the fit succeeds)."""
    V, F = _random_square()
    path = tmp_path / "scan.obj"
    trimesh.Trimesh(V, F, process=False).export(path)
    out = tmp_path / "s.npz"
    out.write_bytes(b"keep me")
    # capfd: CHOLMOD's own "CHOLMOD warning: not positive definite" went to the process's stdout
    r = cli(capfd, "fit", path, "-o", out, "--quiet")
    warning, error = r.err.strip().splitlines()  # random points of a square: hull slivers, said before the work
    assert warning.startswith("trispline: warning: the outline runs along") and "hull slivers" in warning
    assert_cli_error(Result(r.rc, r.out, error), "the fit cannot be solved in float64")
    assert "hull slivers of scattered points, which repair_mesh (--repair) peels off" in error
    assert out.read_bytes() == b"keep me"
    assert_no_temporaries(tmp_path)
    from trispline.fit import fit_surface
    from trispline.fit.errors import NotPositiveDefinite

    with pytest.raises(NotPositiveDefinite, match=r"\(102, 202, 200\) 7\.\d+e\+05"):
        fit_surface(V, F)  # (over the true uv it factors)
    assert cli(capfd, "fit", path, "-o", out, "--quiet", "--repair").rc == 0  # the slivers peeled, it fits
    assert out.read_bytes()[:2] == b"PK"


@pytest.mark.parametrize("mode, match", [((), "slivers too thin to fit"),
                                         (("--param", "harmonic"), "slivers too thin to fit"),
                                         (("--param", "lscm"), "lscm map of this mesh is undefined"),
                                         (("--tolerance-rel", "0.01"), "too thin for a coarse domain"),
                                         (("--tolerance-rel", "0.01", "--param", "harmonic"),
                                          "too thin for a coarse domain")])
def test_a_strip_of_nearly_zero_width_is_bad_input(tmp_path, capfd, mode, match):
    """A scan 1e-9 wide: exit 2 naming the problem, in both fits and with either map -- not a failed
    factorisation (exit 1) nor a solver's own warning on stdout (``capfd``: the descriptors, C's printf too)."""
    x = np.linspace(0.0, 1.0, 120)
    V = np.r_[np.c_[x, 0 * x, 0 * x], np.c_[x, 0 * x + 1e-9, 0 * x]]
    n = x.size
    F = np.r_[[[i, i + 1, n + i] for i in range(n - 1)], [[i + 1, n + i + 1, n + i] for i in range(n - 1)]]
    path = tmp_path / "strip.obj"  # every digit written: trimesh's OBJ keeps 8 decimals, the strip's width none
    path.write_text("".join(f"v {x:.17g} {y:.17g} {z:.17g}\n" for x, y, z in V)
                    + "".join(f"f {a + 1} {b + 1} {c + 1}\n" for a, b, c in F))
    r = cli(capfd, "fit", path, "-o", tmp_path / "s.npz", "-q", *mode)
    assert_cli_error(r, match)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["strip.obj"]
    os.write(1, b"after\n")  # descriptor 1 is the process's own again
    assert capfd.readouterr().out == "after\n"


@pytest.mark.filterwarnings("error")
@pytest.mark.parametrize("faces", [1, 2])
def test_a_scan_of_one_or_two_triangles_approximates_without_warnings(tmp_path, capsys, faces):
    """Every scan vertex is a coarse vertex: nothing is held out to choose the data weight, and nothing warns."""
    V = np.array([[0, 0, 0], [1, 0, 0.1], [1, 1, 0.0], [0, 1, 0.2]], float)[: faces + 2]
    F = np.array([[0, 1, 2], [0, 2, 3]])[:faces]
    path = tmp_path / "tiny.obj"
    trimesh.Trimesh(V, F, process=False).export(path)
    r = cli(capsys, "fit", path, "-o", tmp_path / "s.npz", "--tolerance-rel", "0.01", "-q")
    assert r.rc == 0 and r.err == ""
    s = SplineSurface.load(tmp_path / "s.npz")  # corners=data: every corner point is a scan vertex
    corners = s.evaluate(np.repeat(np.arange(faces), 3), np.tile(np.eye(3), (faces, 1)))
    assert np.abs(corners[:, None, :] - V[None, :, :]).max(2).min(1).max() < 1e-12


def test_demo_with_a_bad_option_leaves_no_folder(tmp_path, capsys):
    for args, message in ((["--mesh-out", "x.obj"], "unrecognized arguments: --mesh-out"),
                          (["--image", "x.png"], "unrecognized arguments: --image"),
                          (["--bend", "0", "--local", "0"], "bend and local weights must be positive")):
        assert_cli_error(cli(capsys, "demo", "-o", tmp_path / "new", *args), message)
        assert list(tmp_path.iterdir()) == []


def test_terminated_is_one_line_and_exit_143(capsys):
    """SIGTERM while outputs are open raises atomic.Terminated: 'trispline: terminated', exit 143."""
    from trispline.fit.cli.common import Parser, run_cli

    def make_parser():
        parser = Parser(prog="trispline")
        parser.set_defaults(func=lambda args, ui: (_ for _ in ()).throw(atomic.Terminated(143)))
        return parser

    capsys.readouterr()
    assert run_cli(make_parser, []) == 143
    assert capsys.readouterr().err.strip() == "trispline: terminated"


class _InterruptOnCollect:
    """Sends SIGINT from its ``__del__``: Python runs the handler there and swallows its KeyboardInterrupt,
    as it did in JAX's garbage-collector callback (the fit then finished: exit 0 and a traceback)."""

    def __del__(self) -> None:
        os.kill(os.getpid(), signal.SIGINT)
        for _ in range(1000):  # the handler runs at the next check of the eval loop, still in here
            pass


def test_an_interrupt_swallowed_by_a_finalizer_still_ends_the_command(tmp_path, capsys, interruptible):
    """Ctrl-C that lands where Python swallows exceptions is raised again at the next progress report:
    exit 130, one line, no output, and no 'Exception ignored' report."""
    from trispline.fit.cli import common

    def make_parser():
        parser = common.Parser(prog="trispline")

        def command(args, ui):
            with ui.stages(("one", "two"), "test") as bar:
                _InterruptOnCollect()  # collected at once: the interrupt is swallowed in __del__
                assert common.Interrupts.pending
                bar.done()  # the next report raises it
                (tmp_path / "out.txt").write_text("should not be reached")
            return 0

        parser.set_defaults(func=command)
        return parser

    capsys.readouterr()
    assert common.run_cli(make_parser, []) == 130
    err = capsys.readouterr().err
    assert err.strip() == "trispline: interrupted" and "Exception ignored" not in err
    assert not (tmp_path / "out.txt").exists()
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler  # handed back


def test_an_interrupt_swallowed_after_the_last_report_ends_the_command_too(capsys, interruptible):
    from trispline.fit.cli import common

    def make_parser():
        parser = common.Parser(prog="trispline")
        parser.set_defaults(func=lambda args, ui: (_InterruptOnCollect(), 0)[1])
        return parser

    capsys.readouterr()
    assert common.run_cli(make_parser, []) == 130
    assert capsys.readouterr().err.strip() == "trispline: interrupted"


def test_a_bar_drawn_by_its_ticker_is_cleared_before_an_interrupts_line(capfd):
    """The bar's elapsed-time redraws are the ticker's; tqdm clears on close only bars its own updates
    drew, so an interrupt's message used to continue the bar's line."""
    from trispline.fit.cli.common import Stages

    with pytest.raises(KeyboardInterrupt):
        with Stages(("start JAX", "fit"), "fit", disable=False):
            time.sleep(Stages.TICK + 1.2)  # past tqdm's delay of 1 s and one tick
            raise KeyboardInterrupt
    err = capfd.readouterr().err
    assert "start JAX" in err and err.endswith("\r")  # drawn, then blanked back to the line's start


@pytest.mark.parametrize("case", ["float faces", "complex V", "object V", "object F", "string V", "NaN V"])
def test_fit_api_wrong_dtypes(case):
    jax = pytest.importorskip("jax")
    jax.config.update("jax_enable_x64", True)
    from trispline.fit.pipeline import fit_surface

    V, F = V_GOOD, F_GOOD
    bad = {"float faces": (V, F + 0.0), "complex V": (V + 0j, F), "object V": (V.astype(object), F),
           "object F": (V, F.astype(object)), "string V": (V.astype(str), F),
           "NaN V": (np.where(np.arange(V.size).reshape(V.shape) == 4, np.nan, V), F)}[case]
    with pytest.raises(InputError, match=r"must (be integers|hold real numbers|be finite)|non-finite"):
        fit_surface(*bad)


# =============================================================================== folds in the data (issue 18)
def test_folds_are_reported_and_warned(tmp_path, capsys):
    """info --json counts the folds; fit warns once, before the work, and --repair cuts them."""
    from folded_meshes import folded_grid

    path = tmp_path / "folded.obj"
    trimesh.Trimesh(*folded_grid(10, [2, 6])[:2], process=False).export(path)
    r = cli(capsys, "info", path, "--json")
    d = json.loads(r.out)
    assert d["folded_edges"] == 3 and d["worst_fold_degrees"] > 150
    r = cli(capsys, "info", path, "--repair", "--json")
    assert "folded flaps" in " ".join(json.loads(r.out)["fit"]["mesh_repair"]["messages"])
    r = cli(capsys, "fit", path, "-o", tmp_path / "s.npz")
    warned = [line for line in r.err.splitlines() if "folds over" in line]
    assert r.rc == 0 and len(warned) == 1 and "3 edges" in warned[0] and "--repair" in warned[0]
    r = cli(capsys, "fit", path, "-o", tmp_path / "s.npz", "--repair")
    assert r.rc == 0 and "folds over" not in r.err and "folded flaps" in r.err


def test_repaired_folds_fit_without_spikes():
    """The folded grid spikes (|H| far above the clean grid's); repaired, it fits as the clean grid."""
    jax = pytest.importorskip("jax")
    jax.config.update("jax_enable_x64", True)
    from folded_meshes import folded_grid

    from trispline.fit.pipeline import fit_surface
    from trispline.fit.render.geometry import surface_curvatures
    from trispline.spline.index import lattice

    def max_h(V, F):
        s = fit_surface(V, F, param="auto").surface
        bary = lattice(4) / 4
        H = surface_curvatures(s, np.repeat(np.arange(s.n_faces), len(bary)), np.tile(bary, (s.n_faces, 1)))[0]
        return float(np.nanmax(np.abs(H)))

    V, F, nf = folded_grid(10, [2, 6])
    clean = max_h(V[:100], F[:nf])
    assert max_h(V, F) > 20 * clean
    r = repair_mesh(V, F)
    assert max_h(r.V, r.F) <= 1.01 * clean


def test_an_interrupt_a_library_turns_into_its_own_error_is_still_an_interrupt(capsys, interruptible):
    """A KeyboardInterrupt raised inside a library's callback can come back as that library's error
    (exit 1 'internal error' before); with the interrupt remembered it ends as one: exit 130."""
    from trispline.fit.cli import common

    def command(args, ui):
        _InterruptOnCollect()  # swallowed; the library then fails for it
        raise RuntimeError("callback failed")

    def make_parser():
        parser = common.Parser(prog="trispline")
        parser.set_defaults(func=command)
        return parser

    capsys.readouterr()
    assert common.run_cli(make_parser, []) == 130
    assert capsys.readouterr().err.strip() == "trispline: interrupted"


def test_slivers_made_by_the_map_are_replaced_or_refused_naming_the_map(tmp_path, capsys):
    """An open cylinder of one row of tall triangles (aspect 31 on the mesh): LSCM squeezes two to aspect
    ~1e12 (the spectral map folds about 60, and is repaired the same way). The fit replaces the map by the harmonic one and says so; a map that cannot be replaced (the
    user's) is refused saying that the map made them (not 'collapse or remove them', which the mesh does
    not need) and which parameterizations to try."""
    from trispline.param import MeshError, refuse_slivers, validate_mesh
    from trispline.param.methods import raw_map

    t = np.linspace(0.0, 2 * np.pi, 64, endpoint=False)
    V = np.r_[np.c_[np.cos(t), np.sin(t), 0 * t], np.c_[np.cos(t), np.sin(t), 0 * t + 3.0]]
    i = np.arange(64)
    F = np.r_[np.c_[i, (i + 1) % 64, 64 + i], np.c_[(i + 1) % 64, 64 + (i + 1) % 64, 64 + i]]
    path = tmp_path / "cylinder.obj"
    trimesh.Trimesh(V, F, process=False).export(path)
    r = cli(capsys, "fit", path, "-o", tmp_path / "s.npz", "-q", "--param", "lscm")
    assert r.rc == 0 and "the lscm map squeezed 2 triangles into slivers" in r.err
    assert "replaced with the harmonic map" in r.err
    assert cli(capsys, "check", tmp_path / "s.npz").rc == 0
    r = cli(capsys, "fit", path, "-o", tmp_path / "d.npz", "-q")  # the default spectral map folds it instead
    assert r.rc == 0 and re.search(r"the spectral map had \d+ flipped", r.err) and "repaired with a harmonic map" in r.err
    assert cli(capsys, "check", tmp_path / "d.npz").rc == 0
    lscm = raw_map(validate_mesh(V, F), "lscm")
    with pytest.raises(MeshError, match="the lscm parameterization squeezed 2 triangles") as e:
        refuse_slivers(lscm, F, V=V, method="lscm")
    assert "--param auto" in str(e.value) and "collapse or remove" not in str(e.value)
    with pytest.raises(MeshError, match="collapse or remove"):  # without the mesh: its own slivers
        refuse_slivers(lscm, F)


def test_an_interrupt_inside_the_bar_s_update_waits_for_its_end(capfd, monkeypatch):
    """Raised inside tqdm, between its lock's acquisitions, an interrupt left the lock held; the bar's ticker
    thread then waited for it for ever and the command hung at exit (seen once in the suite). Inside the bar's
    own updates the interrupt is remembered and raised when the update ends."""
    import signal as _signal

    from trispline.fit.cli.common import Interrupts, Stages

    undo = Interrupts.install()
    try:
        bar = Stages(("a", "b"), "test", disable=False)
        real = bar.bar.update

        def update(n: int) -> None:
            Interrupts.handler(_signal.SIGINT, None)  # the signal lands inside tqdm's update
            real(n)

        monkeypatch.setattr(bar.bar, "update", update)
        with pytest.raises(KeyboardInterrupt):
            bar.at("a", 0.5)
        assert bar.position > 0  # the update ran to its end before the interrupt was raised
        Interrupts.pending = False
        start = time.monotonic()
        bar.close()
        assert time.monotonic() - start < Stages.TICK + 1.5
    finally:
        undo()


class _TerminateOnCollect:
    """Sends SIGTERM from its ``__del__``: the group's handler raises Terminated there, which Python swallows
    (as in JAX's garbage-collector callback: the fit then wrote its files, exit 0 and a traceback)."""

    def __del__(self) -> None:
        os.kill(os.getpid(), signal.SIGTERM)
        for _ in range(1000):
            pass


@pytest.mark.parametrize("kind", ["SIGTERM", "SIGINT"])
def test_a_signal_swallowed_while_outputs_are_written_leaves_none(tmp_path, capsys, interruptible, kind):
    """SIGTERM / Ctrl-C swallowed while a group's files are written: the commit raises it and writes nothing;
    exit 143 / 130 with one line and no 'Exception ignored' report."""
    from trispline.fit.cli import common

    def make_parser():
        parser = common.Parser(prog="trispline")

        def command(args, ui):
            with atomic.AtomicOutputs() as group:
                group.path(tmp_path / "out.txt").write_text("whole")
                (_TerminateOnCollect if kind == "SIGTERM" else _InterruptOnCollect)()
            return 0

        parser.set_defaults(func=command)
        return parser

    (tmp_path / "out.txt").write_text("old")
    capsys.readouterr()
    assert common.run_cli(make_parser, []) == (128 + signal.SIGTERM if kind == "SIGTERM" else 130)
    err = capsys.readouterr().err
    assert err.strip() in ("trispline: terminated", "trispline: interrupted") and "Exception ignored" not in err
    assert (tmp_path / "out.txt").read_text() == "old" and [p.name for p in tmp_path.iterdir()] == ["out.txt"]
    assert signal.getsignal(signal.SIGTERM) is signal.SIG_DFL


def test_a_nearly_indefinite_matrix_that_factors_is_refused_by_its_surface(monkeypatch):
    """Whether the normal matrix of a triangle too thin for float64 factors is rounding luck (the random square's
    did after a rounding-level change of its map, and its net reached 2.9 bounding-box diagonals out): a solved
    surface reaching past ``WILD_NET`` diagonals outside the data's box is refused with the same message. The
    surface is judged, not its net: a hull sliver's net reaches far beyond its patch, which is accepted."""
    import jax

    jax.config.update("jax_enable_x64", True)
    import trispline.fit.pipeline as pipeline
    from trispline.fit import fit_surface
    from trispline.fit.errors import NotPositiveDefinite
    from trispline.fit.reach import box_reach, surface_reach

    V, F = _random_square(seed=0, n=40)  # hull slivers: the net reaches 0.22 diagonals out, the surface 0.11
    fitted = fit_surface(V, F)
    net = float(box_reach(fitted.ctrl, V).max())
    surface = surface_reach(fitted.ctrl, V, 0.0)
    assert 0.0 < surface < 0.75 * net < 0.5
    assert surface_reach(fitted.ctrl, V, net) == pytest.approx(net)  # no net past it: the net's bound
    far = fitted.ctrl.copy()
    far[0, 0] = V.min(0) - [2.0 * np.linalg.norm(np.ptp(V, axis=0)), 0.0, 0.0]  # a corner: the surface goes there
    assert surface_reach(far, V, 0.5) == pytest.approx(2.0)
    monkeypatch.setattr(pipeline, "WILD_NET", 0.5 * (surface + net))  # past the net only: accepted
    assert np.allclose(fit_surface(V, F).ctrl, fitted.ctrl, rtol=0, atol=1e-9)
    monkeypatch.setattr(pipeline, "WILD_NET", 0.5 * surface)  # the same fit, judged as if wild
    with pytest.raises(NotPositiveDefinite, match=r"nearly indefinite .* solved surface reaches .* thinnest triangles"):
        fit_surface(V, F)


# ============================================================ odd inputs found by fuzzing the command line
def _grid_obj(path: Path, n: int = 6, scale: float = 1.0, plane: str = "xy") -> Path:
    """A flat ``n x n`` grid (two triangles a cell; bumped by ``0.1 sin`` when ``plane`` is ``"bumpy"``) as OBJ."""
    t = np.linspace(0.0, 1.0, n + 1)
    x, y = (a.ravel() for a in np.meshgrid(t, t, indexing="ij"))
    z = 0.1 * np.sin(3 * x) * np.cos(2 * y) if plane == "bumpy" else np.zeros_like(x)
    V = scale * (np.column_stack([x, z, y]) if plane == "xz" else np.column_stack([x, y, z]))
    i, j = (a.ravel() for a in np.meshgrid(np.arange(n), np.arange(n), indexing="ij"))
    a, b, c, d = i * (n + 1) + j, (i + 1) * (n + 1) + j, (i + 1) * (n + 1) + j + 1, i * (n + 1) + j + 1
    F = np.stack([np.column_stack([a, b, c]), np.column_stack([a, c, d])], 1).reshape(-1, 3)  # cell by cell
    with open(path, "w") as fh:
        np.savetxt(fh, V, fmt="v %.17g %.17g %.17g")
        np.savetxt(fh, F + 1, fmt="f %d %d %d")
    return path


@pytest.mark.parametrize("plane", ["xy", "xz"])
def test_slim_on_a_small_flat_mesh_fits(tmp_path, capsys, plane):
    """SLIM's step broke down (NaN) on a flat 6 x 6 grid (its faces cell by cell; in another order it did not),
    whose harmonic start is already its optimum, and the energy's SVD of the NaN map stopped the command as an
    internal error: the last finite map stays."""
    mesh = _grid_obj(tmp_path / "plane.obj", plane=plane)
    r = cli(capsys, "fit", mesh, "-o", tmp_path / "s.npz", "--param", "slim", "-q")
    assert r.rc == 0, r.err
    assert cli(capsys, "info", mesh, "--param", "slim", "-q").rc == 0


def test_degenerate_map_energy_is_infinite():
    from trispline.param.distortion import conformal_energy

    V = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0]])
    F = np.array([[0, 1, 2]])
    assert conformal_energy(V, F, V[:, :2]) == pytest.approx(2 * 0.5)
    assert conformal_energy(V, F, np.full((3, 2), np.nan)) == np.inf


@pytest.mark.parametrize("scale, match", [(1e80, "squares overflow"), (1e-80, "underflow"), (1e-300, "underflow")])
def test_coordinates_too_large_or_small_for_double_precision_are_named(tmp_path, capsys, scale, match):
    """At 1e80 every face read as zero-area ('--repair drops such faces', which left none); now the scale is named."""
    mesh = _grid_obj(tmp_path / "m.obj", n=10, scale=scale, plane="bumpy")
    assert_cli_error(cli(capsys, "fit", mesh, "-o", tmp_path / "s.npz"), match)
    assert_cli_error(cli(capsys, "fit", mesh, "-o", tmp_path / "s.npz", "--tolerance-rel", "1e-3"), match)
    r = cli(capsys, "info", mesh)
    assert r.rc == 3 and "REJECTED [scale]" in r.out and "rescale" in r.out
    with pytest.raises(MeshError, match=match):
        md = read_mesh(mesh)
        validate_mesh(md.V, md.F)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["m.obj"]


def test_large_but_representable_coordinates_fit(tmp_path, capsys):
    mesh = _grid_obj(tmp_path / "m.obj", n=10, scale=1e40, plane="bumpy")
    r = cli(capsys, "fit", mesh, "-o", tmp_path / "s.npz", "-q")
    assert r.rc == 0, r.err
    assert np.isfinite(SplineSurface.load(tmp_path / "s.npz").ctrl).all()


def test_float32_mesh_formats_refuse_coordinates_they_cannot_hold(tmp_path, capsys):
    """STL and GLB store 32-bit floats: a surface at 1e40 was written as infinities with exit 0."""
    mesh = _grid_obj(tmp_path / "m.obj", n=10, scale=1e40, plane="bumpy")
    assert cli(capsys, "fit", mesh, "-o", tmp_path / "s.npz", "-q").rc == 0
    before = Snapshot(tmp_path)
    for suffix in (".stl", ".glb"):
        assert_cli_error(cli(capsys, "export", tmp_path / "s.npz", "-o", tmp_path / f"e{suffix}"), "32-bit floats")
        t0 = time.perf_counter()  # refused before the fit
        r = cli(capsys, "fit", mesh, "-o", tmp_path / "t.npz", "--mesh-out", tmp_path / f"t{suffix}")
        assert_cli_error(r, "32-bit floats")
        assert time.perf_counter() - t0 < 5.0
    before.assert_unchanged()
    assert cli(capsys, "export", tmp_path / "s.npz", "-o", tmp_path / "e.ply", "-q").rc == 0


def test_float32_mesh_formats_warn_where_they_round_map_coordinates(tmp_path, capsys):
    """A tile at UTM offsets (5e5, 5e6) written as STL or GLB lost 0.25 m a coordinate without a word: a warning
    names the rounding and the 64-bit formats; the same tile at the origin, or as PLY, writes quietly."""
    mesh = _grid_obj(tmp_path / "m.obj", n=10, scale=1000.0, plane="bumpy")
    V = read_mesh(mesh).V
    utm = tmp_path / "utm.obj"
    with open(utm, "w") as fh:
        np.savetxt(fh, V + [5e5, 5e6, 300.0], fmt="v %.17g %.17g %.17g")
        np.savetxt(fh, read_mesh(mesh).F + 1, fmt="f %d %d %d")
    for name in ("m", "utm"):
        assert cli(capsys, "fit", tmp_path / f"{name}.obj", "-o", tmp_path / f"{name}.npz", "-q").rc == 0
    for suffix in (".stl", ".glb"):
        r = cli(capsys, "export", tmp_path / "utm.npz", "-o", tmp_path / f"utm{suffix}")
        assert r.rc == 0 and "32-bit floats" in r.err and "0.25" in r.err and ".ply" in r.err, r.err
        r = cli(capsys, "export", tmp_path / "m.npz", "-o", tmp_path / f"m{suffix}")
        assert r.rc == 0 and "warning" not in r.err, r.err
    r = cli(capsys, "export", tmp_path / "utm.npz", "-o", tmp_path / "utm.ply")
    assert r.rc == 0 and "warning" not in r.err, r.err
    with pytest.warns(LossyExportWarning, match="32-bit floats"):
        export_mesh(V + [5e5, 5e6, 300.0], read_mesh(mesh).F, tmp_path / "api.stl")

def test_a_surface_file_beyond_double_precision_is_refused(tmp_path, capsys, surface):
    arrays = surface_arrays(surface)
    arrays["control_points"] = surface.ctrl * 1e200
    path = tmp_path / "big.npz"
    np.savez(path, **arrays)
    with pytest.raises(SurfaceFileError, match="overflow double precision"):
        SplineSurface.load(path)
    for args in (("export", path, "-o", tmp_path / "e.obj"), ("render", path, "-o", tmp_path / "r.png"),
                 ("check", path)):
        assert_cli_error(cli(capsys, *args), "overflow double precision")


def _point_surface(path: Path) -> Path:
    """One patch whose 21 control points are all one point: a surface with no defined curvature."""
    uv = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]])
    SplineSurface(uv, np.array([[0, 1, 2]]), np.tile([0.0, 0.0, 1.0], (1, 21, 1))).save(path)
    return path


def test_curvature_picture_of_a_surface_with_no_curvature(tmp_path, capsys):
    path = _point_surface(tmp_path / "point.json")
    r = cli(capsys, "render", path, "-o", tmp_path / "c.png", "--mode", "curvature", "--json", "-q")
    assert r.rc == 0, r.err
    stats = json.loads(r.out)["stats"]
    assert stats["min"] is None and stats["max"] is None
    r = cli(capsys, "render", path, "-o", tmp_path / "d.png", "--mode", "curvature")
    assert r.rc == 0 and "curvature undefined" in r.out, (r.out, r.err)


@pytest.mark.parametrize("value", [np.array("hello"), np.zeros((3, 2)), np.full((4, 3), np.nan)])
def test_deviation_picture_ignores_malformed_stored_data_vertices(tmp_path, capsys, surface, value):
    arrays = surface_arrays(surface)
    arrays["data_vertices"] = value if value.shape != (4, 3) else np.full((surface.n_vertices, 3), np.nan)
    path = tmp_path / "s.npz"
    np.savez(path, **arrays)
    r = cli(capsys, "render", path, "-o", tmp_path / "r.png", "--mode", "deviation")
    assert_cli_error(r, "no usable data vertices")
    assert not (tmp_path / "r.png").exists()


@pytest.mark.parametrize("option", ["--title", "--caption"])
def test_user_text_is_not_mathtext(tmp_path, capsys, surface, option):
    """matplotlib read "$...$" in a title or caption as a formula and stopped at an unknown symbol (exit 1)."""
    surface.save(tmp_path / "s.npz")
    r = cli(capsys, "render", tmp_path / "s.npz", "-o", tmp_path / "r.png", "--backend", "matplotlib",
            option, r"cost: $\undefinedmacro$", "-q")
    assert r.rc == 0, r.err
    assert (tmp_path / "r.png").read_bytes()[:4] == b"\x89PNG"


@pytest.mark.parametrize("command", ["fit", "demo"])
def test_example_below_its_smallest_size_is_bad_input(tmp_path, capsys, command):
    out = ["-o", tmp_path / "s.npz"] if command == "fit" else ["-o", tmp_path / "d"]
    extra = ["--example"] if command == "fit" else []
    r = cli(capsys, command, *extra, "--example-faces", "59", *out)
    assert_cli_error(r, "expected an integer >= 60, got 59")
    assert list(tmp_path.iterdir()) == []


def test_an_output_folder_where_no_file_can_be_made_is_refused_before_the_work(tmp_path, capsys, monkeypatch):
    """Permissions said "writable" (root, a pseudo or read-only file system): the fit ran, then its write failed."""
    import errno

    real = atomic.tempfile.mkstemp

    def refuse(*args, **kwargs):
        if str(kwargs.get("dir", "")) == str(tmp_path / "ro"):
            raise OSError(errno.EROFS, "Read-only file system")
        return real(*args, **kwargs)

    (tmp_path / "ro").mkdir()
    monkeypatch.setattr(atomic.tempfile, "mkstemp", refuse)
    r = cli(capsys, "fit", "--example", "-o", tmp_path / "ro" / "s.npz")
    assert_cli_error(r, "no file can be created in folder")
    assert "Read-only file system" in r.err
    assert "parameterize" not in r.err  # before any stage of the fit
    assert list((tmp_path / "ro").iterdir()) == []


def test_numerical_noise_never_reaches_the_user(tmp_path, capsys):
    """A cell of the scan analysis with a degenerate quadric (an overflow), and a data weight of 0 under the robust
    loss (0 / 0): numpy's RuntimeWarnings were printed; pytest turns any warning into an error here."""
    import trimesh.creation

    s = trimesh.creation.icosphere(2)
    keep = ~(s.vertices[s.faces][:, :, 2] < -0.9).all(1)
    mesh = tmp_path / "cup.obj"
    trimesh.Trimesh(s.vertices, s.faces[keep], process=False).export(mesh)
    r = cli(capsys, "fit", mesh, "-o", tmp_path / "cup.npz", "--tolerance-rel", "1e-3", "-q")
    assert r.rc == 0 and "Warning" not in r.err, r.err
    grid = _grid_obj(tmp_path / "g.obj", n=10, plane="bumpy")
    r = cli(capsys, "fit", grid, "-o", tmp_path / "g.npz", "--tolerance-rel", "1e-3", "--data", "0", "-q")
    assert r.rc == 0 and "Warning" not in r.err, r.err


def test_a_map_that_distorts_too_much_is_named_not_its_triangles(tmp_path, capsys):
    """A flat strip wound 2.5 times onto itself, under SLIM (stopped early from a harmonic start: areas squeezed 67
    times): the message blamed 'the thinnest triangles' of aspect 6 and told the user to merge them."""
    n = 150
    a = 2.5 * 2 * np.pi * np.arange(n + 1) / n
    V = np.stack([np.column_stack([w * np.cos(a), w * np.sin(a), np.zeros_like(a)]) for w in (1.0, 1.5)], 1).reshape(-1, 3)
    i = 2 * np.arange(n)
    F = np.concatenate([np.column_stack([i, i + 2, i + 3]), np.column_stack([i, i + 3, i + 1])])
    mesh = tmp_path / "spiral.obj"
    trimesh.Trimesh(V, F, process=False).export(mesh)
    r = cli(capsys, "fit", mesh, "-o", tmp_path / "s.npz", "--param", "slim", "-q")  # no bar on a slow machine
    if r.rc == 0:  # a better SLIM map needs no message at all
        return
    assert_cli_error(r, "no triangle of the domain is thin")
    assert "merge them" not in r.err and "--param" in r.err


def test_a_given_uv_that_folds_is_not_called_used_as_is(tmp_path, capsys):
    """--param uv of a mesh whose xy projection is degenerate (a wall): the map is replaced, and says so once."""
    mesh = _grid_obj(tmp_path / "wall.obj", n=6, plane="xz")
    r = cli(capsys, "fit", mesh, "-o", tmp_path / "s.npz", "--param", "uv", "-q")
    assert r.rc == 0, r.err
    assert "used as is" not in r.err
    assert "not that uv" in r.err


def _height_grid(path: Path, n: int, z, *, pull: float = 0.0, seed: int = 0) -> Path:
    """An ``n x n`` grid height field ``z(x, y)`` as OBJ; with ``pull``, a fifth of the inner points moved to
    within ``pull`` of a cell's edge (slivers)."""
    t = np.linspace(0.0, 1.0, n + 1)
    x, y = (a.ravel() for a in np.meshgrid(t, t, indexing="ij"))
    inner = (x > 0) & (x < 1) & (y > 0) & (y < 1)
    moved = inner & (np.random.default_rng(seed).random(x.size) < 0.2)
    x = np.where(moved, x + 0.5 / n - pull, x)  # half a cell over, stopping ``pull`` short of the next line
    i, j = (a.ravel() for a in np.meshgrid(np.arange(n), np.arange(n), indexing="ij"))
    a, b, c, d = i * (n + 1) + j, (i + 1) * (n + 1) + j, (i + 1) * (n + 1) + j + 1, i * (n + 1) + j + 1
    F = np.stack([np.column_stack([a, b, c]), np.column_stack([a, c, d])], 1).reshape(-1, 3)
    trimesh.Trimesh(np.column_stack([x, y, z(x, y)]), F, process=False).export(path)
    return path


def test_a_cliff_is_no_hull_and_no_fold(tmp_path, capsys):
    """A height field with a step of 1 over one cell: its steep faces, long and thin where the cliff meets the
    outline, were peeled as hull slivers one behind the other across the mesh, and --repair then kept one half
    (exit 0); its 90-degree creases were called folds, with --repair advised."""
    mesh = _height_grid(tmp_path / "cliff.obj", 40, lambda x, y: 0.1 * np.sin(3 * x) * y + (x > 0.5))
    md = read_mesh(mesh)
    from trispline.param import hull_sliver_faces

    assert not hull_sliver_faces(md.V, md.F).any()
    r = cli(capsys, "fit", mesh, "-o", tmp_path / "s.npz")
    assert r.rc == 0, r.err
    assert "hull slivers" not in r.err and "folds over" not in r.err and "--repair" not in r.err
    r = cli(capsys, "fit", mesh, "-o", tmp_path / "r.npz", "--repair", "--json", "-q")
    assert r.rc == 0, r.err  # asked for, the repair still cuts the steepest faces as flaps (a crease past 90
    assert "connected components" not in r.err  # degrees), but the surface stays whole: no half dropped
    assert SplineSurface.load(tmp_path / "r.npz").n_faces >= 0.95 * len(md.F)


def test_check_passes_what_fit_wrote_over_slivers(tmp_path, capsys):
    """Grid points 1e-4 of a cell from an edge: the stored net was C1 to 2.6e-15, but the sampled gradients
    (divided by the slivers' heights) jumped by 2.2e-9 > 1e-9 and check failed; its rounding floor now counts
    the domain's aspect."""
    mesh = _height_grid(tmp_path / "slivers.obj", 30, lambda x, y: 0.1 * np.sin(3 * x) * np.cos(2 * y), pull=1e-4)
    assert cli(capsys, "fit", mesh, "-o", tmp_path / "s.npz", "-q").rc == 0
    r = cli(capsys, "check", tmp_path / "s.npz", "--json")
    d = json.loads(r.out)
    assert r.rc == 0, (d["relative_residuals"], d["precision_floor"])
    assert d["relative_residuals"]["c1_algebraic"] < 1e-13
    surface = SplineSurface.load(tmp_path / "s.npz")
    broken = surface.ctrl.copy()
    broken[0, 10] += 1e-6  # an inner point of one patch: its C1 across edges breaks
    SplineSurface(surface.uv, surface.faces, broken).save(tmp_path / "b.npz")
    assert cli(capsys, "check", tmp_path / "b.npz", "-q").rc == 3


def test_zebra_far_from_the_origin_keeps_its_stripes(tmp_path, capsys):
    """A surface moved to UTM-like coordinates (5e5, 4e6) drew a blank zebra picture with exit 0: VTK's 32-bit
    floats kept 0.25 m of the points and none of the stripes' texture coordinates."""
    pytest.importorskip("pyvista")
    from PIL import Image

    s = random_c1_surface(60, holes=1, seed=0)
    SplineSurface(s.uv, s.faces, s.ctrl).save(tmp_path / "here.npz")
    SplineSurface(s.uv, s.faces, s.ctrl + [5e5, 4e6, 0.0]).save(tmp_path / "far.npz")
    dark = {}
    for name in ("here", "far"):
        r = cli(capsys, "render", tmp_path / f"{name}.npz", "-o", tmp_path / f"{name}.png", "--mode", "zebra",
                "--backend", "pyvista", "--caption", "", "-q")
        assert r.rc == 0, r.err
        img = np.asarray(Image.open(tmp_path / f"{name}.png").convert("L"), float)
        dark[name] = float((img < 60).mean())
    assert dark["here"] > 0.1 and abs(dark["far"] - dark["here"]) < 0.02, dark


def test_pictures_and_exports_beyond_what_fits_are_refused_before_the_work(tmp_path, capsys, surface, monkeypatch):
    """render --resolution 1000 of 152 patches ran out of 23 GB (the sampling's estimate left out the renderer);
    export --resolution 1000 to OBJ needed ~80 GB (trimesh's text writer) against an estimate of 6.7 GB; demo
    --example-faces 10000000 generated its scan for 161 s before refusing, and advised an option demo lacks."""
    from trispline.spline.util import memory

    surface.save(tmp_path / "s.npz")
    n = surface.n_faces
    r = cli(capsys, "render", tmp_path / "s.npz", "-o", tmp_path / "r.png", "--resolution", 1000)
    assert_cli_error(r, f"draws {n * 1000 * 1000:,} triangles on a picture of 800 x 600 pixels")
    assert cli(capsys, "render", tmp_path / "s.npz", "-o", tmp_path / "r.png", "--resolution", 16, "-q").rc == 0
    monkeypatch.setattr(memory, "available_memory", lambda: 1 << 30)  # a 1 GiB machine
    for suffix, ok in ((".ply", 60), (".obj", 30)):
        t0 = time.perf_counter()
        r = cli(capsys, "export", tmp_path / "s.npz", "-o", tmp_path / f"e{suffix}", "--resolution", 400)
        assert_cli_error(r, "use a lower --resolution")
        assert time.perf_counter() - t0 < 5.0 and not (tmp_path / f"e{suffix}").exists()
        assert cli(capsys, "export", tmp_path / "s.npz", "-o", tmp_path / f"e{suffix}", "--resolution", ok, "-q").rc == 0
    t0 = time.perf_counter()
    assert_cli_error(cli(capsys, "demo", "--example-faces", 10_000_000, "-o", tmp_path / "d"), "ask for fewer --example-faces")
    assert time.perf_counter() - t0 < 5.0 and not (tmp_path / "d").exists()
