"""validate_mesh: one negative test per problem, orientation repair, keep_largest."""
from __future__ import annotations

import numpy as np
import pytest

from trispline.param import MeshError, repair_mesh, validate_mesh
from trispline.param.testing import lift
from trispline.spline.testing.domains import annulus, random_delaunay
from trispline.spline.errors import InputError


def disk(seed: int = 0, n: int = 40):
    return lift(*random_delaunay(n, seed=seed))


def grid_torus(nu: int = 8, nv: int = 6):
    """Closed torus (genus 1) as a quad grid split into triangles."""
    i, j = np.meshgrid(np.arange(nu), np.arange(nv), indexing="ij")
    a, b = 2 * np.pi * i.ravel() / nu, 2 * np.pi * j.ravel() / nv
    V = np.column_stack([(2 + np.cos(b)) * np.cos(a), (2 + np.cos(b)) * np.sin(a), np.sin(b)])
    idx = lambda p, q: (p % nu) * nv + (q % nv)  # noqa: E731
    p, q = i.ravel(), j.ravel()
    F = np.concatenate([np.column_stack([idx(p, q), idx(p + 1, q), idx(p + 1, q + 1)]),
                        np.column_stack([idx(p, q), idx(p + 1, q + 1), idx(p, q + 1)])])
    return V, F


def tetrahedron():
    V = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], float)
    F = np.array([[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]])
    return V, F


def moebius(n: int = 12):
    t = 2 * np.pi * np.arange(n) / n
    V = []
    for s in (-0.3, 0.3):
        V.append(np.column_stack([(1 + s * np.cos(t / 2)) * np.cos(t), (1 + s * np.cos(t / 2)) * np.sin(t),
                                  s * np.sin(t / 2)]))
    V = np.concatenate(V)  # vertex (i, side) = side * n + i
    F = []
    for i in range(n):
        a0, a1 = i, n + i
        if i < n - 1:
            b0, b1 = i + 1, n + i + 1
        else:  # the half twist swaps the sides
            b0, b1 = n, 0
        F += [[a0, b0, b1], [a0, b1, a1]]
    return V, np.array(F)


def test_valid_disk_report():
    V, F = disk()
    vm = validate_mesh(V, F)
    assert vm.report["boundary_loops"] == 1 and vm.report["holes"] == 0 and vm.report["genus"] == 0
    assert vm.report["euler_characteristic"] == 1
    np.testing.assert_array_equal(vm.F, F)
    assert vm.messages == [] and vm.kept is None
    loop = vm.boundary_loops[0]
    # the loop has the surface on its left: it is CCW in the (planar) xy plane
    P = V[loop, :2]
    assert 0.5 * np.sum(P[:, 0] * np.roll(P[:, 1], -1) - np.roll(P[:, 0], -1) * P[:, 1]) > 0


def test_holes_counted():
    V, F = lift(*random_delaunay(200, holes=3, seed=1))
    vm = validate_mesh(V, F)
    assert vm.report["holes"] == 3 and vm.report["boundary_loops"] == 4
    lengths = [np.linalg.norm(V[l] - V[np.roll(l, -1)], axis=1).sum() for l in vm.boundary_loops]
    assert lengths == sorted(lengths, reverse=True)


def test_planar_input_and_cylinder_are_valid():
    uv, F = annulus(3, 16)
    vm = validate_mesh(uv, F)  # (nv, 2) is lifted to z = 0
    assert vm.V.shape == (uv.shape[0], 3) and vm.report["holes"] == 1


def test_non_finite():
    V, F = disk()
    V[[3, 7]] = np.nan
    with pytest.raises(MeshError, match=r"non-finite vertex coordinates .* 2 \(first: 3, 7\)") as e:
        validate_mesh(V, F)
    assert e.value.kinds == ("non_finite",)
    assert isinstance(e.value, InputError)


def test_out_of_range_and_repeated_ids():
    V, F = disk()
    F = F.copy()
    F[4, 1] = len(V) + 2
    F[9, 2] = -1
    with pytest.raises(MeshError, match=r"outside \[0, \d+\): 2 \(first: 4, 9\)"):
        validate_mesh(V, F)
    F2 = disk()[1].copy()
    F2[5] = [F2[5, 0], F2[5, 0], F2[5, 2]]
    with pytest.raises(MeshError, match=r"repeated vertex id: 1 \(first: 5\)") as e:
        validate_mesh(V, F2)
    assert e.value.kinds == ("repeated_vertex_id",)


def test_shape_errors():
    V, F = disk()
    with pytest.raises(MeshError, match="shape"):
        validate_mesh(V[:, :1], F)
    with pytest.raises(MeshError, match="triangles"):
        validate_mesh(V, np.zeros((3, 4), int))
    with pytest.raises(MeshError, match="integer"):
        validate_mesh(V, F.astype(float))
    with pytest.raises(MeshError, match="no faces"):
        validate_mesh(V, np.zeros((0, 3), int))


def test_unreferenced_vertices():
    V, F = disk()
    V = np.concatenate([V, [[5.0, 5.0, 5.0]]])
    with pytest.raises(MeshError, match=rf"used by no face: 1 \(first: {len(V) - 1}\)"):
        validate_mesh(V, F)


def test_zero_area_faces():
    V, F = disk()
    f = 10
    a, b, c = F[f]
    V = V.copy()
    # move one vertex of face f onto the midpoint of the opposite edge (zero area, no id repeated)
    V[c] = 0.5 * (V[a] + V[b])
    with pytest.raises(MeshError, match=r"zero-area faces .*first: .*\b10\b") as e:
        validate_mesh(V, F)
    assert "zero_area" in e.value.kinds


def test_non_manifold_edge():
    V, F = disk()
    e = np.sort(np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]), axis=1)
    uniq, cnt = np.unique(e, axis=0, return_counts=True)
    a, b = uniq[cnt == 2][0]  # an interior edge: adding a third face makes it non-manifold
    V = np.concatenate([V, [[0.5, 0.5, 1.0]]])
    F = np.concatenate([F, [[b, a, len(V) - 1]]])
    with pytest.raises(MeshError, match=r"non-manifold edges \(shared by more than 2 faces\): 1 edges") as e:
        validate_mesh(V, F)
    assert e.value.kinds == ("non_manifold_edges",)


def test_duplicate_faces_are_named_and_repair_mesh_drops_them():
    V, F = disk()
    doubled = np.concatenate([F, F[[3, 0]][:, ::-1]])  # two faces again, one each way round
    with pytest.raises(MeshError, match=r"(?s)duplicate faces \(the three vertices of an earlier face\): 2 \(first: "
                       rf"{len(F)}, {len(F) + 1}\).*--repair") as e:
        validate_mesh(V, doubled)
    assert set(e.value.kinds) == {"duplicate_faces", "non_manifold_edges"}
    r = repair_mesh(V, doubled)
    assert r.changes["duplicate_faces"] == 2 and np.array_equal(r.F, F)


def test_only_repairable_problems_point_at_repair():
    V, F = disk()
    with pytest.raises(MeshError, match="--repair"):
        validate_mesh(V, np.concatenate([F, [[0, 0, 1]]]))
    with pytest.raises(MeshError) as e:
        validate_mesh(V, np.concatenate([F, [[0, 1, len(V)]]]))
    assert "--repair" not in str(e.value)


def test_bowtie_vertex():
    V = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [-1, 0, 0], [-1, -1, 0]], float)
    F = np.array([[0, 1, 2], [0, 3, 4]])
    with pytest.raises(MeshError, match=r"bowtie\) vertices.*: 1 \(first: 0\)") as e:
        validate_mesh(V, F)
    assert e.value.kinds == ("bowtie_vertices",)


def test_components_and_keep_largest():
    V1, F1 = disk(0, 60)
    V2, F2 = disk(1, 10)
    V = np.concatenate([V2 + 5.0, V1])
    F = np.concatenate([F2, F1 + len(V2)])
    with pytest.raises(MeshError, match=rf"2 connected components \(faces per component: {len(F1)}, {len(F2)}\)"
                       r".*keep-largest") as e:
        validate_mesh(V, F)
    assert e.value.kinds == ("components",)
    vm = validate_mesh(V, F, keep_largest=True)
    np.testing.assert_array_equal(vm.kept, np.arange(len(V2), len(V)))
    np.testing.assert_array_equal(vm.kept_faces, np.arange(len(F2), len(F)))
    np.testing.assert_array_equal(vm.F, F1)
    np.testing.assert_array_equal(vm.V, V1)
    assert "kept the largest of 2" in vm.messages[0]
    assert "seam" not in str(e.value)  # apart: no hint


def test_components_split_by_a_seam_of_duplicated_vertices_say_so():
    """Two halves of a square whose middle column of vertices is written twice (as exporters do at texture
    seams): the refusal counts the vertices that coincide across components and says to merge them."""
    n = 6
    x, y = np.meshgrid(np.arange(n + 1.0), np.arange(n + 1.0))
    V = np.column_stack([x.ravel(), y.ravel(), 0.1 * x.ravel() ** 2])
    idx = np.arange((n + 1) ** 2).reshape(n + 1, n + 1)
    a, b, c, d = idx[:-1, :-1].ravel(), idx[:-1, 1:].ravel(), idx[1:, :-1].ravel(), idx[1:, 1:].ravel()
    F = np.r_[np.c_[a, b, d], np.c_[a, d, c]]
    middle = idx[:, n // 2]
    copy = np.full(len(V), -1)
    copy[middle] = len(V) + np.arange(middle.size)
    right = V[F].mean(1)[:, 0] > n // 2
    F[right] = np.where(copy[F[right]] >= 0, copy[F[right]], F[right])
    V = np.r_[V, V[middle]]
    with pytest.raises(MeshError, match=rf"2 connected components.*{2 * middle.size} vertices lie exactly on a "
                                        r"vertex of another component \(a seam.*merge them") as e:
        validate_mesh(V, F)
    assert e.value.kinds == ("components",)


def test_several_problems_in_one_error():
    V = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [-1, 0, 0], [-1, -1, 0], [5, 5, 5], [6, 5, 5], [5, 6, 5]],
                 float)
    F = np.array([[0, 1, 2], [0, 3, 4], [5, 6, 7]])
    with pytest.raises(MeshError, match=r"2 problems") as e:
        validate_mesh(V, F)
    assert set(e.value.kinds) == {"components", "bowtie_vertices"}


def test_closed_mesh():
    with pytest.raises(MeshError, match="closed.*trispline fits open surfaces.*cut") as e:
        validate_mesh(*tetrahedron())
    assert e.value.kinds == ("closed",)


def test_not_a_disk_reports_genus():
    V, F = grid_torus()
    with pytest.raises(MeshError, match="closed"):
        validate_mesh(V, F)
    with pytest.raises(MeshError, match=r"not a disk or a disk with holes: genus 1 with 1 boundary loops") as e:
        validate_mesh(V, F[1:])  # a torus with one face removed
    assert e.value.kinds == ("not_disk",)


def test_non_orientable():
    with pytest.raises(MeshError, match="not orientable") as e:
        validate_mesh(*moebius())
    assert e.value.kinds == ("non_orientable",)


def test_orientation_repaired_in_place():
    V, F = disk(2, 80)
    bad = F.copy()
    flip = np.array([3, 11, 12, 40])
    bad[flip] = bad[flip][:, [0, 2, 1]]
    vm = validate_mesh(V, bad)
    np.testing.assert_array_equal(vm.F, F)  # majority orientation kept, face order kept
    assert vm.messages == ["repaired orientation of 4 faces (rows reversed, face order kept)"]
    assert vm.report["reoriented_faces"] == 4
    # the minority decides nothing: flipping most faces flips the rest back
    most = F[:, [0, 2, 1]].copy()
    most[flip] = F[flip]
    vm2 = validate_mesh(V, most)
    np.testing.assert_array_equal(vm2.F, F[:, [0, 2, 1]])
