"""repair_mesh: a bowtie-ridden, multi-component scan repairs into what validate_mesh and
parameterize accept, with the map back to the input vertices; clean meshes pass unchanged."""
from __future__ import annotations

import numpy as np
import pytest
from folded_meshes import folded_grid, rough_holey_grid
from hypothesis import given, settings
from hypothesis import strategies as st
from trispline.param import (
    MeshError,
    fold_mask,
    inspect_mesh,
    parameterize,
    repair_mesh,
    validate_mesh,
)
from trispline.param.testing import broken_scan, bumpy_disk, lift
from trispline.spline.testing.domains import random_delaunay


def test_broken_scan_repairs_into_its_disk():
    V, F, expected = broken_scan()
    rep = inspect_mesh(V, F)
    assert rep["bowtie_vertices"] == expected["bowtie_vertices"] and rep["non_manifold_edges"] > 0
    assert set(rep["validation"]["problems"]) >= {"components", "zero_area", "non_manifold_edges", "bowtie_vertices"}
    r = repair_mesh(V, F)
    V0, F0 = bumpy_disk(300)
    # the good disk comes back exactly: same faces, same vertex order, the map is the identity
    np.testing.assert_array_equal(r.F, F0)
    np.testing.assert_array_equal(r.source_vertex_index, np.arange(V0.shape[0]))
    np.testing.assert_array_equal(r.source_face_index, np.arange(F0.shape[0]))
    assert r.changes["duplicate_faces"] == expected["duplicate_faces"]
    assert r.changes["zero_area_faces"] == expected["zero_area_faces"]
    assert r.changes["non_manifold_edges"] == 1  # the fin's edge
    assert r.changes["split_vertices"] == expected["bowtie_vertices"] + 2  # and the fin edge's two ends
    assert r.changes["dropped_components"] == 5  # three glued disks, the fin, the separate disk
    assert r.changed and len(r.messages) == 6
    assert "dropped 3 duplicate faces" in " ".join(r.messages)
    vm = validate_mesh(r.V, r.F)
    p = parameterize(vm.V, vm.F)
    fl, dg = fold_mask(p.uv, p.faces)
    assert not fl.any() and not dg.any()


def test_map_back_to_input_vertices():
    V, F, _ = broken_scan(seed=2)
    r = repair_mesh(V, F, keep_largest=False)
    np.testing.assert_array_equal(r.V, V[r.source_vertex_index])
    np.testing.assert_array_equal(r.source_vertex_index[r.F], F[r.source_face_index])
    assert r.changes["dropped_components"] == 0
    rep = inspect_mesh(r.V, r.F)
    assert rep["manifold"] and rep["non_manifold_edges"] == 0 and rep["bowtie_vertices"] == 0
    # seed 2's fin folds over (its two faces more than 90 degrees apart): both are cut off as a flap
    assert r.changes["folded_flap_faces"] == 2
    assert rep["components"] == 5


def test_clean_mesh_is_unchanged():
    V, F = lift(*random_delaunay(200, holes=2, seed=1))
    r = repair_mesh(V, F)
    assert not r.changed and r.messages == []
    np.testing.assert_array_equal(r.F, F)
    np.testing.assert_array_equal(r.V, V)


def test_non_finite_and_repeated_faces_are_dropped():
    V, F = bumpy_disk(100)
    V = V.copy()
    V[F[0, 0]] = np.nan
    F = np.vstack([F, [[F[1, 0], F[1, 0], F[1, 1]]]])
    r = repair_mesh(V, F)
    assert r.changes["non_finite_faces"] == int(np.isin(F, F[0, 0]).any(1).sum())
    assert r.changes["repeated_vertex_faces"] == 1
    assert np.isfinite(r.V).all()
    validate_mesh(r.V, r.F)


def test_refusals():
    V, F = bumpy_disk(50)
    with pytest.raises(MeshError, match=r"F refer to ids outside \[0, "):
        repair_mesh(V, F + V.shape[0])
    with pytest.raises(MeshError, match=r"F must have shape \(nf, 3\)"):
        repair_mesh(V, F[:, :2])
    with pytest.raises(MeshError, match="integer"):
        repair_mesh(V, F.astype(float))
    tri = np.array([[0.0, 0, 0], [1, 0, 0], [2, 0, 0]])
    with pytest.raises(MeshError, match="repair left no faces"):
        repair_mesh(tri, np.array([[0, 1, 2]]))


def test_inspect_judges_the_repaired_mesh():
    V, F, _ = broken_scan()
    rep = inspect_mesh(V, F, repair=True, param="lscm")
    assert rep["validation"]["accepted"] and rep["validation"]["mesh_repair"]["changes"]["duplicate_faces"] == 3
    assert rep["distortion"]["method"] == "lscm" and rep["distortion"]["warning"] is None
    assert list(rep)[-1] == "validation"


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_folded_flaps_are_counted_and_cut(seed):
    rng = np.random.default_rng(seed)
    n = 12
    flaps = sorted(rng.choice(np.arange(0, n - 1, 2), size=3, replace=False).tolist())
    V, F, nf = folded_grid(n, flaps, seed=seed)
    rep = inspect_mesh(V, F)
    assert rep["folded_edges"] == len(flaps) + 1  # one per flap: its edge on the grid
    assert rep["worst_fold_degrees"] > 150
    r = repair_mesh(V, F)
    # the flaps go, every grid face stays (in order), the vertex map is right
    np.testing.assert_array_equal(r.source_face_index, np.arange(nf))
    np.testing.assert_array_equal(r.source_vertex_index, np.arange(n * n))
    # the two-face flap: its folded face is cut, the other then hangs on by one vertex (a pinched fan)
    assert r.changes["folded_flap_faces"] == len(flaps) + 1 and r.changes["pinched_fan_faces"] == 1
    assert any("folded flaps" in m for m in r.messages)
    assert inspect_mesh(r.V, r.F)["folded_edges"] == 0


def test_clean_meshes_lose_no_face_to_the_fold_cut():
    for V, F in (lift(*random_delaunay(300, holes=2, seed=3)), bumpy_disk(500, seed=4)):
        assert inspect_mesh(V, F)["folded_edges"] == 0
        r = repair_mesh(V, F)
        assert r.changes["folded_flap_faces"] == r.changes["pinched_fan_faces"] == 0 and not r.changed


def _pieces_repeat_a_source(r) -> bool:
    """Whether two output vertices of one connected piece come from one input vertex (a pinch)."""
    from trispline.param.tables import vertex_components

    _, piece = vertex_components(r.F, r.V.shape[0])
    used = np.unique(r.F)
    pairs = np.stack([r.source_vertex_index[used], piece[used]], 1)
    return np.unique(pairs, axis=0).shape[0] < used.size


@settings(max_examples=12)
@given(st.floats(0.0, 0.2), st.integers(0, 2**31 - 1))
def test_holes_meeting_at_a_vertex_keep_its_largest_fan(drop, seed):
    # random holes touch each other at vertices: split there, the surface would pinch (pass
    # through one point twice); the repair keeps the largest fan of every such vertex instead
    V, F = rough_holey_grid(14, roughness=0.0, drop=drop, seed=seed)
    r = repair_mesh(V, F)
    np.testing.assert_array_equal(r.V, V[r.source_vertex_index])
    np.testing.assert_array_equal(r.source_vertex_index[r.F], F[r.source_face_index])
    assert not _pieces_repeat_a_source(r)
    vm = validate_mesh(r.V, r.F)  # accepted: one manifold piece, no bowtie
    assert vm.F.shape[0] == r.F.shape[0]
    assert r.changes["folded_flap_faces"] == 0  # smooth: nothing folds
    if r.changes["pinched_fan_faces"]:
        assert any("met itself at a vertex" in m for m in r.messages)
    if drop == 0.0:
        assert not r.changed


def test_a_pinch_drops_the_smaller_fan_only():
    # a 6 x 6 grid with two holes that share one vertex: the smaller fan there goes, nothing else
    V, F = rough_holey_grid(6, roughness=0.0, drop=0.0, seed=0)
    c = 2 * 6 + 2  # vertex (2, 2): the holes are faces of cells (1, 1) and (2, 2)
    hole = [k + s for k in (1 * 5 + 1, 2 * 5 + 2) for s in (0, 25)]  # a cell's two faces: k and k + 5 * 5
    F = np.delete(F, hole, axis=0)
    assert inspect_mesh(V, F)["bowtie_vertices"] == 1
    r = repair_mesh(V, F)
    assert r.changes["pinched_fan_faces"] in (1, 2) and r.changes["split_vertices"] == 0
    assert not _pieces_repeat_a_source(r) and np.isin(c, r.source_vertex_index)
    assert r.F.shape[0] == F.shape[0] - r.changes["pinched_fan_faces"]
