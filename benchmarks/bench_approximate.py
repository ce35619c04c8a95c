"""Approximation of dense scans (issue 15): trispline against quadric decimation and the interpolating fit.

    python benchmarks/bench_approximate.py [--only NAME ...] [--fraction F] [--no-million] [--fast-simplification]
                                           [--no-interpolation] [--methods M ...]
    python benchmarks/bench_approximate.py --denoise [--surfaces bumps,cap] [--data-weights 100,300]
    python benchmarks/bench_approximate.py --compactness [--no-interpolation]
    python benchmarks/bench_approximate.py --speed [--no-million]
    python benchmarks/bench_approximate.py --scattered | --dropouts
    python benchmarks/bench_approximate.py --zebra OUT.png [--only MESH]

**Equal size** (the default table). Rows: every mesh in ``../shared/data`` that trispline
accepts (2% of its vertices when it has at least 20k faces, else 5%), and generated scans
(:mod:`trispline.fit.datasets.truth`, ``bumps``) of 100k and 1M faces: ``generated-100k-clean`` /
``generated-1M-clean`` sampled without noise (they measure the target), and ``generated-100k`` /
``generated-1M`` with noise ``1e-3`` of the diagonal and 0.5% outliers at 50 sigma (the **noise
floor**: their data -> model deviation is the noise's for every method, so their ratios are about 1
and do not measure accuracy; their ``tru`` columns, the model's samples to the TRUE surface, do).
Methods measured in the same run, each row in its own process (so the time and the peak RSS are
that row's own):

* ``qslim`` -- libigl's quadric-error edge collapse (``igl.qslim``: open meshes and
  holes kept) to the same vertex count, the piecewise-linear answer users have today;
* ``fast-simpl`` -- ``fast_simplification`` (optional, benchmarks only; its output may
  be non-manifold, the distances are still exact);
* ``tri-fit`` / ``tri-data`` -- :func:`trispline.fit.approx.approximate_surface` with that
  vertex budget (no tolerance), Huber loss, ``corners="fit"`` / ``"data"``;
* ``interp`` -- the interpolating fit (:func:`trispline.fit.fit_surface`, every scan vertex
  a spline vertex; up to 100k faces).

Deviation both ways, as fractions of the scan's bounding-box diagonal: data -> model
(every scan vertex to the model: exact point-triangle distances, or for the spline the
closest point on the surface) and model -> data (samples on every model face, on a
barycentric lattice of :data:`SAMPLE_STEPS` steps, to the scan's triangles). ``inl max``:
data -> model over the points the robust loss kept (the scan's own for a mesh). ``tru rms`` /
``tru max`` (generated rows): the model's samples (the same lattice) to the true analytic surface.
Targets (issue 15): trispline RMS <= 1/3 and max <= 1/2 of qslim's, both ways (the noise-free rows
and the real meshes; the noisy rows are reported as the noise floor).

**Denoising** (``--denoise``): synthetic truth (four surfaces, 50k vertices, noise sigma =
1e-3 of the diagonal, 0.5% outliers at 50 sigma), the default budget (2%): RMS and max
distance of the surface to the TRUE surface (in sigma), the data weight cross-validated as
by default (``--data-weights`` fixes it), normals against the true ones (RMS
degrees), thin-plate energy ``int k1^2 + k2^2 dA`` against the truth's. Targets: RMS <= 0.5
sigma, normals <= 1 degree, energy within 20%.

**Compactness** (``--compactness``): the shared real scans at a tolerance of 1e-3 of the
diagonal: vertices needed (target <= 5% of the scan's), patches and file size against the
interpolating fit.

**Speed** (``--speed``): ``trispline fit SCAN -o s.npz --tolerance-rel 1e-3`` end to end (a
subprocess: start-up, reading, parameterization, the fit, writing) on generated scans of
100k and 1M faces (noise 1e-4 of the diagonal, 0.5% outliers). Targets: 100k in <= 15 s, 1M
in <= 90 s and <= 10 GB.
"""
from __future__ import annotations

import argparse
import dataclasses
import functools
import json
import resource
import subprocess
import sys
import time
from pathlib import Path
from typing import Callable

import numpy as np

from trispline.fit.datasets.cache import MESH_SUFFIXES, data_folders

#: The real meshes: the first of the data folders (``../shared/data``, then the cache) that has any.
DATA = next((d for d in data_folders() if d.is_dir() and any(p.suffix in MESH_SUFFIXES for p in d.iterdir())),
            data_folders()[0])
#: Meshes with at least this many faces get the small fraction.
LARGE_FACES = 20_000
FRACTION_LARGE, FRACTION_SMALL = 0.02, 0.05
#: Generated scans: name -> (vertex count (faces about twice), noise sigma of the diagonal, outlier fraction).
GENERATED = {"generated-100k-clean": (50_000, 0.0, 0.0), "generated-100k": (50_000, 1e-3, 0.005),
             "generated-1M-clean": (500_000, 0.0, 0.0), "generated-1M": (500_000, 1e-3, 0.005)}
#: ... the noisy ones, whose data -> model deviation is the noise's (the noise floor, not the target).
NOISE_FLOOR = ("generated-100k", "generated-1M")
#: Lattice steps per model face for the model -> data samples.
SAMPLE_STEPS = 4
#: Attempts at hitting the vertex count with qslim (it takes a face count).
QSLIM_TRIES = 3


def load(name: str) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """The scan ``V (n, 3)``, ``F (m, 3)`` of a row (a generated scan or a mesh file, validated) and
    its inliers ``(n,)`` where known (a generated scan's non-outliers), else None."""
    if name in GENERATED:
        s = generated(name)
        return s.V, s.F, ~s.outliers
    from trispline.fit.io import read_mesh
    from trispline.param import validate_mesh

    md = read_mesh(DATA / name)
    vm = validate_mesh(md.V, md.F)  # raises MeshError for what fit would refuse
    return vm.V, vm.F, None


@functools.lru_cache(maxsize=2)
def generated(name: str):
    """The :class:`~trispline.fit.datasets.truth.TruthScan` of a generated row (:data:`GENERATED`)."""
    from trispline.fit.datasets.truth import truth_scan

    n, sigma, outliers = GENERATED[name]
    return truth_scan("bumps", n, sigma=sigma, outliers=outliers, outlier_sigmas=50.0, seed=0)


def truth_columns(name: str, samples: np.ndarray, diag: float) -> dict[str, float]:
    """``tru_rms``, ``tru_max``: the model's ``samples (m, 3)`` to the true surface of a generated row,
    relative to the scan's diagonal (nothing for a mesh file)."""
    if name not in GENERATED:
        return {}
    d = generated(name).distance_to_truth(samples) / diag
    return {"tru_rms": float(np.sqrt(np.mean(d * d))), "tru_max": float(d.max())}


def mesh_names() -> list[str]:
    """The mesh files of :data:`DATA`, sorted."""
    if not DATA.is_dir():
        return []
    return sorted(p.name for p in DATA.iterdir() if p.suffix in MESH_SUFFIXES)


def face_samples(V: np.ndarray, F: np.ndarray, r: int = SAMPLE_STEPS) -> np.ndarray:
    """Points ``(F (r+1)(r+2)/2, 3)`` on every triangle, at its barycentric lattice."""
    from trispline.spline.index import lattice

    w = lattice(r) / r
    return np.einsum("gk,fkd->fgd", w, V[F]).reshape(-1, 3)


def both_ways(V: np.ndarray, F: np.ndarray, U: np.ndarray, G: np.ndarray, keep: np.ndarray | None,
              name: str = "") -> dict[str, float]:
    """RMS and max distance scan -> model and model -> scan (meshes), relative to the scan's diagonal
    (and to the truth: :func:`truth_columns`)."""
    from trispline.fit.approx import summary
    from trispline.param import closest_points

    diag = float(np.linalg.norm(V.max(0) - V.min(0)))
    fwd = np.sqrt(np.maximum(closest_points(V, U, G)[0], 0.0)) / diag
    samples = face_samples(U, G)
    back = np.sqrt(np.maximum(closest_points(samples, V, F)[0], 0.0)) / diag
    a, b = summary(fwd), summary(back)
    return {"fwd_rms": a["rms"], "fwd_max": a["max"], "back_rms": b["rms"], "back_max": b["max"],
            "inl_max": summary(fwd, keep)["max"], **truth_columns(name, samples, diag)}


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


def spline_deviation(surface, V: np.ndarray, F: np.ndarray, keep: np.ndarray | None, name: str = ""
                     ) -> dict[str, float]:
    """Both ways for a spline surface: scan vertices to the surface, tessellation samples to the scan
    (and to the truth: :func:`truth_columns`)."""
    from trispline.fit.approx import summary, surface_deviation
    from trispline.fit.approx.deviation import distance_to_mesh

    diag = float(np.linalg.norm(V.max(0) - V.min(0)))
    fwd = surface_deviation(surface, V).distance / diag
    samples = surface.tessellate(SAMPLE_STEPS).vertices
    back = distance_to_mesh(samples, V, F) / diag
    a, b = summary(fwd), summary(back)
    return {"fwd_rms": a["rms"], "fwd_max": a["max"], "back_rms": b["rms"], "back_max": b["max"],
            "inl_max": summary(fwd, keep)["max"], **truth_columns(name, samples, diag)}


def trispline_row(V: np.ndarray, F: np.ndarray, keep: np.ndarray | None, k: int, corners: str, name: str = ""
                  ) -> dict:
    """The approximation with a budget of ``k`` vertices (no tolerance), Huber loss."""
    import jax

    jax.config.update("jax_enable_x64", True)
    from trispline.fit.approx import approximate_surface

    t0 = time.perf_counter()
    res = approximate_surface(V, F, n_vertices=k, corners=corners, loss="huber")
    row = {"verts": res.stats["vertices"], "model_faces": res.stats["patches"], "seconds": time.perf_counter() - t0,
           "rejected": res.stats["rejected"]}
    return {**row, **spline_deviation(res.surface, V, F, keep, name)}


def interp_row(V: np.ndarray, F: np.ndarray, keep: np.ndarray | None, name: str = "") -> dict:
    """The interpolating fit: every scan vertex a spline vertex."""
    import jax

    jax.config.update("jax_enable_x64", True)
    from trispline.fit import fit_surface

    t0 = time.perf_counter()
    res = fit_surface(V, F)
    row = {"verts": int(V.shape[0]), "model_faces": int(F.shape[0]), "seconds": time.perf_counter() - t0}
    return {**row, **spline_deviation(res.surface, V, F, keep, name)}


METHODS = {"qslim": qslim, "fast-simpl": fast_simpl}
#: The trispline rows: method name -> corner mode.
SPLINES = {"tri-fit": "fit", "tri-data": "data"}
#: The interpolating fit runs on meshes up to this many faces.
INTERP_MAX_FACES = 120_000


def run_row(name: str, fraction: float | None, method: str) -> dict:
    """One row, measured in this process: the model and its deviation both ways."""
    t0 = time.perf_counter()
    V, F, keep = load(name)
    t_load = time.perf_counter() - t0
    frac = fraction if fraction is not None else (FRACTION_LARGE if F.shape[0] >= LARGE_FACES else FRACTION_SMALL)
    k = max(8, int(round(frac * V.shape[0])))
    row = {"mesh": name, "faces": int(F.shape[0]), "frac": frac, "target": k, "method": method}
    t0 = time.perf_counter()
    if method in SPLINES:
        row.update(trispline_row(V, F, keep, k, SPLINES[method], name))
    elif method == "interp":
        row.update(interp_row(V, F, keep, name))
    else:
        U, G = METHODS[method](V, F, k)
        row["verts"], row["model_faces"] = int(U.shape[0]), int(G.shape[0])
        row["seconds"] = time.perf_counter() - t0
        row.update(both_ways(V, F, U, G, keep, name))
    row["load_seconds"] = t_load
    row["peak_mb"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
    return row


def child(task: str, *params) -> dict:
    """``task(*params)`` (a row function of this file) in a fresh interpreter: its own time and peak RSS."""
    cmd = [sys.executable, __file__, "--child", json.dumps([task, *params])]
    out = subprocess.run(cmd, capture_output=True, text=True)
    try:
        return json.loads(out.stdout.strip().splitlines()[-1])
    except (IndexError, json.JSONDecodeError):
        last = (out.stderr.strip().splitlines() or ["no output"])[-1]
        return {"mesh": str(params[0]), "method": str(params[-1]), "error": last[:100]}


HEADER = (f"{'mesh':<34} {'faces':>8} {'frac':>5} {'method':>10} {'verts':>6} "
          f"{'d>m rms':>8} {'d>m max':>8} {'inl max':>8} {'m>d rms':>8} {'m>d max':>8} {'s':>6} {'MB':>6} "
          f"{'tru rms':>8} {'tru max':>8}")


def line(r: dict) -> str:
    """One table row: deviations relative to the diagonal, time of the method alone, peak RSS of the row."""
    head = f"{r['mesh']:<34} {r.get('faces', 0):>8} {r.get('frac', 0):>5.2f} {r['method']:>10}"
    if "error" in r:
        return f"{head}  {r['error']}"
    truth = f" {r['tru_rms']:>8.1e} {r['tru_max']:>8.1e}" if "tru_rms" in r else ""
    return (f"{head} {r['verts']:>6} {r['fwd_rms']:>8.1e} {r['fwd_max']:>8.1e} {r['inl_max']:>8.1e} "
            f"{r['back_rms']:>8.1e} {r['back_max']:>8.1e} {r['seconds']:>6.1f} {r['peak_mb']:>6.0f}{truth}")


def ratios(rows: list[dict]) -> str:
    """trispline against qslim on one mesh: RMS and max ratios both ways (targets 1/3 and 1/2); on a
    noisy generated scan (:data:`NOISE_FLOOR`) labelled the noise floor, with the truth's ratios."""
    by = {r["method"]: r for r in rows if "error" not in r}
    if "qslim" not in by:
        return ""
    q = by["qslim"]
    floor = rows[0]["mesh"] in NOISE_FLOOR
    out = []
    for m in SPLINES:
        if m in by:
            t = by[m]
            rr = [t[k] / max(q[k], 1e-300) for k in ("fwd_rms", "fwd_max", "inl_max", "back_rms", "back_max")]
            met = rr[0] <= 1 / 3 and rr[1] <= 1 / 2 and rr[3] <= 1 / 3 and rr[4] <= 1 / 2
            verdict = "noise floor" if floor else "met" if met else "not met"
            truth = (f", truth rms {t['tru_rms'] / max(q['tru_rms'], 1e-300):.2f}, "
                     f"max {t['tru_max'] / max(q['tru_max'], 1e-300):.2f}" if "tru_rms" in t and "tru_rms" in q else "")
            out.append(f"{m} / qslim: d>m rms {rr[0]:.2f}, max {rr[1]:.2f} (inliers {rr[2]:.2f}), m>d rms {rr[3]:.2f}, "
                       f"max {rr[4]:.2f}{truth}: {verdict}")
    return "    " + "; ".join(out)


def equal_size(args: argparse.Namespace) -> None:
    """The equal-size table (the default)."""
    names = mesh_names()
    names += [g for g in GENERATED if not (args.no_million and "1M" in g)]
    if args.only:
        names = [n for n in names if n in args.only]
    methods = (["qslim"] + (["fast-simpl"] if args.fast_simplification else []) + list(SPLINES)
               + ([] if args.no_interpolation else ["interp"]))
    if args.methods:
        methods = [m for m in methods if m in args.methods]
    print(HEADER)
    print("-" * len(HEADER))
    for name in names:
        rows = []
        for method in methods:
            if method == "interp" and rows and rows[0].get("faces", 0) > INTERP_MAX_FACES:
                continue
            r = child("run_row", name, args.fraction, method)
            if "error" in r and method == methods[0]:  # a mesh trispline refuses: one line, not one per method
                print(f"{name:<34} rejected: {r['error']}", flush=True)
                break
            rows.append(r)
            print(line(r), flush=True)
        if rows:
            print(ratios(rows), flush=True)
    print("deviation relative to the bounding-box diagonal; d>m: scan vertices to the model (inl: the known inliers "
          "of a generated scan), m>d: model samples to the scan, tru: model samples to the true surface (generated);"
          "\ntarget (issue 15): trispline rms <= 1/3 and max <= 1/2 of qslim's at the same vertex count, both ways "
          f"(noise floor: the noisy {', '.join(NOISE_FLOOR)}, whose d>m is the noise's)")


# ---------------------------------------------------------------------------------------- denoising
#: The synthetic truths of ``--denoise`` (:data:`trispline.fit.datasets.truth.SURFACES`).
DENOISE_SURFACES = ("bumps", "cap", "saddle", "barrel")
#: Their scans: vertices, noise (of the diagonal), outlier fraction and size (in sigmas).
DENOISE_SCAN = dict(n_vertices=50_000, sigma=1e-3, outliers=0.005, outlier_sigmas=50.0, seed=0)
#: Samples per patch edge for the distance and normals to the truth.
TRUTH_STEPS = 4


def truth_metrics(scan, surface) -> dict[str, float]:
    """The surface against the true one: RMS and max distance (in sigma) of lattice samples on every
    patch, RMS angle (degrees) of their normals to the true normals there, thin-plate energy ratio."""
    from trispline.fit.datasets.truth import bending_density
    from trispline.fit.energy.quadrature import triangle_quadrature
    from trispline.spline.index import lattice

    nf = surface.n_faces
    w = lattice(TRUTH_STEPS) / TRUTH_STEPS
    face, bary = np.repeat(np.arange(nf), w.shape[0]), np.tile(w, (nf, 1))
    d = surface.evaluate_derivatives(face, bary)
    st = scan.closest_params(d.values)
    t = scan.derivatives(st)
    dist = np.linalg.norm(t.values - d.values, axis=1) / scan.sigma
    n1, n2 = np.cross(d.du, d.dv), np.cross(t.du, t.dv)
    cos = np.abs(np.einsum("nd,nd->n", n1, n2)) / (np.linalg.norm(n1, axis=1) * np.linalg.norm(n2, axis=1))
    angle = np.degrees(np.arccos(np.clip(cos, 0.0, 1.0)))
    qb, qw = triangle_quadrature(4)
    dq = surface.evaluate_derivatives(np.repeat(np.arange(nf), qw.size), np.tile(qb, (nf, 1)), second=True)
    energy = float((surface.triangulation.areas * (bending_density(dq).reshape(nf, -1) * qw).sum(1)).sum())
    return {"rms": float(np.sqrt(np.mean(dist**2))), "max": float(dist.max()),
            "normal_rms": float(np.sqrt(np.mean(angle**2))), "energy_ratio": energy / scan.bending_energy()}


def denoise_row(surface: str, corners: str, loss: str, data_weight: float | None) -> dict:
    """One approximation of a synthetic scan (default budget), measured against the truth."""
    import jax

    jax.config.update("jax_enable_x64", True)
    from trispline.fit.approx import approximate_surface
    from trispline.fit.approx import APPROX_WEIGHTS
    from trispline.fit.datasets.truth import truth_scan

    scan = truth_scan(surface, **DENOISE_SCAN)
    weights = None if data_weight is None else dataclasses.replace(APPROX_WEIGHTS, data=data_weight)  # None: CV
    t0 = time.perf_counter()
    res = approximate_surface(scan.V, scan.F, corners=corners, loss=loss, weights=weights)
    row = {"surface": surface, "corners": corners, "loss": loss, "data": res.stats["data_weight"],
           "verts": res.stats["vertices"], "rejected": res.stats["rejected"], "seconds": time.perf_counter() - t0,
           "param": res.parameterization.method}
    return {**row, **truth_metrics(scan, res.surface)}


def denoise(surfaces: list[str], data_weights: str | None) -> None:
    """The denoising table: both corner modes, the three losses, robust against plain side by side."""
    weights = [None] if data_weights is None else [float(w) for w in data_weights.split(",")]
    head = (f"{'surface':<8} {'corners':>7} {'loss':>7} {'data w':>7} {'verts':>6} {'rms/s':>6} {'max/s':>6} "
            f"{'nrm deg':>7} {'E/E0':>6} {'rej':>5} {'s':>6}")
    print(head)
    print("-" * len(head))
    for surface in surfaces:
        for w in weights:
            for corners in ("data", "fit"):
                for loss in ("l2", "huber", "cauchy"):
                    r = child("denoise_row", surface, corners, loss, w)
                    if "error" in r:
                        print(f"{surface:<8} {corners:>7} {loss:>7}  {r['error']}", flush=True)
                        continue
                    print(f"{surface:<8} {corners:>7} {loss:>7} {r['data']:>7.0f} {r['verts']:>6} {r['rms']:>6.3f} "
                          f"{r['max']:>6.2f} {r['normal_rms']:>7.3f} {r['energy_ratio']:>6.3f} {r['rejected']:>5} "
                          f"{r['seconds']:>6.1f}", flush=True)
    print(f"scans: {DENOISE_SCAN}; distances to the TRUE surface in noise sigmas, normals against the true ones, "
          "E/E0: thin-plate energy over the truth's;\ntargets (issue 15): rms <= 0.5, normals <= 1 degree, "
          "E/E0 within 20%, outliers without visible effect")


# --------------------------------------------------------------------------------------- compactness
#: The tolerance of ``--compactness`` and ``--speed``, relative to the diagonal.
TOLERANCE_REL = 1e-3


def _file_kb(surface) -> float:
    """Size of the surface file (NPZ, as `SplineSurface.save` writes it) in kB."""
    import tempfile

    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "s.npz"
        surface.save(path)
        return path.stat().st_size / 1024.0


def compactness_row(name: str, corners: str | None) -> dict:
    """The approximation at :data:`TOLERANCE_REL` (``corners``), or the interpolating fit (None)."""
    import jax

    jax.config.update("jax_enable_x64", True)
    V, F, _ = load(name)
    t0 = time.perf_counter()
    if corners is None:
        from trispline.fit import fit_surface

        res = fit_surface(V, F)
        row = {"verts": int(V.shape[0]), "patches": int(F.shape[0]), "met": True, "max": 0.0}
    else:
        from trispline.fit.approx import approximate_surface

        res = approximate_surface(V, F, tolerance_rel=TOLERANCE_REL, corners=corners)
        diag = float(np.linalg.norm(V.max(0) - V.min(0)))
        row = {"verts": res.stats["vertices"], "patches": res.stats["patches"], "met": res.stats["met"],
               "max": max(res.stats["deviation"]["max"], res.stats["outline_gap"]) / diag,
               "rejected": res.stats["rejected"]}
    return {"mesh": name, "scan_verts": int(V.shape[0]), "method": "interp" if corners is None else f"tri-{corners}",
            **row, "kb": _file_kb(res.surface), "seconds": time.perf_counter() - t0,
            "peak_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0}


def compactness(only: list[str] | None, interpolation: bool) -> None:
    """The compactness table: vertices needed at the tolerance, patches and file size against interpolation."""
    names = mesh_names()
    names = [n for n in names if not only or n in only]
    head = (f"{'mesh':<34} {'method':>8} {'verts':>7} {'% scan':>7} {'met':>4} {'max/diag':>9} {'patches':>8} "
            f"{'file kB':>9} {'s':>6} {'MB':>6}")
    print(head)
    print("-" * len(head))
    for name in names:
        for corners in ("data", "fit") + ((None,) if interpolation else ()):
            r = child("compactness_row", name, corners)
            if "error" in r:
                print(f"{name:<34} rejected: {r['error']}", flush=True)
                break
            print(f"{name:<34} {r['method']:>8} {r['verts']:>7} {100 * r['verts'] / r['scan_verts']:>6.2f}% "
                  f"{'yes' if r['met'] else 'no':>4} {r['max']:>9.2e} {r['patches']:>8} {r['kb']:>9.0f} "
                  f"{r['seconds']:>6.1f} {r['peak_mb']:>6.0f}", flush=True)
    print(f"tolerance {TOLERANCE_REL:g} of the bounding-box diagonal (max/diag: the larger of the inliers' max "
          "deviation and the outline's largest gap); target (issue 15): met with at most 5% of the scan's vertices")


# --------------------------------------------------------------------------------------------- speed
#: The scans of ``--speed``: name -> vertices (faces about twice); noise 1e-4 of the diagonal, 0.5% outliers.
SPEED_SCANS = {"generated-100k": 50_000, "generated-1M": 500_000}


def speed_row(name: str) -> dict:
    """``trispline fit SCAN --tolerance-rel 1e-3`` in a subprocess: wall time, peak RSS, what it reached."""
    import tempfile

    import trimesh

    from trispline.fit.datasets.truth import truth_scan

    s = truth_scan("bumps", SPEED_SCANS[name], sigma=1e-4, outliers=0.005, outlier_sigmas=50.0, seed=0)
    with tempfile.TemporaryDirectory() as tmp:
        scan, out = Path(tmp) / "scan.ply", Path(tmp) / "s.npz"
        trimesh.Trimesh(s.V, s.F, process=False).export(scan)
        cmd = [sys.executable, "-m", "trispline.fit", "fit", str(scan), "-o", str(out), "--tolerance-rel",
               str(TOLERANCE_REL), "--json", "--quiet"]
        t0 = time.perf_counter()
        r = subprocess.run(cmd, capture_output=True, text=True)
        wall = time.perf_counter() - t0
    if r.returncode != 0:
        return {"mesh": name, "method": "speed", "error": (r.stderr.strip().splitlines() or ["?"])[-1][:100]}
    d = json.loads(r.stdout)
    return {"mesh": name, "faces": int(s.F.shape[0]), "wall": wall, "verts": d["vertices"], "met": d["met"],
            "max": d["deviation"]["max"] / s.diagonal, "timings": d["timings"], "rounds": len(d["rounds"]),
            "peak_gb": resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024.0**2}


def speed(no_million: bool) -> None:
    """The speed table: end to end on the command line, one subprocess per scan."""
    head = f"{'scan':<16} {'faces':>8} {'wall s':>7} {'peak GB':>8} {'verts':>6} {'met':>4} {'max/diag':>9}  stages (s)"
    print(head)
    print("-" * len(head))
    for name in SPEED_SCANS:
        if no_million and name.endswith("1M"):
            continue
        r = child("speed_row", name)
        if "error" in r:
            print(f"{name:<16} {r['error']}", flush=True)
            continue
        stages = ", ".join(f"{k} {v:.1f}" for k, v in r["timings"].items())
        print(f"{name:<16} {r['faces']:>8} {r['wall']:>7.1f} {r['peak_gb']:>8.2f} {r['verts']:>6} "
              f"{'yes' if r['met'] else 'no':>4} {r['max']:>9.2e}  {stages} ({r['rounds']} rounds)", flush=True)
    print(f"trispline fit SCAN -o s.npz --tolerance-rel {TOLERANCE_REL:g} (start-up, reading and writing included); "
          "targets (issue 15): 100k faces <= 15 s, 1M <= 90 s and <= 10 GB")


# ------------------------------------------------------------------------------------ scattered tiles
#: Points of the scattered-point tiles (``--scattered``): Delaunay with its hull slivers.
SCATTERED_POINTS = (10_000, 50_000)


def scattered_row(n_points: int, repair: bool) -> dict:
    """``trispline fit TILE --tolerance-rel 1e-3 [--repair]`` on :func:`~trispline.fit.datasets.tile.scattered_tile`."""
    import tempfile

    import trimesh

    from trispline.fit.datasets.tile import scattered_tile

    V, F = scattered_tile(n_points, seed=0, origin=(512_300.0, 4_231_800.0))
    with tempfile.TemporaryDirectory() as tmp:
        scan, out = Path(tmp) / "tile.obj", Path(tmp) / "s.npz"  # OBJ: every digit (PLY: float32, 0.25 m here)
        trimesh.Trimesh(V, F, process=False).export(scan)
        cmd = [sys.executable, "-m", "trispline.fit", "fit", str(scan), "-o", str(out), "--tolerance-rel",
               str(TOLERANCE_REL), "--json", "--quiet", *(["--repair"] if repair else [])]
        t0 = time.perf_counter()
        r = subprocess.run(cmd, capture_output=True, text=True)
        wall = time.perf_counter() - t0
    if r.returncode != 0:
        return {"error": (r.stderr.strip().splitlines() or ["?"])[-1][:100]}
    d = json.loads(r.stdout)
    return {"faces": int(F.shape[0]), "wall": wall, "verts": d["vertices"], "met": d["met"],
            "max_tol": d["deviation"]["max"] / d["tolerance"], "rounds": len(d["rounds"])}


def _rows(specs: list[tuple[str, str, tuple]], line: Callable[[str, tuple, dict, dict], str]) -> None:
    """One table row per ``(label, task, params)``, each task run in a child; ``line(label, params, row, first)`` formats
    a row against the first that ran (the ratios' base); a failed row prints its label and the error."""
    first = None
    for label, task, params in specs:
        r = child(task, *params)
        if "error" in r:
            print(f"{label} {r['error']}", flush=True)
            continue
        first = first or r
        print(line(label, params, r, first), flush=True)


def scattered() -> None:
    """Scattered-point tiles (hull slivers along every side) as they come and with ``--repair`` (peeled)."""
    head = (f"{'tile':<12} {'faces':>8} {'repair':>6} {'wall s':>7} {'verts':>6} {'met':>4} {'max/tol':>8} "
            f"{'rounds':>6} {'x verts':>8} {'x wall':>7}")
    print(head)
    print("-" * len(head))
    for n in SCATTERED_POINTS:
        _rows([(f"{n:<12} {'':>8} {'yes' if repair else 'no':>6}", "scattered_row", (n, repair)) for repair in (False, True)],
              lambda _, params, r, plain: (
                  f"{params[0]:<12} {r['faces']:>8} {'yes' if params[1] else 'no':>6} {r['wall']:>7.1f} {r['verts']:>6} "
                  f"{'yes' if r['met'] else 'no':>4} {r['max_tol']:>8.2f} {r['rounds']:>6} "
                  f"{r['verts'] / plain['verts']:>8.2f} {r['wall'] / plain['wall']:>7.2f}"))
    print(f"trispline fit TILE -o s.npz --tolerance-rel {TOLERANCE_REL:g} [--repair] on scattered_tile(N, seed=0) "
          "(start-up included); x: over the same tile without --repair")


# ------------------------------------------------------------------------------------ scanner dropouts
#: Faces of the dropout scan (``--dropouts``) and the one-face holes cut into it.
DROPOUT_FACES, DROPOUT_HOLES = 40_000, 100


def dropout_scan(holes: int) -> tuple[np.ndarray, np.ndarray]:
    """``synthetic_scan(DROPOUT_FACES, seed=5, noise=1e-4)`` less ``holes`` interior faces, no two within a
    ring of each other (each a hole of three vertices), picked in a seeded random order."""
    from trispline.fit.datasets.synthetic import synthetic_scan
    from trispline.spline.topology import outline_vertex_mask

    V, F = synthetic_scan(DROPOUT_FACES, seed=5, noise=1e-4)
    near = np.zeros(V.shape[0], bool)  # vertices of the picked faces and of the faces around them
    near[F[outline_vertex_mask(F, V.shape[0])[F].any(1)]] = True
    picked = []
    for f in np.random.default_rng(0).permutation(F.shape[0]):  # a benchmark's set-up, not a hot path
        if len(picked) == holes:
            break
        if not near[F[f]].any():
            picked.append(f)
            near[F[np.isin(F, F[f]).any(1)]] = True
    return V, np.delete(F, picked, axis=0)


def dropout_row(holes: int, fill: int) -> dict:
    """``trispline fit SCAN --tolerance-rel 1e-3 [--fill-holes fill]`` on :func:`dropout_scan`."""
    import tempfile

    import trimesh

    V, F = dropout_scan(holes)
    with tempfile.TemporaryDirectory() as tmp:
        scan, out = Path(tmp) / "scan.ply", Path(tmp) / "s.npz"
        trimesh.Trimesh(V, F, process=False).export(scan)
        cmd = [sys.executable, "-m", "trispline.fit", "fit", str(scan), "-o", str(out), "--tolerance-rel",
               str(TOLERANCE_REL), "--json", "--quiet", *(["--fill-holes", str(fill)] if fill else [])]
        t0 = time.perf_counter()
        r = subprocess.run(cmd, capture_output=True, text=True)
        wall = time.perf_counter() - t0
        size = out.stat().st_size if out.exists() else 0
    if r.returncode != 0:
        return {"error": (r.stderr.strip().splitlines() or ["?"])[-1][:100]}
    d = json.loads(r.stdout)
    return {"faces": int(F.shape[0]), "wall": wall, "verts": d["vertices"], "patches": d["patches"], "met": d["met"],
            "max_tol": d["deviation"]["max"] / d["tolerance"], "gap_tol": d["outline_gap"] / d["tolerance"],
            "filled": d["holes_filled"], "kb": size / 1e3}


def dropouts() -> None:
    """A scan with one-face dropouts: the whole scan, the dropouts kept (default), and spanned (``--fill-holes``)."""
    head = (f"{'scan':<30} {'faces':>7} {'wall s':>7} {'verts':>6} {'patches':>7} {'met':>4} {'max/tol':>8} "
            f"{'gap/tol':>8} {'filled':>6} {'kB':>6} {'x verts':>8}")
    print(head)
    print("-" * len(head))
    specs = [("whole", 0, 0), (f"{DROPOUT_HOLES} dropouts kept", DROPOUT_HOLES, 0),
             (f"{DROPOUT_HOLES} dropouts, --fill-holes 8", DROPOUT_HOLES, 8)]
    _rows([(f"{name:<30}", "dropout_row", (holes, fill)) for name, holes, fill in specs],
          lambda label, _, r, whole: (
              f"{label} {r['faces']:>7} {r['wall']:>7.1f} {r['verts']:>6} {r['patches']:>7} "
              f"{'yes' if r['met'] else 'no':>4} {r['max_tol']:>8.2f} {r['gap_tol']:>8.2f} {r['filled']:>6} "
              f"{r['kb']:>6.0f} {r['verts'] / whole['verts']:>8.2f}"))
    print(f"trispline fit SCAN -o s.npz --tolerance-rel {TOLERANCE_REL:g} [--fill-holes 8] on synthetic_scan("
          f"{DROPOUT_FACES}, seed=5, noise=1e-4) less {DROPOUT_HOLES} interior faces (start-up included); "
          "x verts: over the whole scan")


# ---------------------------------------------------------------------------------------------- zebra
def zebra(name: str, out: str) -> None:
    """Zebra stripes of a shared real scan: the interpolating fit beside the approximation at
    :data:`TOLERANCE_REL` (the issue's README picture); patches and the reached deviation in the titles."""
    import jax

    jax.config.update("jax_enable_x64", True)
    from trispline.fit import fit_surface
    from trispline.fit import render as rd
    from trispline.fit.approx import approximate_surface

    V, F, _ = load(name)
    interp = fit_surface(V, F).surface
    res = approximate_surface(V, F, tolerance_rel=TOLERANCE_REL)
    diag = float(np.linalg.norm(V.max(0) - V.min(0)))
    dev = res.stats["deviation"]["max"] / diag
    panels = [rd.Panel(interp, "zebra", title=f"interpolated: {F.shape[0]:,} patches"),
              rd.Panel(res.surface, "zebra", title=f"approximated: {res.stats['patches']:,} (max {dev:.1e} diag)")]
    rd.write_png(rd.draw_panels(panels, size=(1600, 650)).image, out)
    print(f"wrote {out}")


def _corner_row(label: str, uv: np.ndarray, F: np.ndarray, want: np.ndarray, budgets: range) -> tuple[str, int]:
    """One shape's budgets: ``ok`` (every corner of ``want`` a coarse vertex), ``MISS<count>`` or
    ``err<needed>`` (a budget refused; right when it is below the corners' count)."""
    from trispline.fit.approx import coarse_domain
    from trispline.spline.errors import InputError

    V = np.column_stack([uv, 0.2 * np.sin(3 * uv[:, 0]) * np.cos(2 * uv[:, 1]) + 0.1 * uv[:, 0] * uv[:, 1]])
    cells, good = [], 0
    for b in budgets:
        try:
            dom = coarse_domain(V, F, uv, n_vertices=b)
        except InputError as exc:
            cells.append(f"{b}:err{getattr(exc, 'needed', '?')}")
            good += b < len(want)
            continue
        ok = np.linalg.norm(dom.uv[:, None] - want[None], axis=2).min(0).max() < 1e-9 and dom.stats.n_vertices <= b
        cells.append(f"{b}:{'ok' if ok else f'MISS{dom.stats.n_vertices}'}")
        good += bool(ok)
    return f"{label:<14} " + " ".join(cells), good


def corners_table() -> None:
    """Whether the coarse domain keeps an outline's corners at small budgets (its own uv given): rectangles
    of aspect 1-30 on 20 x 20 and 40 x 40 grids at budgets 3-16, L-shapes of 200-1,500 random points at 4-19."""
    from trispline.spline.testing import domains

    total = good = 0
    for aspect in (1, 2, 4, 10, 30):
        for n in (20, 40):
            uv, F = domains.grid(n - 1)
            uv = uv * [aspect, 1.0]
            text, k = _corner_row(f"rect {aspect}:1 {n}", uv, F, np.array([[0, 0], [aspect, 0], [aspect, 1], [0, 1]]),
                                  range(3, 17))
            print(text, flush=True)
            total, good = total + 14, good + k
    want = np.array([[0, 0], [1, 0], [1, 0.5], [0.5, 0.5], [0.5, 1], [0, 1]])
    for seed in (1, 2):
        for n in (200, 400, 1500):
            uv, F = domains.l_shape(n, seed=seed)
            text, k = _corner_row(f"L {n} s{seed}", uv, F, want, range(4, 20))
            print(text, flush=True)
            total, good = total + 16, good + k
    print(f"every corner kept within the budget, or a budget below the corners refused: {good} of {total}")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--only", nargs="*", help="row names (mesh files or generated-100k / generated-1M)")
    ap.add_argument("--fraction", type=float, help="vertex fraction for every row (default 2%% / 5%%)")
    ap.add_argument("--no-million", action="store_true", help="skip the 1M-face generated scans")
    ap.add_argument("--methods", nargs="*", help="equal size: only these methods (qslim, fast-simpl, tri-fit, "
                                                  "tri-data, interp; qslim first for the ratios)")
    ap.add_argument("--fast-simplification", action="store_true", help="add fast_simplification rows")
    ap.add_argument("--denoise", action="store_true", help="the denoising table on synthetic truth")
    ap.add_argument("--surfaces", default=",".join(DENOISE_SURFACES), help="surfaces of --denoise")
    ap.add_argument("--data-weights", default=None,
                    help="--denoise: comma-separated FitWeights.data values (default: cross-validated, as the fit)")
    ap.add_argument("--compactness", action="store_true", help="the real scans at a tolerance of 1e-3")
    ap.add_argument("--no-interpolation", action="store_true",
                    help="without the interpolating fit (--compactness and the equal-size table)")
    ap.add_argument("--speed", action="store_true", help="trispline fit --tolerance-rel 1e-3 end to end")
    ap.add_argument("--corners", action="store_true", help="the outline's corners at small budgets")
    ap.add_argument("--scattered", action="store_true", help="scattered-point tiles with and without --repair")
    ap.add_argument("--dropouts", action="store_true", help="a scan with one-face holes, kept and --fill-holes")
    ap.add_argument("--zebra", metavar="PNG", help="zebra picture of --only's first mesh (default beetle.off): "
                                                  "interpolated beside approximated at 1e-3")
    ap.add_argument("--child", help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.child:
        task, *params = json.loads(args.child)
        print(json.dumps(globals()[task](*params)))
        return 0
    if args.zebra:
        zebra((args.only or ["beetle.off"])[0], args.zebra)
    elif args.denoise:
        denoise(args.surfaces.split(","), args.data_weights)
    elif args.compactness:
        compactness(args.only, not args.no_interpolation)
    elif args.speed:
        speed(args.no_million)
    elif args.corners:
        corners_table()
    elif args.scattered:
        scattered()
    elif args.dropouts:
        dropouts()
    else:
        equal_size(args)
    return 0


if __name__ == "__main__":
    sys.exit(main())
