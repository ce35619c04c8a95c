"""parameterize on generated disks and disks with holes: fold-free, normalised, faces unchanged."""
from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from trispline.param import (
    MeshError, Parameterization, fill_holes, fold_mask, parameterize, tutte, validate_mesh,
)
from trispline.param.repair import polygon_area
from trispline.param.testing import bumpy_disk, lift
from trispline.spline.testing.domains import annulus, l_shape, random_delaunay
from trispline.spline.topology import Triangulation


def check_domain(p: Parameterization, F: np.ndarray) -> None:
    """The contract every result must meet."""
    assert p.faces is F or np.array_equal(p.faces, F)
    Triangulation(p.uv, p.faces)  # every face CCW with positive area: raises otherwise
    fl, dg = fold_mask(p.uv, p.faces)
    assert not fl.any() and not dg.any()
    np.testing.assert_allclose(0.5 * (p.uv.min(0) + p.uv.max(0)), 0.0, atol=1e-12)
    np.testing.assert_allclose(np.sqrt((p.uv ** 2).sum(1)).max(), 1.0, rtol=1e-12)
    assert polygon_area(p.uv[p.boundary]) > 0  # outer loop CCW
    for key in ("angle_p50", "angle_p90", "angle_p99", "angle_max",
                "area_p50", "area_p90", "area_p99", "area_max"):
        assert np.isfinite(p.distortion[key]) and p.distortion[key] >= 1.0 - 1e-9
    assert p.distortion["angle_p50"] <= p.distortion["angle_p90"] <= p.distortion["angle_p99"] \
        <= p.distortion["angle_max"]


@pytest.mark.parametrize("method", ["harmonic", "lscm", "uv"])
def test_disk(method):
    V, F = lift(*random_delaunay(150, seed=4))
    p = parameterize(V, F, method)
    check_domain(p, F)
    assert p.method == method and p.repaired is None
    assert p.distortion["flipped_before_repair"] == 0


def test_harmonic_boundary_on_circle_by_arc_length():
    V, F = lift(*random_delaunay(150, seed=5))
    p = parameterize(V, F, "harmonic")
    raw = p.transform.to_raw(p.uv)
    loop = p.boundary
    np.testing.assert_allclose(np.linalg.norm(raw[loop], axis=1), 1.0, atol=1e-12)
    # arc-length spacing: circle angles proportional to 3D edge lengths
    seg3 = np.linalg.norm(V[np.roll(loop, -1)] - V[loop], axis=1)
    ang = np.unwrap(np.arctan2(raw[loop, 1], raw[loop, 0]))
    dang = np.diff(np.r_[ang, ang[0] + 2 * np.pi])
    np.testing.assert_allclose(dang / dang.sum(), seg3 / seg3.sum(), atol=1e-9)


def test_uv_method_keeps_given_uv_and_transform():
    uv0, F = random_delaunay(120, seed=6)
    V, F = lift(uv0 * 3.0 + 7.0, F)
    p = parameterize(V, F, "uv")  # height field: uv = V[:, :2]
    np.testing.assert_allclose(p.transform.to_raw(p.uv), V[:, :2], rtol=0, atol=1e-12)
    np.testing.assert_allclose(p.transform.from_raw(V[:, :2]), p.uv, rtol=0, atol=1e-12)
    assert not p.transform.mirrored
    given = np.column_stack([V[:, 1], V[:, 0]])  # swapping axes mirrors: faces come out clockwise
    q = parameterize(V, F, "uv", uv=given)
    check_domain(q, F)
    assert q.transform.mirrored and "mirrored" in q.messages[0]
    np.testing.assert_allclose(q.transform.to_raw(q.uv), given * [-1.0, 1.0], atol=1e-12)


def test_distortion_oracles():
    uv, F = random_delaunay(100, seed=7)
    V = np.column_stack([uv, np.zeros(len(uv))])
    p = parameterize(V, F, "uv")  # isometry: no distortion at all
    assert abs(p.distortion["angle_max"] - 1) < 1e-9 and abs(p.distortion["area_max"] - 1) < 1e-9
    q = parameterize(V, F, "uv", uv=uv * [2.0, 1.0])  # stretch by 2 in u: angle ratio 2, area unchanged
    np.testing.assert_allclose([q.distortion["angle_p50"], q.distortion["angle_max"]], 2.0, rtol=1e-9)
    assert abs(q.distortion["area_max"] - 1) < 1e-9
    r = parameterize(V, F, "lscm")  # planar mesh: LSCM is a similarity
    assert r.distortion["angle_max"] < 1 + 1e-6 and r.distortion["area_max"] < 1 + 1e-6


@pytest.mark.parametrize("method", ["harmonic", "lscm"])
def test_disk_with_holes(method):
    V, F = lift(*random_delaunay(400, holes=3, seed=8), lambda xy: np.sin(3 * xy[:, 0]) * np.cos(3 * xy[:, 1]))
    p = parameterize(V, F, method)
    check_domain(p, F)
    assert p.report["holes"] == 3


def test_cylinder_is_an_annulus():
    uv, F = annulus(6, 40)
    r = np.linalg.norm(uv, axis=1)
    ang = np.arctan2(uv[:, 1], uv[:, 0])
    V = np.column_stack([np.cos(ang), np.sin(ang), 2.0 * r])  # a tube: genus 0, two boundaries
    for method in ("harmonic", "lscm"):
        check_domain(parameterize(V, F, method), F)


def test_l_shape_and_bumpy_disk():
    V, F = lift(*l_shape(300, seed=1))
    for method in ("harmonic", "lscm", "uv"):
        check_domain(parameterize(V, F, method), F)
    V, F = bumpy_disk(3000)
    check_domain(parameterize(V, F, "harmonic"), F)


def test_folded_uv_is_repaired_keeping_the_boundary():
    uv, F = random_delaunay(150, seed=9)
    V = np.column_stack([uv, np.zeros(len(uv))])
    vm = validate_mesh(V, F)
    interior = np.setdiff1d(np.arange(len(uv)), np.concatenate(vm.boundary_loops))
    bad = uv.copy()
    bad[interior[[0, 1]]] = bad[interior[[1, 0]]]  # swap two interior vertices: folds
    nfold = int(np.sum(fold_mask(bad, F)[0] | fold_mask(bad, F)[1]))
    assert nfold > 0
    p = parameterize(V, F, "uv", uv=bad)
    check_domain(p, F)
    assert p.repaired == "composite_harmonic"
    assert p.distortion["flipped_before_repair"] + p.distortion["degenerate_before_repair"] == nfold
    loop = vm.boundary_loops[0]
    np.testing.assert_allclose(p.transform.to_raw(p.uv)[loop], bad[loop], atol=1e-8)
    with pytest.raises(MeshError, match=rf"folds {nfold} triangles") as e:
        parameterize(V, F, "uv", uv=bad, repair=False)
    assert e.value.kinds == ("folded",)


def test_collapsed_uv_falls_back_to_tutte():
    uv, F = random_delaunay(80, seed=10)
    V = np.column_stack([uv, np.zeros(len(uv))])
    flat = np.column_stack([uv[:, 0], np.zeros(len(uv))])  # every triangle degenerate
    p = parameterize(V, F, "uv", uv=flat)
    check_domain(p, F)
    assert p.repaired == "tutte"
    assert p.distortion["degenerate_before_repair"] == len(F)


def test_orientation_repair_is_reported():
    V, F = lift(*random_delaunay(100, seed=11))
    bad = F.copy()
    bad[[2, 5]] = bad[[2, 5]][:, [0, 2, 1]]
    p = parameterize(V, bad, "harmonic")
    np.testing.assert_array_equal(p.faces, F)
    assert any("repaired orientation of 2 faces" in m for m in p.messages)


def test_argument_errors():
    V, F = lift(*random_delaunay(30, seed=12))
    with pytest.raises(MeshError, match="unknown parameterization method 'conformal'"):
        parameterize(V, F, "conformal")
    with pytest.raises(MeshError, match="use method='uv'"):
        parameterize(V, F, "harmonic", uv=V[:, :2])
    with pytest.raises(MeshError, match=r"uv must have shape"):
        parameterize(V, F, "uv", uv=V[:5, :2])
    bad = V[:, :2].copy()
    bad[3] = np.inf
    with pytest.raises(MeshError, match="non-finite uv"):
        parameterize(V, F, "uv", uv=bad)
    # a uv collapsed to one point is all degenerate: repaired, never returned as is
    assert parameterize(V, F, "uv", uv=np.zeros((len(V), 2)) + 1.0).repaired == "tutte"


def test_fill_holes_makes_a_disk():
    V, F = lift(*random_delaunay(200, holes=2, seed=13))
    vm = validate_mesh(V, F)
    Vx, Fx = fill_holes(vm.V, vm.F, vm.boundary_loops[1:])
    assert Fx.shape[0] == F.shape[0] + sum(len(h) for h in vm.boundary_loops[1:])
    np.testing.assert_array_equal(Fx[: len(F)], F)
    vx = validate_mesh(Vx, Fx)
    assert vx.report["holes"] == 0 and vx.messages == []  # consistently oriented fill


@settings(max_examples=20, deadline=None)
@given(seed=st.integers(0, 10_000), holes=st.integers(0, 3), amp=st.floats(0.0, 1.5),
       n=st.integers(30, 300))
def test_property_fold_free(seed, holes, amp, n):
    uv, F = random_delaunay(n, holes=holes, seed=seed)
    V, F = lift(uv, F, lambda xy: amp * np.sin(4 * xy[:, 0] + seed) * np.cos(3 * xy[:, 1]))
    vm = validate_mesh(V, F)
    for method in ("harmonic", "lscm"):
        check_domain(parameterize(V, F, method), F)
    # Tutte on the hole-filled mesh with a convex boundary never folds
    Vx, Fx = fill_holes(vm.V, vm.F, vm.boundary_loops[1:])
    loop = vm.boundary_loops[0]
    t = np.linspace(0, 2 * np.pi, len(loop), endpoint=False)
    emb = tutte(Fx, len(Vx), loop, np.column_stack([np.cos(t), np.sin(t)]))
    fl, dg = fold_mask(emb, Fx)
    assert not fl.any() and not dg.any()
