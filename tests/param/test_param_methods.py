"""SLIM and auto parameterization, the distortion report, and the domain in the user's frame."""
from __future__ import annotations

import importlib

import igl
import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from trispline.param import (
    UVTransform, distortion_report, parameterize, reverse_faces, slim_uv, user_domain, validate_mesh,
)
from trispline.param.methods import far_apart, lscm_uv, raw_map, spectral_uv
from trispline.param.validate import face_areas_3d
from trispline.spline.topology import signed_areas
from trispline.param.testing import bumpy_disk, lift, nearly_closed
from trispline.spline.errors import InputError
from trispline.spline.surface import SplineSurface
from trispline.spline.testing.domains import random_delaunay
from trispline.spline.tolerances import ANGLE_DISTORTION_WARN, AREA_DISTORTION_WARN

from test_param import check_domain
from test_param_data import data_mesh, needs_data

#: The module (the package's ``parameterize`` attribute is the function of that name).
parameterize_module = importlib.import_module("trispline.param.parameterize")


# ------------------------------------------------------------------------------ lscm
def _pins(vm):
    i, j = far_apart(vm.V, vm.boundary_loops[0])
    return np.array([i, j]), np.array([[0.0, 0.0], [float(np.linalg.norm(vm.V[i] - vm.V[j])), 0.0]])


@pytest.mark.parametrize("backend", ["cholespy", "pardiso"])
@pytest.mark.parametrize("mesh", ["disk", "holes", "nearly_closed"])
def test_lscm_is_libigls_map(mesh, backend):
    if backend == "pardiso":
        pytest.importorskip("pypardiso")
    V, F = {"disk": lambda: bumpy_disk(600), "holes": lambda: lift(*random_delaunay(400, holes=3, seed=2)),
            "nearly_closed": lambda: nearly_closed(1500)}[mesh]()
    vm = validate_mesh(V, F)
    pins, at = _pins(vm)
    ref, _ = igl.lscm(vm.V, vm.F, pins, at)
    uv = lscm_uv(vm, pins, at, backend=backend)
    assert np.abs(uv - ref).max() <= 1e-9 * np.abs(ref).max()
    np.testing.assert_array_equal(uv[pins], at)


def test_lscm_of_a_large_scan_is_libigls_map():
    """The default backend at a size where it is PARDISO (when installed): 60k unknowns."""
    from trispline.fit.datasets.truth import truth_scan

    s = truth_scan("bumps", 15_000, sigma=1e-3, outliers=0.005, outlier_sigmas=50.0, seed=1)
    vm = validate_mesh(s.V, s.F)
    ref, _ = igl.lscm(vm.V, vm.F, *_pins(vm))
    uv = raw_map(vm, "lscm")
    assert np.abs(uv - ref).max() <= 1e-9 * np.abs(ref).max()


@pytest.mark.parametrize("seed", [0, 1])
def test_the_spectral_map_of_a_flat_mesh_is_a_similarity_of_it(seed):
    """A conformal map of a planar mesh is the plane itself up to a similarity (the energy is 0 there), with no
    mirror; the spectral map finds it without pins."""
    uv0, F = random_delaunay(300, holes=1, seed=seed)
    vm = validate_mesh(np.column_stack([uv0, np.zeros(len(uv0))]), F)
    uv = spectral_uv(vm)
    P1 = np.column_stack([uv0, np.ones(len(uv0))])
    A, *_ = np.linalg.lstsq(P1, uv, rcond=None)
    assert np.abs(P1 @ A - uv).max() <= 1e-8 * np.ptp(uv)
    G = A[:2].T @ A[:2]  # a rotation times a scale: G = s^2 I, det > 0
    assert np.abs(G - G[0, 0] * np.eye(2)).max() <= 1e-9 * G[0, 0] and np.linalg.det(A[:2]) > 0


def test_the_spectral_map_of_a_scan_does_not_depend_on_its_face_order_or_the_backend():
    """LSCM's two pins come from the outline's first vertex, which the face order picks; the spectral map has
    none. 60k unknowns: PARDISO where installed, against cholespy. Scaled to the mesh's area."""
    from trispline.fit.datasets.truth import truth_scan

    s = truth_scan("bumps", 15_000, sigma=1e-3, outliers=0.005, outlier_sigmas=50.0, seed=1)
    vm = validate_mesh(s.V, s.F)
    uv = raw_map(vm, "spectral")
    shuffled = raw_map(validate_mesh(s.V, s.F[np.random.default_rng(3).permutation(len(s.F))]), "spectral")
    assert np.abs(shuffled - uv).max() <= 1e-8 * np.ptp(uv)
    assert np.abs(spectral_uv(vm, backend="cholespy") - uv).max() <= 1e-8 * np.ptp(uv)
    assert signed_areas(uv, vm.F).sum() == pytest.approx(face_areas_3d(vm.V, vm.F).sum(), rel=1e-9)


@settings(max_examples=12)
@given(seed=st.integers(0, 2**16), n=st.integers(20, 200), height=st.sampled_from([0.0, 0.2, 1.0]))
def test_the_spectral_map_of_random_points_with_hull_slivers_is_defined_and_does_not_depend_on_the_listing(
        seed, n, height):
    """Random points of a square and its corners, Delaunay: hull slivers along the sides (aspect up to ~1e6),
    flat or lifted. The shifted energy once failed to factor on such meshes, and Lanczos in the boundary-only
    inner product broke down on small ones; now the map exists, covers the mesh's area, and is the same with
    the vertices renumbered and the faces shuffled: up to a rotation (its axes are those of the map's second
    moments, which a nearly square outline leaves nearly free: seed 0, n 116 turned by 4e-7), and to 1e-6 of
    its extent (the eigenvector's own conditioning: the energy's rounding, which the listing changes, over the
    gap to the next eigenvalues; seed 1, n 22 moved 3.2e-7 at any Lanczos tolerance; the sphere cap and the
    15k-face scan above hold to 1e-8). LSCM's pins moved a sphere cap's fit by 7e-4 of its diagonal."""
    from scipy.spatial import Delaunay

    rng = np.random.default_rng(seed)
    P = np.r_[rng.random((n, 2)), [[0, 0], [1, 0], [0, 1], [1, 1]]]
    V = np.c_[P, height * np.sin(3 * P[:, 0]) * np.cos(2 * P[:, 1])]
    F = Delaunay(P).simplices
    vm = validate_mesh(V, F)
    uv = spectral_uv(vm)
    assert np.isfinite(uv).all()
    assert signed_areas(uv, vm.F).sum() == pytest.approx(face_areas_3d(vm.V, vm.F).sum(), rel=1e-9)
    old = rng.permutation(len(V))
    moved = spectral_uv(validate_mesh(V[old], np.argsort(old)[F][rng.permutation(len(F))]))
    u, _, vt = np.linalg.svd(uv[old].T @ moved)  # the rotation that takes one onto the other (Procrustes)
    turn = u @ vt
    assert np.linalg.det(turn) > 0 and abs(np.arctan2(turn[1, 0], turn[0, 0])) <= 1e-4
    assert np.abs(moved - uv[old] @ turn).max() <= 1e-6 * np.ptp(uv)


# ------------------------------------------------------------------------------ slim
@pytest.mark.parametrize("mesh", ["disk", "holes", "nearly_closed"])
def test_slim_is_fold_free_and_nearly_conformal(mesh):
    V, F = {"disk": lambda: bumpy_disk(600), "holes": lambda: lift(*random_delaunay(300, holes=2, seed=2)),
            "nearly_closed": lambda: nearly_closed(1500)}[mesh]()
    p = parameterize(V, F, "slim", polynomial=False)  # SLIM's own map (a lifted plane would take its projection)
    check_domain(p, F)
    assert p.method == "slim" and p.repaired is None and p.warning is None
    assert p.distortion["angle_max"] < 2.0  # conformal energy: close to LSCM's angles
    assert p.distortion["score"] == p.distortion["angle_max"]


def test_slim_uv_starts_from_tutte_and_lowers_the_angle_distortion():
    V, F = nearly_closed(1500)
    vm = validate_mesh(V, F)
    one = slim_uv(vm, max_iterations=1)
    many = slim_uv(vm)
    d1, d2 = distortion_report(V, F, one), distortion_report(V, F, many)
    assert d1["flipped"] == d2["flipped"] == 0
    assert d2["angle_p99"] < d1["angle_p99"]


# ------------------------------------------------------------------------------ auto
def test_auto_keeps_the_spectral_map_when_it_is_good():
    V, F = nearly_closed(1500)
    spectral = parameterize(V, F, "spectral")
    auto = parameterize(V, F, "auto")
    assert auto.method == "spectral" and spectral.distortion["score"] <= ANGLE_DISTORTION_WARN
    np.testing.assert_array_equal(auto.uv, spectral.uv)  # the same map, bit for bit
    assert auto.reason.startswith("auto chose spectral") and auto.reason in auto.messages
    assert set(auto.candidates) == {"spectral"}


def test_auto_ranks_every_map_when_the_spectral_map_is_not_good(monkeypatch):
    monkeypatch.setattr(parameterize_module, "ANGLE_DISTORTION_WARN", 1.0)  # nothing is good now
    V, F = lift(*random_delaunay(200, holes=1, seed=3))
    auto = parameterize(V, F, "auto")
    assert set(auto.candidates) == {"spectral", "harmonic", "slim"}
    scores = {k: d["score"] for k, d in auto.candidates.items()
              if d["flipped_before_repair"] + d["degenerate_before_repair"] == 0}
    assert auto.method == min(scores, key=scores.get)
    check_domain(auto, F)
    for k in auto.candidates:
        if k != auto.method:
            assert f"{k} score" in auto.reason


@needs_data("halftunnel.off")
def test_auto_passes_over_a_folded_spectral_map():
    m = data_mesh("halftunnel.off")
    auto = parameterize(m.V, m.F, "auto")
    assert auto.candidates["spectral"]["flipped_before_repair"] > 0
    assert auto.method == "slim" and auto.distortion["flipped_before_repair"] == 0
    assert "2 folds repaired" in auto.reason and auto.warning is None


# ------------------------------------------------------------------------ distortion
def test_distortion_report_of_an_isometry_and_of_a_fold():
    uv, F = random_delaunay(80, seed=1)
    V = np.column_stack([uv, np.zeros(len(uv))])
    rep = distortion_report(V, F, uv * 3.0)  # a similarity: no distortion at all
    for k in ("angle_p50", "angle_max", "area_p50", "area_max", "score"):
        assert rep[k] == pytest.approx(1.0, abs=1e-9), k
    assert rep["flipped"] == rep["degenerate"] == 0 and rep["warning"] is None
    folded = uv.copy()
    inner = np.setdiff1d(np.arange(len(uv)), validate_mesh(V, F).boundary_loops[0])[0]
    folded[inner] += 5.0
    rep = distortion_report(V, F, folded)
    assert rep["flipped"] > 0 and "folded triangles" in rep["warning"]


def test_warning_names_what_is_distorted():
    base = dict(angle_p50=1.0, angle_p90=1.0, angle_p99=1.0, angle_max=1.0, area_p50=1.0, area_p90=1.0,
                area_p99=1.0, area_max=1.0)
    from trispline.param.distortion import warning

    assert warning(base) is None
    sheared = dict(base, angle_max=2 * ANGLE_DISTORTION_WARN)
    assert "angle distortion max" in warning(sheared, method="lscm") and "--param auto" in warning(sheared, method="lscm")
    assert "--param auto" not in warning(sheared, method="auto")
    assert "given uv is used as is" in warning(sheared, method="uv")  # a height field's own parameters
    shrunk = dict(base, area_p99=2 * AREA_DISTORTION_WARN, area_max=3 * AREA_DISTORTION_WARN)
    assert "area distortion p99" in warning(shrunk) and "spike" not in warning(shrunk)


@pytest.mark.parametrize("V, F, uv, match", [
    (np.zeros((3, 2)), [[0, 1, 2]], np.zeros((3, 2)), r"V must have shape \(n, 3\)"),
    (np.zeros((3, 3)), [[0, 1, 3]], np.zeros((3, 2)), r"F refer to ids outside \[0, 3\)"),
    (np.zeros((3, 3)), [[0, 1, 2]], np.zeros((4, 2)), r"uv must have shape \(3, 2\)"),
    (np.zeros((3, 3)), [[0, 1, 2]], np.full((3, 2), np.nan), "uv has non-finite entries"),
    (np.zeros((3, 3)), np.zeros((0, 3), int), np.zeros((3, 2)), "at least 1 row"),
])
def test_distortion_report_refuses_bad_arrays(V, F, uv, match):
    with pytest.raises(InputError, match=match):
        distortion_report(V, F, uv)


# --------------------------------------------------------------- the user's domain
def _net_over(p, seed=0) -> np.ndarray:
    """An exactly C1 net over ``p``'s normalised domain (a random smooth-ish quintic per face)."""
    from trispline.spline.propagation import build_space

    space = build_space(p.uv, p.faces)
    free = np.random.default_rng(seed).normal(size=(space.n_free, 3))
    return space.control_points(free)


@pytest.mark.parametrize("mirror", [False, True])
def test_user_domain_evaluates_at_the_users_own_uv(mirror):
    uv0, F = random_delaunay(150, holes=1, seed=7)
    xy = uv0 * [250.0, 40.0] + [6.1e5, 5.2e6]  # a terrain tile in UTM-like coordinates
    if mirror:
        xy = xy * [-1.0, 1.0]  # clockwise in the user's frame: parameterize mirrors it
    V, F = lift(xy, F, height=lambda p: 1e-3 * (p[:, 0] - p[:, 0].mean()))
    p = parameterize(V, F, "uv")
    assert p.transform.mirrored is mirror
    ctrl = _net_over(p)
    normalised = SplineSurface(p.uv, p.faces, ctrl)
    uv, faces, ctrl_u = user_domain(p, ctrl)
    np.testing.assert_array_equal(uv, xy)  # exactly the user's coordinates
    user = SplineSurface(uv, faces, ctrl_u)
    # the same surface: at every vertex and at points inside faces, in each frame's coordinates
    np.testing.assert_allclose(user.evaluate_uv(xy), normalised.evaluate_uv(p.uv), rtol=0, atol=1e-8)
    fi = np.arange(faces.shape[0])
    bary = np.random.default_rng(1).dirichlet(np.ones(3), size=fi.size)
    inside = (bary[:, :, None] * xy[p.faces[fi]]).sum(1)
    inside_n = (bary[:, :, None] * p.uv[p.faces[fi]]).sum(1)
    # points given to 1e-16 x 5e6 m locate to ~1e-10 of a 20 m triangle; the random net is steep
    np.testing.assert_allclose(user.evaluate_uv(inside), normalised.evaluate_uv(inside_n), rtol=0, atol=1e-6)


def test_user_domain_maps_vertices_the_fit_moved_through_the_transform():
    """The spline core may snap nearly singular vertices: those go back through the stored
    normalisation, every other vertex stays exactly the user's."""
    uv0, F = random_delaunay(80, seed=3)
    xy = uv0 * [30.0, 20.0] + [1e3, -2e3]
    V, F = lift(xy, F, height=lambda p: 0.01 * p[:, 0])
    p = parameterize(V, F, "uv")
    used = p.uv.copy()
    used[[4, 9]] += 1e-13  # as a snap would
    uv, faces, _ = user_domain(p, _net_over(p), used)
    keep = np.setdiff1d(np.arange(len(xy)), [4, 9])
    np.testing.assert_array_equal(uv[keep], xy[keep])
    np.testing.assert_array_equal(uv[[4, 9]], p.transform.to_output(used[[4, 9]]))
    assert not np.array_equal(uv[[4, 9]], xy[[4, 9]])


def test_user_domain_keeps_the_normalised_domain_of_the_other_methods():
    V, F = bumpy_disk(200)
    p = parameterize(V, F, "lscm")
    ctrl = _net_over(p)
    uv, faces, out = user_domain(p, ctrl)
    assert uv is p.uv and faces is p.faces and out is ctrl


def test_transform_round_trips_through_a_surface_file(tmp_path):
    V, F = bumpy_disk(200)
    p = parameterize(V, F, "harmonic")
    t = p.transform
    np.testing.assert_allclose(t.to_output(p.uv), t.to_raw(p.uv) * ([-1, 1] if t.mirrored else [1, 1]))
    s = SplineSurface(p.uv, p.faces, _net_over(p), extras=t.as_extras())
    s.save(tmp_path / "s.npz")
    back = UVTransform.from_extras(SplineSurface.load(tmp_path / "s.npz").extras)
    np.testing.assert_array_equal(back.centre, t.centre)
    assert back.scale == t.scale and back.mirrored == t.mirrored
    assert UVTransform.from_extras({}) is None


def test_reverse_faces_is_the_same_patch():
    p = parameterize(*bumpy_disk(100), "lscm")
    ctrl = _net_over(p)
    faces_r, ctrl_r = reverse_faces(p.faces, ctrl)
    bary = np.random.default_rng(0).dirichlet(np.ones(3), size=p.faces.shape[0])
    fi = np.arange(p.faces.shape[0])
    a = SplineSurface(p.uv, p.faces, ctrl).evaluate(fi, bary)
    mirrored_uv = p.uv * [-1.0, 1.0]  # reversed faces are CCW in the mirrored domain
    b = SplineSurface(mirrored_uv, faces_r, ctrl_r).evaluate(fi, bary[:, [0, 2, 1]])
    np.testing.assert_allclose(a, b, rtol=0, atol=1e-13)


# ------------------------------------------------------------------------------ maps that overlap themselves
def test_outline_crossings_counts_where_a_map_covers_the_plane_twice():
    from trispline.param.distortion import outline_crossings
    from trispline.param.testing import helicoid_strip

    V, F = helicoid_strip()
    vm = validate_mesh(V, F)
    lscm = parameterize(V, F, method="lscm")  # fold-free, wound three times around its centre
    assert not np.logical_or(*parameterize_module.fold_mask(lscm.uv, lscm.faces)).any()
    assert outline_crossings(lscm.uv, vm.boundary_loops) > 100
    assert outline_crossings(parameterize(V, F, method="harmonic").uv, vm.boundary_loops) == 0
    assert outline_crossings(V[:, :2], vm.boundary_loops) > 0  # (x, y): every turn over the first
    ends = V[:, :2].copy()
    ends[-6:] = ends[:6]  # both end edges on one line, their points duplicated (Triangle crashed there)
    assert outline_crossings(ends, vm.boundary_loops) > 0
    uv, faces = random_delaunay(200, holes=2, seed=3)
    assert outline_crossings(uv, validate_mesh(np.c_[uv, 0 * uv[:, 0]], faces).boundary_loops) == 0


def _brute_crossings(P: np.ndarray) -> int:
    """Pairs of a closed polygon's edges that share no vertex and cross or touch (exact orientations)."""
    n, count = len(P), 0

    def o(p, q, r):
        return np.sign((q[0] - p[0]) * (r[1] - p[1]) - (q[1] - p[1]) * (r[0] - p[0]))

    for i in range(n):
        for j in range(i + 1, n):
            if len({i, (i + 1) % n, j, (j + 1) % n}) == 4:
                a, b, c, d = P[i], P[(i + 1) % n], P[j], P[(j + 1) % n]
                count += bool(o(a, b, c) * o(a, b, d) <= 0 and o(c, d, a) * o(c, d, b) <= 0)
    return count


@settings(max_examples=60, deadline=None)
@given(st.integers(4, 30), st.integers(0, 2**31 - 1), st.booleans())
def test_outline_crossings_equal_a_brute_force_count(n, seed, star):
    """Random polygons, simple (star-shaped) or tangled: the grid's pairs miss no crossing."""
    from trispline.param.distortion import outline_crossings

    rng = np.random.default_rng(seed)
    if star:
        ang = np.sort(rng.uniform(0, 2 * np.pi, n))
        P = rng.uniform(0.5, 1.0, n)[:, None] * np.column_stack([np.cos(ang), np.sin(ang)])
    else:
        P = rng.normal(size=(n, 2)) * np.array([1.0, rng.uniform(0.01, 1.0)])
    assert outline_crossings(P, [np.arange(n)]) == _brute_crossings(P)


def test_a_local_tangle_of_the_outline_is_no_overlap():
    """Two consecutive outline points swapped (a noisy outline's LSCM map tangles so): their segments cross,
    but only a few steps apart along the loop, which is no second cover of the plane."""
    from trispline.param.distortion import TANGLE_SEGMENTS, outline_crossings

    t = np.linspace(0, 2 * np.pi, 40, endpoint=False)
    P = np.column_stack([np.cos(t), np.sin(t)])
    P[[10, 11]] = P[[11, 10]]
    assert outline_crossings(P, [np.arange(40)]) > 0
    assert outline_crossings(P, [np.arange(40)], tangle=TANGLE_SEGMENTS) == 0
    P[20:25] = P[20:25] * np.array([-1.0, 1.0])  # a run folded over to the other side: far apart along the loop
    assert outline_crossings(P, [np.arange(40)], tangle=TANGLE_SEGMENTS) > 0


@pytest.mark.parametrize("method", ["lscm", "auto"])
def test_embedded_replaces_a_map_that_overlaps_itself(method):
    from trispline.param.distortion import outline_crossings
    from trispline.param.testing import helicoid_strip

    V, F = helicoid_strip()
    p = parameterize(V, F, method=method, embedded=True)
    assert outline_crossings(p.uv, validate_mesh(V, F).boundary_loops) == 0
    assert p.repaired in ("harmonic", "slim") and any("overlaps itself" in m for m in p.messages)
    check_domain(p, F)


def test_embedded_refuses_the_users_uv_that_overlap_themselves():
    from trispline.param import MeshError
    from trispline.param.testing import helicoid_strip

    V, F = helicoid_strip()
    with pytest.raises(MeshError, match="overlaps itself.*one-to-one map is needed") as info:
        parameterize(V, F, method="uv", embedded=True)
    assert "overlap" in info.value.kinds
    assert parameterize(V, F, method="uv").method == "uv"  # the interpolating fit may use them (warned)


def test_a_validation_the_caller_has_is_not_run_again(monkeypatch):
    """``validated=``: the same map as without it, and no second :func:`validate_mesh` (0.3 s at 100k faces);
    one of other arrays is refused."""
    from trispline.param import MeshError

    V, F = bumpy_disk(400)
    F = F.copy()
    F[::5] = F[::5, ::-1]  # inconsistently oriented: validation reverses these rows
    vm = validate_mesh(V, F)
    plain = parameterize(V, F)
    calls = []
    monkeypatch.setattr(parameterize_module, "validate_mesh", lambda *a, **k: calls.append(1))
    p = parameterize(V, F, validated=vm)
    assert not calls
    np.testing.assert_array_equal(p.uv, plain.uv)
    np.testing.assert_array_equal(p.faces, plain.faces)
    with pytest.raises(MeshError, match="not the validation of these V and F"):
        parameterize(V[:-1], F, validated=vm)


def test_slim_starts_from_the_harmonic_map_where_it_folds_nothing_else_from_tutte(monkeypatch):
    """SLIM's start: the harmonic map (near-conformal inside: few iterations) when fold-free, else Tutte's
    embedding (every inner vertex the mean of its neighbours, the outline on the same circle); the SLIM map
    from it is fold-free and at most as sheared as the harmonic map."""
    import trispline.param.methods as methods
    from trispline.fit.datasets.analytic import analytic_mesh
    from trispline.param import validate_mesh
    from trispline.param.distortion import face_distortion, fold_mask, score, summarize
    from trispline.param.repair import fill_holes, tutte

    m = analytic_mesh("bump_hole", 800)
    vm = validate_mesh(m.V, m.F)
    Vx, Fx = fill_holes(vm.V, vm.F, vm.boundary_loops[1:])
    outer = vm.boundary_loops[0]
    harmonic = methods.harmonic_uv(Vx, Fx, outer)
    np.testing.assert_array_equal(methods.slim_start(Vx, Fx, outer), harmonic)
    uv = methods.raw_map(vm, "slim")
    assert not np.logical_or(*fold_mask(uv, vm.F)).any()
    sheared = lambda x: score(summarize(*face_distortion(vm.V, vm.F, x[: len(vm.V)])))  # noqa: E731
    assert sheared(uv) <= sheared(harmonic)
    inner = np.setdiff1d(np.arange(len(Vx)), outer)
    folded = harmonic.copy()
    folded[inner[:2]] = folded[inner[:2]][::-1]  # two inner vertices swapped: their triangles flip
    assert np.logical_or(*fold_mask(folded, Fx)).any()
    monkeypatch.setattr(methods, "harmonic_uv", lambda *a: folded)
    start = methods.slim_start(Vx, Fx, outer)
    np.testing.assert_allclose(start[outer], harmonic[outer], atol=1e-12)  # the same circle
    np.testing.assert_allclose(start, tutte(Fx, len(Vx), outer, harmonic[outer]), atol=1e-12)
    assert not np.logical_or(*fold_mask(start, Fx)).any()
