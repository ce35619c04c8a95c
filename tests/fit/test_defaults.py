"""The defaults a new user meets (issue 20): the view, the zebra stripe count, the curvature range,
the caption, the export size, and where the real meshes are found (the generated scan's own
tests are in test_export.py, next to the synthetic scan's).

Surfaces are built without a fit (exact nets of graphs, rotated rigidly), so no JAX is needed.
"""
from __future__ import annotations

import json
import os
import warnings

import numpy as np
import pytest
import trimesh
from PIL import Image

from trispline.fit import render as rd
from trispline.fit.cli import export as export_cli
from trispline.fit.cli import render as render_cli
from trispline.fit.cli.common import Parser, run_cli
from trispline.fit.datasets import cache
from trispline.fit.io import export as ex
from trispline.fit.io import sizes
from trispline.fit.io.export import LargeExportWarning
from trispline.fit.render.backends import pyvista_unusable
from trispline.spline.polynomial import polynomial_control_net
from trispline.spline.surface import SplineSurface
from trispline.spline.testing import random_c1_surface
from trispline.spline.testing.domains import grid

BACKENDS = (["pyvista"] if pyvista_unusable() is None else []) + ["matplotlib"]


def graph(func, n: int = 4, R: np.ndarray | None = None) -> SplineSurface:
    """The exact net of the graph ``(u, v, func(u, v))`` over ``grid(n)`` centred at 0, rotated by ``R``."""
    uv, faces = grid(n)
    uv = uv - 0.5
    R = np.eye(3) if R is None else R
    ctrl = polynomial_control_net(uv, faces, lambda p: np.column_stack([p[:, 0], p[:, 1], func(p[:, 0], p[:, 1])]))
    return SplineSurface(uv, faces, ctrl @ R.T)


def bump(u, v):
    return 0.25 * (u * u + 0.6 * v * v) - 0.1 * u * v


#: Rigid rotations turning the graph's normal (+z) away from the old default (iso) camera.
UPSIDE_DOWN = np.diag([1.0, -1.0, -1.0])                           # 180 degrees about x: normal -z
FACING_MINUS_X = np.array([[0.0, 0, -1], [0, 1, 0], [1, 0, 0]])     # about y: normal +z -> -x


def front_and_back(img: np.ndarray) -> tuple[float, float]:
    """Fractions of the drawn (not white) pixels between the title and the legend that are the
    front's blue and the back's tan."""
    h = img.shape[0]
    c = img[int(0.15 * h):int(0.8 * h)].reshape(-1, 3).astype(float)
    drawn = c.min(1) < 235
    r, b = c[drawn, 0], c[drawn, 2]
    return float((b > r + 20).mean()), float((r > b + 20).mean())


# ============================================================================ the view
@pytest.mark.parametrize("backend", BACKENDS)
@pytest.mark.parametrize("R", [UPSIDE_DOWN, FACING_MINUS_X], ids=["upside-down", "facing-minus-x"])
def test_default_view_shows_the_front_of_a_surface_facing_away(backend, R):
    s = graph(bump, R=R)
    iso = rd.parse_view("iso")
    ref = rd.reference_sample(s, curvature=False)
    normal = rd.mean_normal(ref.points, ref.triangles)
    assert normal @ iso.toward < -0.4  # the old default camera is behind the surface
    opts = dict(size=(320, 240), patch_lines=False, backend=backend, caption=False)
    auto = rd.draw(s, "shaded", **opts)
    old = rd.draw(s, "shaded", view="iso", **opts)
    front, back = front_and_back(auto.image)
    assert front > 0.95 and back < 0.01, (front, back)  # the front, blue
    front, back = front_and_back(old.image)
    assert back > 0.95 and front < 0.01, (front, back)  # negative control: iso sees the tan back
    v = auto.stats["view"]
    assert v["auto"] and not old.stats["view"]["auto"]
    np.testing.assert_allclose(rd.View(v["azimuth"], v["elevation"], v["roll"]).toward, normal, atol=1e-12)


def test_default_view_of_zebra_and_curvature_faces_the_front_too():
    s = graph(bump, R=UPSIDE_DOWN)
    for mode in ("zebra", "curvature"):
        pic = rd.draw(s, mode, size=(200, 150), backend="matplotlib", caption=False)
        v = pic.stats["view"]
        assert v["auto"] and rd.View(v["azimuth"], v["elevation"], v["roll"]).toward[2] < -0.99


@pytest.mark.parametrize("sweep, wraps", [(360.0, True), (320.0, True), (240.0, False), (90.0, False)])
def test_a_surface_that_wraps_around_is_seen_from_the_iso_view(sweep, wraps):
    # a tube (or most of one) has no mean normal to look along: end-on it was a circle
    a, h = np.meshgrid(np.radians(np.linspace(0.0, sweep, 41)), np.linspace(0.0, 1.0, 5))
    V = np.column_stack([np.cos(a.ravel()), np.sin(a.ravel()), h.ravel()])
    i, j = np.meshgrid(np.arange(4), np.arange(40), indexing="ij")
    p, q = (i * 41 + j).ravel(), (i * 41 + j + 1).ravel()
    F = np.concatenate([np.column_stack([p, q, q + 41]), np.column_stack([p, q + 41, p + 41])])
    assert (rd.facing_view(V, F) == rd.parse_view("iso")) is wraps


def test_facing_view_keeps_z_or_y_up_and_turns_with_the_mesh():
    V = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0]])
    F = np.array([[0, 1, 2]])
    assert rd.facing_view(V, F) == rd.parse_view("top")  # a height field: exactly the top view
    assert rd.facing_view(V, F[:, ::-1]).toward @ [0, 0, -1] == pytest.approx(1.0)
    assert rd.facing_view(np.zeros((3, 3)), F) == rd.parse_view("iso")  # no area: iso
    rng = np.random.default_rng(0)
    for _ in range(20):
        Q = np.linalg.qr(rng.normal(size=(3, 3)))[0]
        Q *= np.sign(np.linalg.det(Q))
        v = rd.facing_view(V @ Q.T, F)
        n = Q @ [0, 0, 1.0]
        np.testing.assert_allclose(v.toward, n, atol=1e-12)  # along the normal, on its side
        np.testing.assert_allclose([v.up @ v.toward, v.right @ v.toward, v.up @ v.right], 0, atol=1e-12)
        np.testing.assert_allclose(np.cross(v.up, v.toward), v.right, atol=1e-12)  # right-handed, as before
        steep = abs(n[2]) > np.cos(np.radians(rd.view.STEEP_DEGREES))
        ref = np.array([0, 1.0, 0]) if steep else np.array([0, 0, 1.0])
        want = ref - (ref @ n) * n
        np.testing.assert_allclose(v.up, want / np.linalg.norm(want), atol=1e-9)  # world z (or y) up on screen


def test_auto_view_is_shared_by_panels_and_a_panel_may_name_its_own():
    s = graph(bump, R=FACING_MINUS_X)
    pic = rd.draw_panels([rd.Panel(s, "shaded"), rd.Panel(graph(bump), "shaded"),
                          rd.Panel(s, "shaded", options=dict(view="top"))], size=(600, 200),
                         backend="matplotlib", caption=False)
    views = [p["view"] for p in pic.stats["panels"]]
    assert views[0] == views[1] and views[0]["auto"] and views[1]["auto"]
    assert views[2] == dict(azimuth=-90.0, elevation=90.0, roll=0.0, auto=False)
    assert rd.check_view(" Auto ") == rd.AUTO and rd.check_view("iso") == rd.parse_view("iso")
    with pytest.raises(rd.RenderError, match="unknown view 'automatic': use auto, one of iso"):
        rd.check_view("automatic")
    with pytest.raises(rd.RenderError, match="resolve_view"):
        rd.parse_view("auto")
    assert rd.resolve_view("auto", *graph(lambda u, v: 0 * u).tessellate(1)[:2]) == rd.parse_view("top")


# ============================================================================ zebra stripes
def test_auto_stripes_keep_twelve_where_they_are_wide_and_the_same_picture():
    s = graph(bump)
    opts = dict(view="top", size=(400, 300), patch_lines=False, backend="matplotlib", caption=False)
    auto = rd.draw(s, "zebra", **opts)
    assert auto.stats["stripes"] == rd.zebra.MAX_STRIPES and auto.stats["stripes_auto"]
    assert auto.stats["stripe_pixels"] >= rd.zebra.MIN_STRIPE_PIXELS
    set12 = rd.draw(s, "zebra", stripes=12, **opts)
    above_legend = slice(0, int(0.8 * 300))  # the legend says "automatic" or "set"
    np.testing.assert_array_equal(auto.image[above_legend], set12.image[above_legend])  # the old default's stripes
    assert not set12.stats["stripes_auto"] and set12.stats["stripe_pixels"] == auto.stats["stripe_pixels"]


def test_stripe_pixels_measure_the_picture():
    """On a plane seen from the top with horizontal tubes, a stripe pair's width in the picture
    is the width stripe_pixels predicts."""
    s = graph(lambda u, v: 0 * u, n=3)
    pic = rd.draw(s, "zebra", view="top", size=(360, 360), stripe_angle=0.0, stripes=6, patch_lines=False,
                  backend="pyvista" if "pyvista" in BACKENDS else "matplotlib", caption=False)
    col = pic.image[int(0.3 * 360):int(0.7 * 360), 180].astype(float).mean(-1) < 128
    runs = np.diff(np.flatnonzero(np.diff(col.astype(np.int8))))
    assert runs.size >= 2
    np.testing.assert_allclose(2 * np.median(runs), pic.stats["stripe_pixels"], rtol=0.08)


def rough_surface() -> SplineSurface:
    """Exactly C1 with a bumpy normal field: many patches, large free-point wiggle."""
    return random_c1_surface(800, holes=0, seed=2, wiggle=1e-3, graph=(0.2, -0.1, 0.05))


def test_auto_stripes_follow_the_rendered_size_and_never_go_narrow():
    s = rough_surface()
    counts, widths = [], []
    for size in ((200, 150), (400, 300), (1600, 1200)):
        pic = rd.draw(s, "zebra", size=size, patch_lines=False, backend="matplotlib", caption=False, resolution=2)
        counts.append(pic.stats["stripes"])
        widths.append(pic.stats["stripe_pixels"])
    assert counts == sorted(counts) and counts[0] < counts[-1], counts  # more pixels, more stripes
    for c, w in zip(counts, widths):
        assert w >= rd.zebra.MIN_STRIPE_PIXELS or c == rd.zebra.MIN_STRIPES, (c, w)
    # and the legend says what was chosen
    pic = rd.draw(s, "zebra", size=(200, 150), patch_lines=False, backend="matplotlib", caption=False, resolution=2)
    assert f"{pic.stats['stripes']:g} stripe pairs per diagonal (automatic)" in " ".join(pic.legend)


def _downsample(img: np.ndarray, k: int) -> np.ndarray:
    h, w = img.shape[:2]
    return img.reshape(h // k, k, w // k, k, 3).astype(float).mean((1, 3))


@pytest.mark.skipif("pyvista" not in BACKENDS, reason="needs pyvista (stripe textures)")
def test_auto_stripes_alias_less_than_twelve():
    """Aliasing measured: a picture against the same picture drawn 4x larger and box-filtered down
    (the grey that stripes finer than a pixel should blend to). The automatic count aliases far less."""
    s = rough_surface()
    errs = {}
    for stripes in (None, 12):
        opts = dict(patch_lines=False, backend="pyvista", caption=False, title="", resolution=3, stripes=stripes)
        small = rd.draw(s, "zebra", size=(320, 240), **opts)
        view = rd.View(**{k: small.stats["view"][k] for k in ("azimuth", "elevation", "roll")})
        big = rd.draw(s, "zebra", size=(1280, 960), view=view, **dict(opts, stripes=small.stats["stripes"]))
        drawn = small.image.min(-1) < 250
        drawn[int(0.8 * 240):] = False  # leave the legend out
        errs[stripes] = float(np.abs(small.image.mean(-1) - _downsample(big.image, 4).mean(-1))[drawn].mean())
    assert errs[None] < 0.6 * errs[12], errs


# ============================================================================ curvature range
def test_curvature_colour_range_does_not_change_with_resolution():
    s = rough_surface()
    stats = [rd.draw(s, "curvature", resolution=r, size=(200, 150), backend="matplotlib", caption=False).stats
             for r in (1, 2, 4)]
    for st in stats[1:]:
        np.testing.assert_allclose(st["clim"], stats[0]["clim"], rtol=1e-2)  # exactly equal, in fact
        assert (st["min"], st["max"]) == (stats[0]["min"], stats[0]["max"])
    assert stats[0]["unit"] == "1/model unit" and stats[0]["percentile"] == rd.scene.CURVATURE_PERCENTILE
    # the samples drawn did change: 1, 2 and 4 steps per edge
    assert len({st["samples"] for st in stats}) == 3
    pic = rd.draw(s, "curvature", curvature="gaussian", size=(200, 150), backend="matplotlib", caption=False)
    assert pic.stats["unit"] == "1/model unit^2"
    assert "98th percentile of abs(K)" in " ".join(pic.legend) and "1/model unit^2" in pic.legend[0]


def test_reference_sample_is_fixed_and_spread():
    s = rough_surface()
    ref = rd.reference_sample(s)
    assert ref.resolution == rd.sampling.REFERENCE_RESOLUTION
    np.testing.assert_array_equal(np.unique(ref.face_idx), np.arange(s.n_faces))
    sub = rd.sample_surface(s, 2, faces=np.array([5, 1]))
    full = rd.sample_surface(s, 2)
    np.testing.assert_array_equal(sub.face_idx[:6], 5)
    np.testing.assert_array_equal(sub.points[:6], full.points[30:36])
    np.testing.assert_array_equal(sub.mean_curvature[6:], full.mean_curvature[6:12])


# ============================================================================ caption
def test_caption_date_file_and_version(monkeypatch):
    monkeypatch.setenv("SOURCE_DATE_EPOCH", "1700000000")
    assert rd.caption.picture_date() == "2023-11-14"
    text = rd.caption_text("some/folder/scan.npz")
    assert text == f"2023-11-14, scan.npz, trispline {rd.caption.package_version()}"
    assert rd.caption_text() == f"2023-11-14, trispline {rd.caption.package_version()}"
    monkeypatch.delenv("SOURCE_DATE_EPOCH")
    assert len(rd.caption.picture_date()) == 10


@pytest.mark.parametrize("backend", BACKENDS)
def test_caption_sits_in_the_bottom_right_corner(backend):
    s = graph(bump)
    opts = dict(size=(400, 300), backend=backend, patch_lines=False)
    plain = rd.draw(s, "shaded", caption=False, **opts).image
    marked = rd.draw(s, "shaded", caption="2025-01-01, s.npz, trispline 9", **opts).image
    diff = np.abs(plain.astype(int) - marked.astype(int)).sum(-1) > 0
    ys, xs = np.nonzero(diff)
    # the caption's pixels are in the bottom right corner; the legend moved up a row (bottom left)
    corner = (ys > 0.9 * 300) & (xs > 0.5 * 400)
    assert corner.sum() > 50 and xs[corner].max() > 0.95 * 400  # right-aligned at the edge
    assert (ys[~corner] > 0.75 * 300).all()  # nothing else moved but the legend


def test_cli_caption_names_the_surface_file(tmp_path, capsys):
    s = graph(bump)
    path = tmp_path / "bump.npz"
    s.save(path)
    out = tmp_path / "b.png"
    assert render_cli.main(["render", str(path), "-o", str(out), "--size", "200x150", "--json",
                            "--backend", "matplotlib"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["caption"].endswith(f"bump.npz, trispline {rd.caption.package_version()}")
    assert data["view_auto"] is True and data["stats"]["view"]["auto"] is True
    assert render_cli.main(["render", str(path), "-o", str(out), "--size", "200x150", "--json",
                            "--backend", "matplotlib", "--caption", "", "--mode", "zebra", "--view", "iso"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["caption"] == "" and data["view_auto"] is False and data["stats"]["stripes_auto"] is True


# ============================================================================ help
def _render_parser():
    parser = Parser(prog="trispline")
    sub = parser.add_subparsers(dest="command", parser_class=Parser)
    return render_cli.add_parser(sub), sub


def test_render_and_export_help_say_every_default():
    p, sub = _render_parser()
    export_cli.add_parser(sub)
    for name in ("render", "export"):
        for action in sub.choices[name]._actions:  # noqa: SLF001
            if action.help is None or action.dest in ("help", "json", "quiet", "debug", "surface"):
                continue
            text = action.help.lower()
            assert "default" in text or "required" in text, (name, action.dest, action.help)
    text = p.format_help()
    for word in ("auto", "mean normal", "stripe pairs", "1/model unit", "--caption", "pip install"):
        assert word in " ".join(text.split()), word


# ============================================================================ export size
def test_export_resolution_follows_the_patch_count():
    assert sizes.export_resolution(100) == 8 and sizes.export_resolution(23_000) == 8
    assert sizes.export_resolution(63_000) == 4  # 1M triangles, not 437 MB of OBJ
    assert sizes.export_resolution(2_000_000) == 1
    for n in (10, 1000, 50_000, 400_000):
        r = sizes.export_resolution(n)
        assert r == 8 or n * r * r <= sizes.EXPORT_TRIANGLES < n * (r + 1) ** 2


@pytest.mark.parametrize("suffix", [".obj", ".ply", ".stl", ".glb", ".off"])
def test_estimated_export_size_is_within_five_percent(tmp_path, suffix):
    s = random_c1_surface(300, seed=3)
    for r in (1, 4):
        out = ex.export_surface(s, tmp_path / f"s{suffix}", resolution=r)
        est = sizes.estimate_export_bytes(s, out, r)
        assert abs(est / out.stat().st_size - 1) < 0.05, (r, est, out.stat().st_size)
    assert sizes.estimate_export_bytes(s, tmp_path / "s.npz") is None
    assert sizes.estimate_export_bytes(s, tmp_path / "s.ply") == sizes.estimate_export_bytes(
        s, tmp_path / "s.ply", sizes.export_resolution(s.n_faces))


def test_large_export_warns_before_writing(tmp_path, monkeypatch):
    s = random_c1_surface(60, seed=1)
    monkeypatch.setattr(ex, "LARGE_EXPORT_BYTES", 1000)
    with pytest.warns(LargeExportWarning, match=r"s\.obj will be about .* MB .* resolution 8"):
        ex.export_surface(s, tmp_path / "s.obj")
    monkeypatch.setattr(ex, "LARGE_EXPORT_BYTES", 10**12)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        ex.export_surface(s, tmp_path / "s.obj")


def test_cli_export_reports_size_and_warns(tmp_path, capsys, monkeypatch):
    s = random_c1_surface(60, seed=1)
    path = tmp_path / "s.npz"
    s.save(path)
    out = tmp_path / "s.ply"

    def cli(*argv: str) -> int:
        def make():
            parser = Parser(prog="trispline")
            export_cli.add_parser(parser.add_subparsers(dest="command", parser_class=Parser))
            return parser

        return run_cli(make, ["export", str(path), "-o", str(out), "--json", *argv])

    assert cli() == 0
    data = json.loads(capsys.readouterr().out)
    assert data["resolution"] == sizes.export_resolution(s.n_faces) and data["resolution_auto"]
    assert data["estimated_bytes"] == sizes.estimate_export_bytes(s, out) and data["warnings"] == []
    assert abs(data["estimated_bytes"] / out.stat().st_size - 1) < 0.05
    assert cli("--resolution", "2") == 0  # an explicit resolution is honoured
    data = json.loads(capsys.readouterr().out)
    assert data["resolution"] == 2 and not data["resolution_auto"]
    assert trimesh.load(out, process=False).faces.shape[0] == 4 * s.n_faces == data["mesh_triangles"]
    monkeypatch.setattr(ex, "LARGE_EXPORT_BYTES", 1000)
    assert cli() == 0
    captured = capsys.readouterr()
    data = json.loads(captured.out)
    assert len(data["warnings"]) == 1 and "will be about" in data["warnings"][0]
    assert "warning: s.ply will be about" in captured.err


# ============================================================================ data
def test_data_cache_copies_and_finds(tmp_path, monkeypatch, capsys):
    src, dest = tmp_path / "shared", tmp_path / "cache"
    src.mkdir()
    (src / "a.obj").write_text("v 0 0 0\n")
    (src / "b.OFF").write_text("OFF\n")
    (src / "README.md").write_text("sources\n")
    (src / "notes.txt").write_text("not copied\n")
    monkeypatch.setenv("TRISPLINE_DATA", str(dest))
    monkeypatch.setenv("TRISPLINE_SHARED_DATA", str(tmp_path / "none"))
    assert cache.find_data("a.obj") is None
    assert cache.main([str(src)]) == 0
    assert "3 files in" in capsys.readouterr().out
    assert sorted(p.name for p in dest.iterdir()) == ["README.md", "a.obj", "b.OFF"]
    assert cache.find_data("a.obj") == dest / "a.obj" and cache.cache_folder() == dest
    # the checkout's shared folder comes first; copying again keeps the files
    monkeypatch.setenv("TRISPLINE_SHARED_DATA", str(src))
    assert cache.find_data("a.obj") == src / "a.obj"
    mtime = os.stat(dest / "a.obj").st_mtime_ns
    assert [p.name for p in cache.copy_shared(src, dest)] == ["README.md", "a.obj", "b.OFF"]
    assert os.stat(dest / "a.obj").st_mtime_ns == mtime
    assert cache.main([str(tmp_path / "missing")]) == 2
    assert "no data folder" in capsys.readouterr().err
    monkeypatch.delenv("TRISPLINE_DATA")
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert cache.cache_folder() == tmp_path / "xdg" / "trispline" / "data"
    assert "python -m trispline.fit.datasets.cache" in cache.MISSING_DATA


def test_picture_of_the_generated_scan_faces_its_front(real_mesh, tmp_path):
    """The generated scan seen by default: its front, blue, although it faces -y."""
    V, F = real_mesh
    out = rd.render_panels([rd.Panel(mesh=(V, F))], tmp_path / "scan.png", size=(300, 200), backend="matplotlib",
                           caption=False)
    with Image.open(out) as im:
        assert im.size == (300, 200)
    v = rd.draw_panels([rd.Panel(mesh=(V, F))], size=(100, 80), backend="matplotlib").stats["panels"][0]["view"]
    assert rd.View(v["azimuth"], v["elevation"], v["roll"]).toward @ rd.mean_normal(V, F) == pytest.approx(1.0)


def test_panels_side_by_side_share_the_automatic_stripe_count():
    smooth, rough = graph(bump), rough_surface()
    opts = dict(size=(800, 300), backend="matplotlib", caption=False, view="top")
    alone = [rd.draw(x, "zebra", size=(266, 300), backend="matplotlib", caption=False, view="top").stats["stripes"]
             for x in (rough, smooth)]
    assert alone[0] < alone[1]  # each on its own would differ
    pic = rd.draw_panels([rd.Panel(rough, "zebra"), rd.Panel(smooth, "zebra"),
                          rd.Panel(smooth, "zebra", options=dict(stripes=5))], **opts)
    stats = pic.stats["panels"]
    assert stats[0]["stripes"] == stats[1]["stripes"] == alone[0] and stats[1]["stripes_auto"]
    assert stats[2]["stripes"] == 5 and not stats[2]["stripes_auto"]
