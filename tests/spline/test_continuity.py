"""The C0/C1 residuals gather each edge's points correctly (an independent per-edge loop is the oracle)."""
from __future__ import annotations

import numpy as np

from trispline.spline.continuity import continuity_report, continuity_residuals
from trispline.spline.index import local_index
from trispline.spline.propagation import build_space
from trispline.spline.testing import domains
from trispline.spline.topology import Triangulation


def _loop_residuals(tri: Triangulation, ctrl: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(c0 (E,), c1 (E, 5))`` edge by edge from the faces' vertex order (no tables, no diamond ids)."""
    c0, c1 = [], []
    for a, b in tri.edges[tri.interior_edges]:
        fa = [f for f in range(tri.n_faces) if {a, b} <= set(tri.faces[f])]
        f0, f1 = fa
        if (list(tri.faces[f0]).index(b) - list(tri.faces[f0]).index(a)) % 3 != 1:
            f0, f1 = f1, f0  # f0 runs a -> b (counter-clockwise), as the module's diamonds do
        loc0 = {int(v): k for k, v in enumerate(tri.faces[f0])}
        loc1 = {int(v): k for k, v in enumerate(tri.faces[f1])}
        p = next(v for v in loc0 if v not in (a, b))
        q = next(v for v in loc1 if v not in (a, b))
        c0.append(max(np.linalg.norm(ctrl[f0, local_index({loc0[a]: j, loc0[b]: 5 - j})]
                                     - ctrl[f1, local_index({loc1[a]: j, loc1[b]: 5 - j})]) for j in range(6)))
        # q = lam p + mu a + nu b in uv
        lam, mu, nu = np.linalg.solve(np.vstack([np.column_stack([tri.uv[p], tri.uv[a], tri.uv[b]]), np.ones(3)]),
                                      np.r_[tri.uv[q], 1.0])
        row = []
        for i in range(5):
            xq = ctrl[f1, local_index({loc1[q]: 1, loc1[a]: i, loc1[b]: 4 - i})]
            xp = ctrl[f0, local_index({loc0[p]: 1, loc0[a]: i, loc0[b]: 4 - i})]
            xa = ctrl[f0, local_index({loc0[a]: i + 1, loc0[b]: 4 - i})]
            xb = ctrl[f0, local_index({loc0[a]: i, loc0[b]: 5 - i})]
            row.append(np.linalg.norm(xq - (lam * xp + mu * xa + nu * xb)))
        c1.append(row)
    return np.array(c0), np.array(c1)


def test_residuals_match_a_per_edge_loop():
    uv, faces = domains.random_delaunay(40, seed=3)
    tri = Triangulation(uv, faces)
    ctrl = np.random.default_rng(7).standard_normal((tri.n_faces, 21, 3))
    res = continuity_residuals(tri, ctrl)
    c0, c1 = _loop_residuals(tri, ctrl)
    np.testing.assert_allclose(res["c0"], c0, rtol=1e-12, atol=1e-12)
    # the module's diamond coefficients are the oracle's (1, -lam, -mu, -nu) times one factor per edge
    ratio = res["c1"] / c1
    np.testing.assert_allclose(ratio, np.broadcast_to(ratio[:, :1], ratio.shape), rtol=1e-9)
    assert (ratio > 0).all()
    rep = continuity_report(tri, ctrl[..., :1])  # one coordinate: the scale is its range
    assert rep["scale"] == float(np.ptp(ctrl[..., 0]))


def test_a_c1_net_reports_zero_and_a_broken_one_does_not():
    uv, faces = domains.random_delaunay(40, seed=3)
    space = build_space(Triangulation(uv, faces))
    free = np.random.default_rng(1).standard_normal((space.n_free, 3))
    ctrl = space.control_points(free)
    assert continuity_report(space.tri, ctrl)["c1_relative"] < 1e-10
    tri = space.tri
    interior = {tuple(sorted(e)) for e in tri.edges[tri.interior_edges].tolist()}
    f = next(f for f in range(tri.n_faces) if tuple(sorted(tri.faces[f, 1:].tolist())) in interior)
    ctrl[f, local_index({0: 1, 1: 2, 2: 2})] += 1e-3  # a point of the C1 conditions of an interior edge
    assert continuity_report(tri, ctrl)["c1_relative"] > 1e-6


def test_sampled_continuity_in_edge_ranges_equals_one_range_and_reports_each(monkeypatch):
    """The sampled check runs in edge ranges on threads: per-edge jumps bit for bit those of one range,
    the gradient scale to rounding, and ``report`` rises to 1 once per range."""
    from trispline.spline import patches

    uv, faces = domains.random_delaunay(400, holes=1, seed=3)
    space = build_space(uv, faces)
    ctrl = space.control_points(np.random.default_rng(2).normal(size=(space.n_free, 3)))
    whole = patches.numeric_continuity(space.tri.uv, space.tri.faces, ctrl, 5)
    monkeypatch.setattr(patches, "CONTINUITY_CHUNK", 64)
    seen: list[float] = []
    ranged = patches.numeric_continuity(space.tri.uv, space.tri.faces, ctrl, 5, seen.append)
    np.testing.assert_array_equal(ranged["c0_per_edge"], whole["c0_per_edge"])
    np.testing.assert_array_equal(ranged["c1_per_edge"], whole["c1_per_edge"])
    np.testing.assert_allclose(ranged["gradient_scale"], whole["gradient_scale"], rtol=1e-13)
    assert len(seen) == -(-space.tri.interior_edges.size // 64) and seen == sorted(seen) and seen[-1] == 1.0
    assert whole["c1_relative"] < 1e-12  # a C1 net: the jumps are rounding
