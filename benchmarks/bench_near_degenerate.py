"""Near-degenerate triangulations (issue 14): accuracy of the propagation and of the fit.

A 30 x 30 criss-cross grid (every quad centre singular) and an alternating grid, their
interior vertices perturbed by ``eps`` of the local edge length. Each row measures the
build of today (snap + double-double pass) and, in the same run, the peer: the
double-only build before issue 14 (``snap_tol=0, exact_tol=0``).

    spline table  linear data and a global quintic reproduced through the free points
                  (max error / max |net|), max |M|, the elimination statistic (the weights M
                  holds, star points collapsed into their frame: O(1) in both builds -- the
                  peer's are bounded but wrong by ~1e-16 / eps), singular, snapped (moved) and
                  double-double ('dd') vertices, the largest move over the local edge length,
                  C1 of random free points, the build's wall time
    fit table     ``fit_surface(V, F, uv=V[:, :2])`` (``--param uv``) of the height field
                  z = Franke's exponential: worst |x(u, v) - u|, |y(u, v) - v| over 28 points
                  per patch relative to the domain size, and the height error against the
                  true function (RMS, max) -- the fit's accuracy

    python benchmarks/bench_near_degenerate.py [--n 30] [--no-fit]
"""
from __future__ import annotations

import argparse
import contextlib
import time

import numpy as np

from trispline.spline.continuity import continuity_report
from trispline.spline.index import lattice
from trispline.spline.polynomial import polynomial_control_net, random_polynomial
from trispline.spline.propagation import build_space
from trispline.spline.testing import domains

EPS = [0.0, 1e-14, 1e-12, 1e-9, 1e-7, 1e-5, 1e-3, 1e-2]
FIT_EPS = [0.0, 1e-12, 1e-9, 1e-7, 1e-5, 1e-3, 1e-2]  # the table
PEER = dict(snap_tol=0.0, exact_tol=0.0)  # the double-only build before issue 14


def reproduction(space, fn) -> float:
    """``max |M free(net) - net| / max |net|`` for the exact control net of ``fn``."""
    tri = space.tri
    net = polynomial_control_net(tri.uv, tri.faces, fn)
    pts = np.zeros((space.n_points, 3))
    pts[space.point_index.ravel()] = net.reshape(-1, 3)
    return float(np.abs(space.control_points(space.free_from_points(pts)) - net).max() / np.abs(net).max())


def spline_row(uv: np.ndarray, faces: np.ndarray, **kw) -> dict:
    t0 = time.perf_counter()
    space = build_space(uv, faces, **kw)
    build = time.perf_counter() - t0
    quintic = random_polynomial(5, 3, seed=2)
    st = space.stats
    ctrl = space.control_points(np.random.default_rng(0).normal(size=(space.n_free, 3)))
    plane = lambda p: np.column_stack([p[:, 0], p[:, 1], 0.3 * p[:, 0] - 0.2 * p[:, 1]])  # noqa: E731
    return dict(lin=reproduction(space, plane), quintic=reproduction(space, quintic),
                max_M=float(np.abs(space.M.data).max()),
                elim=st["max_elimination_coefficient"], singular=space.n_singular, snapped=st["snapped_vertices"],
                exact=st["exact_vertices"], move=st["max_relative_move"],
                c1=continuity_report(space.tri, ctrl)["c1_relative"], build=build)


def spline_table(n: int) -> None:
    print(f"# spline: {n} x {n} grids perturbed by eps; 'peer' = the double-only build (snap_tol=0, exact_tol=0)")
    hdr = (f"{'grid':>10} {'eps':>6} | {'lin':>7} {'peer':>7} | {'quintic':>7} {'peer':>7} | "
           f"{'max|M|':>6} {'peer':>6} | {'elim':>5} {'peer':>5} | {'sing':>4} {'snap':>4} {'dd':>4} "
           f"{'move/h':>7} {'C1':>7} | {'build s':>7} {'peer':>6}")
    print(hdr)
    print("-" * len(hdr))
    for kind in ("crisscross", "alternate"):
        uv0, faces = domains.grid(n, diagonal=kind)
        for eps in EPS:
            uv = domains.perturb(uv0, faces, eps, seed=1) if eps else uv0
            a, b = spline_row(uv, faces), spline_row(uv, faces, **PEER)
            print(f"{kind:>10} {eps:>6.0e} | {a['lin']:>7.1e} {b['lin']:>7.1e} | {a['quintic']:>7.1e} "
                  f"{b['quintic']:>7.1e} | {a['max_M']:>6.1f} {b['max_M']:>6.1f} | {a['elim']:>5.1f} {b['elim']:>5.1f} | "
                  f"{a['singular']:>4} {a['snapped']:>4} {a['exact']:>4} {a['move']:>7.1e} {a['c1']:>7.1e} | "
                  f"{a['build']:>7.3f} {b['build']:>6.3f}")


@contextlib.contextmanager
def peer_build(enabled: bool):
    """Make the fit build its space the double-only way (the peer), for the duration."""
    from trispline.fit import pipeline

    saved = pipeline.build_space
    if enabled:
        pipeline.build_space = lambda tri: saved(tri, **PEER)
    try:
        yield
    finally:
        pipeline.build_space = saved


def fit_row(uv: np.ndarray, faces: np.ndarray, peer: bool) -> dict:
    from trispline.fit import fit_surface
    from trispline.fit.datasets import franke

    V = np.column_stack([uv, franke.exponential(uv[:, 0], uv[:, 1])])
    with peer_build(peer):
        t0 = time.perf_counter()
        res = fit_surface(V, faces, uv=V[:, :2])
        seconds = time.perf_counter() - t0
    s = res.surface
    bary = lattice(6) / 6.0
    fi = np.repeat(np.arange(len(faces)), len(bary))
    bb = np.tile(bary, (len(faces), 1))
    xyz = s.evaluate(fi, bb)
    dom = np.einsum("nk,nkd->nd", bb, s.uv[s.faces[fi]])
    dz = xyz[:, 2] - franke.exponential(xyz[:, 0], xyz[:, 1])
    size = float(np.ptp(s.uv, axis=0).max())
    return dict(xy=float(np.abs(xyz[:, :2] - dom).max()) / size, rms=float(np.sqrt(np.mean(dz**2))),
                zmax=float(np.abs(dz).max()), move=res.space.stats["max_move"] / size, c1=res.c1_residual, s=seconds)


def fit_table(n: int) -> None:
    import jax

    jax.config.update("jax_enable_x64", True)
    uv0, faces = domains.grid(n, diagonal="crisscross")
    print(f"\n# fit --param uv of a {n} x {n} criss-cross height field (Franke exponential); 'peer' as above")
    hdr = (f"{'eps':>6} | {'|x-u|':>7} {'peer':>7} | {'z RMS':>9} {'peer':>9} | {'z max':>9} {'peer':>9} | "
           f"{'move':>7} {'C1':>7} {'fit s':>5}")
    print(hdr)
    print("-" * len(hdr))
    for eps in FIT_EPS:
        uv = domains.perturb(uv0, faces, eps, seed=1) if eps else uv0
        a, b = fit_row(uv, faces, False), fit_row(uv, faces, True)
        print(f"{eps:>6.0e} | {a['xy']:>7.1e} {b['xy']:>7.1e} | {a['rms']:>9.3e} {b['rms']:>9.3e} | {a['zmax']:>9.3e} "
              f"{b['zmax']:>9.3e} | {a['move']:>7.1e} {a['c1']:>7.1e} {a['s']:>5.1f}")
    print("target (issue 14): |x-u| <= 1e-12 in every row; z RMS / max equal to the exact grid's (eps = 0)")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", type=int, default=30, help="grid cells per side")
    ap.add_argument("--no-fit", action="store_true", help="only the spline table (no JAX)")
    args = ap.parse_args()
    spline_table(args.n)
    if not args.no_fit:
        fit_table(args.n)


if __name__ == "__main__":
    main()
