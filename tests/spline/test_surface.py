"""SplineSurface: immutability, evaluation, tessellation, NPZ/JSON round trips and load errors."""
from __future__ import annotations

import dataclasses
import json
import os

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from trispline.spline.testing import domains
from trispline.spline.errors import InputError, TriangulationError
from trispline.spline.locate import OutsideDomainError
from trispline.spline.polynomial import polynomial_control_net, random_polynomial
from trispline.spline.serialize import FORMAT, SurfaceFileError, write_surface
from trispline.spline.surface import SplineSurface


@pytest.fixture
def poly_surface():
    uv, faces = domains.random_delaunay(40, holes=1, seed=3)
    func = random_polynomial(5, 3, 4)
    return SplineSurface(uv, faces, polynomial_control_net(uv, faces, func)), func


def test_surface_is_immutable_and_copies_inputs():
    uv, faces = domains.grid(2)
    ctrl = polynomial_control_net(uv, faces, random_polynomial(2, 3, 0))
    s = SplineSurface(uv, faces, ctrl, extras={"w": np.arange(3)})
    for a in (s.uv, s.faces, s.ctrl, s.extras["w"]):
        assert not a.flags.writeable
        with pytest.raises(ValueError):
            a[0] = 0
    with pytest.raises(dataclasses.FrozenInstanceError):
        s.ctrl = ctrl  # type: ignore[misc]
    with pytest.raises(TypeError):
        s.extras["x"] = 1  # type: ignore[index]
    assert uv.flags.writeable and ctrl.flags.writeable  # the caller's arrays untouched
    assert s.faces.dtype == np.int64 and s.ctrl.dtype == np.float64


def test_constructor_validates():
    uv, faces = domains.grid(2)
    ctrl = np.zeros((faces.shape[0], 21, 3))
    with pytest.raises(InputError, match="control_points must have shape"):
        SplineSurface(uv, faces, ctrl[:, :, :2])
    with pytest.raises(TriangulationError, match="counter-clockwise"):
        SplineSurface(uv, faces[:, ::-1], ctrl)
    bad = ctrl.copy()
    bad[3, 4, 0] = np.nan
    with pytest.raises(InputError, match=r"NaN.*faces 1 \(first: 3\)"):
        SplineSurface(uv, faces, bad)


def test_evaluate_and_evaluate_uv(poly_surface):
    s, func = poly_surface
    rng = np.random.default_rng(0)
    fidx = rng.integers(0, s.n_faces, 50)
    bary = rng.dirichlet(np.ones(3), 50)
    p = np.einsum("nk,nkc->nc", bary, s.uv[s.faces[fidx]])
    np.testing.assert_allclose(s.evaluate(fidx, bary), func(p), atol=1e-11)
    d = s.evaluate_derivatives(fidx, bary)
    np.testing.assert_allclose(d.du, func.gradient(p)[0], atol=1e-9)
    np.testing.assert_allclose(s.evaluate_uv(p), func(p), atol=1e-11)
    with pytest.raises(OutsideDomainError):
        s.evaluate_uv(np.array([[5.0, 5.0]]))
    out = s.evaluate_uv(np.array([[5.0, 5.0], [0.01, 0.01]]), strict=False)
    assert np.isnan(out[0]).all() and np.isfinite(out[1]).all()


def test_tessellate_and_continuity(poly_surface):
    s, func = poly_surface
    mesh = s.tessellate(5)
    np.testing.assert_allclose(mesh.vertices, func(mesh.uv), atol=1e-11)
    c = s.continuity()
    assert c["c0_relative"] < 1e-12 and c["c1_relative"] < 1e-9


# ------------------------------------------------------------------- files
@settings(max_examples=10, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(suffix=st.sampled_from([".npz", ".json"]), seed=st.integers(0, 100))
def test_round_trip(tmp_path, suffix, seed):
    uv, faces = domains.random_delaunay(15, seed=seed)
    ctrl = np.random.default_rng(seed).standard_normal((faces.shape[0], 21, 3))
    s = SplineSurface(uv, faces, ctrl, extras={"free": np.arange(6.0).reshape(2, 3), "note": "fit"})
    path = tmp_path / f"s{seed}{suffix}"
    s.save(path)
    t = SplineSurface.load(path)
    np.testing.assert_array_equal(t.uv, s.uv)  # JSON floats round-trip exactly (repr)
    np.testing.assert_array_equal(t.faces, s.faces)
    np.testing.assert_array_equal(t.ctrl, s.ctrl)
    np.testing.assert_array_equal(np.asarray(t.extras["free"]), s.extras["free"])
    assert t.extras["note"] == "fit"
    assert [p.name for p in tmp_path.iterdir() if p.name.startswith(".")] == []  # no temp files left


def test_npz_keys_are_the_documented_ones(tmp_path, poly_surface):
    s, _ = poly_surface
    s.save(tmp_path / "s.npz")
    with np.load(tmp_path / "s.npz", allow_pickle=False) as z:
        assert set(z.files) == {"format", "version", "degree", "uv", "faces", "control_points"}
        assert str(z["format"]) == "trispline.surface"
        assert int(z["version"]) == 1 and int(z["degree"]) == 5
        assert z["uv"].dtype == np.float64 and z["uv"].shape == (s.n_vertices, 2)
        assert z["faces"].dtype == np.int64 and z["faces"].shape == (s.n_faces, 3)
        assert z["control_points"].dtype == np.float64 and z["control_points"].shape == (s.n_faces, 21, 3)
    s.save(tmp_path / "s.json")
    d = json.loads((tmp_path / "s.json").read_text())
    assert set(d) == {"format", "version", "degree", "uv", "faces", "control_points"}
    assert d["format"] == FORMAT and d["version"] == 1 and d["degree"] == 5


def _base(tmp_path):
    uv, faces = domains.grid(2)
    ctrl = np.zeros((faces.shape[0], 21, 3))
    return dict(format=np.array(FORMAT), version=np.array(1), degree=np.array(5),
                uv=uv, faces=faces, control_points=ctrl)


@pytest.mark.parametrize(
    "change, message",
    [
        (dict(format=np.array("something.else")), "not a trispline surface"),
        (dict(version=np.array(2)), "unsupported surface file version 2"),
        (dict(degree=np.array(3)), "degree 3 is not supported"),
        (dict(format=None), "no 'format' key"),
        (dict(control_points=None), r"missing required keys \['control_points'\]"),
        (dict(uv=np.zeros((9, 3))), r"uv must have shape \(V, 2\)"),
        (dict(faces=np.zeros((8, 4), np.int64)), r"faces must have shape \(F, 3\)"),
        (dict(faces=np.full((8, 3), 0.5)), "faces must hold integers"),
        (dict(control_points=np.zeros((8, 20, 3))), r"control_points must have shape \(8, 21, 3\)"),
        (dict(uv=np.full((9, 2), np.nan)), "NaN or infinite uv"),
        (dict(control_points=np.full((8, 21, 3), np.inf)), "NaN or infinite control points"),
        (dict(faces=np.full((8, 3), 99, np.int64)), r"faces refer to ids outside \[0, 9\)"),
        (dict(faces="flip"), "counter-clockwise"),
    ],
)
@pytest.mark.parametrize("suffix", [".npz", ".json"])
def test_load_errors(tmp_path, change, message, suffix):
    data = _base(tmp_path)
    for k, v in change.items():
        if v is None:
            del data[k]
        elif isinstance(v, str) and v == "flip":
            data[k] = data[k][:, ::-1].copy()
        else:
            data[k] = v
    path = tmp_path / f"bad{suffix}"
    if suffix == ".npz":
        np.savez(path, **data)
    else:
        # NaN / Infinity tokens as other JSON writers emit them
        path.write_text(json.dumps({k: np.asarray(v).tolist() for k, v in data.items()}))
    with pytest.raises(SurfaceFileError, match=message):
        SplineSurface.load(path)


def test_unknown_keys_are_kept_not_fatal(tmp_path):
    data = _base(tmp_path)
    np.savez(tmp_path / "x.npz", **data, future_key=np.arange(4), another=np.array("hello"))
    s = SplineSurface.load(tmp_path / "x.npz")
    assert set(s.extras) == {"future_key", "another"}


def test_file_level_errors(tmp_path):
    with pytest.raises(SurfaceFileError, match="no such surface file"):
        SplineSurface.load(tmp_path / "missing.npz")
    with pytest.raises(SurfaceFileError, match="unknown surface file suffix"):
        SplineSurface.load(tmp_path / "s.obj")
    (tmp_path / "junk.npz").write_bytes(b"this is not a zip")
    with pytest.raises(SurfaceFileError, match="not an NPZ archive"):
        SplineSurface.load(tmp_path / "junk.npz")
    (tmp_path / "junk.json").write_text("{not json")
    with pytest.raises(SurfaceFileError, match="not a JSON file"):
        SplineSurface.load(tmp_path / "junk.json")
    (tmp_path / "list.json").write_text("[1, 2]")
    with pytest.raises(SurfaceFileError, match="top level must be an object"):
        SplineSurface.load(tmp_path / "list.json")
    assert issubclass(SurfaceFileError, InputError)


def test_failed_save_leaves_nothing(tmp_path, poly_surface, monkeypatch):
    s, _ = poly_surface
    target = tmp_path / "s.npz"
    s.save(target)
    before = target.read_bytes()

    def boom(*a, **k):
        raise OSError("disk full")

    monkeypatch.setattr(np, "savez", boom)
    with pytest.raises(OSError, match="disk full"):
        s.save(target)
    assert target.read_bytes() == before  # old file intact
    assert sorted(p.name for p in tmp_path.iterdir()) == ["s.npz"]  # no temp file
    with pytest.raises(SurfaceFileError, match="unknown surface file suffix"):
        s.save(tmp_path / "s.txt")
    with pytest.raises(SurfaceFileError, match="folder"):
        s.save(tmp_path / "nope" / "s.npz")
    with pytest.raises(SurfaceFileError, match="reserved keys"):
        write_surface(tmp_path / "r.json", s.uv, s.faces, s.ctrl, extras={"uv": 1})
    with pytest.raises(SurfaceFileError, match="JSON"):
        write_surface(tmp_path / "r.json", s.uv, s.faces, s.ctrl, extras={"bad": object()})
    assert not (tmp_path / "r.json").exists()
    assert os.listdir(tmp_path) == ["s.npz"]


@pytest.mark.parametrize("name", ["s.npz", "s.json"])
def test_save_writes_files_with_the_permissions_of_any_other_output(tmp_path, poly_surface, name):
    """Like the CLI's outputs: 0o666 minus the umask for a new file, the old mode for a replaced one."""
    s, _ = poly_surface
    target = tmp_path / name
    mask = os.umask(0o027)
    try:
        s.save(target)
        assert target.stat().st_mode & 0o777 == 0o666 & ~0o027
        target.chmod(0o604)
        s.save(target)
        assert target.stat().st_mode & 0o777 == 0o604
    finally:
        os.umask(mask)
    assert SplineSurface.load(target).ctrl.tobytes() == s.ctrl.tobytes()
    assert os.listdir(tmp_path) == [name]  # no temporary file left


def test_npz_members_are_stored_and_compressed_archives_still_read(tmp_path, poly_surface):
    """Saving stores the members (deflating float64 nets costs seconds for ~20%); older
    compressed files read back to the same surface, bit for bit."""
    import zipfile

    surface, _ = poly_surface
    out = tmp_path / "s.npz"
    surface.save(out)
    with zipfile.ZipFile(out) as z:
        assert {i.compress_type for i in z.infolist()} == {zipfile.ZIP_STORED}
    old = tmp_path / "old.npz"
    with np.load(out, allow_pickle=False) as a:
        np.savez_compressed(old, **{k: a[k] for k in a.files})
    back = SplineSurface.load(old)
    np.testing.assert_array_equal(back.ctrl, surface.ctrl)
    np.testing.assert_array_equal(back.uv, surface.uv)
    np.testing.assert_array_equal(back.faces, surface.faces)
