"""Local editing cost: SplineEditor.move vs a full rebuild ``M @ free`` (the peer).

    python benchmarks/bench_edit.py [--faces 1000 100000 1000000] [--edits 2000] [--batch 1000]

Domains: perturbed regular grids (``domains.grid`` + ``domains.perturb(0.2)``) with
about the requested number of faces. For each size, in one run:

* ``edit us``: median wall time of one ``editor.move(j, xyz)`` from Python (random free
  point ``j`` of any kind; the call returns the changed point ids, the affected patches
  and their new control points), with the mean and the 95th percentile (the machine
  is shared, so the mean carries other processes' noise; the garbage collector is off
  while timing, as in ``timeit``);
* ``batch us/edit``: one ``editor.move(ids, xyz)`` with ``--batch`` distinct random free
  points, divided by the batch size;
* ``rebuild ms``: the peer, a full ``space.M @ free`` (what an editor without local
  control would do per edit), and the speedup of a single edit over it.

The last line checks the claims of issue 6: per-edit time flat across sizes (largest
within 2x of smallest) and under 100 us.

Second table (``--refair-faces``, skip with ``--refair-faces`` and no value): local
re-fairing (:class:`trispline.fit.refair.LocalRefairer`) after one data vertex near the
middle of a fitted height field ``z = sin 3x cos 2y`` moves up by a quarter of the
domain, for ``k = 1..4`` rings, against a global refit (``fit_surface`` on the moved
data, JIT already warm from the first fit) in the same run. ``excess`` is
``(E_local - E_global) / (E_edit - E_global)``: the share of the energy the global
refit removes that the local re-fairing leaves (0 = as good as the global refit,
1 = no better than moving the corner point alone).
"""
from __future__ import annotations

import argparse
import gc
import time

import numpy as np

from trispline.spline.testing import domains
from trispline.spline.edit import SplineEditor
from trispline.spline.propagation import build_space


def grid_with_faces(n_faces: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    n = max(2, int(round(np.sqrt(n_faces / 2.0))))
    uv, f = domains.grid(n, n)
    return domains.perturb(uv, f, 0.2, seed=seed), f


def time_single(ed: SplineEditor, ids: np.ndarray, pos: np.ndarray) -> np.ndarray:
    out = np.empty(ids.size)
    clock = time.perf_counter
    gc.disable()
    try:
        for i in range(ids.size):
            t0 = clock()
            ed.move(int(ids[i]), pos[i])
            out[i] = clock() - t0
    finally:
        gc.enable()
    return out


def run(n_faces: int, n_edits: int, batch: int, seed: int = 0) -> dict:
    rng = np.random.default_rng(seed)
    uv, f = grid_with_faces(n_faces, seed)
    t0 = time.perf_counter()
    space = build_space(uv, f)
    t_build = time.perf_counter() - t0
    free = rng.normal(size=(space.n_free, 3))
    t0 = time.perf_counter()
    ed = SplineEditor(space, free)
    t_init = time.perf_counter() - t0
    ids = rng.integers(space.n_free, size=n_edits)
    pos = rng.normal(size=(n_edits, 3))
    time_single(ed, ids[: min(200, n_edits)], pos)  # warm-up
    single = time_single(ed, ids, pos)
    bids = rng.choice(space.n_free, size=min(batch, space.n_free), replace=False)
    bpos = rng.normal(size=(bids.size, 3))
    reps = 5
    t0 = time.perf_counter()
    for _ in range(reps):
        ed.move(bids, bpos)
    t_batch = (time.perf_counter() - t0) / reps / bids.size
    # peer: full rebuild (best of 3)
    t_full = min(_timed(lambda: space.M @ ed.free) for _ in range(3))
    exact = bool(np.array_equal(ed.points, space.M @ ed.free))
    return dict(faces=space.tri.n_faces, n_free=space.n_free, nnz=space.M.nnz, build=t_build, init=t_init,
                edit=float(np.median(single)), mean=float(single.mean()), p95=float(np.percentile(single, 95)), batch=t_batch,
                full=t_full, exact=exact)


def _timed(fn) -> float:
    t0 = time.perf_counter()
    fn()
    return time.perf_counter() - t0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--faces", type=int, nargs="+", default=[1000, 100_000, 1_000_000])
    ap.add_argument("--edits", type=int, default=2000)
    ap.add_argument("--batch", type=int, default=1000)
    ap.add_argument("--refair-faces", type=int, nargs="*", default=[2000, 20_000])
    args = ap.parse_args()
    hdr = (f"{'faces':>9} {'n_free':>9} {'nnz(M)':>10} {'build s':>8} {'init s':>7} {'edit us':>8} "
           f"{'mean us':>7} {'p95 us':>7} {'batch us/edit':>13} {'rebuild ms':>10} {'speedup':>8} {'=rebuild':>8}")
    print(hdr)
    print("-" * len(hdr))
    rows = []
    for n in args.faces:
        r = run(n, args.edits, args.batch)
        rows.append(r)
        print(f"{r['faces']:>9} {r['n_free']:>9} {r['nnz']:>10} {r['build']:>8.2f} {r['init']:>7.2f} "
              f"{r['edit'] * 1e6:>8.1f} {r['mean'] * 1e6:>7.1f} {r['p95'] * 1e6:>7.1f} {r['batch'] * 1e6:>13.2f} "
              f"{r['full'] * 1e3:>10.2f} {r['full'] / r['edit']:>8.0f} {str(r['exact']):>8}", flush=True)
    ratio = rows[-1]["edit"] / rows[0]["edit"]
    worst = max(r["edit"] for r in rows)
    print(f"\nmedian per-edit time, largest / smallest mesh: {ratio:.2f}x (claim: < 2x); "
          f"worst median {worst * 1e6:.1f} us (claim: < 100 us); "
          f"edits bit-identical to the rebuild: {all(r['exact'] for r in rows)}")
    if args.refair_faces:
        refair_table(args.refair_faces)


def refair_table(sizes: list[int]) -> None:
    import jax

    jax.config.update("jax_enable_x64", True)
    from trispline.fit.pipeline import fit_surface
    from trispline.fit.refair import LocalRefairer, fairness_energy

    hdr = (f"\n{'faces':>7} {'rings':>5} {'free moved':>10} {'patches':>7} {'local ms':>8} "
           f"{'global s':>8} {'E edit':>10} {'E local':>10} {'E global':>10} {'excess':>8}")
    print(hdr)
    print("-" * len(hdr))
    for n in sizes:
        uv, f = grid_with_faces(n, seed=1)
        V = np.column_stack([uv, np.sin(3 * uv[:, 0]) * np.cos(2 * uv[:, 1])])
        result = fit_surface(V, f, uv=uv)
        v = int(np.argmin(np.linalg.norm(uv - 0.5, axis=1)))
        V2 = V.copy()
        V2[v, 2] += 0.25
        t0 = time.perf_counter()
        refit = fit_surface(V2, f, uv=uv)
        t_global = time.perf_counter() - t0
        e_global = fairness_energy(refit.space, refit.free, V2, result.weights)["total"]
        ed = SplineEditor.from_fit(result)
        ed.move_vertex(v, V2[v])
        e_edit = fairness_energy(ed.space, ed.free, V2, result.weights)["total"]
        for rings in (1, 2, 3, 4):
            rf = LocalRefairer.from_fit(result, rings=rings)
            rf.move_vertex(v, V2[v])  # warm-up (and undone below)
            rf = LocalRefairer.from_fit(result, rings=rings)
            t0 = time.perf_counter()
            res = rf.move_vertex(v, V2[v])
            t_local = time.perf_counter() - t0
            e_local = rf.energy()["total"]
            excess = (e_local - e_global) / (e_edit - e_global)
            print(f"{f.shape[0]:>7} {rings:>5} {res.free_ids.size:>10} {res.faces.size:>7} {t_local * 1e3:>8.1f} "
                  f"{t_global:>8.2f} {e_edit:>10.4g} {e_local:>10.4g} {e_global:>10.4g} {excess:>8.1e}", flush=True)


if __name__ == "__main__":
    main()
