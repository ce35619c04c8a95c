"""Fit the built-in synthetic scan, export it, and check the result.

    python examples/01_fit_synthetic_scan.py [OUT_DIR] [--readme-image]

The scan (trispline.fit.datasets.synthetic) is an open, bumpy, slightly noisy surface
patch with a hole. The script fits an exactly C1 quintic spline that
interpolates every scan vertex, writes the surface file (NPZ, docs/design.md §6), a
tessellated PLY with analytic normals, the control net and a rendered picture to
OUT_DIR (default: $TRISPLINE_EXAMPLE_OUT or ./example_output), and asserts that
the surface interpolates the data and is C1 across every patch boundary.
``--readme-image`` also renders docs/images/fitted_scan.png (the README picture).
"""
from __future__ import annotations

import os
import sys
import time
from pathlib import Path

import jax

jax.config.update("jax_enable_x64", True)  # the fit runs in float64

import numpy as np  # noqa: E402

from trispline.fit.io.export import export_control_net, export_surface  # noqa: E402
from trispline.fit.pipeline import fit_surface  # noqa: E402
from trispline.fit.render import mean_normal_view, render  # noqa: E402
from trispline.fit.datasets.synthetic import synthetic_scan  # noqa: E402
from trispline.spline.index import CORNER  # noqa: E402
from trispline.spline.continuity import continuity_report  # noqa: E402
from trispline.spline.surface import SplineSurface  # noqa: E402

args = [a for a in sys.argv[1:] if not a.startswith("--")]
out = Path(args[0] if args else os.environ.get("TRISPLINE_EXAMPLE_OUT", "example_output"))
out.mkdir(parents=True, exist_ok=True)

# --- the five lines of the README
V, F = synthetic_scan(800, seed=0)                 # (nv, 3), (nf, 3): an open scan with a hole
t0 = time.perf_counter()
result = fit_surface(V, F, param="harmonic")        # FitResult
result.surface.save(out / "scan_surface.npz")
surface = SplineSurface.load(out / "scan_surface.npz")
print(f"fitted {len(V)} vertices / {len(F)} patches in {time.perf_counter() - t0:.1f} s, "
      f"{result.iterations} Gauss-Newton steps; energies "
      + ", ".join(f"{k} {v:.3g}" for k, v in result.energies.items()))

# --- exports (each written atomically)
export_surface(surface, out / "scan_surface.ply", resolution=8)
export_control_net(surface, out / "scan_control_net.obj")
export_surface(surface, out / "fitted_scan.png", resolution=6)  # shaded, along the mean normal
if "--readme-image" in sys.argv:
    docs = Path(__file__).resolve().parents[1] / "docs" / "images"
    docs.mkdir(parents=True, exist_ok=True)
    render(surface, docs / "fitted_scan.png", "shaded", view=mean_normal_view(V, F), size=(704, 462), resolution=6,
           title=f"fitted C1 quintic spline ({surface.n_faces} patches)")
    print(f"wrote {docs / 'fitted_scan.png'}")

# --- checks: vertex i of the scan is the corner point of domain vertex i; C1 everywhere
corners = np.empty_like(V)
corners[surface.faces.ravel()] = np.asarray(surface.ctrl)[:, CORNER].reshape(-1, 3)
np.testing.assert_array_equal(corners, V)
c1 = continuity_report(surface.triangulation, surface.ctrl)
jumps = surface.continuity()
print(f"C1 residual (algebraic, relative) {c1['c1_relative']:.2e}; "
      f"sampled gradient jump (relative) {jumps['c1_relative']:.2e}; files in {out}")
assert c1["c1_relative"] < 1e-12 and jumps["c1_relative"] < 1e-9
assert all((out / n).stat().st_size > 0 for n in ("scan_surface.npz", "scan_surface.ply",
                                                   "scan_control_net.obj", "fitted_scan.png"))
