"""Exact CAD export: conversion, writing, file size and read-back of STEP, IGES and 3dm.

    python benchmarks/bench_cad.py [--faces 1000 10000 100000] [--formats .step .igs .3dm] [--merge]

For each size, a quintic spline over a perturbed grid (a random quintic polynomial's net)
is converted into ``3 F`` bi-quintic tensor patches (:func:`trispline.spline.tensor.tensor_net`,
timed alone, best of ``--repeat``), then written by :func:`trispline.fit.io.cad.export_cad`
(conversion, B-rep tables, the Open CASCADE shell and the writer: the whole call) and read
back (Open CASCADE's STEP/IGES readers, transfer included; rhino3dm for 3dm). The peer,
measured in the same run, is the tessellated export of the same surface to OBJ
(``export_surface(..., resolution=8)``); ``x OBJ`` is the CAD write time over it. ``cpu s``
is the write's CPU time (all threads): on a loaded machine it shows the share it got.
"""
from __future__ import annotations

import argparse
import os
import resource
import tempfile
import time
from pathlib import Path

import numpy as np

from trispline.fit.io.cad import cad_layout, export_cad, occ_shell, read_cad
from trispline.fit.io.export import export_surface
from trispline.spline.polynomial import polynomial_control_net, random_polynomial
from trispline.spline.surface import SplineSurface
from trispline.spline.tensor import tensor_net
from trispline.spline.testing import domains


def grid_surface(n_faces: int) -> SplineSurface:
    """About ``n_faces`` quintic patches over a perturbed grid (a random quintic's exact net)."""
    nx = max(1, int(round(np.sqrt(n_faces / 2))))
    uv, faces = domains.grid(nx)
    uv = domains.perturb(uv, faces, 0.2, seed=0)
    poly = random_polynomial(5, 1, 0)
    ctrl = polynomial_control_net(uv, faces, lambda p: np.column_stack([p, 0.1 * poly(p)]))
    return SplineSurface(uv, faces, ctrl)


def timed(fn) -> tuple[float, object]:
    t = time.perf_counter()
    out = fn()
    return time.perf_counter() - t, out


def cpu_timed(fn) -> tuple[float, float]:
    """Wall and CPU seconds (all threads) of ``fn()``: CPU time shows a loaded machine's share."""
    t, c = time.perf_counter(), time.process_time()
    fn()
    return time.perf_counter() - t, time.process_time() - c


def read_back(path: Path) -> int:
    """Read a written file; returns its number of faces (surfaces for 3dm)."""
    if path.suffix == ".3dm":
        import rhino3dm

        return len(rhino3dm.File3dm.Read(str(path)).Objects)
    from OCP.TopAbs import TopAbs_FACE
    from OCP.TopExp import TopExp_Explorer

    explorer, n = TopExp_Explorer(read_cad(path), TopAbs_FACE), 0
    while explorer.More():
        n += 1
        explorer.Next()
    return n


def conversion_row(surface: SplineSurface, repeat: int) -> dict:
    tri = surface.triangulation
    _ = tri.edge_faces, tri.vertex_corner  # the topology is the surface's, built once
    best = min(timed(lambda: tensor_net(surface.uv, surface.faces, surface.ctrl, triangulation=tri))[0]
               for _ in range(repeat))
    net = tensor_net(surface.uv, surface.faces, surface.ctrl, triangulation=tri)
    t_shell, _ = timed(lambda: occ_shell(net, cad_layout(net)))
    return dict(convert=best, rate=surface.n_faces / best, shell=t_shell)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--faces", type=int, nargs="+", default=[1_000, 10_000, 100_000])
    ap.add_argument("--formats", nargs="+", default=[".step", ".igs", ".3dm"])
    ap.add_argument("--merge", action="store_true", help="also write with merge=True")
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    head = (f"{'patches':>8} {'faces':>8} {'convert s':>9} {'patches/s':>10} {'shell s':>8} {'format':>12} "
            f"{'write s':>8} {'cpu s':>7} {'MB':>7} {'read s':>8} {'OBJ s':>6} {'x OBJ':>6}")
    print(head)
    print("-" * len(head))
    with tempfile.TemporaryDirectory() as folder:
        for suffix in args.formats:  # load Open CASCADE / rhino3dm (seconds) outside the timings
            read_back(export_cad(grid_surface(2), Path(folder) / f"warm{suffix}"))
        for target in args.faces:
            surface = grid_surface(target)
            conv = conversion_row(surface, args.repeat)
            t_obj, _ = timed(lambda: export_surface(surface, Path(folder) / "peer.obj", resolution=8))
            for suffix in args.formats:
                for merge in ([False, True] if args.merge else [False]):
                    path = Path(folder) / f"s{suffix}"
                    t_write, c_write = cpu_timed(lambda: export_cad(surface, path, merge=merge))
                    t_read, n = timed(lambda: read_back(path))
                    assert n == (2 if merge else 3) * surface.n_faces, n
                    name = suffix + (" merged" if merge else "")
                    print(f"{surface.n_faces:>8} {n:>8} {conv['convert']:>9.3f} {conv['rate']:>10.3g} "
                          f"{conv['shell']:>8.2f} {name:>12} {t_write:>8.2f} {c_write:>7.2f} "
                          f"{path.stat().st_size / 1e6:>7.1f} "
                          f"{t_read:>8.2f} {t_obj:>6.2f} {t_write / t_obj:>6.1f}", flush=True)
                    path.unlink()
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 2**20
    print(f"peak memory {peak:.1f} GB; load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores")


if __name__ == "__main__":
    main()
