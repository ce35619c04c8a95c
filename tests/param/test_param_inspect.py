"""inspect_mesh (counts on valid and broken meshes, the validation verdict), harmonic_uv,
closest_points and the default parameterization method."""
from __future__ import annotations

import numpy as np
import pytest

from trispline.param import (
    DEFAULT_METHOD, MeshError, closest_points, harmonic_uv, inspect_mesh, parameterize, validate_mesh,
)
from trispline.param.testing import lift
from trispline.spline.errors import InputError
from trispline.spline.testing.domains import random_delaunay

from test_param_validate import disk, grid_torus, moebius, tetrahedron


def test_valid_mesh_agrees_with_validate_mesh():
    V, F = lift(*random_delaunay(200, holes=2, seed=1))
    rep = inspect_mesh(V, F)
    vm = validate_mesh(V, F)
    for key in ("vertices", "faces", "edges", "boundary_loops", "holes", "genus", "euler_characteristic",
                "components"):
        assert rep[key] == vm.report[key], key
    assert rep["manifold"] and not rep["closed"] and rep["bowtie_vertices"] == 0
    assert rep["boundary_edges"] == sum(len(loop) for loop in vm.boundary_loops)
    assert rep["degenerate_faces"] == {"repeated_vertex": 0, "zero_area": 0} and rep["non_finite_vertices"] == 0
    np.testing.assert_array_equal(rep["bounds"], [V.min(0), V.max(0)])
    assert rep["validation"] == dict(accepted=True, problems=[], message="", repairs=[])
    assert list(rep)[-1] == "validation"


def test_closed_and_torus():
    rep = inspect_mesh(*tetrahedron())
    assert rep["closed"] and rep["boundary_loops"] == 0 and rep["genus"] == 0 and rep["manifold"]
    assert rep["validation"]["problems"] == ["closed"] and "closed" in rep["validation"]["message"]
    V, F = grid_torus()
    rep = inspect_mesh(V, F[1:])  # one face removed: genus 1 with one boundary loop
    assert rep["boundary_loops"] == 1 and rep["genus"] == 1 and rep["validation"]["problems"] == ["not_disk"]


def test_non_orientable_strip_is_counted():
    rep = inspect_mesh(*moebius())
    assert rep["manifold"] and rep["boundary_loops"] == 1 and rep["components"] == 1
    assert rep["validation"]["problems"] == ["non_orientable"]


def test_broken_meshes_are_counted_not_refused():
    V = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [-1, 0, 0], [-1, -1, 0], [5, 5, 5], [6, 5, 5], [5, 6, 5]],
                 float)
    F = np.array([[0, 1, 2], [0, 3, 4], [5, 6, 7]])
    rep = inspect_mesh(V, F)
    assert rep["components"] == 2 and rep["bowtie_vertices"] == 1 and not rep["manifold"]
    assert "boundary_loops" not in rep and "holes" not in rep  # not counted on a non-manifold mesh
    assert set(rep["validation"]["problems"]) == {"components", "bowtie_vertices"}
    assert "2 problems" in rep["validation"]["message"]
    keep = inspect_mesh(V, F, keep_largest=True)  # the largest component is the bowtie
    assert keep["validation"]["problems"] == ["bowtie_vertices"]
    V1, F1 = disk(0, 60)
    V2, F2 = disk(1, 10)
    V, F = np.concatenate([V2 + 5.0, V1]), np.concatenate([F2, F1 + len(V2)])
    rep = inspect_mesh(V, F)
    assert rep["components"] == 2 and rep["manifold"] and rep["boundary_loops"] == 2 and "holes" not in rep
    keep = inspect_mesh(V, F, keep_largest=True)
    assert keep["validation"]["accepted"] and "kept the largest of 2" in keep["validation"]["repairs"][0]
    assert keep["holes"] == 0 and keep["genus"] == 0  # validate_mesh's counts of the kept component


def test_repeated_vertex_and_zero_area_faces():
    V, F = disk()
    F = F.copy()
    F[5] = [F[5, 0], F[5, 0], F[5, 2]]
    rep = inspect_mesh(V, F)
    assert rep["degenerate_faces"] == {"repeated_vertex": 1, "zero_area": 0}
    assert "bowtie_vertices" not in rep and not rep["manifold"]
    assert rep["validation"]["problems"] == ["repeated_vertex_id"]
    V, F = disk()
    V = V.copy()
    a, b, c = F[10]
    V[c] = 0.5 * (V[a] + V[b])
    rep = inspect_mesh(V, F)
    assert rep["degenerate_faces"]["zero_area"] == 1 and rep["validation"]["problems"] == ["zero_area"]


def test_non_finite_vertices_counted_without_a_warning():
    V, F = disk()
    V = V.copy()
    V[[3, 7]] = np.nan
    rep = inspect_mesh(V, F)  # filterwarnings = error: no "mean of empty slice" on the way
    assert rep["non_finite_vertices"] == 2 and rep["degenerate_faces"]["zero_area"] == 0
    finite = np.isfinite(V).all(1)
    np.testing.assert_array_equal(rep["bounds"], [V[finite].min(0), V[finite].max(0)])
    assert rep["validation"]["problems"] == ["non_finite"]


def test_argument_errors():
    V, F = disk()
    with pytest.raises(MeshError, match=r"F must have shape \(nf, 3\)") as e:
        inspect_mesh(V, F[:, :2])
    assert e.value.kinds == ("shape",)
    with pytest.raises(MeshError, match="integer"):
        inspect_mesh(V, F.astype(float))
    bad = F.copy()
    bad[2, 1] = len(V)
    with pytest.raises(InputError, match=r"F refer to ids outside \[0, (\d+)\): \1 \(row 2\)"):
        inspect_mesh(V, bad)


def test_default_method_is_the_spectral_conformal_map():
    V, F = disk(3, 80)
    assert DEFAULT_METHOD == "spectral"
    p = parameterize(V, F)
    assert p.method == DEFAULT_METHOD
    np.testing.assert_array_equal(p.uv, parameterize(V, F, "spectral").uv)


def test_harmonic_uv_is_the_raw_harmonic_map_of_a_disk():
    V, F = disk(4, 120)
    vm = validate_mesh(V, F)
    raw = harmonic_uv(vm.V, vm.F, vm.boundary_loops[0])
    np.testing.assert_allclose(np.linalg.norm(raw[vm.boundary_loops[0]], axis=1), 1.0, atol=1e-12)
    p = parameterize(V, F, "harmonic", smooth=False)  # the raw map itself, not smoothed
    np.testing.assert_allclose(p.transform.to_raw(p.uv), raw, atol=1e-12)


def test_closest_points():
    V = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], float)
    F = np.array([[0, 1, 2]])
    sq, idx, C = closest_points(np.array([[0.25, 0.25, 2.0], [2.0, 0.0, 0.0]]), V, F)
    np.testing.assert_allclose(sq, [4.0, 1.0])
    np.testing.assert_array_equal(idx, [0, 0])
    np.testing.assert_allclose(C, [[0.25, 0.25, 0.0], [1.0, 0.0, 0.0]])
    with pytest.raises(InputError, match=r"P must have shape \(n, 3\), got \(2,\)"):
        closest_points(np.zeros(2), V, F)
    with pytest.raises(InputError, match="non-finite"):
        closest_points(np.array([[np.nan, 0.0, 0.0]]), V, F)
    with pytest.raises(InputError, match=r"F refer to ids outside \[0, 3\)"):
        closest_points(np.zeros((1, 3)), V, F + 1)
