"""The ``trispline`` command line, run as a subprocess (``python -m trispline.fit``).

Every error case checks: the exit code (2 bad input, 1 internal, 3 check/info
found a problem), exactly one line ``trispline: error: ...`` on stderr, no
traceback, nothing on stdout, and no output or temporary file left behind.
Only two commands fit (JAX start-up and compilation cost ~10 s each); the
error cases are rejected before JAX is imported.
"""
from __future__ import annotations

import dataclasses
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import trimesh

import trispline.fit.cli as cli
from trispline.fit.cli import check as check_command
from trispline.fit.io import read_mesh
from trispline.fit.datasets.synthetic import synthetic_scan
from trispline.spline.index import CORNER
from trispline.spline.surface import SplineSurface

from trispline.spline.testing import random_c1_surface


def run(*args: str | os.PathLike, cwd: Path | None = None, timeout: float = 300) -> subprocess.CompletedProcess:
    env = dict(os.environ, PYTHONWARNINGS="")
    return subprocess.run([sys.executable, "-m", "trispline.fit", *map(str, args)], capture_output=True,
                          text=True, cwd=cwd, timeout=timeout, env=env)


def assert_input_error(r: subprocess.CompletedProcess, match: str, code: int = 2) -> None:
    assert r.returncode == code, (r.returncode, r.stdout, r.stderr)
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1, r.stderr
    assert lines[0].startswith("trispline: error: "), r.stderr
    assert match in lines[0], (match, lines[0])
    assert "Traceback" not in r.stderr and r.stdout == ""


def only_inputs(folder: Path, *inputs: str) -> None:
    """Nothing but the input files: no output, no temporary file."""
    assert sorted(p.name for p in folder.iterdir()) == sorted(inputs)


def write_obj(path: Path, V, F, extra: str = "") -> Path:
    lines = [f"v {x!r} {y!r} {z!r}" for x, y, z in np.asarray(V, float).tolist()]
    lines += [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in np.asarray(F).tolist()]
    path.write_text("\n".join(lines) + "\n" + extra)
    return path


def grid_patch(n: int = 3, offset=(0.0, 0.0, 0.0)) -> tuple[np.ndarray, np.ndarray]:
    """A flat n x n grid of squares split into triangles (an open disk)."""
    i, j = np.meshgrid(np.arange(n + 1), np.arange(n + 1), indexing="ij")
    V = np.column_stack([i.ravel(), j.ravel(), 0.1 * (i * j).ravel()]).astype(float) + offset
    idx = lambda a, b: a * (n + 1) + b  # noqa: E731
    F = []
    for a in range(n):
        for b in range(n):
            F += [(idx(a, b), idx(a + 1, b), idx(a + 1, b + 1)), (idx(a, b), idx(a + 1, b + 1), idx(a, b + 1))]
    return V, np.array(F)


# ------------------------------------------------------------------------ bad meshes
@pytest.fixture(scope="module")
def meshes(tmp_path_factory) -> dict[str, Path]:
    d = tmp_path_factory.mktemp("meshes")
    out = {}
    V, F = grid_patch()
    out["good"] = write_obj(d / "good.obj", V, F)
    sphere = trimesh.creation.icosphere(subdivisions=1)
    sphere.export(d / "closed.obj")
    out["closed"] = d / "closed.obj"
    # three faces on the edge (0, 1): non-manifold
    Vn = np.array([[0, 0, 0], [1, 0, 0], [0.5, 1, 0], [0.5, -1, 0], [0.5, 0, 1]], float)
    out["nonmanifold"] = write_obj(d / "nonmanifold.obj", Vn, [[0, 1, 2], [1, 0, 3], [0, 1, 4]])
    V2, F2 = grid_patch(2, offset=(10.0, 0.0, 0.0))
    out["components"] = write_obj(d / "components.obj", np.vstack([V, V2]), np.vstack([F, F2 + len(V)]))
    Vnan = V.copy()
    Vnan[5, 1] = np.nan
    out["nan"] = write_obj(d / "nan.obj", Vnan, F)
    out["xyz"] = d / "mesh.xyz"
    out["xyz"].write_text("0 0 0\n1 0 0\n")
    return out


def _collinear_face_mesh(d: Path) -> Path:
    """A manifold disk with one zero-area face: D lies on the edge AB of the face (A, B, D)."""
    V = np.array([[0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [1.0, 1.0, 0.3], [1.0, 0.0, 0.0]])  # A B C D
    F = np.array([[0, 3, 2], [3, 1, 2], [0, 1, 3]])
    return write_obj(d / "collinear.obj", V, F)


def test_fit_missing_file(tmp_path):
    r = run("fit", tmp_path / "missing.obj", "-o", tmp_path / "s.npz")
    assert_input_error(r, "mesh file not found")
    only_inputs(tmp_path)


def test_unknown_mesh_format(meshes, tmp_path):
    assert_input_error(run("info", meshes["xyz"]), "unknown mesh format '.xyz'")
    r = run("fit", meshes["xyz"], "-o", tmp_path / "s.npz")
    assert_input_error(r, "unknown mesh format")
    only_inputs(tmp_path)


@pytest.mark.parametrize("out, match", [
    ("s.txt", "unknown output format '.txt'"),
    ("missing/s.npz", "does not exist"),
])
def test_fit_bad_output_path(meshes, tmp_path, out, match):
    r = run("fit", meshes["good"], "-o", tmp_path / out)
    assert_input_error(r, match)
    only_inputs(tmp_path)


def test_fit_bad_mesh_out_suffix(meshes, tmp_path):
    r = run("fit", meshes["good"], "-o", tmp_path / "s.npz", "--mesh-out", tmp_path / "m.npz")
    assert_input_error(r, "unknown output format '.npz'")
    r = run("fit", meshes["good"], "-o", tmp_path / "s.npz", "--mesh-out", tmp_path / "s.npz")
    assert_input_error(r, "unknown output format")
    only_inputs(tmp_path)


@pytest.mark.parametrize("name, match, kind", [
    ("closed", "the mesh is closed", "closed"),
    ("nonmanifold", "non-manifold edges", "non_manifold_edges"),
    ("components", "2 connected components", "components"),
    ("nan", "non-finite vertex coordinates", "non_finite"),
])
def test_fit_rejects_invalid_mesh_and_info_says_why(meshes, tmp_path, name, match, kind):
    r = run("fit", meshes[name], "-o", tmp_path / "s.npz", "--mesh-out", tmp_path / "s.obj")
    assert_input_error(r, match)
    only_inputs(tmp_path)
    r = run("info", meshes[name], "--json")
    assert r.returncode == 3, r.stderr
    rep = json.loads(r.stdout)
    assert rep["fit"]["accepted"] is False and kind in rep["fit"]["problems"]
    assert match in rep["fit"]["message"]
    if name == "closed":
        assert rep["boundary_loops"] == 0 and rep["closed"] is True and rep["manifold"] is True
    if name == "nonmanifold":
        assert rep["non_manifold_edges"] == 1 and rep["manifold"] is False
    if name == "components":
        assert rep["components"] == 2
    if name == "nan":
        assert rep["non_finite_vertices"] == 1


def test_fit_rejects_zero_area_face(tmp_path):
    d = tmp_path / "in"
    d.mkdir()
    mesh = _collinear_face_mesh(d)
    r = run("fit", mesh, "-o", tmp_path / "s.npz")
    assert_input_error(r, "zero-area faces")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["in"]
    r = run("info", mesh, "--json")
    rep = json.loads(r.stdout)
    assert r.returncode == 3 and rep["degenerate_faces"]["zero_area"] == 1
    assert rep["fit"]["problems"] == ["zero_area"]


def test_info_on_good_mesh(meshes):
    r = run("info", meshes["good"], "--json")
    assert r.returncode == 0, r.stderr
    rep = json.loads(r.stdout)
    assert rep["vertices"] == 16 and rep["faces"] == 18 and rep["components"] == 1
    assert rep["boundary_loops"] == 1 and rep["holes"] == 0 and rep["manifold"] is True
    assert rep["degenerate_faces"] == {"repeated_vertex": 0, "zero_area": 0}
    assert rep["fit"]["accepted"] is True and rep["warnings"] == []
    r = run("info", meshes["good"])
    assert r.returncode == 0 and "fit: accepted" in r.stdout


def test_info_keep_largest_accepts_components(meshes):
    r = run("info", meshes["components"], "--keep-largest", "--json")
    assert r.returncode == 0, r.stderr
    rep = json.loads(r.stdout)
    assert rep["fit"]["accepted"] and "kept the largest" in rep["fit"]["repairs"][0]


@pytest.mark.parametrize("content, match", [
    (b"this is not a zip archive at all", "not an NPZ archive"),
    (None, "not a trispline surface"),
    ("truncated", "not an NPZ archive"),
])
def test_corrupt_surface_files(tmp_path, content, match):
    bad = tmp_path / "bad.npz"
    if content is None:
        np.savez(bad, something=np.arange(3))
    elif content == "truncated":
        random_c1_surface(20).save(bad)
        bad.write_bytes(bad.read_bytes()[:200])
    else:
        bad.write_bytes(content)
    for args in (("check", bad), ("export", bad, "-o", tmp_path / "out.obj")):
        assert_input_error(run(*args), match)
    only_inputs(tmp_path, "bad.npz")


def test_surface_file_missing_and_bad_suffix(tmp_path):
    assert_input_error(run("check", tmp_path / "nothere.npz"), "no such surface file")
    (tmp_path / "s.txt").write_text("x")
    assert_input_error(run("export", tmp_path / "s.txt", "-o", tmp_path / "o.obj"), "unknown surface file suffix")
    only_inputs(tmp_path, "s.txt")


@pytest.mark.parametrize("args, match", [
    (("fit", "m.obj", "-o", "s.npz", "--param", "spherical"), "argument --param: invalid choice: 'spherical'"),
    ((), "required: COMMAND"),
    (("frobnicate",), "invalid choice: 'frobnicate'"),
    (("fit", "-o", "s.npz"), "required: MESH (or --example)"),
    (("fit", "m.obj", "--example", "-o", "s.npz"), "either MESH or --example"),
    (("fit", "m.obj"), "required: -o/--output"),
    (("fit", "m.obj", "-o", "s.npz", "--bend", "-1"), "argument --bend: expected a finite number >= 0"),
    (("fit", "m.obj", "-o", "s.npz", "--resolution", "0"), "expected a positive integer"),
    (("export", "s.npz"), "nothing to write"),
    (("export", "s.npz", "-o", "x.obj", "--net-lines"), "--net-lines needs --control-net"),
    (("check", "s.npz", "--tolerance", "nan"), "expected a finite number"),
    (("export", "s.npz", "s.step"), "unrecognized arguments: s.step; an output is named with -o: -o s.step"),
    (("info", "m.obj", "n.obj"), "unrecognized arguments: n.obj (see"),  # info writes nothing: no -o advice
])
def test_usage_errors(tmp_path, args, match):
    assert_input_error(run(*args, cwd=tmp_path), match)
    only_inputs(tmp_path)


def test_version_and_help():
    r = run("--version")
    assert r.returncode == 0 and r.stdout.startswith("trispline ")
    r = run("fit", "--help")
    assert r.returncode == 0 and "--keep-largest" in r.stdout and "--blend-power" in r.stdout


def test_weight_flags_match_fitweights():
    from trispline.fit.pipeline import FitWeights

    fields = [(f.name, type(f.default)) for f in dataclasses.fields(FitWeights)]
    assert list(cli.WEIGHT_FIELDS) == fields
    parser = cli.build_parser()
    args = parser.parse_args(["fit", "m.obj", "-o", "s.npz"] + [
        x for name, kind in cli.WEIGHT_FIELDS for x in (f"--{name.replace('_', '-')}", "2")])
    assert all(getattr(args, f"w_{name}") == 2 for name, _ in cli.WEIGHT_FIELDS)


def test_light_commands_do_not_import_jax(meshes, tmp_path):
    code = ("import sys; from trispline.fit.cli import main; "
            f"rc = main(['info', {str(meshes['good'])!r}, '--quiet']); "
            "assert rc == 0, rc; assert 'jax' not in sys.modules, 'jax imported'")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr


def test_fit_prefetches_jax_beside_reading_the_mesh_and_still_fails_fast(tmp_path):
    """``fit`` imports JAX in a thread while it reads the mesh; a bad mesh still ends at once with exit 2."""
    from trispline.fit.cli.common import prefetch

    thread = prefetch("json", "no_such_module_xyz")  # a missing module ends the thread, raises nowhere
    thread.join(30)
    assert not thread.is_alive() and "json" in sys.modules
    bad = tmp_path / "bad.obj"
    bad.write_text("v 0 0 0\nv 1 0 0\nf 1 2 3\n")  # a face naming a vertex that does not exist
    r = subprocess.run([sys.executable, "-m", "trispline.fit", "fit", str(bad), "-o", str(tmp_path / "s.npz")],
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 2 and r.stderr.count("error:") == 1 and "Traceback" not in r.stderr, r.stderr
    assert not (tmp_path / "s.npz").exists()


def test_the_program_ends_at_once_with_every_output_whole(tmp_path):
    """As a program, a successful ``fit`` ends by ``os._exit`` after flushing (no 0.3-0.5 s of interpreter
    teardown): its JSON on stdout and its files are complete."""
    out = tmp_path / "s.npz"
    r = subprocess.run([sys.executable, "-m", "trispline.fit", "fit", "--example", "--example-faces", "300", "-o",
                        str(out), "--mesh-out", str(tmp_path / "s.ply"), "--json"],
                       capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    d = json.loads(r.stdout)
    assert d["outputs"] == [str(out), str(tmp_path / "s.ply")]
    assert SplineSurface.load(out).n_faces == d["patches"]
    assert trimesh.load(tmp_path / "s.ply").faces.shape[0] > 0


# ------------------------------------------------------------ check, export (no fit)
@pytest.fixture(scope="module")
def c1_file(tmp_path_factory) -> Path:
    p = tmp_path_factory.mktemp("surf") / "c1.npz"
    random_c1_surface(30).save(p)
    return p


def test_check_passes_on_c1_and_fails_on_broken_surface(c1_file, tmp_path):
    r = run("check", c1_file, "--json")
    assert r.returncode == 0, r.stderr
    rep = json.loads(r.stdout)
    assert rep["ok"] and rep["failed"] == [] and rep["patches"] > 0
    assert rep["c1_algebraic"]["c1_relative"] < 1e-12 and rep["holes"] == 1
    s = SplineSurface.load(c1_file)
    ctrl = np.array(s.ctrl)
    ctrl[3, 4] += 1e-3  # an interior point: C0 intact, C1 broken across the face's edges
    broken = tmp_path / "broken.json"
    SplineSurface(s.uv, s.faces, ctrl).save(broken)
    r = run("check", broken, "--json")
    assert r.returncode == 3
    rep = json.loads(r.stdout)
    assert not rep["ok"] and "c1_algebraic" in rep["failed"] and "c0_algebraic" not in rep["failed"]
    assert rep["relative_residuals"]["c1_algebraic"] > 1e-5
    assert r.stderr.strip().startswith("trispline: check failed: ")
    # a loose tolerance accepts it
    assert run("check", broken, "--tolerance", "0.1", "--quiet").returncode == 0


def test_check_names_and_skips_malformed_optional_keys(c1_file, tmp_path, capsys):
    """Optional keys another writer got wrong do not make check an internal error: it says which it skipped."""
    s = SplineSurface.load(c1_file)
    extras = dict(fit_weight_names=np.array(["bend", "tilt"]), fit_weights=np.array(["a", "b"]),
                  fit_energy_names=np.array(["bend"]), fit_energies=np.array([2.0]),
                  approx_deviation_names=np.array(["max"]), approx_deviation=np.array([[1.0, 2.0]]))
    SplineSurface(s.uv, s.faces, s.ctrl, extras=extras).save(tmp_path / "odd.npz")
    capsys.readouterr()
    assert cli.main(["check", str(tmp_path / "odd.npz"), "--json", "--quiet"]) == 0
    out, err = capsys.readouterr()
    rep = json.loads(out)
    assert rep["ok"] and rep["energies"] == {"bend": 2.0} and "weights" not in rep
    assert rep["ignored_keys"] == ["fit_weight_names", "fit_weights", "approx_deviation_names", "approx_deviation"]
    assert "ignored malformed optional keys: fit_weight_names" in err


@pytest.mark.parametrize("suffix", [".obj", ".ply", ".stl", ".glb", ".json", ".png"])
def test_export_each_format(c1_file, tmp_path, suffix):
    out = tmp_path / f"out{suffix}"
    args = ["export", c1_file, "-o", out, "--resolution", "3", "--json"]
    if suffix == ".obj":
        args += ["--control-net", tmp_path / "net.obj", "--net-lines"]
    r = run(*args)
    assert r.returncode == 0, r.stderr
    rep = json.loads(r.stdout)
    s = SplineSurface.load(c1_file)
    if suffix in (".obj", ".ply", ".stl", ".glb"):
        m = trimesh.load(out, process=False, force="mesh")
        assert m.faces.shape[0] == rep["mesh_triangles"] == 9 * s.n_faces
        if suffix != ".stl":
            assert m.vertices.shape[0] == rep["mesh_vertices"]
            np.testing.assert_allclose(m.vertices[: s.n_vertices],
                                       _corner_points(s), atol=1e-6 if suffix == ".glb" else 1e-14)
    elif suffix == ".json":
        np.testing.assert_array_equal(SplineSurface.load(out).ctrl, s.ctrl)
    else:
        assert out.read_bytes()[:4] == b"\x89PNG"
    expected = sorted([out.name] + (["net.obj"] if suffix == ".obj" else []))
    assert sorted(p.name for p in tmp_path.iterdir()) == expected


def _corner_points(s: SplineSurface) -> np.ndarray:
    out = np.empty((s.n_vertices, 3))
    out[s.faces.ravel()] = np.asarray(s.ctrl)[:, CORNER].reshape(-1, 3)
    return out


# ---------------------------------------------------------- in-process: exit 1, atomic
def test_internal_error_is_exit_1_without_traceback(c1_file, monkeypatch, capsys):
    def boom(*a, **k):
        raise ZeroDivisionError("simulated bug")

    monkeypatch.setattr(check_command, "surface_report", boom)
    assert cli.main(["check", str(c1_file)]) == 1
    err = capsys.readouterr().err
    assert err.strip().splitlines() == [
        "trispline: internal error: ZeroDivisionError: simulated bug (run with --debug for the traceback)"]
    assert cli.main(["check", str(c1_file), "--debug"]) == 1
    err = capsys.readouterr().err
    assert "Traceback" in err and "simulated bug" in err


def test_failure_after_writing_started_leaves_no_file(c1_file, tmp_path, monkeypatch, capsys):
    """The second output fails half-way: neither output nor any temporary file remains."""
    from trispline.fit.io import export as ex

    def half_written(points, segments, tmp):
        Path(tmp).write_text("v 0 0 0\n")
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(ex, "_write_obj_lines", half_written)
    rc = cli.main(["export", str(c1_file), "-o", str(tmp_path / "s.ply"),
                   "--control-net", str(tmp_path / "net.obj"), "--net-lines"])
    assert rc == 1
    assert "No space left on device" in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []


def test_interrupt_leaves_no_file(c1_file, tmp_path, monkeypatch, capsys):
    from trispline.fit.io import export as ex

    def interrupted(*a, **k):
        Path(a[3]).write_bytes(b"ply\n")
        raise KeyboardInterrupt

    monkeypatch.setattr(ex, "_write_ply", interrupted)
    assert cli.main(["export", str(c1_file), "-o", str(tmp_path / "s.ply")]) == 130
    assert list(tmp_path.iterdir()) == []


# ------------------------------------------------------------------- real fits (2)
@pytest.fixture(scope="module")
def fitted(tmp_path_factory):
    """Fit an OBJ with texture coordinates (--param uv), an unreferenced vertex and a
    second component (--keep-largest)."""
    d = tmp_path_factory.mktemp("fit")
    V, F = synthetic_scan(80, seed=1)
    T = synthetic_scan(80, seed=1, rotate=False)[0][:, :2] * 3.0 + 7.0  # vt: the scan's own plane
    Vx = np.insert(V, 5, [[9.0, 9.0, 9.0]], axis=0)  # unreferenced vertex at index 5
    Tx = np.insert(T, 5, [[0.0, 0.0]], axis=0)
    Fx = np.where(F >= 5, F + 1, F)
    Vt, Ft = grid_patch(1, offset=(5.0, 5.0, 0.0))  # a second, smaller component
    Fx = np.vstack([Fx, Ft + len(Vx)])
    Tx = np.vstack([Tx, Vt[:, :2]])
    Vx = np.vstack([Vx, Vt])
    lines = [f"v {x!r} {y!r} {z!r}" for x, y, z in Vx.tolist()]
    lines += [f"vt {u!r} {v!r}" for u, v in Tx.tolist()]
    lines += [f"f {a}/{a} {b}/{b} {c}/{c}" for a, b, c in (Fx + 1).tolist()]
    mesh = d / "scan.obj"
    mesh.write_text("\n".join(lines) + "\n")
    r = run("fit", mesh, "-o", d / "s.npz", "--keep-largest", "--param", "uv", "--mesh-out", d / "s.ply",
            "--image", d / "s.png", "--control-net", d / "net.glb", "--tilt", "2.5", "--resolution", "3", "--json")
    return d, mesh, r, Tx


def test_fit_keep_largest_maps_vertices_and_writes_everything(fitted):
    d, mesh, r, Tx = fitted
    assert r.returncode == 0, r.stderr
    rep = json.loads(r.stdout)  # stdout is pure JSON (progress and warnings on stderr)
    assert rep["converged"] and rep["c1_residual"] < 1e-12 and rep["max_interpolation_error"] == 0.0
    assert rep["weights"]["tilt"] == 2.5 and rep["param"] == "uv"
    assert any("dropped 1 vertices" in w for w in rep["warnings"])
    assert any("kept the largest of 2 connected components" in w for w in rep["warnings"])
    assert "trispline: warning: " in r.stderr
    assert sorted(p.name for p in d.iterdir()) == ["net.glb", "s.npz", "s.ply", "s.png", "scan.obj"]
    s = SplineSurface.load(d / "s.npz")
    src = np.asarray(s.extras["source_vertex_index"])
    raw = np.array([ln.split()[1:] for ln in mesh.read_text().splitlines() if ln.startswith("v ")], float)
    np.testing.assert_array_equal(_corner_points(s), raw[src])  # exact interpolation of the file's vertices
    assert 5 not in src and s.n_vertices == len(raw) - 1 - 4
    # the domain is the file's vt (up to the normalising similarity), vertex for vertex
    vt = Tx[src]
    A, *_ = np.linalg.lstsq(np.column_stack([vt, np.ones(len(vt))]), s.uv, rcond=None)
    np.testing.assert_allclose(np.column_stack([vt, np.ones(len(vt))]) @ A, s.uv, atol=1e-12)
    energies = dict(zip(s.extras["fit_energy_names"].tolist(), s.extras["fit_energies"].tolist()))
    assert energies == pytest.approx(rep["energies"])
    ply = trimesh.load(d / "s.ply", process=False, force="mesh")
    assert ply.faces.shape[0] == 9 * s.n_faces


def test_check_and_info_after_fit(fitted):
    d, mesh, _, _ = fitted
    r = run("check", d / "s.npz", "--json")
    assert r.returncode == 0, r.stderr
    rep = json.loads(r.stdout)
    assert rep["ok"] and rep["energies"]["bend"] > 0 and rep["weights"]["tilt"] == 2.5
    assert rep["max_interpolation_error"] == 0.0 and rep["param"] == "uv" and rep["holes"] == 1
    r = run("info", mesh)
    assert r.returncode == 3 and "REJECTED [components]" in r.stdout  # without --keep-largest
    assert "dropped 1 vertices" in r.stderr and "texture coordinates (vt): yes" in r.stdout


def test_demo_keeps_vertex_order(tmp_path):
    """The README's first command: fit the built-in scan; corner point i is scan vertex i."""
    r = run("demo", "-o", tmp_path / "demo", "--example-faces", "80", "--quiet")
    assert r.returncode == 0, r.stderr
    assert r.stdout == ""  # --quiet
    d = tmp_path / "demo"
    assert sorted(p.name for p in d.iterdir()) == ["scan.obj", "surface.npz", "surface.ply", "surface.png"]
    md = read_mesh(d / "scan.obj")
    s = SplineSurface.load(d / "surface.npz")
    V, F = synthetic_scan(80)
    np.testing.assert_allclose(md.V, V, atol=1e-14)
    np.testing.assert_array_equal(s.faces, F)  # same rows, same order, same orientation
    np.testing.assert_array_equal(_corner_points(s), np.asarray(s.extras["data_vertices"]))
    np.testing.assert_allclose(_corner_points(s), V, atol=0)
    assert (d / "surface.png").read_bytes()[:4] == b"\x89PNG"


def test_fit_that_does_not_converge_is_exit_3_and_writes_nothing(tmp_path):
    # the default terms are quadratic and solved exactly by one step; the angle term is not
    r = run("fit", "--example", "--example-faces", "60", "--angle", "1", "--max-steps", "1", "-o", tmp_path / "s.npz",
            "--mesh-out", tmp_path / "s.obj")
    assert r.returncode == 3, (r.stdout, r.stderr)
    lines = r.stderr.strip().splitlines()
    assert lines[-1].startswith("trispline: error: the fit did not converge in 1 Gauss-Newton steps (--max-steps 1)")
    assert "throw=False" not in r.stderr  # the library's advice, not the command line's
    assert "Traceback" not in r.stderr and r.stdout == ""
    only_inputs(tmp_path)


# ===================================================== issue 18/20: the fit's options, in-process
def main_json(capsys, *args) -> dict:
    """``trispline ARGS --json --quiet`` in-process; the parsed JSON (asserts exit 0)."""
    capsys.readouterr()
    rc = cli.main([str(a) for a in args] + ["--json", "--quiet"])
    out, err = capsys.readouterr()
    assert rc == 0, err
    return json.loads(out)


def test_help_says_every_default(capsys):
    """Every option that takes a value says its default (or that it is required) in --help;
    every weight flag its FitWeights default and a meaning."""
    import argparse

    from trispline.fit.cli.reference import _subparsers
    from trispline.fit.weights import FitWeights

    for name, parser in _subparsers(cli.build_parser()).items():
        for group in parser._action_groups:
            for a in group._group_actions:
                if not a.option_strings or a.nargs == 0 or isinstance(a, argparse._HelpAction):
                    continue
                text = parser._get_formatter()._expand_help(a)
                assert "default" in text or "required" in text, (name, a.option_strings, text)
    fit_parser = _subparsers(cli.build_parser())["fit"]
    for f in dataclasses.fields(FitWeights):
        flag = "--" + f.name.replace("_", "-")
        action = next(a for a in fit_parser._actions if flag in a.option_strings)
        assert action.help == f"{cli.fit.WEIGHT_HELP[f.name]} (default {getattr(FitWeights(), f.name):g})"


def test_docs_cli_md_is_the_generated_reference():
    """docs/cli.md is the parser's reference (regenerate: python -m trispline.fit.cli.reference > docs/cli.md)."""
    from trispline.fit.cli.reference import cli_reference

    page = Path(__file__).resolve().parents[2] / "docs" / "cli.md"
    assert page.read_text() == cli_reference(), "regenerate: python -m trispline.fit.cli.reference > docs/cli.md"
    assert "## `trispline render`" in page.read_text() and "--blend-power" in page.read_text()


def test_demo_offers_only_what_it_uses():
    demo = cli.build_parser()._subparsers._group_actions[0].choices["demo"]
    flags = {s for a in demo._actions for s in a.option_strings}
    assert not flags & {"--mesh-out", "--image", "--control-net"}
    assert {"--resolution", "--param", "--repair", "--bend"} <= flags


def test_fit_param_uv_evaluates_at_the_users_xy(tmp_path, capsys):
    """A height field fitted with --param uv: the file's uv is exactly (x, y), the surface there is z."""
    from scipy.spatial import Delaunay

    xy = np.random.default_rng(5).uniform([300.0, -20.0], [340.0, 10.0], (200, 2))  # not a unit domain
    F = Delaunay(xy).simplices
    V = np.column_stack([xy, np.sin(xy[:, 0] / 7) * np.cos(xy[:, 1] / 5)])
    mesh = write_obj(tmp_path / "h.obj", V, F)
    d = main_json(capsys, "fit", mesh, "-o", tmp_path / "s.npz", "--param", "uv")
    assert d["param_chosen"] == "uv"
    s = SplineSurface.load(tmp_path / "s.npz")
    np.testing.assert_array_equal(s.uv, V[:, :2])
    assert {"uv_centre", "uv_scale", "uv_mirrored"} <= set(s.extras)
    inside = V[F, :2].mean(1)  # (nf, 2): the triangles' centroids, between the vertices
    P = s.evaluate(*s.locate(inside))
    np.testing.assert_allclose(P[:, :2], inside, rtol=0, atol=1e-9)  # x(u, v) = u, y(u, v) = v
    np.testing.assert_allclose(s.evaluate(*s.locate(V[:, :2])), V, rtol=0, atol=1e-9)


def test_fit_repair_maps_back_to_the_input(tmp_path, capsys):
    from trispline.param.testing import broken_scan

    V, F, expected = broken_scan(300)
    mesh = write_obj(tmp_path / "broken.obj", V, F)
    r = run("fit", mesh, "-o", tmp_path / "x.npz")
    assert r.returncode == 2 and "bowtie" in r.stderr  # refused without --repair
    capsys.readouterr()
    rc = cli.main(["fit", str(mesh), "-o", str(tmp_path / "s.npz"), "--repair", "--json"])
    out, err = capsys.readouterr()
    assert rc == 0, err
    d = json.loads(out)
    assert "repair: " in err and d["repair"]["changes"]["split_vertices"] >= expected["bowtie_vertices"]
    s = SplineSurface.load(tmp_path / "s.npz")
    src = np.asarray(s.extras["source_vertex_index"])
    corners = np.empty((s.triangulation.n_vertices, 3))
    corners[s.faces.ravel()] = s.ctrl[:, CORNER].reshape(-1, 3)
    np.testing.assert_array_equal(corners, V[src])  # every surface vertex is an input vertex


def test_fit_param_auto_reports_choice_and_distortion(tmp_path, capsys):
    from trispline.param.testing import nearly_closed

    V, F = nearly_closed(600, seed=1)
    mesh = write_obj(tmp_path / "closed.obj", V, F)
    d = main_json(capsys, "fit", mesh, "-o", tmp_path / "s.npz", "--param", "auto")
    assert d["param"] == "auto" and d["param_chosen"] in ("spectral", "harmonic", "slim")
    assert d["param_reason"].startswith("auto chose " + d["param_chosen"])
    assert d["distortion"]["flipped_before_repair"] == 0 or d["param_chosen"] != "spectral"
    assert {"angle_max", "area_max", "score"} <= set(d["distortion"])
    assert SplineSurface.load(tmp_path / "s.npz").extras["fit_param_chosen"] == d["param_chosen"]
    info = main_json(capsys, "info", mesh, "--param", "auto")
    assert info["distortion"]["method"] == d["param_chosen"]


@pytest.mark.parametrize("case", ["utm tile", "offset 1e6", "offset 1e9", "tiny at 1e9"])
def test_far_from_the_origin_fits_pass_their_own_check(tmp_path, capsys, case):
    """A UTM terrain tile (x ~ 5e5, y ~ 5e6, 20 m wide) and meshes offset by 1e6 and 1e9 fit, and
    ``check`` of the output passes: residuals measured relative to the centre, against the
    tolerance plus the stored coordinates' own rounding (which at 1e9 is all a file can hold)."""
    from trispline.param.testing import bumpy_disk

    V, F = bumpy_disk(120)
    offset, scale = {"utm tile": ((5e5, 5e6, 120.0), 10.0), "offset 1e6": ((1e6,) * 3, 1.0),
                     "offset 1e9": ((1e9,) * 3, 1.0), "tiny at 1e9": ((1e9,) * 3, 1e-3)}[case]
    mesh = write_obj(tmp_path / "far.obj", V * scale + np.array(offset), F)
    d = main_json(capsys, "fit", mesh, "-o", tmp_path / "s.npz")
    assert d["max_interpolation_error"] == 0.0
    c = main_json(capsys, "check", tmp_path / "s.npz")
    assert c["ok"] and c["failed"] == []
    floor = c["precision_floor"]
    for k, v in c["relative_residuals"].items():
        assert v <= 1e-9 + 8 * floor[k]
    if case == "utm tile":  # a real tile keeps nearly all its digits: the floor is below the tolerance
        assert c["relative_residuals"]["c1_algebraic"] <= 1e-9 and floor["c1_algebraic"] < 1e-9


def test_check_still_fails_a_broken_surface_far_from_the_origin(tmp_path, capsys):
    s = random_c1_surface(40, holes=0, seed=2)
    ctrl = np.array(s.ctrl) + 1e6
    ctrl[3, 10] += 1e-4 * np.ptp(ctrl.reshape(-1, 3), axis=0).max()
    SplineSurface(s.uv, s.faces, ctrl).save(tmp_path / "b.npz")
    capsys.readouterr()
    assert cli.main(["check", str(tmp_path / "b.npz"), "--quiet"]) == 3


def test_fit_json_sizes_energies_and_picture(tmp_path, capsys, monkeypatch):
    """--json reports the mesh output's estimated size and normalised energies; those of one mesh
    at two scales agree (the data-unit energies do not); --image goes through the one renderer."""
    from trispline.fit.io.sizes import estimate_export_bytes, export_resolution
    from trispline.param.testing import bumpy_disk

    V, F = bumpy_disk(80)
    drawn = []
    import trispline.fit.render as render

    real = render.draw

    def spy(*args, **kwargs):
        drawn.append(kwargs)
        return real(*args, **kwargs)

    monkeypatch.setattr(render, "draw", spy)
    res = {}
    for scale in (1.0, 1000.0):
        mesh = write_obj(tmp_path / f"m{scale:g}.obj", V * scale, F)
        out = tmp_path / f"s{scale:g}"
        res[scale] = main_json(capsys, "fit", mesh, "-o", f"{out}.npz", "--mesh-out", f"{out}.obj",
                               "--image", f"{out}.png")
    d = res[1.0]
    s = SplineSurface.load(tmp_path / "s1.npz")
    assert d["mesh_resolution"] == export_resolution(s.n_faces)
    assert d["estimated_bytes"] == estimate_export_bytes(s, tmp_path / "s1.obj", d["mesh_resolution"])
    assert abs(d["estimated_bytes"] / (tmp_path / "s1.obj").stat().st_size - 1) < 0.05
    for k, v in d["energies_normalised"].items():
        np.testing.assert_allclose(res[1000.0]["energies_normalised"][k], v, rtol=1e-6, atol=1e-12)
    assert res[1000.0]["energies"]["bend"] > 1e5 * d["energies"]["bend"]
    assert len(drawn) == 2 and drawn[0]["resolution"] is None and drawn[0]["caption"].endswith(
        f"m1.obj, trispline {cli.common.version()}")


@pytest.mark.parametrize("mirror", [False, True])
def test_fit_param_uv_keeps_the_files_texture_coordinates(tmp_path, capsys, mirror):
    """--param uv with OBJ vt (a clockwise one too): the file's uv is the vt exactly, and the surface at
    a vertex's vt is that vertex."""
    from trispline.param.testing import bumpy_disk

    V, F = bumpy_disk(80)
    vt = V[:, :2] * np.array([2.0, -3.0 if mirror else 3.0]) + np.array([5.0, 0.25])
    lines = [f"v {x!r} {y!r} {z!r}" for x, y, z in V.tolist()] + [f"vt {u!r} {v!r}" for u, v in vt.tolist()]
    lines += [f"f {a + 1}/{a + 1} {b + 1}/{b + 1} {c + 1}/{c + 1}" for a, b, c in F.tolist()]
    mesh = tmp_path / "t.obj"
    mesh.write_text("\n".join(lines) + "\n")
    main_json(capsys, "fit", mesh, "-o", tmp_path / "s.npz", "--param", "uv")
    s = SplineSurface.load(tmp_path / "s.npz")
    md = read_mesh(mesh)
    np.testing.assert_array_equal(s.uv, md.uv)
    assert bool(s.extras["uv_mirrored"]) is mirror
    np.testing.assert_allclose(s.evaluate(*s.locate(md.uv)), md.V, rtol=0, atol=1e-9)


def test_fit_param_uv_refuses_texture_coordinates_it_cannot_use(tmp_path, capsys):
    """--param uv where a face has no vt: exit 2 naming it, not (x, y) in their place without a word."""
    mesh = tmp_path / "t.obj"
    mesh.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nvt 0 0\nvt 2 0\nvt 0 2\nvt 2 2\n"
                    "f 1/1 2/2 3/3\nf 2 4 3\n")
    (tmp_path / "s.npz").write_bytes(b"old")
    capsys.readouterr()
    assert cli.main(["fit", str(mesh), "-o", str(tmp_path / "s.npz"), "--param", "uv", "--quiet"]) == 2
    err = capsys.readouterr().err
    assert "face 2 has no texture coordinates" in err and len(err.strip().splitlines()) == 1
    assert (tmp_path / "s.npz").read_bytes() == b"old"


def test_mesh_problems_name_the_files_vertex_numbers_after_unused_ones_are_dropped(tmp_path, capsys):
    """Two triangles meeting at one vertex (a bowtie), after an unused first vertex: the message names the
    bowtie by its number in the file (3), not in the mesh without the unused one (2)."""
    mesh = tmp_path / "bow.obj"
    mesh.write_text("v 9 9 9\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 2 1 0\nv 2 2 0\nf 2 3 4\nf 4 5 6\n")
    for cmd in (["fit", str(mesh), "-o", str(tmp_path / "s.npz"), "--quiet"], ["info", str(mesh), "--json"]):
        capsys.readouterr()
        assert cli.main(cmd) in (2, 3)
        out = capsys.readouterr()
        assert "bowtie) vertices, where separate fans of faces meet: 1 (first: 3)" in out.err + out.out


def test_fit_is_the_librarys_default_fit_over_its_own_map(tmp_path):
    """``trispline fit scan.obj`` fits as ``fit_surface(V, F)`` does: over its own map (the outline faired as
    a curve, the map's own outline fits), not as over given uv (it passed ``uv=`` before: no curved outline)."""
    import jax

    jax.config.update("jax_enable_x64", True)
    from trispline.fit import fit_surface

    V, F = synthetic_scan(300, noise=0.0)
    out = tmp_path / "s.npz"
    r = run("fit", write_obj(tmp_path / "scan.obj", V, F), "-o", out, "--quiet")
    assert r.returncode == 0, r.stderr
    lib = fit_surface(V, F)
    assert lib.curved_outline
    np.testing.assert_allclose(SplineSurface.load(out).ctrl, lib.surface.ctrl, rtol=0, atol=1e-9 * np.ptp(V))
