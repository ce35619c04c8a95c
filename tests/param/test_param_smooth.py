"""uv smoothing (param/smooth.py): exact on polynomial maps, boundary on the outline, fold-free."""
from __future__ import annotations

import importlib

import numpy as np
import pytest

from trispline.param import parameterize, validate_mesh
from trispline.param.distortion import fold_mask
from trispline.param.smooth import fit_weights, smooth_uv
from trispline.param.testing import bumpy_disk
from trispline.spline.testing.domains import perturb, random_delaunay

smooth_module = importlib.import_module("trispline.param.smooth")


def _square(n: int = 300, seed: int = 0) -> tuple[np.ndarray, np.ndarray, list[np.ndarray]]:
    """A planar unit square mesh ``V (nv, 3)`` (z = 0), ``F`` and its boundary loops."""
    uv, F = random_delaunay(n, seed=seed)
    V = np.column_stack([uv, np.zeros(len(uv))])
    return V, F, validate_mesh(V, F).boundary_loops


def test_a_loops_arc_lengths_are_exact_on_a_circle_and_the_chords_on_straight_sides():
    rng = np.random.default_rng(3)
    t = np.sort(rng.uniform(0, 2 * np.pi, 40))
    r = 1.7
    P = np.column_stack([r * np.cos(t), r * np.sin(t), np.full(40, 0.3)])
    arcs = smooth_module._arc_lengths(P, np.zeros(40, bool))
    exact = r * np.diff(np.append(t, t[0] + 2 * np.pi))
    chords = np.linalg.norm(np.roll(P, -1, 0) - P, axis=1)
    np.testing.assert_allclose(arcs, exact, rtol=1e-12)
    assert np.abs(chords - exact).max() > 1e-4 * exact.max()  # what the arcs correct
    # a square with 3 points a side: straight, and its corners take no curvature across them
    s = np.array([0.0, 0.5, 1.0])
    sq = np.concatenate([np.column_stack([s[:-1], 0 * s[:-1]]), np.column_stack([1 + 0 * s[:-1], s[:-1]]),
                         np.column_stack([1 - s[:-1], 1 + 0 * s[:-1]]), np.column_stack([0 * s[:-1], 1 - s[:-1]])])
    sq = np.column_stack([sq, np.zeros(len(sq))])
    corner = smooth_module.loop_corners(sq)
    assert corner.sum() == 4
    np.testing.assert_allclose(smooth_module._arc_lengths(sq, corner), 0.5, rtol=1e-14)


@pytest.mark.parametrize("dim, degree", [(1, 3), (2, 3), (2, 2), (2, 1)])
def test_fit_weights_reproduce_polynomials_of_their_degree(dim, degree):
    rng = np.random.default_rng(1)
    x = rng.uniform(-2, 2, (5, 16, dim))
    x[:, 0] = 0.0  # the vertex itself
    w = rng.uniform(0.2, 1.0, (5, 16))
    s = fit_weights(x, w, degree)
    np.testing.assert_allclose(s.sum(1), 1.0, atol=1e-12)
    for c in rng.normal(size=(3, 10)):  # value at 0 of a polynomial of the degree = its constant
        y = c[0] + sum(c[1 + k] * x[..., k % dim] ** (1 + k // dim) for k in range(degree * dim))
        np.testing.assert_allclose((s * y).sum(1), c[0], atol=1e-10)


def test_fit_weights_fall_back_to_lower_degree_and_to_the_vertex():
    x = np.zeros((2, 6, 2))
    x[0, :, 0] = np.arange(6) - 2.0  # collinear: no 2D fit of any degree is well posed
    x[0] = np.roll(x[0], -2, 0)  # the vertex (at 0) first
    x[1, :3] = [[0, 0], [1, 0], [0, 1]]  # three points: degree 1 only (6 coefficients need 6 points)
    x[1, 3:] = [[0.0, 0.0]] * 3
    w = np.ones((2, 6))
    w[1, 3:] = 0.0
    s = fit_weights(x, w, 3)
    np.testing.assert_array_equal(s[0], np.eye(6)[0])
    np.testing.assert_allclose(s[1, :3], [1.0, 0.0, 0.0], atol=1e-12)  # the plane through 3 points at 0


@pytest.mark.parametrize("method", ["global", "local"])
def test_an_affine_map_is_reproduced_exactly(method):
    V, F, loops = _square()
    A = np.array([[1.3, 0.4], [-0.2, 0.9]])
    uv = V[:, :2] @ A.T + [0.5, -1.0]
    new, info = smooth_uv(V, F, uv, loops, method=method)
    np.testing.assert_allclose(new, uv, atol=1e-12)
    assert info["moved_max"] < 1e-10 and not info["fallback"] and info["reverted"] == 0


def _rough_square() -> tuple[np.ndarray, np.ndarray, list[np.ndarray], np.ndarray]:
    """The 600-vertex square, its loops and its map jittered: interior by 2% of an edge, sides along themselves."""
    V, F, loops = _square(600, seed=2)
    rough = perturb(V[:, :2], F, 0.02, seed=3)  # interior jittered by 2% of an edge
    bnd = loops[0]
    # also jitter the boundary vertices along their sides (not the corners)
    rng = np.random.default_rng(4)
    on_x = np.isin(V[bnd, 1], [0.0, 1.0]) & ~np.isin(V[bnd, 0], [0.0, 1.0])
    on_y = np.isin(V[bnd, 0], [0.0, 1.0]) & ~np.isin(V[bnd, 1], [0.0, 1.0])
    rough[bnd[on_x], 0] += 0.002 * rng.uniform(-1, 1, on_x.sum())
    rough[bnd[on_y], 1] += 0.002 * rng.uniform(-1, 1, on_y.sum())
    return V, F, loops, rough


@pytest.mark.parametrize("method", ["global", "local"])
def test_a_rough_map_is_smoothed_boundary_kept_on_its_sides_and_corners_fixed(method):
    V, F, loops, rough = _rough_square()
    bnd = loops[0]
    on_x = np.isin(V[bnd, 1], [0.0, 1.0]) & ~np.isin(V[bnd, 0], [0.0, 1.0])
    on_y = np.isin(V[bnd, 0], [0.0, 1.0]) & ~np.isin(V[bnd, 1], [0.0, 1.0])
    new, info = smooth_uv(V, F, rough, loops, method=method)
    assert not info["fallback"]
    err_before = np.linalg.norm(rough - V[:, :2], axis=1)
    err_after = np.linalg.norm(new - V[:, :2], axis=1)
    # noise averaged over a 2-ring (about 19 points) by a cubic (10 coefficients): ~ sqrt(10/19)
    assert np.sqrt(np.mean(err_after**2)) < 0.7 * np.sqrt(np.mean(err_before**2))
    # the sides are straight in uv: their vertices stay exactly on them, the corners do not move
    np.testing.assert_allclose(new[bnd[on_x], 1], V[bnd[on_x], 1], atol=1e-13)
    np.testing.assert_allclose(new[bnd[on_y], 0], V[bnd[on_y], 0], atol=1e-13)
    corners = bnd[np.isin(V[bnd, 0], [0.0, 1.0]) & np.isin(V[bnd, 1], [0.0, 1.0])]
    assert corners.size == 4
    np.testing.assert_array_equal(new[corners], rough[corners])
    flipped, degenerate = fold_mask(new, F)
    assert not (flipped | degenerate).any()


def test_the_global_solve_removes_more_of_the_jitter_than_rounds_of_fits():
    """Interior error left of a jitter (sides jittered along themselves too): one pass of cubic fits
    over 2-rings 56%, three passes 46%, the global solve (the interior map nearest the pass whose fits'
    residuals are small) 43%."""
    V, F, loops, rough = _rough_square()
    inside = np.ones(len(V), bool)
    inside[loops[0]] = False
    err = {}
    for method, passes in (("local", 0), ("local", 1), ("local", 3), ("global", None)):
        new, _ = smooth_uv(V, F, rough, loops, method=method, passes=passes)
        err[method, passes] = np.sqrt(np.mean(np.sum((new - V[:, :2])[inside] ** 2, 1)))
    assert err["local", 1] < 0.6 * err["local", 0]
    assert err["global", None] < min(0.85 * err["local", 1], err["local", 3])


@pytest.mark.parametrize("amp", [0.0005, 0.004])
def test_a_loops_solve_smooths_the_outline_unless_it_moves_a_vertex_too_far(amp):
    """Sides jittered along themselves by ``amp`` (an edge is about 0.04): at 0.0005 a pass leaves 58% of
    it, the loop's solve 43%; at 0.004 the solve would move vertices more than ``BOUNDARY_MAX_MOVE`` of
    an edge, so the loop keeps the pass's uv (which itself kept most of them: 95% left)."""
    V, F, loops = _square(600, seed=2)
    bnd = loops[0]
    on_x = np.isin(V[bnd, 1], [0.0, 1.0]) & ~np.isin(V[bnd, 0], [0.0, 1.0])
    on_y = np.isin(V[bnd, 0], [0.0, 1.0]) & ~np.isin(V[bnd, 1], [0.0, 1.0])
    rng = np.random.default_rng(4)
    rough = V[:, :2].copy()
    rough[bnd[on_x], 0] += amp * rng.uniform(-1, 1, on_x.sum())
    rough[bnd[on_y], 1] += amp * rng.uniform(-1, 1, on_y.sum())
    out = {m: smooth_uv(V, F, rough, loops, method=m)[0][bnd] for m in ("local", "global")}
    err = {m: np.sqrt(np.mean(np.sum((x - V[bnd, :2]) ** 2, 1))) for m, x in out.items()}
    if amp < 0.001:
        assert err["global"] < 0.8 * err["local"]
    else:
        np.testing.assert_array_equal(out["global"], out["local"])


def test_the_default_method_is_global_up_to_its_size_and_local_above(monkeypatch):
    V, F, loops, rough = _rough_square()
    local, _ = smooth_uv(V, F, rough, loops, method="local")
    glob, _ = smooth_uv(V, F, rough, loops, method="global")
    assert np.abs(glob - local).max() > 1e-4
    np.testing.assert_array_equal(smooth_uv(V, F, rough, loops)[0], glob)
    monkeypatch.setattr(smooth_module, "GLOBAL_MAX_VERTICES", len(V) - 1)
    np.testing.assert_array_equal(smooth_uv(V, F, rough, loops)[0], local)
    with pytest.raises(ValueError, match="smoothing method"):
        smooth_uv(V, F, rough, loops, method="both")


def test_lscm_of_a_curved_disk_stays_fold_free_and_moves_little():
    V, F = bumpy_disk(1500)
    p = parameterize(V, F)
    new, info = smooth_uv(V, F, p.uv, validate_mesh(V, F).boundary_loops)
    flipped, degenerate = fold_mask(new, F)
    assert not (flipped | degenerate).any() and not info["fallback"]
    assert 0 < info["moved_max"] < 0.05  # a fraction of an edge: a smoothing, not a new map


def _displace(vertex: int, by: float):
    """An ``_interior`` that moves ``vertex`` by ``by`` (folding its faces), everything else as before."""
    real = smooth_module._interior

    def fake(uv, nb, s):
        out = real(uv, nb, s)
        out[nb[:, 0] == vertex] += by
        return out
    return fake


def test_a_fold_reverts_the_folded_faces_vertices(monkeypatch):
    V, F, loops = _square(300, seed=5)
    uv = perturb(V[:, :2], F, 0.02, seed=6)
    v = int(np.argmin(np.linalg.norm(V[:, :2] - 0.5, axis=1)))
    monkeypatch.setattr(smooth_module, "_interior", _displace(v, 0.3))
    new, info = smooth_uv(V, F, uv, loops, method="local")
    assert not info["fallback"] and info["reverted"] >= 1
    np.testing.assert_array_equal(new[v], uv[v])
    flipped, degenerate = fold_mask(new, F)
    assert not (flipped | degenerate).any()


def test_folds_left_after_the_rounds_return_the_map_unchanged(monkeypatch):
    V, F, loops = _square(300, seed=5)
    uv = perturb(V[:, :2], F, 0.02, seed=6)
    v = int(np.argmin(np.linalg.norm(V[:, :2] - 0.5, axis=1)))
    monkeypatch.setattr(smooth_module, "_interior", _displace(v, 0.3))
    monkeypatch.setattr(smooth_module, "REVERT_ROUNDS", 0)
    new, info = smooth_uv(V, F, uv, loops, method="local")
    assert info["fallback"]
    np.testing.assert_array_equal(new, uv)


def test_a_global_solve_that_folds_gives_way_to_the_one_pass(monkeypatch):
    """The camel head's three maps: the global solve folded faces of each (37-42 vertices reverted), and the
    fit had 4 patches above 20x the data's largest curvature; with the one pass (12-14 reverted) none."""
    V, F, loops = _square(300, seed=5)
    uv = perturb(V[:, :2], F, 0.02, seed=6)
    v = int(np.argmin(np.linalg.norm(V[:, :2] - 0.5, axis=1)))
    real = smooth_module._global

    def folding(S, uv_, *args):
        out = real(S, uv_, *args)
        if len(out) == len(V):  # the interior's solve, not a loop's
            out[v] += 0.3
        return out
    monkeypatch.setattr(smooth_module, "_global", folding)
    new, info = smooth_uv(V, F, uv, loops, method="global")
    assert info["method"] == "local" and not info["fallback"] and info["reverted"] == 0
    np.testing.assert_array_equal(new, smooth_uv(V, F, uv, loops, method="local")[0])


# ------------------------------------------------------------------------------ in parameterize
def test_parameterize_smooths_by_default_and_reports_it():
    """The local fits' smoothing (the polynomial map that may replace it: tests/param/test_param_polymap.py)."""
    V, F = bumpy_disk(800)
    p = parameterize(V, F, polynomial=False)
    raw = parameterize(V, F, smooth=False)
    assert set(p.smoothing) == {"moved_max", "reverted", "fallback", "method", "unfolded", "polynomial"}
    assert p.smoothing["polynomial"] == 0 and raw.smoothing == {}
    assert 0 < p.smoothing["moved_max"] < 0.05 and not p.smoothing["fallback"]
    assert 0 < np.abs(p.uv - raw.uv).max() < 0.01
    flipped, degenerate = fold_mask(p.uv, F)
    assert not (flipped | degenerate).any() and p.warning is None


def test_harmonic_outline_stays_on_its_circle_and_given_uv_is_kept():
    V, F = bumpy_disk(800)
    p = parameterize(V, F, "harmonic")
    raw = p.transform.to_raw(p.uv)
    np.testing.assert_allclose(np.linalg.norm(raw[p.boundary], axis=1), 1.0, atol=1e-12)
    assert p.smoothing["moved_max"] > 0
    given = parameterize(V, F, "uv", uv=V[:, :2])
    np.testing.assert_allclose(given.transform.to_raw(given.uv), V[:, :2], atol=1e-14)
    assert given.smoothing == {}


def test_a_badly_sheared_repair_gives_way_to_the_harmonic_map():
    """Enneper's LSCM folds one triangle; its composite-harmonic repair shears one 3e8-fold."""
    from trispline.fit.datasets.analytic import analytic_mesh

    m = analytic_mesh("enneper", 800)
    p = parameterize(m.V, m.F, "lscm")  # the spectral map does not fold it
    assert p.repaired == "harmonic" and p.distortion["flipped_before_repair"] == 1
    assert p.distortion["score"] < 1.2 and p.smoothing["moved_max"] > 0
    assert any("repaired with a harmonic map" in msg for msg in p.messages)



def test_a_boundary_vertex_the_loop_fit_would_move_far_keeps_its_uv():
    V, F, loops = _square(600, seed=2)
    bnd = loops[0]
    bottom = bnd[np.flatnonzero((V[bnd, 1] == 0.0) & (V[bnd, 0] > 0.3) & (V[bnd, 0] < 0.7))]
    top = bnd[np.flatnonzero((V[bnd, 1] == 1.0) & (V[bnd, 0] > 0.3) & (V[bnd, 0] < 0.7))]
    small, big = bottom[len(bottom) // 2], top[len(top) // 2]
    h = np.median(np.linalg.norm(V[F[:, 0], :2] - V[F[:, 1], :2], axis=1))
    uv = V[:, :2].copy()
    uv[small, 1] -= 0.2 * smooth_module.BOUNDARY_MAX_MOVE * h  # a kink the loop fit irons out
    uv[big, 1] += 10 * smooth_module.BOUNDARY_MAX_MOVE * h  # one that would reshape the outline
    new, _ = smooth_uv(V, F, uv, loops)
    assert abs(new[small, 1]) < 0.5 * abs(uv[small, 1])
    np.testing.assert_array_equal(new[big], uv[big])


def test_a_badly_sheared_repair_gives_way_to_slim_when_harmonic_fails(monkeypatch):
    from trispline.fit.datasets.analytic import analytic_mesh

    pp = importlib.import_module("trispline.param.parameterize")
    real = pp.raw_map

    def no_harmonic(vm, method, uv=None, report=None):
        if method == "harmonic":
            raise pp.MeshError("no harmonic map here", ["test"])
        return real(vm, method, uv, report)

    monkeypatch.setattr(pp, "raw_map", no_harmonic)
    m = analytic_mesh("enneper", 800)
    p = parameterize(m.V, m.F, "lscm")
    assert p.repaired == "slim" and p.distortion["flipped_before_repair"] == 1
    assert p.distortion["score"] < 2.0 and p.smoothing["moved_max"] > 0


def test_more_passes_smooth_more_and_keep_an_affine_map():
    """Each pass fits the last pass's map: an affine map stays exact, a rough one gets smoother."""
    V, F, loops = _square(400, seed=3)
    A = np.array([[1.2, 0.3], [-0.2, 0.9]])
    affine = V[:, :2] @ A.T + [0.5, -1.0]
    for passes in (1, 3):
        out, info = smooth_uv(V, F, affine, loops, passes=passes, method="local")
        np.testing.assert_allclose(out, affine, atol=1e-12)
    inside = np.ones(len(V), bool)
    inside[np.concatenate(loops)] = False
    rough = affine + np.random.default_rng(4).normal(scale=2e-3, size=affine.shape)
    dev = [np.sqrt(np.mean((smooth_uv(V, F, rough, loops, passes=p, method="local")[0] - affine)[inside] ** 2))
           for p in (0, 1, 3)]
    assert dev[1] < 0.7 * dev[0] and dev[2] < 0.9 * dev[1]  # measured 0.56 and 0.82


def test_a_folded_lscm_map_is_replaced_by_a_global_map_without_the_outline_repair(monkeypatch):
    """The composite-harmonic repair (33 of 55 s at 200k faces) lost to the harmonic or SLIM map on every
    mesh measured: a free boundary's folded map goes straight to them. Progress rises to 1 meanwhile."""
    from trispline.fit.datasets.analytic import analytic_mesh

    pp = importlib.import_module("trispline.param.parameterize")

    def no_repair(*args, **kwargs):
        raise AssertionError("the outline-keeping repair ran")

    monkeypatch.setattr(pp, "repair_folds", no_repair)
    m = analytic_mesh("enneper", 800)
    seen: list[float] = []
    p = parameterize(m.V, m.F, "lscm", report=seen.append)
    assert p.repaired == "harmonic" and p.distortion["flipped_before_repair"] == 1
    assert len(seen) >= 4 and np.all(np.diff(seen) >= 0) and seen[-1] == 1.0


def test_slim_reports_each_iteration():
    from trispline.param.methods import slim_uv

    V, F = bumpy_disk(400)
    seen: list[float] = []
    slim_uv(validate_mesh(V, F), max_iterations=5, report=seen.append)
    np.testing.assert_allclose(seen, np.arange(1, len(seen) + 1) / 5)
    assert len(seen) >= 2


def test_slim_stops_after_the_iteration_that_passes_its_time_budget():
    from trispline.param.methods import slim_uv

    V, F = bumpy_disk(400)
    seen: list[float] = []
    uv = slim_uv(validate_mesh(V, F), max_iterations=5, max_seconds=0.0, report=seen.append)
    assert seen == [0.2] and np.isfinite(uv).all()
    assert not np.logical_or(*fold_mask(uv, F)).any()


def test_the_cheap_well_posedness_test_agrees_with_the_eigenvalues():
    """``_first_columns``: the same rows well posed as ``_well_posed`` (rcond by eigenvalues) and their
    inverses' first columns, for well and badly conditioned, rank-deficient and exactly singular normal
    matrices in one batch (an exactly singular one makes the batched inverse fail: every row the exact way)."""
    from trispline.param.smooth import _first_columns, _well_posed

    rng = np.random.default_rng(7)
    Q = np.linalg.qr(rng.normal(size=(12, 10, 10)))[0]
    rcond = np.array([1.0, 1e-2, 1e-6, 3e-8, 1.5e-8, 0.7e-8, 1e-9, 1e-12, 0.0, 1.0, 1e-4, 1e-10])
    spectra = np.linspace(1.0, 0.0, 10)[None, :] * (1 - rcond[:, None]) + rcond[:, None]
    G = np.einsum("nij,nj,nkj->nik", Q, spectra, Q)
    singular = np.concatenate([G, np.diag(np.r_[np.ones(9), 0.0])[None]])  # an exact zero pivot
    with pytest.raises(np.linalg.LinAlgError):
        np.linalg.inv(singular)
    for batch in (G, singular):
        ok, z = _first_columns(batch)
        np.testing.assert_array_equal(ok, _well_posed(batch))
        assert ok.sum() >= 5 and (~ok).sum() >= 2
        np.testing.assert_allclose(z[ok], np.linalg.inv(batch[ok])[:, :, 0], rtol=1e-6, atol=1e-9)
        assert not z[~ok].any()
