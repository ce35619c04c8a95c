"""The propagation map M spans exactly the C1 quintic spline space (docs/design.md §3)."""
from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from triangulations import triangulations

from trispline.spline.testing import domains
from trispline.spline.continuity import c1_vectors, continuity_report
from trispline.spline.errors import TriangulationError
from trispline.spline.polynomial import polynomial_control_net, random_polynomial
from trispline.spline.index import CORNER
from trispline.spline.propagation import KIND_FLIP, KIND_INNER, build_space, working_origin
from trispline.spline.topology import Triangulation

C1_TOL = 1e-10


def singular_vertex_count(uv: np.ndarray, faces: np.ndarray) -> int:
    """Independent oracle: interior valence-4 vertices whose four edges lie on two lines."""
    from trispline.spline.topology import Triangulation

    t = Triangulation(uv, faces)
    count = 0
    for v in np.flatnonzero(~t.boundary_vertex_mask):
        ring = [w for w in np.unique(t.edges[(t.edges == v).any(1)]) if w != v]
        if len(ring) != 4:
            continue
        d = uv[ring] - uv[v]
        d /= np.linalg.norm(d, axis=1)[:, None]
        # each direction has an exactly opposite one (sine below 1e-13, cosine negative)
        sin = np.abs(d[:, None, 0] * d[None, :, 1] - d[:, None, 1] * d[None, :, 0])
        opposite = (sin < 1e-13) & (d @ d.T < 0)
        if opposite.any(axis=1).all():
            count += 1
    return count


def random_free(space, seed=0):
    return np.random.default_rng(seed).normal(size=(space.n_free, 3))


@settings(max_examples=60, deadline=None)
@given(triangulations())
def test_random_free_points_give_exactly_c1_surfaces(case):
    kind, uv, faces = case
    space = build_space(uv, faces)
    ctrl = space.control_points(random_free(space))
    rep = continuity_report(space.tri, ctrl)
    assert rep["c0_max"] == 0.0  # shared storage
    assert rep["c1_relative"] < C1_TOL, (kind, rep)


@settings(max_examples=60, deadline=None)
@given(triangulations())
def test_free_count_equals_spline_space_dimension(case):
    kind, uv, faces = case
    space = build_space(uv, faces)
    sigma = singular_vertex_count(uv, faces)
    assert space.n_singular == sigma, kind
    v_int = int((~space.tri.boundary_vertex_mask).sum())
    e_int = int(space.tri.interior_edges.size)
    assert space.n_free == 21 * len(faces) - 11 * e_int + 3 * v_int + sigma


@settings(max_examples=25, deadline=None)
@given(triangulations(max_faces=120))
def test_M_has_full_rank_and_spans_the_c1_null_space(case):
    """rank(M) = n_free and dim null(C1 conditions) = n_free: range(M) is the whole space."""
    kind, uv, faces = case
    if len(faces) > 150:
        uv, faces = domains.random_delaunay(30, seed=1)
    space = build_space(uv, faces)
    M = space.M.toarray()
    s = np.linalg.svd(M, compute_uv=False)
    assert s[-1] / s[0] > 1e-9, kind
    # C1 condition matrix on the global points, independent of the propagation
    eye = np.eye(space.n_points)
    C = c1_vectors(space.tri, eye[space.point_index]).reshape(-1, space.n_points)
    if C.shape[0]:
        sc = np.linalg.svd(C, compute_uv=False)
        rank = int(np.sum(sc > 1e-11 * sc[0]))
    else:
        rank = 0
    assert space.n_points - rank == space.n_free, kind


def test_rows_are_affine_combinations():
    space = build_space(*domains.random_delaunay(80, holes=2, seed=3))
    np.testing.assert_allclose(space.M.sum(axis=1), 1.0, atol=1e-12)


def test_a_net_computed_about_a_point_is_the_same_net_with_exact_corners():
    space = build_space(*domains.random_delaunay(80, holes=2, seed=3))
    free = random_free(space, seed=1)
    about = np.array([0.3, -2.0, 5.0])
    ctrl = space.control_points(free, about=about)
    np.testing.assert_allclose(ctrl, space.control_points(free), rtol=0, atol=1e-13)
    np.testing.assert_array_equal(ctrl[:, CORNER], free[space.corner_free[space.tri.faces]])


@pytest.mark.parametrize("offset, seed", [(1e6, 0), (1e6, 1), (1e9, 0), (1e9, 1)])
def test_far_off_nets_about_their_working_origin_are_c1_to_the_rounding_of_their_coordinates(offset, seed):
    space = build_space(*domains.random_delaunay(300, holes=2, seed=3))
    free = 10.0 * random_free(space, seed) + offset
    origin = working_origin(free)
    np.testing.assert_allclose(origin, offset, atol=50.0)  # the box centre of a 10-sigma cloud
    rounding = np.finfo(float).eps * np.abs(free).max() / np.ptp(free, axis=0).max()
    ctrl = space.control_points(free, about=origin)
    # measured: 0.25-0.4 x rounding about the origin found; 1.6-2.2 x computed about (0, 0, 0)
    assert continuity_report(space.tri, ctrl - origin)["c1_relative"] < rounding
    assert working_origin(free - offset) is None  # data about the origin: nothing to move


@settings(max_examples=40, deadline=None)
@given(triangulations(), st.integers(0, 100))
def test_global_quintic_polynomials_are_reproduced(case, seed):
    kind, uv, faces = case
    space = build_space(uv, faces)
    centre = tuple(uv.mean(0))
    scale = float(np.ptp(uv, axis=0).max())
    poly = random_polynomial(5, 3, seed, centre=centre)
    ctrl = polynomial_control_net(uv, faces, lambda x: poly((x - np.array(centre)) / scale + np.array(centre)))
    # the exact net, as global points
    P = np.zeros((space.n_points, 3))
    P[space.point_index.ravel()] = ctrl.reshape(-1, 3)
    free = space.free_from_points(P)
    rebuilt = space.control_points(free)
    np.testing.assert_allclose(rebuilt, ctrl, atol=1e-9 * np.abs(ctrl).max())


def test_negative_control_one_moved_inner_point_breaks_c1_not_c0():
    uv, faces = domains.random_delaunay(60, seed=5)
    space = build_space(uv, faces)
    ctrl = space.control_points(random_free(space, 1))
    assert continuity_report(space.tri, ctrl)["c1_relative"] < C1_TOL
    f = space.tri.edge_faces[space.tri.interior_edges[0], 0]
    bad = ctrl.copy()
    scale = continuity_report(space.tri, ctrl)["scale"]
    bad[f, 4] += 1e-3 * scale  # near-corner inner point (3,1,1): off every edge
    rep = continuity_report(space.tri, bad)
    assert rep["c0_max"] == 0.0
    assert rep["c1_relative"] > 1e-4


def test_singular_vertices_gain_one_free_point_each():
    uv, faces = domains.grid(4, diagonal="crisscross")
    space = build_space(uv, faces)
    assert space.n_singular == 16  # every quad centre
    assert space.n_free == space.expected_dimension()


@pytest.mark.parametrize("eps", [1e-12, 1e-8, 1e-5, 1e-2])
def test_nearly_collinear_edges_keep_coefficients_bounded(eps):
    uv, faces = domains.grid(6, diagonal="alternate")
    uv2 = domains.perturb(uv, faces, eps, seed=2)
    space = build_space(uv2, faces)
    assert space.stats["max_coefficient"] < 50
    ctrl = space.control_points(random_free(space))
    assert continuity_report(space.tri, ctrl)["c1_relative"] < C1_TOL


def test_paper_choice_where_well_conditioned():
    """On a well-shaped mesh every inner point is free and one flip per interior edge."""
    uv, faces = domains.grid(8)
    space = build_space(uv, faces)
    assert np.sum(space.free_kind == KIND_INNER) == 3 * len(faces)
    t = space.tri
    assert np.sum(space.free_kind == KIND_FLIP) == t.interior_edges.size + t.boundary_edges.size


def test_invalid_domains_are_rejected_with_the_face_named():
    uv, faces = domains.grid(2)
    flipped = faces.copy()
    flipped[3] = flipped[3][[0, 2, 1]]
    with pytest.raises(TriangulationError, match=r"counter-clockwise.*\(first: 3"):
        build_space(uv, flipped)
    with pytest.raises(TriangulationError, match="not used by any face"):
        build_space(np.vstack([uv, [[5.0, 5.0]]]), faces)
    with pytest.raises(TriangulationError, match="outside"):
        build_space(uv, np.vstack([faces, [[0, 1, 99]]]))
    bad = uv.copy()
    bad[0, 0] = np.nan
    with pytest.raises(TriangulationError, match="non-finite"):
        build_space(bad, faces)


def test_non_manifold_edges_and_bowtie_vertices_are_rejected():
    # an edge (0, 1) with three faces on it: two of them traverse it in the same direction
    uv = np.array([[0.0, 0.0], [1.0, 0.0], [0.5, 1.0], [0.5, -1.0], [0.6, 2.0]])
    three = np.array([[0, 1, 2], [1, 0, 3], [0, 1, 4]])
    with pytest.raises(TriangulationError, match=r"directed edge used twice.*faces .*\(first: 0"):
        build_space(uv, three)
    # two triangles that share only vertex 0: one vertex, two fans
    uv = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [-1.0, 0.0], [0.0, -1.0]])
    bowtie = np.array([[0, 1, 2], [0, 3, 4]])
    with pytest.raises(TriangulationError, match=r"bowtie\) vertices.*: 1 \(first: 0\)"):
        build_space(uv, bowtie)
    # the same triangles joined by a third one: a valid incomplete star
    tri = Triangulation(uv, np.vstack([bowtie, [[0, 2, 3]]]))
    assert tri._fans[2][0] == 1 and tri.vertex_fan(0).tolist() == [0, 2, 1]


@pytest.fixture(params=["inline", "threaded"])
def thread_mode(request, monkeypatch):
    """Run inline, or force the threaded paths (tiny ranges) that large meshes take."""
    if request.param == "threaded":
        from trispline.spline.propagation import space as _space
        from trispline.spline.util import parallel as _parallel, sparse as _sparse

        monkeypatch.setattr(_parallel, "PARALLEL_MIN", 1)
        monkeypatch.setattr(_parallel, "CHUNK", 7)
        monkeypatch.setattr(_space, "PATCH_CHUNK", 5)
        monkeypatch.setattr(_sparse, "THREADED_NNZ", 0)
    return request.param


@pytest.mark.parametrize("shape", [(), (1,), (3,)])
def test_patch_points_is_the_gather_of_the_net(shape, thread_mode):
    uv, faces = domains.random_delaunay(60, holes=1, seed=4)
    space = build_space(uv, faces)
    net = np.random.default_rng(0).normal(size=(space.n_points,) + shape)
    np.testing.assert_array_equal(space.patch_points(net), net[space.point_index])
    free = np.random.default_rng(1).normal(size=(space.n_free,) + shape)
    np.testing.assert_array_equal(space.control_points(free), (space.M @ free)[space.point_index])
    with pytest.raises(ValueError, match="rows"):
        space.patch_points(net[:-1])


def _space_arrays(space) -> dict:
    M = space.M
    return dict(data=M.data, indices=M.indices, indptr=M.indptr, point_index=space.point_index,
                free_kind=space.free_kind, free_point=space.free_point,
                singular=space.singular_vertices, frame_scale=space.frame_scale)


@settings(max_examples=30, deadline=None)
@given(triangulations(), st.integers(1, 50))
def test_threaded_build_equals_the_inline_build_bit_for_bit(case, chunk):
    """Large meshes build M on ranges of edges in threads; the ranges must not change a bit."""
    from trispline.spline.propagation import elimination
    from trispline.spline.util import parallel as _parallel, sparse as _sparse

    kind, uv, faces = case
    inline = _space_arrays(build_space(uv, faces))
    saved = _parallel.PARALLEL_MIN, _parallel.CHUNK, elimination.SYSTEM_BATCH, _sparse.THREADED_NNZ
    try:  # force threads, many small ranges and batches of eliminated vertex systems
        _parallel.PARALLEL_MIN, _parallel.CHUNK, elimination.SYSTEM_BATCH = 1, chunk, 1 + chunk % 4
        _sparse.THREADED_NNZ = 0
        threaded = _space_arrays(build_space(uv, faces))
    finally:
        _parallel.PARALLEL_MIN, _parallel.CHUNK, elimination.SYSTEM_BATCH, _sparse.THREADED_NNZ = saved
    for name, value in inline.items():
        assert threaded[name].dtype == value.dtype, name
        np.testing.assert_array_equal(threaded[name], value, err_msg=f"{kind}: {name}")
