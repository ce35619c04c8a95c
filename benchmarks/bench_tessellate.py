"""Tessellation throughput: trispline.spline.tessellate vs a plain per-patch de Casteljau loop.

    python benchmarks/bench_tessellate.py [--faces 10000 100000] [--resolution 8]

Both produce, for every patch, the surface points of the regular barycentric grid
with ``r`` steps per edge and unit normals. ``tessellate`` evaluates every shared
boundary point once (``V + (r-1)E + (r-1)(r-2)/2 F`` vertices, plus triangles and uv);
the peer evaluates every patch's ``(r+1)(r+2)/2`` points separately by de Casteljau
in a Python loop over patches (no triangles). Throughput = points produced / second.
The peer is timed on at most ``--peer-max`` patches and scaled linearly (marked ``*``).
"""
from __future__ import annotations

import argparse
import time

import numpy as np

from trispline.spline.testing import domains
from trispline.spline.bernstein import bary_grid
from trispline.spline.polynomial import polynomial_control_net, random_polynomial
from trispline.spline.tessellate import tessellate
from trispline.spline.topology import Triangulation

_EXP = [(i, j, 5 - i - j) for i in range(5, -1, -1) for j in range(5 - i, -1, -1)]


def de_casteljau_patch(ctrl: np.ndarray, bary: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """One patch: ``ctrl (21, 3)`` at ``bary (n, 3)`` -> points ``(n, 3)``, unit normals ``(n, 3)``."""
    level = {e: np.broadcast_to(ctrl[n], (bary.shape[0], 3)) for n, e in enumerate(_EXP)}
    la, lb, lc = (bary[:, k : k + 1] for k in range(3))
    for deg in range(4, 0, -1):  # down to the linear level
        level = {
            (i, j, deg - i - j): la * level[(i + 1, j, deg - i - j)]
            + lb * level[(i, j + 1, deg - i - j)]
            + lc * level[(i, j, deg - i - j + 1)]
            for i in range(deg, -1, -1) for j in range(deg - i, -1, -1)
        }
    a, b, c = level[(1, 0, 0)], level[(0, 1, 0)], level[(0, 0, 1)]
    point = la * a + lb * b + lc * c
    n = np.cross(b - a, c - a)
    return point, n / np.linalg.norm(n, axis=1, keepdims=True)


def peer(ctrl: np.ndarray, r: int) -> int:
    bary = bary_grid(r)
    for f in range(ctrl.shape[0]):
        de_casteljau_patch(ctrl[f], bary)
    return ctrl.shape[0] * bary.shape[0]


def best_of(fn, repeat: int) -> tuple[float, float, object]:
    """Best wall time, best CPU time (all threads) and the last result."""
    best, best_cpu, out = np.inf, np.inf, None
    for _ in range(repeat):
        t, c = time.perf_counter(), time.process_time()
        out = fn()
        best = min(best, time.perf_counter() - t)
        best_cpu = min(best_cpu, time.process_time() - c)
    return best, best_cpu, out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--faces", type=int, nargs="+", default=[10_000, 100_000])
    ap.add_argument("--resolution", type=int, default=8)
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--peer-max", type=int, default=10_000)
    args = ap.parse_args()
    r = args.resolution
    rows = []
    for target in args.faces:
        nx = max(1, int(round(np.sqrt(target / 2))))
        uv, faces = domains.grid(nx)
        uv = domains.perturb(uv, faces, 0.2, seed=0)
        ctrl = polynomial_control_net(uv, faces, random_polynomial(5, 3, 0))
        nf = faces.shape[0]
        tri = Triangulation(uv, faces)
        _ = tri.edge_faces  # build the edge tables outside the timing
        t_pre, c_pre, mesh = best_of(lambda: tessellate(uv, faces, ctrl, r, triangulation=tri), args.repeat)
        t_all, c_all, _ = best_of(lambda: tessellate(uv, faces, ctrl, r), args.repeat)
        m = mesh.vertices.shape[0]
        sub = min(nf, args.peer_max)
        t_peer, c_peer, pts = best_of(lambda: peer(ctrl[:sub], r), 1)
        scale = nf / sub
        t_peer_full, c_peer_full = t_peer * scale, c_peer * scale
        peer_pts = int(pts * scale)
        star = "*" if sub < nf else ""
        rows.append((nf, "tessellate (topology cached)", t_pre, c_pre, m, t_peer_full / t_pre))
        rows.append((nf, "tessellate (incl. topology)", t_all, c_all, m, t_peer_full / t_all))
        rows.append((nf, f"peer: per-patch de Casteljau{star}", t_peer_full, c_peer_full, peer_pts, 1.0))
    print(f"resolution {r}; best of {args.repeat}; * = peer timed on {args.peer_max} patches, scaled; "
          "cpu = process CPU seconds (all threads)")
    print(f"{'faces':>8} | {'method':<34} | {'wall s':>7} | {'cpu s':>7} | {'points':>9} | "
          f"{'Mpts/s wall':>11} | {'Mpts/s cpu':>10} | {'speedup':>7}")
    print("-" * 113)
    for nf, name, t, c, m, sp in rows:
        print(f"{nf:>8} | {name:<34} | {t:>7.3f} | {c:>7.3f} | {m:>9} | {m / t / 1e6:>11.2f} | "
              f"{m / max(c, 1e-9) / 1e6:>10.2f} | {sp:>7.1f}")


if __name__ == "__main__":
    main()
