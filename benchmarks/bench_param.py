"""Parameterization time against a bare libigl harmonic solve on the same mesh.

    python benchmarks/bench_param.py [--repeat 3] [--quick]

Meshes: a generated bumpy disk of ~10k faces, ../shared/data/mountain.obj (50k faces,
when present) and a generated bumpy disk of ~200k faces. Columns (best of ``repeat``):

* ``igl.harmonic``: ``igl.map_vertices_to_circle`` + ``igl.harmonic`` on the outer loop
  (the peer: the bare solve, with the boundary loop already known), through the thin
  wrapper :func:`trispline.param.harmonic_uv`;
* ``validate``: :func:`trispline.param.validate_mesh`;
* ``harmonic`` / ``lscm``: :func:`trispline.param.parameterize` end to end (validation,
  hole filling, solve, fold check, normalisation, distortion report);
* ``x bare``: ``harmonic`` over ``igl.harmonic``.
"""
from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from trispline.fit.io import read_mesh
from trispline.param import harmonic_uv, parameterize, validate_mesh
from trispline.param.testing import bumpy_disk

DATA = Path(__file__).resolve().parents[2] / "shared" / "data"


def best(fn, repeat: int) -> float:
    times = []
    for _ in range(repeat):
        t = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t)
    return min(times)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--quick", action="store_true", help="skip the 200k-face mesh")
    args = ap.parse_args()
    meshes = [("bumpy disk 10k", *bumpy_disk(10_000))]
    if (DATA / "mountain.obj").exists():
        m = read_mesh(DATA / "mountain.obj")
        meshes.append(("mountain.obj", m.V, m.F))
    else:
        print("(../shared/data/mountain.obj not present: skipped)")
    if not args.quick:
        meshes.append(("bumpy disk 200k", *bumpy_disk(200_000)))

    head = f"{'mesh':18s} {'faces':>8s} {'igl.harmonic':>13s} {'validate':>9s} {'harmonic':>9s} " \
           f"{'x bare':>7s} {'lscm':>8s}  {'angle p50/p99 (h)':>18s} {'area p50/p99 (h)':>17s}"
    print(head)
    print("-" * len(head))
    for name, V, F in meshes:
        vm = validate_mesh(V, F)
        loop = vm.boundary_loops[0]

        t_bare = best(lambda: harmonic_uv(V, F, loop), args.repeat)
        t_val = best(lambda: validate_mesh(V, F), args.repeat)
        t_h = best(lambda: parameterize(V, F, "harmonic"), args.repeat)
        t_l = best(lambda: parameterize(V, F, "lscm"), args.repeat)
        d = parameterize(V, F, "harmonic").distortion
        print(f"{name:18s} {F.shape[0]:8d} {t_bare:12.3f}s {t_val:8.3f}s {t_h:8.3f}s {t_h / t_bare:6.1f}x "
              f"{t_l:7.3f}s  {d['angle_p50']:8.3f} / {d['angle_p99']:6.2f} {d['area_p50']:7.3f} / "
              f"{d['area_p99']:6.2f}")


if __name__ == "__main__":
    np.seterr(all="raise")
    main()
