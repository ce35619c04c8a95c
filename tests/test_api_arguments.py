"""Bad arguments to the Python API end in trispline's own exception naming the argument, never in a numpy, scipy,
JAX or equinox error from deep inside, nor in a silently wrong result (found by fuzzing the API)."""
from __future__ import annotations

import numpy as np
import pytest

from trispline.fit import FitWeights, fit_surface
from trispline.fit.approx import approximate_surface
from trispline.fit.io import export_mesh, export_surface
from trispline.param import validate_mesh
from trispline.param.distortion import warning
from trispline.param.inspect import inspect_mesh
from trispline.param.testing import bumpy_disk
from trispline.spline.checks import check_ids
from trispline.spline.errors import InputError
from trispline.spline.testing import random_c1_surface


@pytest.fixture(scope="module")
def disk() -> tuple[np.ndarray, np.ndarray]:
    return bumpy_disk(120)


@pytest.fixture(scope="module")
def surface():
    return random_c1_surface(30, holes=0, seed=1)


@pytest.mark.parametrize("kw, match", [
    (dict(bend="1"), "weight bend must be a real number, got '1'"),
    (dict(tilt=None), "weight tilt must be a real number"),
    (dict(local=1j), "weight local must be a real number"),
    (dict(data=np.array([1.0, 2.0])), "weight data must be a real number"),
    (dict(angle=-1.0), "weight angle must be finite and >= 0, got -1.0"),
    (dict(blend_power=-1), "blend_power must be finite and >= 0"),
    (dict(blend_power=float("nan")), "blend_power must be finite"),
    (dict(blend_power=17), r"blend_power must be in \[0, 16\]"),
    (dict(fit_degree=2.5), r"fit_degree must be an integer in \[2, 3\], got 2.5"),
    (dict(fit_degree=4), r"fit_degree must be an integer in \[2, 3\]"),
    (dict(fit_rings=True), "fit_rings must be an integer"),
])
def test_fit_weights_name_the_bad_value(kw, match):
    with pytest.raises(InputError, match=match):
        FitWeights(**kw)


def test_fit_weights_keep_their_values():
    w = FitWeights(bend=2, fit_rings=2.0)
    assert w.bend == 2.0 and isinstance(w.bend, float) and w.fit_rings == 2 and isinstance(w.fit_rings, int)
    assert FitWeights(bend=2) == FitWeights(bend=2.0)


@pytest.mark.parametrize("kw, match", [
    (dict(max_steps=0), r"max_steps must be an integer in \[1, 1000000\]"),
    (dict(max_steps=1.5), "max_steps must be an integer"),
    (dict(max_steps="5"), "max_steps must be an integer"),
    (dict(max_steps=True), "max_steps must be an integer"),
    (dict(max_steps=10**20), "max_steps must be an integer"),
    (dict(progress=5), "progress must be a function or None"),
    (dict(solver="lm"), "solver must be an optimistix least-squares solver"),
    (dict(throw="no"), "throw must be True or False"),
])
def test_fit_surface_options(disk, kw, match):
    with pytest.raises(InputError, match=match):
        fit_surface(*disk, **kw)


@pytest.mark.parametrize("bad, match", [(lambda n: n, r"outside \[0, (\d+)\): \1"), (lambda n: -1, "outside")])
def test_approximate_surface_checks_face_ids(disk, bad, match):
    V, F = disk
    F2 = np.concatenate([F, [[0, 1, bad(len(V))]]])
    with pytest.raises(InputError, match=match):
        approximate_surface(V, F2, tolerance_rel=1e-2)


@pytest.mark.parametrize("kw, match", [
    (dict(tolerance="0.1"), "tolerance must be a real number"),
    (dict(tolerance=np.array([0.1])), "tolerance must be a real number"),
    (dict(tolerance_rel=1e-3 + 0j), "tolerance_rel must be a real number"),
    (dict(tolerance_rel=1e-3, max_rounds=0), "max_rounds must be an integer >= 1"),
    (dict(tolerance_rel=1e-3, max_rounds=None), "max_rounds must be an integer"),
    (dict(tolerance_rel=1e-3, fill_holes=None), "fill_holes must be an integer >= 0, got None"),
    (dict(tolerance_rel=1e-3, outline_tolerance="no"), "outline_tolerance must be True or False"),
    (dict(tolerance_rel=1e-3, progress=5), "progress must be a function or None"),
    (dict(n_vertices=2.5), "n_vertices must be an integer"),
])
def test_approximate_surface_options(disk, kw, match):
    with pytest.raises(InputError, match=match):
        approximate_surface(*disk, **kw)


def test_barycentric_coordinates_must_sum_to_one(surface, disk):
    """A quintic's Bernstein basis is homogeneous: coordinates summing to 1.5 gave points 1.5^5 too far out."""
    face = np.arange(3)
    with pytest.raises(InputError, match="bary rows must sum to 1.*row 0 sums to 1.5"):
        surface.evaluate(face, np.full((3, 3), 0.5))
    with pytest.raises(InputError, match="bary rows must sum to 1"):
        surface.evaluate_derivatives(face, np.array([[0.2, 0.2, 0.2]] * 3))
    outside = np.array([[-0.25, 0.75, 0.5]] * 3)  # outside the triangle, summing to 1: an extrapolation, allowed
    assert np.isfinite(surface.evaluate(face, outside)).all()
    V, F = disk
    with pytest.raises(InputError, match="data_points bary rows must sum to 1"):
        fit_surface(V, F, data_points=(np.zeros(1, int), np.array([[0.5, 0.5, 0.5]]), V[:1]))


def test_surface_method_arguments(surface):
    for call, match in ((lambda: surface.tessellate(None), "resolution must be an integer"),
                        (lambda: surface.tessellate(2.5), "resolution must be an integer"),
                        (lambda: surface.continuity(2.5), "n_samples must be an integer"),
                        (lambda: surface.continuity("7"), "n_samples must be an integer"),
                        (lambda: surface.evaluate_derivatives(np.arange(1), np.full((1, 3), 1 / 3), second="no"),
                         "second must be True or False")):
        with pytest.raises(InputError, match=match):
            call()


def test_export_mesh_checks_what_it_writes(tmp_path, disk):
    """It wrote face ids past the vertices, negative ids (as ``f 1 2 0``), NaN vertices and quads, with success."""
    V, F = disk
    cases = {
        "id past the vertices": (V, np.concatenate([F, [[0, 1, len(V)]]]), None, "F refer to ids outside"),
        "negative id": (V, np.concatenate([F, [[0, 1, -1]]]), None, "F refer to ids outside"),
        "NaN vertex": (np.where(np.arange(len(V))[:, None] == 3, np.nan, V), F, None, "V has non-finite entries"),
        "float faces": (V, F + 0.5, None, "F must hold integers"),
        "quads": (V, np.column_stack([F, F[:, :1]]), None, "F must have shape"),
        "no vertices": (np.zeros((0, 3)), F, None, "F refer to ids outside"),
        "normals of the wrong shape": (V, F, np.ones((3, 3)), "normals must have shape"),
    }
    for name, (V_, F_, normals, match) in cases.items():
        for suffix in (".obj", ".stl"):
            with pytest.raises(InputError, match=match):
                export_mesh(V_, F_, tmp_path / f"m{suffix}", normals=normals)
    assert list(tmp_path.iterdir()) == []
    export_mesh(V, F, tmp_path / "m.obj")
    assert (tmp_path / "m.obj").stat().st_size > 0


def test_export_surface_arguments(tmp_path, surface):
    for call, match in ((lambda: export_surface(surface, tmp_path / "a.obj", resolution=float("nan")), "resolution"),
                        (lambda: export_surface(surface, tmp_path / "a.obj", resolution=2.5), "resolution"),
                        (lambda: export_surface("surface.npz", tmp_path / "a.obj"), "surface must be a SplineSurface"),
                        (lambda: export_surface(surface, 5), "output path must be a str or os.PathLike"),
                        (lambda: export_surface(surface, tmp_path / "a.png", bogus_opt=3), "unknown picture option bogus_opt"),
                        (lambda: export_surface(surface, tmp_path / "a.step", merge="yes"), "merge must be True or False")):
        with pytest.raises(InputError, match=match):
            call()
    assert list(tmp_path.iterdir()) == []


def test_out_of_range_ids_name_the_ids_not_only_their_rows():
    with pytest.raises(InputError, match=r"F refer to ids outside \[0, 50\): 50, -1, 99 \(rows 0, 2\)"):
        check_ids(np.array([[0, 1, 50], [0, 1, 2], [7, -1, 99]]), "F", 50)
    V = np.random.default_rng(0).random((10, 3))
    with pytest.raises(InputError, match=r"faces with vertex ids outside \[0, 10\): 2 \(first: 1, 2\); the ids 12, -1"):
        validate_mesh(V, np.array([[0, 1, 2], [2, 3, 12], [0, -1, 4]]))


def test_no_advice_to_use_the_map_that_was_already_used():
    """halftunnel: "repaired with a slim map", then "try --param auto or --param slim"."""
    summary = dict(angle_max=20.0, angle_p99=12.0, area_p99=2.0, area_max=3.0)
    assert "--param slim" in warning(summary, 1, "lscm")
    assert "--param slim" not in warning(summary, 1, "lscm", "slim")


def test_genus_is_a_whole_number(disk):
    assert inspect_mesh(*disk)["genus"] == 0 and isinstance(inspect_mesh(*disk)["genus"], int)


# ----------------------------------------------------------------- the local editor (fuzz round 3)
@pytest.fixture()
def editor():
    from trispline.spline.edit import SplineEditor

    return SplineEditor.from_surface(random_c1_surface(40, holes=1, seed=0))


@pytest.mark.parametrize("call, match", [
    (lambda ed: ed.inner_point(1.5, 0), "face must be an integer"),
    (lambda ed: ed.inner_point(0, 1.7), "local index must be an integer"),
    (lambda ed: ed.flip_point(0, float("nan")), "local index must be an integer"),
    (lambda ed: ed.mid_point(1.5, 0), "edge must be an integer"),
    (lambda ed: ed.mid_point(0, 0.5), "end must be an integer"),
    (lambda ed: ed.point_free_id(1.5), "control point id must be an integer"),
    (lambda ed: ed.point_free_id("x"), "control point id must be an integer"),
    (lambda ed: ed.describe_point(-1), "control point id must be an integer"),
    (lambda ed: ed.move_vertex("3", [0.0, 0.0, 0.0]), "vertex must be an integer"),
    (lambda ed: ed.move_vertex(float("nan"), [0.0, 0.0, 0.0]), "vertex must be an integer"),
    (lambda ed: ed.move_vertex(None, [0.0, 0.0, 0.0]), "vertex must be an integer"),
    (lambda ed: ed.move_vertex(3, [1.0, 2.0]), "xyz must have shape"),
    (lambda ed: ed.move_vertex(3, "abc"), "xyz must be real numbers"),
    (lambda ed: ed.translate(3, [1.0, 2.0]), "delta must have shape"),
    (lambda ed: ed.translate(3, "abc"), "delta must be real numbers"),
    (lambda ed: ed.move(3, [1e300, 0.0, 0.0]), "overflow double precision"),
    (lambda ed: ed.move_vertex(3, [1e308] * 3), "overflow double precision"),
    (lambda ed: ed.patch_ctrl([-1]), "faces refer to ids outside"),
    (lambda ed: ed.patch_ctrl([1.5]), "faces must hold integers"),
])
def test_editor_ids_and_positions(editor, call, match):
    """Non-integer ids were truncated (inner_point(1.5, 0) was face 1's), huge positions left the net inf/NaN,
    wrong shapes and strings ended in numpy's errors."""
    before = editor.free.copy()
    with pytest.raises(InputError, match=match):
        call(editor)
    np.testing.assert_array_equal(editor.free, before)  # a refused edit changes nothing


@pytest.mark.parametrize("rtol, match", [(float("nan"), "rtol must be finite"), (-1.0, "rtol must be finite and > 0"),
                                        ("1e-9", "rtol must be a real number")])
def test_editor_from_surface_tolerance(rtol, match):
    """rtol=nan accepted any net (err > nan is false) and replaced it by its projection without a word."""
    from trispline.spline.edit import SplineEditor

    with pytest.raises(InputError, match=match):
        SplineEditor.from_surface(random_c1_surface(40, holes=1, seed=0), rtol=rtol)
    with pytest.raises(InputError, match="surface must be a SplineSurface"):
        SplineEditor.from_surface("x.npz")


def test_refair_rings_are_checked_and_a_failed_move_is_undone():
    import jax

    jax.config.update("jax_enable_x64", True)
    from trispline.fit.refair import LocalRefairer

    result = fit_surface(*bumpy_disk(300))
    rf = LocalRefairer.from_fit(result, rings=2)
    for rings in (float("nan"), "2", True, 0):
        with pytest.raises(InputError, match="rings must be an integer"):
            rf.move_vertex(5, rf.V[5], rings=rings)
    faces, _ = rf.region(5, rings=10**9)  # grows until it covers the mesh, then stops (was a loop of 10^9 rings)
    assert faces.size == len(result.faces)
    V0, free0 = rf.V.copy(), rf.editor.free.copy()
    with pytest.raises(InputError):
        rf.move_vertex(5, [1e300, 0.0, 0.0])
    np.testing.assert_array_equal(rf.V, V0)
    np.testing.assert_array_equal(rf.editor.free, free0)
