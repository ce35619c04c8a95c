"""Approximation at equal size (issue 15): quadric-error decimation against trispline, one table.

    python benchmarks/bench_approximate.py [--only NAME ...] [--fraction F] [--no-million] [--fast-simplification]

Rows: every mesh in ``../shared/data`` that trispline accepts (2% of its vertices when
it has at least 20k faces, else 5%), and generated scans (:mod:`trispline.fit.datasets.truth`,
``bumps`` with noise ``1e-3`` of the diagonal and 0.5% outliers at 50 sigma) of 100k
and 1M faces. Peers measured in the same run, each in its own process (so the time
and the peak RSS are that row's own):

* ``qslim`` -- libigl's quadric-error edge collapse (``igl.qslim``: open meshes and
  holes kept) to the same vertex count, the piecewise-linear answer users have today;
* ``fast-simpl`` -- ``fast_simplification`` (optional, benchmarks only; its output may
  be non-manifold, the distances are still exact);
* ``trispline`` -- the approximating spline: **a slot** (``-``) until the fit of issue 15
  exists; :func:`trispline_row` says what it will measure.

Deviation both ways, as fractions of the scan's bounding-box diagonal: data -> model
(every scan vertex to the model: exact point-triangle distances, or for the spline the
closest point on the surface) and model -> data (samples on every model face, on a
barycentric lattice of :data:`SAMPLE_STEPS` steps, to the scan's triangles).
Targets (issue 15): trispline RMS <= 1/3 and max <= 1/2 of qslim's, both ways.
"""
from __future__ import annotations

import argparse
import json
import resource
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

DATA = Path(__file__).resolve().parents[2] / "shared" / "data"
#: Meshes with at least this many faces get the small fraction.
LARGE_FACES = 20_000
FRACTION_LARGE, FRACTION_SMALL = 0.02, 0.05
#: Generated scans: name -> vertex count (faces about twice).
GENERATED = {"generated-100k": 50_000, "generated-1M": 500_000}
#: Lattice steps per model face for the model -> data samples.
SAMPLE_STEPS = 4
#: Attempts at hitting the vertex count with qslim (it takes a face count).
QSLIM_TRIES = 3


def load(name: str) -> tuple[np.ndarray, np.ndarray]:
    """The scan ``V (n, 3)``, ``F (m, 3)`` of a row: a generated scan or a mesh file, validated."""
    if name in GENERATED:
        from trispline.fit.datasets.truth import truth_scan

        s = truth_scan("bumps", GENERATED[name], sigma=1e-3, outliers=0.005, outlier_sigmas=50.0, seed=0)
        return s.V, s.F
    from trispline.fit.io import read_mesh
    from trispline.param import validate_mesh

    md = read_mesh(DATA / name)
    vm = validate_mesh(md.V, md.F)  # raises MeshError for what fit would refuse
    return vm.V, vm.F


def face_samples(V: np.ndarray, F: np.ndarray, r: int = SAMPLE_STEPS) -> np.ndarray:
    """Points ``(F (r+1)(r+2)/2, 3)`` on every triangle, at its barycentric lattice."""
    from trispline.spline.index import lattice

    w = lattice(r) / r
    return np.einsum("gk,fkd->fgd", w, V[F]).reshape(-1, 3)


def both_ways(V: np.ndarray, F: np.ndarray, U: np.ndarray, G: np.ndarray) -> dict[str, float]:
    """RMS and max distance scan -> model and model -> scan (meshes), relative to the scan's diagonal."""
    from trispline.fit.approx import summary
    from trispline.param import closest_points

    diag = float(np.linalg.norm(V.max(0) - V.min(0)))
    fwd = np.sqrt(np.maximum(closest_points(V, U, G)[0], 0.0)) / diag
    back = np.sqrt(np.maximum(closest_points(face_samples(U, G), V, F)[0], 0.0)) / diag
    a, b = summary(fwd), summary(back)
    return {"fwd_rms": a["rms"], "fwd_max": a["max"], "back_rms": b["rms"], "back_max": b["max"]}


def qslim(V: np.ndarray, F: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray]:
    """libigl's quadric decimation to about ``k`` vertices (its target is a face count: rescaled)."""
    import igl

    m = 2 * k
    for _ in range(QSLIM_TRIES):
        out = igl.qslim(np.asfortranarray(V, np.float64), np.asfortranarray(F, np.int32), int(m))
        U, G = np.asarray(out[0]), np.asarray(out[1], np.int64)
        if abs(U.shape[0] - k) <= 0.02 * k:
            break
        m = max(4, int(round(m * k / max(U.shape[0], 1))))
    return U, G


def fast_simpl(V: np.ndarray, F: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray]:
    """``fast_simplification`` to about ``2 k`` faces (benchmarks only; not a trispline dependency)."""
    import fast_simplification

    U, G = fast_simplification.simplify(V.astype(np.float32), F.astype(np.int32),
                                        target_reduction=max(0.0, 1.0 - 2.0 * k / F.shape[0]))
    return np.asarray(U, np.float64), np.asarray(G, np.int64)


def trispline_row(V: np.ndarray, F: np.ndarray, k: int) -> dict | None:
    """SLOT for the approximating fit (issue 15, second half); returns None until it exists.

    It will parameterize the scan (LSCM), build :func:`trispline.fit.approx.coarse_domain`
    with ``n_vertices=k``, fit, and measure :func:`trispline.fit.approx.surface_deviation`
    (scan -> surface) and :func:`trispline.fit.approx.mesh_deviation` (surface -> scan), both
    relative to the diagonal, with the same keys as :func:`both_ways` plus ``verts``.
    """
    return None


METHODS = {"qslim": qslim, "fast-simpl": fast_simpl, "trispline": None}


def run_row(name: str, fraction: float | None, method: str) -> dict:
    """One row, measured in this process: the peer's model and its deviation both ways."""
    t0 = time.perf_counter()
    V, F = load(name)
    t_load = time.perf_counter() - t0
    frac = fraction if fraction is not None else (FRACTION_LARGE if F.shape[0] >= LARGE_FACES else FRACTION_SMALL)
    k = max(8, int(round(frac * V.shape[0])))
    row = {"mesh": name, "faces": int(F.shape[0]), "frac": frac, "target": k, "method": method}
    t0 = time.perf_counter()
    if method == "trispline":
        res = trispline_row(V, F, k)
        if res is None:
            return {**row, "slot": True}
        row.update(res)
    else:
        U, G = METHODS[method](V, F, k)
        row["verts"], row["model_faces"] = int(U.shape[0]), int(G.shape[0])
        row["seconds"] = time.perf_counter() - t0
        row.update(both_ways(V, F, U, G))
    row["load_seconds"] = t_load
    row["peak_mb"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
    return row


def child(name: str, fraction: float | None, method: str) -> dict:
    """:func:`run_row` in a fresh interpreter (its own time and peak RSS); a failure becomes ``error``."""
    cmd = [sys.executable, __file__, "--row", json.dumps([name, fraction, method])]
    out = subprocess.run(cmd, capture_output=True, text=True)
    try:
        return json.loads(out.stdout.strip().splitlines()[-1])
    except (IndexError, json.JSONDecodeError):
        last = (out.stderr.strip().splitlines() or ["no output"])[-1]
        return {"mesh": name, "method": method, "error": last[:100]}


HEADER = (f"{'mesh':<34} {'faces':>8} {'frac':>5} {'method':>10} {'verts':>6} "
          f"{'d>m rms':>8} {'d>m max':>8} {'m>d rms':>8} {'m>d max':>8} {'s':>6} {'MB':>6}")


def line(r: dict) -> str:
    """One table row: deviations relative to the diagonal, time of the method alone, peak RSS of the row."""
    head = f"{r['mesh']:<34} {r.get('faces', 0):>8} {r.get('frac', 0):>5.2f} {r['method']:>10}"
    if "error" in r:
        return f"{head}  {r['error']}"
    if r.get("slot"):
        return f"{head} {'-':>6} {'-':>8} {'-':>8} {'-':>8} {'-':>8} {'-':>6} {'-':>6}  (slot: the fit of issue 15)"
    return (f"{head} {r['verts']:>6} {r['fwd_rms']:>8.1e} {r['fwd_max']:>8.1e} {r['back_rms']:>8.1e} "
            f"{r['back_max']:>8.1e} {r['seconds']:>6.1f} {r['peak_mb']:>6.0f}")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--only", nargs="*", help="row names (mesh files or generated-100k / generated-1M)")
    ap.add_argument("--fraction", type=float, help="vertex fraction for every row (default 2%% / 5%%)")
    ap.add_argument("--no-million", action="store_true", help="skip the 1M-face generated scan")
    ap.add_argument("--fast-simplification", action="store_true", help="add fast_simplification rows")
    ap.add_argument("--row", help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.row:
        print(json.dumps(run_row(*json.loads(args.row))))
        return 0
    names = sorted(p.name for p in DATA.iterdir() if p.suffix in (".obj", ".off", ".ply", ".stl")) if DATA.is_dir() else []
    names += [g for g in GENERATED if not (args.no_million and g.endswith("1M"))]
    if args.only:
        names = [n for n in names if n in args.only]
    methods = ["qslim"] + (["fast-simpl"] if args.fast_simplification else []) + ["trispline"]
    print(HEADER)
    print("-" * len(HEADER))
    for name in names:
        for method in methods:
            r = child(name, args.fraction, method)
            if "error" in r:  # a mesh trispline refuses: one line, not one per method
                print(f"{name:<34} rejected: {r['error']}", flush=True)
                break
            print(line(r), flush=True)
    print("deviation relative to the bounding-box diagonal; d>m: scan vertices to the model, m>d: model samples "
          "to the scan;\ntarget (issue 15): trispline rms <= 1/3 and max <= 1/2 of qslim's at the same vertex count")
    return 0


if __name__ == "__main__":
    sys.exit(main())
