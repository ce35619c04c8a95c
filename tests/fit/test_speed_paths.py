"""The fast paths of the fit equal their plain definitions; the factor's memory is estimated and refused.

Each fast path (issue 19) is checked against a slow, obviously-correct oracle written here:
the per-patch assembly of ``H`` against the sparse triple product ``A^T B A``, the local
fits against a per-vertex loop, their grouped evaluation against the formula point by
point, the neighbour order against a lexicographic sort, and the one Gauss--Newton step
against Gauss--Newton iterated to convergence.
"""
from __future__ import annotations

import ctypes
import time
import importlib.util

import jax
import jax.numpy as jnp
import numpy as np
import pytest
import scipy.sparse as sp
from bench_modules import speed_scan
from scipy.spatial import Delaunay

jax.config.update("jax_enable_x64", True)

from trispline.fit import energy as en  # noqa: E402
from trispline.fit import gauss_newton, solve  # noqa: E402
from trispline.fit.datasets.franke import exponential, sample_points  # noqa: E402
from trispline.fit.datasets.synthetic import synthetic_scan  # noqa: E402
from trispline.fit.errors import FactorMemoryError  # noqa: E402
from trispline.fit.gauss_newton import QuadraticStep, iterate  # noqa: E402
from trispline.fit.pipeline import fit_surface  # noqa: E402
from trispline.fit.progress import accepts_fraction, map_reporting, span  # noqa: E402
from trispline.fit.solve import SparseCholesky, estimate_factor_bytes  # noqa: E402
from trispline.fit.stages import ASSEMBLE, FIT_STAGES, SOLVE  # noqa: E402
from trispline.fit.targets import (RBF_KERNELS, TIE_RTOL, _poly3, local_rbf_fit,  # noqa: E402
                                    padded_neighbours, vertex_rings)
from trispline.fit.weights import FitWeights  # noqa: E402
from trispline.spline.errors import InputError  # noqa: E402
from trispline.spline.propagation import build_space  # noqa: E402
from trispline.spline.testing.domains import orient_ccw, random_delaunay  # noqa: E402
from trispline.spline.topology import outline_vertex_mask  # noqa: E402
from trispline.spline.topology import Triangulation  # noqa: E402
from trispline.spline.util.parallel import Workers  # noqa: E402
from trispline.spline.util.sparse import compact  # noqa: E402

HAS_PARDISO = importlib.util.find_spec("pypardiso") is not None


def _franke(n: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    p = sample_points(n, seed=seed)
    F = orient_ccw(p, Delaunay(p).simplices)
    return np.column_stack([p, exponential(p[:, 0], p[:, 1])]), F


@pytest.fixture(scope="module", params=["franke", "holes"])
def problem(request):
    """``(V, space, weights)``: a height field, and a bumpy surface over a domain with holes."""
    if request.param == "franke":
        V, F = _franke(150, seed=4)
        uv = V[:, :2]
    else:
        uv, F = random_delaunay(260, holes=2, seed=7)
        V = np.column_stack([uv, np.sin(3 * uv[:, 0]) * np.cos(2 * uv[:, 1])])
    return V, build_space(Triangulation(uv, F)), FitWeights()


# ---------------------------------------------------------------- normal equations
def test_per_patch_assembly_equals_the_triple_product(problem):
    V, space, w = problem
    prob = en.setup_problem(V, space, w)
    ctx = en.term_context(space, V, w)
    parts = en.normal_parts(en.setup_terms(ctx), space.tri.n_faces, 2 * space.tri.n_vertices)
    M = sp.csc_matrix(space.M)
    A = sp.csr_matrix(M[:, prob.free_r])[np.asarray(space.point_index).ravel()]
    c = np.asarray(M[:, space.corner_free] @ V)[np.asarray(space.point_index).ravel()]
    B = sp.block_diag(list(parts.blocks), format="csr")
    frame_pos = np.asarray(prob.args["frame_pos"])
    k = A.shape[1]
    H_ref = A.T @ B @ A + sp.csr_matrix((parts.frame_weight, (frame_pos, frame_pos)), shape=(k, k))
    rhs_ref = A.T @ (parts.patch_rhs.reshape(-1, 3) - B @ c)
    np.add.at(rhs_ref, frame_pos, parts.frame_rhs)
    H, rhs = en.normal_equations(A, c, frame_pos, parts)
    scale = abs(H_ref).max()
    assert abs(H - H_ref).max() <= 1e-13 * scale
    np.testing.assert_allclose(rhs, rhs_ref, rtol=0, atol=1e-13 * np.abs(rhs_ref).max())
    U, _ = en.normal_equations(A, c, frame_pos, parts, upper=True)
    assert abs(U - sp.triu(H_ref)).max() <= 1e-13 * scale and sp.tril(U, -1).nnz == 0
    assert abs(prob.H - H_ref).max() <= 1e-13 * scale  # the problem's full H, built from its upper triangle
    assert prob.H_nnz == H.nnz
    x = np.random.default_rng(0).normal(size=(k, 3))
    np.testing.assert_allclose(prob.gradient(x), H_ref @ x - prob.rhs, rtol=0, atol=1e-12 * scale * np.abs(x).max())
    U_kept, rhs_kept = U, rhs
    U, rhs = en.normal_equations(A, c, frame_pos, parts, upper=True, release=True)  # consumes parts
    assert parts.blocks is None and parts.patch_rhs is None
    assert (U != U_kept).nnz == 0 and np.array_equal(rhs, rhs_kept)  # the same numbers, bit for bit


def test_local_diagonals_through_flat_views_equal_the_plain_indexing(problem):
    """The ``local`` term's ``add_normal`` (flat views of the blocks, one index array) adds what the plain
    ``blocks[face, slot, slot]`` indexing adds, bit for bit; on parts it cannot view flat (not contiguous)
    it falls back to that indexing."""
    from trispline.fit.energy import local
    from trispline.spline.index import NCTRL

    V, space, w = problem
    a = en.setup_terms(en.term_context(space, V, w))["local"]
    n = space.tri.n_faces
    rng = np.random.default_rng(5)
    blocks, rhs = rng.normal(size=(n, NCTRL, NCTRL)), rng.normal(size=(n, NCTRL, 3))
    want_b, want_r = blocks.copy(), rhs.copy()
    face, slot = np.divmod(a["index"], NCTRL)
    want_b[face, slot, slot] += a["scale"] ** 2
    want_r[face, slot] += (a["scale"] ** 2)[:, None] * a["target"]
    flat = en.NormalParts(blocks.copy(), rhs.copy(), np.zeros(0), np.zeros((0, 3)))
    local.add_normal(flat, a)
    assert np.array_equal(flat.blocks, want_b) and np.array_equal(flat.patch_rhs, want_r)
    strided = en.NormalParts(np.zeros((n, NCTRL, 2 * NCTRL))[:, :, ::2], np.zeros((n, NCTRL, 6))[:, :, ::2],
                             np.zeros(0), np.zeros((0, 3)))
    strided.blocks[...], strided.patch_rhs[...] = blocks, rhs
    local.add_normal(strided, a)
    assert np.array_equal(strided.blocks, want_b) and np.array_equal(strided.patch_rhs, want_r)


def test_pattern_from_the_patches_equals_the_assembled_one(problem):
    """``upper_pattern`` (known before any term is set up) is the pattern ``setup_problem`` assembles,
    and ``setup_problem`` hands a maker of it (and of its elimination order) to ``on_pattern`` first."""
    V, space, w = problem
    seen = []
    prob = en.setup_problem(V, space, w, on_pattern=lambda *makers: seen.append(makers))
    ((make, _),) = seen
    P = make()
    U = sp.csr_array(prob.H_upper)
    assert P.shape == U.shape and np.array_equal(P.indptr, U.indptr) and np.array_equal(P.indices, U.indices)


def test_compact_shrinks_the_summed_views_in_place_or_copies_them():
    """``compact`` leaves the values as they are and ``data``/``indices`` exactly ``nnz`` long, owning their
    memory: shrunk in place where nothing else views the COO-sized buffers, copied where something does."""
    rng = np.random.default_rng(3)
    r, c, v = rng.integers(0, 300, 40000), rng.integers(0, 300, 40000), rng.normal(size=40000)
    for viewed in (False, True):
        U = sp.csr_array((v, (r, c)), shape=(300, 300))
        U.sum_duplicates()
        assert U.data.base is not None and U.data.base.size > U.nnz  # prefix views of the COO-sized arrays
        ref, kept = U.toarray(), U.data if viewed else None
        before = None if kept is None else kept.copy()
        compact(U)
        for a in (U.data, U.indices):
            assert a.base is None and a.size == U.nnz
        np.testing.assert_array_equal(U.toarray(), ref)
        if viewed:  # the outside view still reads what it read
            assert not np.shares_memory(U.data, kept)
            np.testing.assert_array_equal(kept, before)


@pytest.mark.parametrize("backend", ["pardiso", "cholespy"] if HAS_PARDISO else ["cholespy"])
def test_factor_analysed_on_the_pattern_equals_a_plain_one(backend, monkeypatch):
    """The factor whose analysis ran in the background on the pattern alone solves exactly as a
    plain factor of the values (same ordering, same numbers); another pattern is refused by
    ``set_values`` and analysed afresh by ``PatternAnalysis.factor``."""
    monkeypatch.setenv("TRISPLINE_SOLVER", backend)
    V, F = speed_scan(6000)
    space = build_space(Triangulation(V[:, :2], F))
    analysis, orders = solve.PatternAnalysis(), []

    def start(pattern, ordering):
        orders.append(ordering())
        analysis.start(pattern, lambda: orders[0])

    prob = en.setup_problem(V, space, FitWeights(), on_pattern=start)
    factor = analysis.factor(prob.H_upper, max_bytes="available")
    b = np.random.default_rng(1).normal(size=(prob.rhs.shape[0], 3))
    plain = SparseCholesky(prob.H_upper, upper=True, ordering=orders[0])
    np.testing.assert_array_equal(factor.solve(b), plain.solve(b))
    other = sp.csr_array(prob.H_upper[:-1, :-1])
    deferred = SparseCholesky(other, upper=True, defer=True)
    with pytest.raises(ValueError, match="pattern"):
        deferred.set_values(prob.H_upper)
    fresh = solve.PatternAnalysis()
    fresh.start(other)
    refit = fresh.factor(prob.H_upper)  # not the analysed pattern: a plain factor of the values
    np.testing.assert_array_equal(refit.solve(b), SparseCholesky(prob.H_upper, upper=True).solve(b))


# ---------------------------------------------------------------- local fits
def _lexsorted_neighbours(uv, faces, rings, max_neighbours, wider=None):
    """The neighbour lists by one lexicographic sort of (vertex, tie of distances, column): the plain definition
    (``wider``: vertices with a ring more, rows of the dense ``rings + 1`` table)."""
    nv = uv.shape[0]
    R = vertex_rings(faces, nv, rings)
    if wider is not None:
        R = sp.csr_matrix(np.where(wider[:, None], vertex_rings(faces, nv, rings + 1).toarray(), R.toarray()))
    row = np.repeat(np.arange(nv), np.diff(R.indptr))
    col = R.indices.astype(np.int64)
    dist = np.linalg.norm(uv[col] - uv[row], axis=1)
    tie = np.empty_like(dist)  # distances within TIE_RTOL of the row's farthest from the one before: one tie
    for v in range(nv):
        at = np.flatnonzero(row == v)
        near = np.sort(dist[at])
        runs = np.cumsum(np.r_[0, np.diff(near) > TIE_RTOL * near.max(initial=0)])
        tie[at] = runs[np.searchsorted(near, dist[at])]
    order = np.lexsort((col, tie, row))
    row, col = row[order], col[order]
    rank = np.arange(row.size) - R.indptr[row]
    keep = rank < max_neighbours
    count = np.minimum(np.diff(R.indptr), max_neighbours)
    nbr = np.full((nv, int(count.max())), -1, np.int64)
    nbr[row[keep], rank[keep]] = col[keep]
    return nbr, count


@pytest.mark.parametrize("rings, most, chunk", [(3, 32, None), (2, 32, None), (1, 4, None), (3, 32, 7)])
def test_neighbour_order_equals_a_lexicographic_sort(rings, most, chunk, monkeypatch):
    from trispline.fit import targets
    from trispline.spline.testing.domains import grid

    if chunk is not None:  # rows sorted in chunks of their own widths (targets.NEAREST_CHUNK): many chunk edges
        monkeypatch.setattr(targets, "NEAREST_CHUNK", chunk)
    for uv, F in (random_delaunay(300, holes=1, seed=2), grid(9, 7)):  # the grid has ties in distance
        nbr, count = padded_neighbours(uv, F, rings, most)
        ref_nbr, ref_count = _lexsorted_neighbours(uv, F, rings, most)
        np.testing.assert_array_equal(nbr, ref_nbr)
        np.testing.assert_array_equal(count, ref_count)
        on = outline_vertex_mask(F, len(uv))  # the outline's vertices with a ring more (targets.OUTLINE_RING)
        nbr, count = padded_neighbours(uv, F, rings, most, on)
        ref_nbr, ref_count = _lexsorted_neighbours(uv, F, rings, most, on)
        np.testing.assert_array_equal(nbr, ref_nbr)
        np.testing.assert_array_equal(count, ref_count)
        assert (count[on] >= padded_neighbours(uv, F, rings, most)[1][on]).all()


def _vertex_fit(X, Y, valid, p, q):
    """One vertex's interpolant with kernel ``r^p`` and degree ``q``: ``(lam, coef, loo score)`` or None."""
    Xv, Yv = X[valid], Y[valid]
    m = (q + 1) * (q + 2) // 2
    if Xv.shape[0] < max(2 * m, 3):
        return None
    r = np.linalg.norm(Xv[:, None] - Xv[None, :], axis=2)
    P = np.stack([np.ones(len(Xv)), Xv[:, 0], Xv[:, 1], Xv[:, 0] ** 2, Xv[:, 0] * Xv[:, 1], Xv[:, 1] ** 2,
                  Xv[:, 0] ** 3, Xv[:, 0] ** 2 * Xv[:, 1], Xv[:, 0] * Xv[:, 1] ** 2, Xv[:, 1] ** 3], axis=1)[:, :m]
    n = len(Xv)
    A = np.block([[r**p, P], [P.T, np.zeros((m, m))]])
    S = np.linalg.solve(A, np.vstack([Yv, np.zeros((m, Yv.shape[1]))]))
    Ainv = np.linalg.inv(A)
    nloo = min(7, n)
    e = S[:nloo] / np.diag(Ainv)[:nloo, None]
    return S[:n], S[n:], np.sqrt(np.sum(e * e))


def test_local_fits_equal_a_per_vertex_loop(problem):
    V, space, _ = problem
    tri = space.tri
    fit = local_rbf_fit(tri.uv, V, tri.faces)
    K = fit.centres.shape[1]
    nbr, _ = padded_neighbours(tri.uv, tri.faces, 3, wider=outline_vertex_mask(tri.faces, tri.n_vertices))
    rng = np.random.default_rng(5)
    for v in range(tri.n_vertices):
        valid = np.concatenate([[True], nbr[v] >= 0])[:K]
        X = fit.centres[v]
        Y = V[np.concatenate([[v], np.where(nbr[v] >= 0, nbr[v], 0)])[:K]] - V[v] - X @ fit.slope[v]
        best = None
        for p, q in RBF_KERNELS:
            out = _vertex_fit(X, Y, valid, p, q)
            if out is not None and np.isfinite(out[2]) and (best is None or out[2] < best[3]):
                best = (p, out[0], out[1], out[2])
        assert fit.power[v] == (best[0] if best else 0), v
        if best is None:
            continue
        # the interpolants agree (their coefficients are as ill-conditioned as the r^7 systems)
        P = X[valid].mean(0) + 0.5 * rng.normal(size=(5, 2))
        r = np.linalg.norm(P[:, None] - X[valid][None], axis=2)
        ref = r ** best[0] @ best[1] + _poly3(P[:, 0], P[:, 1])[:, :best[2].shape[0]] @ best[2]
        got = fit.evaluate(np.full(5, v), (fit.origin[v] + fit.scale[v] * P)) - fit.value[v] - P @ fit.slope[v]
        np.testing.assert_allclose(got, ref, rtol=0, atol=1e-9 * (np.abs(Y).max() + 1e-300))


def test_grouped_evaluation_equals_the_formula_point_by_point(problem):
    V, space, _ = problem
    tri = space.tri
    fit = local_rbf_fit(tri.uv, V, tri.faces, max_degree=3)
    assert len(set(fit.power.tolist())) > 1  # mixed kernels within one call
    rng = np.random.default_rng(3)
    vertex = rng.integers(0, tri.n_vertices, 400)
    points = tri.uv[vertex][:, None] + 0.05 * rng.normal(size=(400, 21, 2))
    out = fit.evaluate(vertex, points)
    ref = np.empty_like(out)
    for i, v in enumerate(vertex):
        X = (points[i] - fit.origin[v]) / fit.scale[v]
        r = np.linalg.norm(X[:, None] - fit.centres[v][None], axis=2)
        phi = r ** fit.power[v] if fit.power[v] else np.zeros_like(r)
        ref[i] = fit.value[v] + X @ fit.slope[v] + phi @ fit.lam[v] + _poly3(X[:, 0], X[:, 1]) @ fit.coef[v]
    np.testing.assert_allclose(out, ref, rtol=0, atol=1e-10 * np.abs(ref).max())
    np.testing.assert_allclose(fit.evaluate(vertex, points[:, 0]), out[:, 0], rtol=0, atol=1e-12 * np.abs(ref).max())


# ---------------------------------------------------------------- the solve
def test_one_step_equals_gauss_newton_iterated_to_convergence(problem):
    V, space, w = problem
    prob = en.setup_problem(V, space, w)
    factor = SparseCholesky(prob.H_upper, upper=True)
    x, energies, steps, ok = QuadraticStep(prob).run(factor)
    # from the optimum optimistix's step test dithers at rounding: 65 steps on the height field, whose gradient is
    # 3e-16 of the start's throughout
    x_ref, energies_ref, steps_ref, ok_ref = iterate(prob, factor, None, 200)
    assert ok and ok_ref and steps == 1 and steps_ref > 1
    np.testing.assert_allclose(x, x_ref, rtol=0, atol=1e-9 * np.abs(x_ref).max())  # GN_RTOL
    total = sum(energies_ref.values())
    for k in energies:  # quadratic in x, whose tolerance is 1e-9: a small term 2.3e-8 apart of itself (holes)
        assert energies[k] == pytest.approx(energies_ref[k], rel=1e-8, abs=1e-8 * total)
    g = np.asarray(jax.grad(lambda y: 0.5 * sum(jnp.sum(r * r) for r in en.residuals(y, prob.args).values()))(
        jnp.asarray(x)))
    assert np.abs(g).max() <= 1e-12 * np.abs(prob.rhs).max()  # exact to rounding, not just to 1e-6


def test_step_compiled_for_memory_equals_the_default_compile(problem):
    """The step compiled with ``gauss_newton.CPU_COMPILER_OPTIONS`` (XLA:CPU's memory-optimised scheduler,
    no XNNPACK/YNNPACK dot fusions) computes what the default compile computes, to the dots' rounding,
    in no more temporaries; the scheduler alone changes no bit."""
    V, space, w = problem
    prob = en.setup_problem(V, space, w)
    factor = SparseCholesky(prob.H_upper, upper=True)
    x0 = jax.ShapeDtypeStruct(prob.rhs.shape, jnp.float64)
    lowered = jax.jit(gauss_newton._one_step).lower(x0, prob.args, jax.ShapeDtypeStruct((), jnp.int64))
    ours, plain = gauss_newton._compile(lowered), lowered.compile()
    args = (jnp.zeros(prob.rhs.shape), prob.args, jnp.asarray(factor.handle, jnp.int64))
    (x, e), (x_ref, e_ref) = ours(*args), plain(*args)
    x_ref = np.asarray(x_ref)
    np.testing.assert_allclose(np.asarray(x), x_ref, rtol=0, atol=1e-12 * np.abs(x_ref).max())
    for k in e_ref:
        assert float(e[k]) == pytest.approx(float(e_ref[k]), rel=1e-10, abs=1e-300)
    if jax.default_backend() == "cpu":
        assert ours.memory_analysis().temp_size_in_bytes <= plain.memory_analysis().temp_size_in_bytes
        scheduled = lowered.compile(compiler_options=gauss_newton.CPU_COMPILER_OPTIONS[-1])
        np.testing.assert_array_equal(np.asarray(scheduled(*args)[0]), x_ref)


def test_fit_with_progress_fractions():
    V, F = synthetic_scan(2500)
    calls = []
    res = fit_surface(V, F, progress=lambda stage, seconds, fraction=None: calls.append((stage, seconds, fraction)))
    ends = [c[0] for c in calls if c[2] is None]
    assert ends == list(FIT_STAGES) and res.iterations == 1
    within = [c[2] for c in calls if c[0] == ASSEMBLE and c[2] is not None]
    assert len(within) >= 4 and within == sorted(within) and 0 < within[0] and within[-1] <= 1
    # the compiled step reports as each of its two host solves ends, before the stage's end
    solve = [c[2] for c in calls if c[0] == SOLVE]
    assert solve == [0.45, 0.9, None]
    # every stage reports within itself: the map's steps, the space's steps and M's, the analysis (the numerical
    # factorisation's share written too where it lasts: tests/fit/test_progress_watch.py), the finish
    for stage in FIT_STAGES:
        inside = [c[2] for c in calls if c[0] == stage and c[2] is not None]
        assert len(inside) >= (1 if stage == "factor" else 2), (stage, inside)
        assert inside == sorted(inside) and 0 < inside[0] and inside[-1] <= 1, (stage, inside)
    assert len([c for c in calls if c[0] == "build" and c[2] is not None]) >= 8 + 6  # its steps and M's
    two = []
    V2, F2 = synthetic_scan(200)
    fit_surface(V2, F2, progress=lambda stage, seconds: two.append(stage))
    assert two == list(FIT_STAGES)  # the two-argument form is only called at stage ends


def test_progress_helpers():
    assert accepts_fraction(lambda a, b, c=None: None) and accepts_fraction(lambda *a: None)
    assert not accepts_fraction(lambda a, b: None)
    seen = []
    span(seen.append, 0.5, 1.0)(0.5)
    assert seen == [0.75]
    with Workers(10_000, parallel_min=1) as work:
        out = map_reporting(work, lambda lo, hi: (lo, hi), 10_000, 1000, seen.append)
    assert out == [(lo, min(lo + 1000, 10_000)) for lo in range(0, 10_000, 1000)]
    assert seen[1:] == sorted(seen[1:]) and seen[-1] == 1.0


def test_cli_stages_bar_moves_within_a_stage():
    from trispline.fit.cli.common import Stages

    bar = Stages(["a", "b", "c"], "t", disable=True)
    bar.at("b", 0.5)
    assert bar.i == 1 and bar.position == Stages.UNITS + int(0.5 * (Stages.UNITS - 1))
    bar.done("b")
    assert bar.i == 2 and bar.position == 2 * Stages.UNITS
    bar.at("a", 0.9)  # never backwards
    assert bar.i == 2 and bar.position == 2 * Stages.UNITS


def test_cli_bar_elapsed_time_ticks_through_a_silent_stage(capsys, monkeypatch):
    """A stage that reports nothing until it ends (PARDISO's numerical phase) still shows its elapsed
    time counting: the bar redraws itself once it is due to show (after a second), and not before."""
    from trispline.fit.cli.common import Stages

    monkeypatch.setattr(Stages, "TICK", 0.05)
    bar = Stages(["factor"], "fit", disable=False)
    bar.bar.delay = 0.3
    time.sleep(0.15)
    assert capsys.readouterr().err == ""  # not yet due: nothing drawn
    for _ in range(100):  # redrawn within a few ticks once due, with nothing reported by the stage
        time.sleep(0.05)
        if "fit: factor" in capsys.readouterr().err:
            break
    else:
        pytest.fail("the bar never redrew itself")
    bar.close()
    assert not bar._ticker.is_alive()


# ---------------------------------------------------------------- the factor's memory
@pytest.mark.skipif(not HAS_PARDISO, reason="pypardiso not installed")
def test_factor_memory_estimates_match_the_measured_factor():
    """PARDISO's analysis and the formula both predict what the numerical factorisation allocates.

    Measured: the bytes MKL's allocator holds after the numerical phase less those before
    (``mkl_mem_stat``; the factor is all PARDISO allocates there). MKL keeps its work buffers
    (~26 MB) in its pools after a first factorisation and the fit hands them back
    (``release_free_heap``): the same matrix factored once first, so that the figure is the
    factor's whatever ran before (without it: 68 / 114 / 196 MB, the factor plus those buffers).
    """
    for n_faces in (4_000, 10_000, 20_000):
        V, F = speed_scan(n_faces)
        space = build_space(Triangulation(V[:, :2], F))
        prob = en.setup_problem(V, space, FitWeights())
        SparseCholesky(prob.H_upper, "pardiso", upper=True)  # a first factorisation fills MKL's pools (freed at once)
        factor = SparseCholesky(prob.H_upper, "pardiso", upper=True, defer=True)
        mkl = factor._solver.libmkl
        mkl.mkl_mem_stat.restype = ctypes.c_int64
        buffers = ctypes.c_int(0)
        before = mkl.mkl_mem_stat(ctypes.byref(buffers))
        factor.factorize()
        measured = mkl.mkl_mem_stat(ctypes.byref(buffers)) - before
        formula = estimate_factor_bytes(prob.H_upper.shape[0], prob.H_upper.nnz)
        # the analysis's figure also covers the solves' work space: an upper bound, within 2x
        assert 0.5 * factor.estimate <= measured <= 1.05 * factor.estimate, (n_faces, factor.estimate, measured)
        assert 0.8 * measured <= formula <= 1.5 * measured, (n_faces, formula, measured)
        x = factor.solve(prob.rhs)
        assert np.abs(prob.gradient(x)).max() <= 1e-9 * np.abs(prob.rhs).max()


def test_fit_refused_above_available_memory(monkeypatch, tmp_path):
    V, F = synthetic_scan(600)
    monkeypatch.setattr(solve, "available_memory", lambda: 1 << 20)
    called = []
    monkeypatch.setattr(en, "setup_problem", lambda *a, **k: called.append(1))
    with pytest.raises(FactorMemoryError, match=r"needs about [0-9.]+ [kMGT]?B, but only .*trispline fit --tolerance") as info:
        fit_surface(V, F)
    assert isinstance(info.value, InputError) and not called  # refused before the assembly
    assert info.value.estimate > info.value.available == 1 << 20

    from trispline.fit.cli import main

    out = tmp_path / "s.npz"
    assert main(["fit", "--example", "--example-faces", "300", "-o", str(out), "--quiet"]) == 2
    assert not out.exists()


def test_fit_refused_by_its_size_before_the_parameterization(monkeypatch, tmp_path, capsys):
    """The whole fit's peak (about 24 kB a face) against the available memory, before the map: a 1M-face
    scan's LSCM map and its repair took 1.5 min before the factor's check could refuse it."""
    from trispline.fit import limits
    from trispline.fit.cli import main

    V, F = synthetic_scan(600)
    need = limits.estimate_fit_bytes(F.shape[0])
    assert need == limits.FIT_BASE_BYTES + limits.FIT_BYTES_PER_FACE * F.shape[0]
    monkeypatch.setattr(limits, "available_memory", lambda: need - 1)
    param = importlib.import_module("trispline.param.parameterize")
    monkeypatch.setattr(param, "validate_mesh", lambda *a, **k: pytest.fail("parameterized"))
    with pytest.raises(FactorMemoryError, match=rf"interpolating fit of {F.shape[0]:,} faces needs about .* "
                                                r"--tolerance") as info:
        fit_surface(V, F)
    assert info.value.estimate == need and info.value.available == need - 1
    out = tmp_path / "s.npz"
    monkeypatch.setattr(limits, "available_memory", lambda: limits.FIT_BASE_BYTES)
    assert main(["fit", "--example", "--example-faces", "300", "-o", str(out), "--quiet"]) == 2
    assert "interpolating fit of" in capsys.readouterr().err and not out.exists()
    monkeypatch.setattr(limits, "available_memory", lambda: need)
    limits.check_fit_memory(F.shape[0])  # exactly enough: accepted


def test_factor_refused_after_its_analysis():
    V, F = _franke(400, seed=1)
    space = build_space(Triangulation(V[:, :2], F))
    prob = en.setup_problem(V, space, FitWeights())
    backend = "pardiso" if HAS_PARDISO else "cholespy"
    with pytest.raises(FactorMemoryError, match="approximate"):
        SparseCholesky(prob.H_upper, backend, upper=True, max_bytes=1000)
    f = SparseCholesky(prob.H_upper, backend, upper=True, max_bytes=10 * (1 << 30))
    assert 0 < f.estimate < 10 * (1 << 30)
