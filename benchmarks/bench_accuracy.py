"""Accuracy of scattered-data interpolation: trispline vs scipy and matplotlib peers.

For each Renka--Brown test function (Franke's six and four more) and each N, N
points in the unit square (corners and sides sampled too) are Delaunay
triangulated and interpolated by

* ``trispline``  -- :func:`trispline.fit.fit_surface` with ``uv = (x, y)``
* ``CT``         -- ``scipy.interpolate.CloughTocher2DInterpolator``
* ``minE``       -- ``matplotlib.tri.CubicTriInterpolator(kind="min_E")``

on the same points. Errors are measured on a 101 x 101 grid: RMS, max, and the
finite-difference thin-plate energy of each interpolant (the exact function's
in the ``exact`` column).

    python benchmarks/bench_accuracy.py                 # full table (N = 100, 400, 1600)
    python benchmarks/bench_accuracy.py --n 400 --functions exponential,cliff
    python benchmarks/bench_accuracy.py --tilt 1 --local 10   # try other weights
    python benchmarks/bench_accuracy.py --sparse        # issue 17: sparse node sets, see below

``--sparse`` (issue 17) runs the sparse protocol instead: node sets of :data:`SPARSE_N`
points (25 to 100) whose boundary is sampled only at the square's four corners
(``sample_points(n, boundary_fraction=0)``: long thin triangles along the sides, where a
local fit is a one-sided extrapolation), every function; the target is trispline at or
below the better peer in every case.
"""
from __future__ import annotations

import argparse
import sys
import time
import warnings

import jax
import numpy as np

jax.config.update("jax_enable_x64", True)

import matplotlib.tri as mtri  # noqa: E402
from scipy.interpolate import CloughTocher2DInterpolator  # noqa: E402
from scipy.spatial import Delaunay  # noqa: E402

from trispline.fit import FitWeights, fit_surface  # noqa: E402
from trispline.fit.datasets.franke import RENKA_BROWN, sample_points  # noqa: E402
from trispline.spline.bernstein import basis  # noqa: E402
from trispline.spline.testing.domains import orient_ccw  # noqa: E402

GRID = 101
#: The sparse node sets' sizes (``--sparse``); their boundary points are the four corners only.
SPARSE_N = (25, 33, 50, 65, 100)


def grid_points(n: int = GRID) -> tuple[np.ndarray, np.ndarray]:
    t = np.linspace(0.0, 1.0, n)
    X, Y = np.meshgrid(t, t, indexing="xy")
    return X, Y


def eval_spline(uv, faces, ctrl, X, Y) -> np.ndarray:
    """Heights of a height-field spline (``x(u,v) = u``) at grid points."""
    tri = mtri.Triangulation(uv[:, 0], uv[:, 1], faces)
    finder = tri.get_trifinder()
    x, y = X.ravel(), Y.ravel()
    f = finder(x, y)
    # points exactly on the square's boundary can be missed by the finder: nudge inwards
    miss = f < 0
    if miss.any():
        eps = 1e-12
        f[miss] = finder(np.clip(x[miss], eps, 1 - eps), np.clip(y[miss], eps, 1 - eps))
    if (f < 0).any():
        raise RuntimeError(f"{int((f < 0).sum())} grid points outside the triangulation")
    P = uv[faces[f]]  # (n, 3, 2)
    a, b, c = P[:, 0], P[:, 1], P[:, 2]
    det = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])
    l1 = ((x - a[:, 0]) * (c[:, 1] - a[:, 1]) - (y - a[:, 1]) * (c[:, 0] - a[:, 0])) / det
    l2 = ((b[:, 0] - a[:, 0]) * (y - a[:, 1]) - (b[:, 1] - a[:, 1]) * (x - a[:, 0])) / det
    bary = np.column_stack([1 - l1 - l2, l1, l2])
    z = np.einsum("nk,nk->n", basis(bary), ctrl[f, :, 2])
    return z.reshape(X.shape)


def fd_thin_plate(Z: np.ndarray) -> float:
    """Finite-difference thin-plate energy of grid values over the unit square."""
    h = 1.0 / (Z.shape[0] - 1)
    zxx = (Z[1:-1, 2:] - 2 * Z[1:-1, 1:-1] + Z[1:-1, :-2]) / h**2
    zyy = (Z[2:, 1:-1] - 2 * Z[1:-1, 1:-1] + Z[:-2, 1:-1]) / h**2
    zxy = (Z[2:, 2:] - Z[2:, :-2] - Z[:-2, 2:] + Z[:-2, :-2]) / (4 * h**2)
    return float(np.sum(zxx**2 + 2 * zxy**2 + zyy**2) * h**2)


def run_case(name: str, func, n: int, weights: FitWeights, seed: int = 0, boundary_fraction: float | None = None
             ) -> dict:
    p = sample_points(n, seed=seed, boundary_fraction=boundary_fraction)
    z = func(p[:, 0], p[:, 1])
    faces = orient_ccw(p, Delaunay(p).simplices)
    X, Y = grid_points()
    exact = func(X, Y)
    out = {"exact": (0.0, 0.0, fd_thin_plate(exact))}

    t0 = time.perf_counter()
    V = np.column_stack([p, z])
    res = fit_surface(V, faces, uv=p, weights=weights)
    Zt = eval_spline(p, res.faces, res.ctrl, X, Y)
    t_fit = time.perf_counter() - t0

    ct = CloughTocher2DInterpolator(p, z)
    Zc = ct(X, Y)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        tri = mtri.Triangulation(p[:, 0], p[:, 1], faces)
        mi = mtri.CubicTriInterpolator(tri, z, kind="min_E")
        Zm = np.asarray(mi(X, Y).filled(np.nan))
    for key, Z in (("trispline", Zt), ("CT", Zc), ("minE", Zm)):
        err = Z - exact
        ok = np.isfinite(err)
        out[key] = (float(np.sqrt(np.mean(err[ok] ** 2))), float(np.abs(err[ok]).max()), fd_thin_plate(np.where(ok, Z, exact)))
    out["time"] = t_fit
    out["c1"] = res.c1_residual
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", default="100,400,1600", help="comma-separated point counts")
    ap.add_argument("--functions", default=",".join(RENKA_BROWN), help="comma-separated names")
    ap.add_argument("--seed", type=int, default=0)
    d = FitWeights()
    for k in ("bend", "tilt", "local", "angle", "blend_power"):
        ap.add_argument(f"--{k.replace('_', '-')}", type=float, default=getattr(d, k))
    ap.add_argument("--fit-degree", type=int, default=d.fit_degree)
    ap.add_argument("--fit-rings", type=int, default=d.fit_rings)
    ap.add_argument("--quiet", action="store_true", help="only the summary line")
    ap.add_argument("--sparse", action="store_true",
                    help=f"sparse node sets (N = {', '.join(map(str, SPARSE_N))}, boundary sampled at the corners only)")
    a = ap.parse_args(argv)
    w = FitWeights(bend=a.bend, tilt=a.tilt, local=a.local, angle=a.angle, blend_power=a.blend_power,
                   fit_degree=a.fit_degree, fit_rings=a.fit_rings)
    ns = list(SPARSE_N) if a.sparse else [int(s) for s in a.n.split(",")]
    fraction = 0.0 if a.sparse else None
    names = a.functions.split(",")
    print(f"weights: {w}")
    hdr = (f"{'function':<12} {'N':>5} | {'RMS trispline':>13} {'CT':>9} {'minE':>9} {'ratio':>6} | "
           f"{'max trispline':>13} {'CT':>9} {'minE':>9} | {'TP exact':>9} {'trisp':>9} {'CT':>9} {'minE':>9} | {'fit s':>5}")
    if not a.quiet:
        print(hdr)
        print("-" * len(hdr))
    ratios = []
    wins = 0
    for name in names:
        for n in ns:
            r = run_case(name, RENKA_BROWN[name], n, w, seed=a.seed, boundary_fraction=fraction)
            best = min(r["CT"][0], r["minE"][0])
            ratio = r["trispline"][0] / best
            ratios.append(ratio)
            wins += r["trispline"][0] <= best
            if not a.quiet:
                print(f"{name:<12} {n:>5} | {r['trispline'][0]:13.3e} {r['CT'][0]:9.3e} {r['minE'][0]:9.3e} {ratio:6.2f} | "
                      f"{r['trispline'][1]:13.3e} {r['CT'][1]:9.3e} {r['minE'][1]:9.3e} | "
                      f"{r['exact'][2]:9.3e} {r['trispline'][2]:9.3e} {r['CT'][2]:9.3e} {r['minE'][2]:9.3e} | {r['time']:5.2f}")
            sys.stdout.flush()
    ratios = np.array(ratios)
    print(f"summary: trispline RMS <= best peer in {wins}/{ratios.size} cases; ratio to best peer: "
          f"geo-mean {np.exp(np.log(ratios).mean()):.3f}, max {ratios.max():.3f}, "
          f"cases <= 0.5: {(ratios <= 0.5).sum()}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
