"""Hull slivers: a triangulation of scattered points is peeled down to the spacing of its points along
its outline; a mesh with an honest outline loses no face; repair, inspect and the command line say so."""
from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from trispline.fit.datasets.cache import find_data
from trispline.fit.datasets.face import face_scan
from trispline.fit.datasets.synthetic import synthetic_scan
from trispline.fit.datasets.tile import TILE_SIZE, scattered_tile
from trispline.fit.io import read_mesh
from trispline.param import inspect_mesh, repair_mesh, validate_mesh
from trispline.param import hull as hull_module
from trispline.param.hull import hull_sliver_faces
from trispline.param.testing import lift
from trispline.spline.testing.domains import random_delaunay
from trispline.spline.topology import undirected_edges

REAL = ["beetle.off", "camelhead.off", "face_gpjs.obj", "halftunnel.off", "inspired_mesh.obj", "lilium.obj",
        "mountain.obj", "snail.obj"]


def longest_outline_edge(V: np.ndarray, F: np.ndarray) -> float:
    """The longest outline edge over the median edge."""
    he, _, edge, count = undirected_edges(F, V.shape[0])
    length = np.linalg.norm(V[he[:, 0]] - V[he[:, 1]], axis=1)
    return float(length[count[edge] == 1].max() / np.median(length))


def long_outline_edges(V: np.ndarray, F: np.ndarray, ratio: float) -> int:
    """How many outline edges are longer than ``ratio`` times the median edge."""
    he, _, edge, count = undirected_edges(F, V.shape[0])
    length = np.linalg.norm(V[he[:, 0]] - V[he[:, 1]], axis=1)
    return int((length[count[edge] == 1] > ratio * np.median(length)).sum())


@settings(max_examples=8)
@given(st.integers(300, 4000), st.integers(0, 2**31 - 1))
def test_a_scattered_tile_is_peeled_down_to_the_spacing_of_its_points(n, seed):
    V, F = scattered_tile(n, seed=seed)
    assert longest_outline_edge(V, F) > 10  # each side one chord of the hull: a whole side
    peeled = hull_sliver_faces(V, F)
    assert 0 < peeled.sum() <= hull_module.HULL_MAX_SHARE * F.shape[0]
    assert long_outline_edges(V, F[~peeled], 6.0) <= 1  # a face just too fat for a sliver may stay (1 in 40)
    again = hull_sliver_faces(V, F[~peeled]).sum()
    assert again <= max(3, 0.06 * peeled.sum())  # nearly a fixed point: the spacing moves a little
    vm = validate_mesh(V, F[~peeled], keep_largest=True)  # still one disk
    assert vm.report["holes"] == 0


def test_one_round_peels_only_the_faces_on_the_outline_now():
    V, F = scattered_tile(2000, seed=3)
    first = hull_sliver_faces(V, F, rounds=1)
    assert first.sum() == 4  # the four sides' chords
    assert (first <= hull_sliver_faces(V, F)).all()


@pytest.mark.parametrize("mesh", [
    pytest.param(lambda: synthetic_scan(3000, seed=1), id="synthetic scan"),
    pytest.param(lambda: face_scan(3000, seed=2), id="face scan"),
    pytest.param(lambda: lift(*random_delaunay(800, holes=2, seed=4)), id="random points, sampled border"),
])
def test_a_mesh_with_an_honest_outline_loses_nothing(mesh):
    V, F = mesh()
    assert not hull_sliver_faces(V, F).any()
    assert inspect_mesh(V, F)["hull_slivers"] == 0


@pytest.mark.parametrize("name", REAL)
def test_the_shared_real_scans_lose_nothing(name):
    path = find_data(name)
    if path is None:
        pytest.skip(f"{name} not in ../shared/data")
    m = read_mesh(path)
    assert not hull_sliver_faces(m.V, m.F).any()


def test_a_coarse_column_along_the_rim_of_a_graded_grid_keeps_its_points():
    """A grid of 30 x 30 whose last column is 15x as wide: its faces are as thin as hull slivers and stack
    the same way, but peeling them would drop the points along the rim, which no hull sliver holds."""
    t = np.linspace(0.0, 1.0, 30)
    u, v = np.meshgrid(np.r_[t[:-1] * 0.5, 1.0], t, indexing="ij")
    idx = np.arange(900).reshape(30, 30)
    a, b, c, d = idx[:-1, :-1].ravel(), idx[1:, :-1].ravel(), idx[1:, 1:].ravel(), idx[:-1, 1:].ravel()
    F = np.concatenate([np.c_[a, b, c], np.c_[a, c, d]])
    V = np.c_[u.ravel(), v.ravel(), np.zeros(900)]
    peeled = hull_sliver_faces(V, F)
    assert peeled.sum() <= 2  # at most the first face at each end of the column
    assert np.isin(np.arange(900), F[~peeled]).all()


def test_a_mesh_made_of_such_faces_keeps_them(monkeypatch):
    """More than HULL_MAX_SHARE of the faces would go: they are the mesh, not a hull around it."""
    V, F = scattered_tile(1000, seed=5)
    share = hull_sliver_faces(V, F).sum() / F.shape[0]
    monkeypatch.setattr(hull_module, "HULL_MAX_SHARE", share / 2)
    assert not hull_sliver_faces(V, F).any()


def test_repair_peels_them_and_says_so():
    V, F = scattered_tile(3000, seed=0)
    r = repair_mesh(V, F)
    first = hull_sliver_faces(V, F).sum()
    assert first <= r.changes["hull_sliver_faces"] <= first + 3 and first > 0  # and those the first peel bared
    assert any(m.startswith(f"peeled {r.changes['hull_sliver_faces']} hull slivers") for m in r.messages)
    np.testing.assert_array_equal(r.V, V[r.source_vertex_index])
    assert longest_outline_edge(r.V, r.F) < 8
    assert inspect_mesh(r.V, r.F)["hull_slivers"] == 0
    rep = inspect_mesh(V, F)
    assert rep["hull_slivers"] == first and rep["longest_outline_edge"] > 15


def test_the_tile_is_a_square_of_its_size():
    V, F = scattered_tile(500, seed=1, origin=(500_000.0, 4_000_000.0))
    np.testing.assert_allclose(V[:, :2].min(0), [500_000.0, 4_000_000.0])
    np.testing.assert_allclose(V[:, :2].max(0), [500_000.0 + TILE_SIZE, 4_000_000.0 + TILE_SIZE])
    with pytest.raises(ValueError, match="positive integer"):
        scattered_tile(0)
