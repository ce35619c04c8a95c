"""End-to-end fitting speed: time per stage at 10k, 50k, 100k, 200k faces.

Generated "scans": a wavy height field on a jittered grid with a few holes cut
out, written to OBJ, then loaded, parameterized (harmonic), fitted and saved.
``mountain.obj`` from ``../shared/data`` is added when present.

    python benchmarks/bench_fit_speed.py                     # 10k 50k 100k 200k
    python benchmarks/bench_fit_speed.py --faces 10000,50000 --no-real

Peer in the same run: ``scipy.interpolate.CloughTocher2DInterpolator`` building
its interpolant on the same vertices (a height-field-only cubic, shown for scale).
"""
from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import jax
import numpy as np

jax.config.update("jax_enable_x64", True)

from scipy.interpolate import CloughTocher2DInterpolator  # noqa: E402

from trispline.fit import FitWeights, fit_surface  # noqa: E402
from trispline.fit.io import load_mesh  # noqa: E402

DATA = Path(__file__).resolve().parents[2] / "shared" / "data"


def make_scan(n_faces: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """A jittered-grid height field with about ``n_faces`` faces."""
    rng = np.random.default_rng(seed)
    n = int(np.sqrt(n_faces / 2.0))
    t = np.linspace(0, 1, n + 1)
    X, Y = np.meshgrid(t, t, indexing="xy")
    h = 1.0 / n
    J = rng.uniform(-0.25 * h, 0.25 * h, (2,) + X.shape)
    J[:, [0, -1], :] = 0
    J[:, :, [0, -1]] = 0
    x, y = (X + J[0]).ravel(), (Y + J[1]).ravel()
    idx = np.arange((n + 1) ** 2).reshape(n + 1, n + 1)
    a, b, c, d = idx[:-1, :-1].ravel(), idx[:-1, 1:].ravel(), idx[1:, 1:].ravel(), idx[1:, :-1].ravel()
    flip = rng.random(a.size) < 0.5
    f1 = np.where(flip[:, None], np.column_stack([a, b, d]), np.column_stack([a, b, c]))
    f2 = np.where(flip[:, None], np.column_stack([b, c, d]), np.column_stack([a, c, d]))
    F = np.concatenate([f1, f2])
    z = 0.15 * np.sin(6 * x) * np.cos(5 * y) + 0.05 * np.sin(23 * x * y) + 0.002 * rng.standard_normal(x.size)
    V = np.column_stack([x, y, z])
    return V, F


def write_obj(path: Path, V: np.ndarray, F: np.ndarray) -> None:
    with open(path, "w") as fh:
        np.savetxt(fh, V, fmt="v %.9g %.9g %.9g")
        np.savetxt(fh, F + 1, fmt="f %d %d %d")


def run(path: Path, label: str, weights: FitWeights) -> dict:
    t0 = time.perf_counter()
    V, F = load_mesh(path)
    t_load = time.perf_counter() - t0
    res = fit_surface(V, F, param="harmonic", weights=weights)
    t1 = time.perf_counter()
    res.surface.save(Path(tempfile.mkdtemp()) / "surface.npz")
    t_save = time.perf_counter() - t1
    # peer: Clough-Tocher on the same vertices (xy as domain)
    t2 = time.perf_counter()
    CloughTocher2DInterpolator(V[:, :2], V[:, 2])
    t_peer = time.perf_counter() - t2
    tm = dict(res.timings)
    row = dict(label=label, faces=F.shape[0], free=res.stats["n_solved"], load=t_load, **tm, save=t_save)
    row["total"] = t_load + sum(tm.values()) + t_save
    row["steps"] = res.iterations
    row["c1"] = res.c1_residual
    row["peer"] = t_peer
    return row


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--faces", default="10000,50000,100000,200000")
    ap.add_argument("--no-real", action="store_true", help="skip mountain.obj")
    a = ap.parse_args(argv)
    w = FitWeights()
    stages = ["load", "parameterize", "build", "assemble", "factor", "solve", "finish", "save"]
    hdr = f"{'mesh':<14} {'faces':>7} {'unknowns':>8} | " + " ".join(f"{s:>8}" for s in stages) + \
        f" | {'total s':>8} {'GN':>3} {'C1 rel':>8} | {'CT peer s':>9}"
    print(hdr)
    print("-" * len(hdr))
    jobs = []
    tmp = Path(tempfile.mkdtemp())
    for nf in [int(s) for s in a.faces.split(",")]:
        V, F = make_scan(nf)
        p = tmp / f"scan_{nf}.obj"
        write_obj(p, V, F)
        jobs.append((p, f"scan {nf // 1000}k"))
    if not a.no_real and (DATA / "mountain.obj").exists():
        jobs.append((DATA / "mountain.obj", "mountain.obj"))
    for p, label in jobs:
        r = run(p, label, w)
        print(f"{r['label']:<14} {r['faces']:>7} {r['free']:>8} | "
              + " ".join(f"{r.get(s, 0.0):8.2f}" for s in stages)
              + f" | {r['total']:8.2f} {r['steps']:>3} {r['c1']:8.1e} | {r['peer']:9.2f}")
        sys.stdout.flush()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
