"""End-to-end fitting speed and memory: time per stage, total / factorisation, peak memory.

Rows (each in its own process, so its peak memory is its own):

* ``scan Nk``: a wavy height field on a jittered grid, written to OBJ, then loaded,
  parameterized (harmonic), fitted and saved in-process (``fit_surface``);
* ``mountain.obj`` from ``../shared/data`` when present;
* ``CLI random``: ``trispline fit --param uv`` end to end (interpreter and JAX start
  included) on a height field over random points (Delaunay), by default 100k faces.

Peer in the same run: ``scipy.interpolate.CloughTocher2DInterpolator`` building its
interpolant on the same points (a height-field-only cubic, shown for scale); ``x CT`` is
the row's total over that build time. ``total/factor`` is the row's total (load to save)
over its factorisation: the same normal matrix ordered (the fit's patch ordering), analysed and
factored again after the fit with nothing else running (``factor alone``; inside the fit the order
and the analysis overlap the assembly and share its cores; the CLI row: its factor stage); ``peak
MiB`` the process's peak resident memory; ``CPU s`` the process's CPU seconds (user + system: what
the row costs whatever the machine's load; for in-process rows they include the peer's build and
the ``alone`` factorisation, ~7 CPU s at 100k faces; the CLI row's are the fit's own). ``analysis``: the wall
seconds of the factorisation's analysis, which runs in the background beside ``assemble``
(``fit.solve.PatternAnalysis``), ``wait`` how long the ``factor`` stage waited for it (in-process rows).

    python benchmarks/bench_fit_speed.py                         # 10k 50k 100k 200k, CLI 100k
    python benchmarks/bench_fit_speed.py --faces 500000 --cli 0 --no-real
"""
from __future__ import annotations

import argparse
import contextlib
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

DATA = Path(__file__).resolve().parents[2] / "shared" / "data"
STAGES = ["load", "parameterize", "build", "assemble", "factor", "solve", "finish", "save"]


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
    return np.column_stack([x, y, z]), F


def make_random_scan(n_faces: int, seed: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """A height field over random points of the unit square (Delaunay): about ``n_faces`` faces."""
    from scipy.spatial import Delaunay

    rng = np.random.default_rng(seed)
    p = rng.random((n_faces // 2 + 2, 2))
    F = Delaunay(p).simplices
    x, y = p.T
    e1, e2 = p[F[:, 1]] - p[F[:, 0]], p[F[:, 2]] - p[F[:, 0]]
    ccw = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0] > 0
    F = np.where(ccw[:, None], F, F[:, [0, 2, 1]])
    z = 0.15 * np.sin(6 * x) * np.cos(5 * y) + 0.05 * np.sin(23 * x * y)
    return np.column_stack([x, y, z]), F


def write_obj(path: Path, V: np.ndarray, F: np.ndarray) -> None:
    with open(path, "w") as fh:
        np.savetxt(fh, V, fmt="v %.9g %.9g %.9g")
        np.savetxt(fh, F + 1, fmt="f %d %d %d")


def clough_tocher_seconds(V: np.ndarray) -> float:
    """Seconds scipy's CloughTocher2DInterpolator takes to build on ``V[:, :2] -> V[:, 2]``."""
    from scipy.interpolate import CloughTocher2DInterpolator

    t = time.perf_counter()
    CloughTocher2DInterpolator(V[:, :2], V[:, 2])
    return time.perf_counter() - t


def memory_touch_seconds(mib: int = 256) -> tuple[float, float]:
    """``(first, again)``: seconds per GiB to write ``mib`` MiB of fresh memory, and to write it once more.

    A virtual machine that backs its memory lazily, or hands freed pages back to its host (virtio
    free page reporting), makes every process pay on its first touch of a page: measured on the
    project's 2-core VMs 3.3-3.6 s/GiB first against 0.1-0.3 s/GiB again, so a fit that writes
    a few GB of fresh arrays loses seconds that a machine with resident memory does not (the
    row's wall, system and CPU seconds all rise). Printed with each run, so that tables from
    different machines can be told apart.
    """
    a = np.empty(mib << 17)  # float64: 8 bytes each
    t = time.perf_counter()
    a.fill(1.0)
    first = time.perf_counter() - t
    t = time.perf_counter()
    a.fill(2.0)
    again = time.perf_counter() - t
    return first * 1024 / mib, again * 1024 / mib


def fit_row(path: Path) -> dict:
    """Load, fit (harmonic) and save ``path`` in this process; the row's figures (run in a child)."""
    import jax

    jax.config.update("jax_enable_x64", True)
    from trispline.fit import fit_surface
    from trispline.fit.io import load_mesh

    t0 = time.perf_counter()
    V, F = load_mesh(path)
    t_load = time.perf_counter() - t0
    with normal_matrix_kept() as kept:
        res = fit_surface(V, F, param="harmonic")
    t1 = time.perf_counter()
    res.surface.save(Path(tempfile.mkdtemp()) / "surface.npz")
    row = dict(faces=int(F.shape[0]), free=int(res.stats["n_solved"]), load=t_load, **res.timings,
               save=time.perf_counter() - t1, steps=int(res.iterations), c1=float(res.c1_residual),
               analysis=float(res.stats["analysis_seconds"]), wait=float(res.stats["analysis_wait_seconds"]))
    row["total"] = sum(row[s] for s in STAGES)
    row["alone"] = factorisation_alone(kept["H_upper"], kept.get("ordering"))
    row["peer"] = clough_tocher_seconds(V)
    return row


@contextlib.contextmanager
def normal_matrix_kept():
    """Keep the upper triangle of the normal matrix the fit factors (``kept["H_upper"]``) and the maker
    of its elimination order (``kept["ordering"]``: it holds the patch incidence, ~15 MB at 100k faces)."""
    from trispline.fit.solve import PatternAnalysis

    kept, factor, start = {}, PatternAnalysis.factor, PatternAnalysis.start

    def keeping(self, H_upper, **kw):
        kept["H_upper"] = H_upper
        return factor(self, H_upper, **kw)

    def starting(self, pattern, ordering=None):
        kept["ordering"] = ordering
        return start(self, pattern, ordering)

    PatternAnalysis.factor, PatternAnalysis.start = keeping, starting
    try:
        yield kept
    finally:
        PatternAnalysis.factor, PatternAnalysis.start = factor, start


def factorisation_alone(H_upper, ordering=None) -> float:
    """Seconds of the factorisation the fit cannot avoid, on its own after the fit: the same
    matrix ordered (``ordering()``, the fit's :func:`~trispline.fit.ordering.patch_ordering`), analysed
    and factored by the same backend with nothing else running (the peer of ``t/factor``; inside
    the fit the ordering and the analysis overlap the assembly and share its cores)."""
    from trispline.fit.solve import SparseCholesky

    t = time.perf_counter()
    SparseCholesky(H_upper, upper=True, ordering=None if ordering is None else ordering())
    return time.perf_counter() - t


def run_child(cmd: list[str]) -> tuple[float, float, float, str]:
    """``(wall seconds, peak RSS in MiB, CPU seconds, stdout)`` of a child process (reaped with ``wait4``:
    its own rusage)."""
    t = time.perf_counter()
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    out = proc.stdout.read()
    err = proc.stderr.read()
    _, status, usage = os.wait4(proc.pid, 0)
    wall = time.perf_counter() - t
    proc.returncode = os.waitstatus_to_exitcode(status)
    if proc.returncode != 0:
        raise RuntimeError(f"{' '.join(map(str, cmd))} failed ({proc.returncode}):\n{err[-2000:]}")
    return wall, usage.ru_maxrss / 1024, usage.ru_utime + usage.ru_stime, out


def factorisation_seconds(r: dict) -> float:
    """The row's factorisation: measured alone after the fit (in-process rows), else its factor stage."""
    return r.get("alone") or r.get("factor") or float("nan")


def print_row(label: str, r: dict) -> None:
    ratio = r["total"] / factorisation_seconds(r)
    print(f"{label:<14} {r['faces']:>7} {r.get('free', 0):>8} | "
          + " ".join(f"{r[s]:8.2f}" if s in r else f"{'':>8}" for s in STAGES)
          + f" | {r['total']:8.2f} {ratio:7.2f} {r.get('steps', ''):>3} {r.get('c1', float('nan')):8.1e}"
          + f" {r['peak']:8.0f} {r['cpu']:7.1f} | {r['peer']:7.2f} {r['total'] / r['peer']:7.1f}"
          + (f" | {r['analysis']:8.2f} {r['wait']:6.2f} {r['alone']:7.2f}" if "analysis" in r else ""))
    sys.stdout.flush()


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--faces", default="10000,50000,100000,200000", help="scan sizes (comma separated; '' for none)")
    ap.add_argument("--cli", type=int, default=100000, help="faces of the CLI random-point row (0: none)")
    ap.add_argument("--no-real", action="store_true", help="skip mountain.obj")
    ap.add_argument("--row", metavar="OBJ", help=argparse.SUPPRESS)  # internal: one in-process row, JSON out
    a = ap.parse_args(argv)
    if a.row:
        print(json.dumps(fit_row(Path(a.row))))
        return 0
    hdr = (f"{'mesh':<14} {'faces':>7} {'unknowns':>8} | " + " ".join(f"{s[:8]:>8}" for s in STAGES)
           + f" | {'total s':>8} {'t/factor':>7} {'GN':>3} {'C1 rel':>8} {'peak MiB':>8} {'CPU s':>7}"
           + f" | {'CT s':>7} {'x CT':>7} | {'analysis':>8} {'wait':>6} {'alone':>7}")
    first, again = memory_touch_seconds()
    print(f"load average at start {os.getloadavg()[0]:.2f} ({os.cpu_count()} cores); fresh memory "
          f"{first:.2f} s/GiB to write first, {again:.2f} s/GiB again")
    print(hdr)
    print("-" * len(hdr))
    tmp = Path(tempfile.mkdtemp())
    jobs = []
    for nf in [int(s) for s in a.faces.split(",") if s]:
        V, F = make_scan(nf)
        write_obj(tmp / f"scan_{nf}.obj", V, F)
        jobs.append((tmp / f"scan_{nf}.obj", f"scan {nf // 1000}k"))
    if not a.no_real and (DATA / "mountain.obj").exists():
        jobs.append((DATA / "mountain.obj", "mountain.obj"))
    for path, label in jobs:
        wall, peak, cpu, out = run_child([sys.executable, __file__, "--row", str(path)])
        r = json.loads(out.strip().splitlines()[-1])
        r.update(peak=peak, cpu=cpu)
        print_row(label, r)
    if a.cli:
        V, F = make_random_scan(a.cli)
        path = tmp / "random.obj"
        write_obj(path, V, F)
        cmd = [sys.executable, "-m", "trispline.fit", "fit", str(path), "-o", str(tmp / "random.npz"),
               "--param", "uv", "--json", "--quiet"]
        wall, peak, cpu, out = run_child(cmd)
        d = json.loads(out)
        r = dict(faces=int(F.shape[0]), total=wall, peak=peak, cpu=cpu, peer=clough_tocher_seconds(V),
                 steps=d["iterations"], c1=d["c1_residual"], **d["timings"])
        print_row(f"CLI random {a.cli // 1000}k", r)
    print(f"load average at end {os.getloadavg()[0]:.2f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
