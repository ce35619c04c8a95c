"""Incremental local editing (docs/design.md §3 'Local control', paper 5.3).

* exactness: any sequence of edits equals a full rebuild ``M @ free`` and stays C1;
* locality: the patches an edit reports are derived here from the topology
  (Triangulation tables and the space's choice of free points), independently of M,
  and compared exactly; a numeric check confirms nothing outside changes;
* the API: addressing by meaning, dependent points refused with their controllers,
  every validation error.
"""
from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from triangulations import triangulations

from trispline.spline.testing import domains
from trispline.spline.continuity import continuity_report
from trispline.spline.edit import DependentPointError, NotC1Error, SplineEditor
from trispline.spline.errors import InputError
from trispline.spline.propagation import (
    KIND_CORNER, KIND_FLIP, KIND_FRAME, KIND_INNER, KIND_MID, build_space,
)

C1_TOL = 1e-10


def editor_for(uv, faces, seed=0):
    space = build_space(uv, faces)
    free = np.random.default_rng(seed).normal(size=(space.n_free, 3))
    return SplineEditor(space, free)


# ----------------------------------------------------------------- topology oracle
class Oracle:
    """Expected affected patches of each free point, from the topology alone."""

    def __init__(self, space):
        self.space = space
        t = space.tri
        self.t = t
        self.lay = space.layout
        self.free_pts = set(space.free_point[space.free_point >= 0].tolist())
        F = t.faces
        self.ring = [set() for _ in range(t.n_vertices)]
        for f in range(t.n_faces):
            for v in F[f]:
                self.ring[v].add(f)

    def paper_direction(self, s: int) -> bool:
        """The vertex system of ``s`` solved for the middle points (no switch, no singularity)."""
        t, lay = self.t, self.lay
        for e in np.flatnonzero((t.edges == s).any(1)):
            end = 0 if t.edges[e, 0] == s else 1
            if not t.boundary_edge_mask[e] and int(lay.mid(e, end)) in self.free_pts:
                return False
        for f, k in zip(*np.nonzero(t.faces == s)):
            if int(lay.inner(f, k)) not in self.free_pts:
                return False
        return True

    def expected(self, j: int) -> tuple[set, bool]:
        """``(faces, exact)``: the affected patches (exact) or an upper bound."""
        sp_, t, lay = self.space, self.t, self.lay
        kind = int(sp_.free_kind[j])
        if kind in (KIND_CORNER, KIND_FRAME):
            v = j if kind == KIND_CORNER else (j - t.n_vertices) // 2
            return set(self.ring[v]), True
        p = int(sp_.free_point[j])
        if kind == KIND_INNER:
            f, k = divmod(p - lay.inner0, 3)
            s = int(t.faces[f, k])
            if not self.paper_direction(s):
                return set(self.ring[s]), False
            out = {f}
            for m in ((k + 1) % 3, (k + 2) % 3):  # the two edges of f at s
                g = int(t.face_adjacency[f, m])
                if g >= 0:
                    out.add(g)
            return out, True
        if kind == KIND_FLIP:
            f, k = divmod(p - lay.flip0, 3)
            e = int(t.face_edges[f, k])
            return {int(g) for g in t.edge_faces[e] if g >= 0}, True
        assert kind == KIND_MID
        e, end = divmod(p - lay.mid0, 2)
        if t.boundary_edge_mask[e]:
            return {int(g) for g in t.edge_faces[e] if g >= 0}, True
        return set(self.ring[int(t.edges[e, end])]), False  # switched direction at that end


def check_locality(ed: SplineEditor, ids: np.ndarray, rng) -> int:
    oracle = Oracle(ed.space)
    n_exact = 0
    for j in ids:
        want, exact = oracle.expected(int(j))
        res = ed.translate(int(j), rng.normal(size=3))
        got = set(res.faces.tolist())
        if exact:
            assert got == want, (ed.describe_free(int(j)), sorted(got), sorted(want))
            n_exact += 1
        else:
            assert got <= want, (ed.describe_free(int(j)), sorted(got - want))
        # the moved point's own patches are always affected
        if ed.space.free_point[j] >= 0:
            own = np.flatnonzero((ed.space.point_index == ed.space.free_point[j]).any(1))
            assert set(own.tolist()) <= got
    return n_exact


@settings(max_examples=50, deadline=None)
@given(triangulations(max_faces=200), st.integers(0, 2**31 - 1))
def test_locality_matches_topology(case, seed):
    kind, uv, faces = case
    ed = editor_for(uv, faces, seed)
    rng = np.random.default_rng(seed)
    n = ed.space.n_free
    ids = rng.choice(n, size=min(n, 120), replace=False)
    check_locality(ed, ids, rng)
    assert ed.rebuild_error() == 0.0


@pytest.mark.parametrize("name", ["delaunay", "alternate", "crisscross", "near_alternate"])
def test_locality_every_free_point(name):
    """Every free point of a mesh, with the exact set wherever the paper's direction holds."""
    if name == "delaunay":
        uv, f = domains.random_delaunay(60, seed=3)
    elif name == "near_alternate":
        uv, f = domains.grid(5, diagonal="alternate")
        uv = domains.perturb(uv, f, 1e-5, seed=1)
    else:
        uv, f = domains.grid(5, diagonal=name)
    ed = editor_for(uv, f, 1)
    n_exact = check_locality(ed, np.arange(ed.space.n_free), np.random.default_rng(0))
    kinds = ed.space.free_kind
    # corners, frames, flips and boundary points are always exact
    assert n_exact >= int(np.isin(kinds, [KIND_CORNER, KIND_FRAME, KIND_FLIP]).sum())
    if name == "delaunay":  # only the straight boundary's vertices switch direction
        assert n_exact >= 0.8 * ed.space.n_free


def test_nothing_outside_reported_points_changes():
    uv, f = domains.random_delaunay(80, seed=5)
    ed = editor_for(uv, f, 2)
    rng = np.random.default_rng(1)
    for j in rng.choice(ed.space.n_free, 40, replace=False):
        before = ed.points.copy()
        res = ed.translate(int(j), rng.normal(size=3))
        changed = np.flatnonzero((ed.points != before).any(1))
        assert set(changed.tolist()) <= set(res.points.tolist())
        assert ed.space.point_index[res.faces].size  # patches exist
        outside = np.setdiff1d(np.arange(ed.space.tri.n_faces), res.faces)
        np.testing.assert_array_equal(ed.ctrl[outside], before[ed.space.point_index[outside]])
        np.testing.assert_array_equal(res.ctrl, ed.ctrl[res.faces])


def test_corner_region_move_touches_exactly_the_ring_and_locally_few_points():
    uv, f = domains.random_delaunay(150, seed=7)
    ed = editor_for(uv, f, 3)
    t = ed.space.tri
    v = int(np.flatnonzero(~t.boundary_vertex_mask)[0])
    ring = np.flatnonzero((t.faces == v).any(1))
    for j in [ed.corner_point(v), *ed.frame_points(v)]:
        res = ed.translate(j, [0.1, 0.2, 0.3])
        np.testing.assert_array_equal(res.faces, ring)
        # points: corner, stars at v, middle points at v's end, dependent flips of v's edges
        deg = int((t.edges == v).any(1).sum())
        assert res.points.size <= 1 + deg + deg + deg
    # flip point: the other flip only
    e = int(t.interior_edges[0])
    f0, k0 = t.edge_faces[e, 0], t.edge_opposite[e, 0]
    f1, k1 = t.edge_faces[e, 1], t.edge_opposite[e, 1]
    flips = {int(ed.space.layout.flip(f0, k0)), int(ed.space.layout.flip(f1, k1))}
    free_flip = [p for p in flips if ed.point_free_id(p) >= 0]
    assert len(free_flip) == 1
    res = ed.move_point(free_flip[0], [1.0, 2.0, 3.0])
    assert set(res.points.tolist()) == flips
    np.testing.assert_array_equal(res.faces, np.sort([f0, f1]))


# ------------------------------------------------------------------- exactness
@settings(max_examples=50, deadline=None)
@given(triangulations(max_faces=200), st.integers(0, 2**31 - 1))
def test_any_edit_sequence_equals_full_rebuild_and_stays_c1(case, seed):
    kind, uv, faces = case
    ed = editor_for(uv, faces, seed)
    rng = np.random.default_rng(seed)
    n, nv = ed.space.n_free, ed.space.tri.n_vertices
    for step in range(25):
        op = step % 4
        if op == 0:
            ed.move(int(rng.integers(n)), rng.normal(size=3))
        elif op == 1:
            k = int(rng.integers(1, min(n, 50) + 1))
            ed.move(rng.choice(n, k, replace=False), rng.normal(size=(k, 3)) * 10.0)
        elif op == 2:
            ed.move_vertex(int(rng.integers(nv)), rng.normal(size=3), carry_frame=bool(rng.integers(2)))
        else:
            ed.translate(rng.choice(n, 3, replace=False) if n >= 3 else 0, rng.normal(size=3))
    full = ed.space.control_points(ed.free)
    ctrl = ed.ctrl
    scale = np.abs(full).max()
    np.testing.assert_allclose(ctrl, full, rtol=0, atol=1e-12 * scale)
    np.testing.assert_array_equal(ctrl, full)  # same summation order as scipy: bit for bit
    rep = continuity_report(ed.space.tri, ctrl)
    assert rep["c1_relative"] < C1_TOL, (kind, rep)


def test_undo_restores_bitwise():
    uv, f = domains.grid(6, diagonal="crisscross")
    ed = editor_for(uv, f, 4)
    before = ed.points.copy()
    rng = np.random.default_rng(2)
    ids = rng.choice(ed.space.n_free, 30, replace=False)
    res = ed.move(ids, rng.normal(size=(30, 3)))
    assert (ed.points != before).any()
    ed.move(res.free_ids, res.old_free)
    np.testing.assert_array_equal(ed.points, before)


def test_batch_equals_sequence_of_single_edits():
    uv, f = domains.random_delaunay(100, seed=9)
    a, b = editor_for(uv, f, 5), editor_for(uv, f, 5)
    rng = np.random.default_rng(3)
    ids = rng.choice(a.space.n_free, 200, replace=False)
    pos = rng.normal(size=(200, 3))
    res = a.move(ids, pos)
    pts, fcs = set(), set()
    for j, p in zip(ids, pos):
        r = b.move(int(j), p)
        pts |= set(r.points.tolist())
        fcs |= set(r.faces.tolist())
    np.testing.assert_array_equal(a.points, b.points)
    assert set(res.points.tolist()) == pts and set(res.faces.tolist()) == fcs


def test_move_vertex_reinterpolates_and_translates_the_corner_region():
    uv, f = domains.random_delaunay(60, seed=2)
    ed = editor_for(uv, f, 6)
    t, lay = ed.space.tri, ed.space.layout
    v = int(np.flatnonzero(~t.boundary_vertex_mask)[0])
    es = np.flatnonzero((t.edges == v).any(1))
    stars = lay.star(es, (t.edges[es, 1] == v).astype(np.int64))
    rel = ed.points[stars] - ed.points[v]
    xyz = np.array([3.0, -1.0, 2.0])
    res = ed.move_vertex(v, xyz)
    np.testing.assert_array_equal(ed.points[v], xyz)
    np.testing.assert_array_equal(res.faces, np.flatnonzero((t.faces == v).any(1)))
    np.testing.assert_allclose(ed.points[stars] - ed.points[v], rel, atol=1e-12)
    ed.move_vertex(v, xyz + 1.0, carry_frame=False)  # tilts instead: stars move less
    assert not np.allclose(ed.points[stars] - ed.points[v], rel)
    assert continuity_report(t, ed.ctrl)["c1_relative"] < C1_TOL


# ------------------------------------------------------------ addressing by meaning
def test_addressing_by_meaning():
    uv, f = domains.random_delaunay(50, seed=1)
    ed = editor_for(uv, f, 7)
    sp_, lay, t = ed.space, ed.space.layout, ed.space.tri
    assert ed.corner_point(3) == sp_.corner_free[3]
    np.testing.assert_array_equal(ed.frame_points(3), sp_.frame_free[3])
    j = ed.inner_point(4, 1)
    assert sp_.free_point[j] == lay.inner(4, 1) and sp_.free_kind[j] == KIND_INNER
    be = int(t.boundary_edges[0])
    j = ed.mid_point(be, 0)
    assert sp_.free_point[j] == lay.mid(be, 0) and sp_.free_kind[j] == KIND_MID
    for j in range(sp_.n_free):
        text = ed.describe_free(j)
        assert text.startswith(f"free {j} (")
    # exactly one of each interior edge's flips is free, addressed by (face, local edge)
    e = int(t.interior_edges[0])
    got = []
    for side in (0, 1):
        try:
            got.append(ed.flip_point(t.edge_faces[e, side], t.edge_opposite[e, side]))
        except DependentPointError as exc:
            assert exc.point == lay.flip(t.edge_faces[e, side], t.edge_opposite[e, side])
    assert len(got) == 1 and sp_.free_kind[got[0]] == KIND_FLIP


def test_dependent_point_is_refused_naming_its_controllers():
    uv, f = domains.random_delaunay(50, seed=1)
    ed = editor_for(uv, f, 8)
    t, lay = ed.space.tri, ed.space.layout
    e = int(t.interior_edges[0])
    dep = int(lay.mid(e, 0))
    assert ed.point_free_id(dep) == -1
    row = ed.space.M.tocsr()[[dep], :].toarray()[0]
    want = np.flatnonzero(row)
    with pytest.raises(DependentPointError) as info:
        ed.move_point(dep, [0.0, 0.0, 0.0])
    np.testing.assert_array_equal(np.sort(info.value.controllers), want)
    msg = str(info.value)
    assert f"control point {dep}" in msg and "middle point of edge" in msg
    for j in want:
        assert f"free {j} (" in msg
    assert "inner" in msg and "corner" in msg and "frame" in msg
    with pytest.raises(DependentPointError, match="star point"):
        ed.move_point(int(lay.star(0, 0)), [0.0, 0.0, 0.0])
    with pytest.raises(DependentPointError):
        ed.mid_point(e, 1)
    assert isinstance(info.value, InputError)


def test_grid_inner_points_switch_direction_and_stay_local():
    """On an alternating grid some vertex systems pivot onto inner points: those are
    dependent (refused) and the free middle points replace them, still local."""
    uv, f = domains.grid(4, diagonal="alternate")
    ed = editor_for(uv, f, 9)
    kinds = ed.space.free_kind
    t = ed.space.tri
    interior_mids = [j for j in np.flatnonzero(kinds == KIND_MID)
                     if not t.boundary_edge_mask[(ed.space.free_point[j] - ed.space.layout.mid0) // 2]]
    assert interior_mids, "expected switched vertex systems on the alternating grid"
    refused = 0
    for fi in range(t.n_faces):
        for k in range(3):
            try:
                ed.inner_point(fi, k)
            except DependentPointError:
                refused += 1
    assert refused == len(interior_mids) - ed.space.n_singular


# ------------------------------------------------------------------- validation
def test_validation_errors():
    uv, f = domains.random_delaunay(30, seed=1)
    space = build_space(uv, f)
    free = np.zeros((space.n_free, 3))
    with pytest.raises(InputError, match="shape"):
        SplineEditor(space, free[:-1])
    bad = free.copy()
    bad[5, 1] = np.nan
    with pytest.raises(InputError, match=r"free has non-finite entries in 1 \(first: 5\)"):
        SplineEditor(space, bad)
    ed = SplineEditor(space, free)
    with pytest.raises(InputError, match="outside"):
        ed.move(space.n_free, [0, 0, 0])
    with pytest.raises(InputError, match="outside"):
        ed.move([-1, 2], np.zeros((2, 3)))
    with pytest.raises(InputError, match="repeat"):
        ed.move([3, 4, 3], np.zeros((3, 3)))
    with pytest.raises(InputError, match="integer"):
        ed.move(1.5, [0, 0, 0])
    with pytest.raises(InputError, match="positions must have shape"):
        ed.move([1, 2], np.zeros((3, 3)))
    with pytest.raises(InputError, match="positions has non-finite entries"):
        ed.move(1, [0, np.inf, 0])
    with pytest.raises(InputError, match="vertex"):
        ed.move_vertex(space.tri.n_vertices, [0, 0, 0])
    with pytest.raises(InputError, match="vertex"):
        ed.frame_points(-1)
    with pytest.raises(InputError, match="face"):
        ed.inner_point(space.tri.n_faces, 0)
    with pytest.raises(InputError, match="local index"):
        ed.flip_point(0, 3)
    with pytest.raises(InputError, match="edge"):
        ed.mid_point(space.tri.n_edges, 0)
    with pytest.raises(InputError, match="control point id"):
        ed.move_point(space.n_points, [0, 0, 0])
    with pytest.raises(InputError, match="control point id"):
        ed.controllers(-1)
    # a failed edit leaves the state untouched
    assert ed.rebuild_error() == 0.0 and not ed.free.any()


def test_from_surface_round_trip_and_non_c1_refused():
    from trispline.spline.surface import SplineSurface

    uv, f = domains.random_delaunay(40, seed=4)
    ed = editor_for(uv, f, 10)
    surf = ed.to_surface()
    ed2 = SplineEditor.from_surface(surf)
    np.testing.assert_allclose(ed2.ctrl, ed.ctrl, atol=1e-12 * np.abs(ed.ctrl).max())
    from trispline.spline.index import FLIP

    lay = ed.space.layout
    dep = [p for p in range(lay.flip0, lay.n_points) if ed.point_free_id(p) < 0][0]
    fi, k = divmod(dep - lay.flip0, 3)
    ctrl = np.array(surf.ctrl)
    ctrl[fi, FLIP[k]] += 0.5  # a dependent flip point moved off the C1 space
    with pytest.raises(NotC1Error, match=rf"patches 1 \(first: {fi}\)"):
        SplineEditor.from_surface(SplineSurface(uv, f, ctrl))
    with pytest.raises(InputError, match="ctrl"):
        SplineEditor.from_surface(surf, build_space(*domains.random_delaunay(41, seed=4)))
