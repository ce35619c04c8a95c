"""Fairness tuning: sweep the bend and tilt weights, tabulate energies and deviations.

    python examples/02_fairness_sweep.py [OUT_DIR]

For each weight value the synthetic scan is fitted again (the JAX solve is
compiled once; later fits reuse it) and the script records

* the energy terms (``FitResult.energies`` include their weights, so the raw term is
  divided by its weight for the plot),
* the deviation of the surface from the noise-free shape the scan was sampled
  from (``synthetic.scan_height``), RMS and max over a dense sample grid,
* the deviation from the input mesh itself (the piecewise-linear surface over the
  same uv domain), RMS and max.

It writes OUT_DIR/fairness_sweep_zebra.png (zebra stripes of the tilt sweep's surfaces side
by side, rendered off-screen by trispline.fit.render), and
OUT_DIR/fairness_sweep.csv and OUT_DIR/fairness_sweep.png (matplotlib,
off-screen) and asserts the law every weighted least-squares fit obeys: raising
a term's weight never raises that term.
"""
from __future__ import annotations

import csv
import os
import sys
import time
from pathlib import Path

import jax

jax.config.update("jax_enable_x64", True)

import numpy as np  # noqa: E402
from matplotlib.backends.backend_agg import FigureCanvasAgg  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402

from trispline.spline.util.atomic import atomic_path  # noqa: E402
from trispline.fit.pipeline import FitWeights, fit_surface  # noqa: E402
from trispline.fit.render import Panel, render_panels  # noqa: E402
from trispline.fit.datasets.synthetic import ROTATION, scan_height, synthetic_scan  # noqa: E402
from trispline.spline.bernstein import bary_grid  # noqa: E402

out = Path(sys.argv[1] if len(sys.argv) > 1 else os.environ.get("TRISPLINE_EXAMPLE_OUT", "example_output"))
out.mkdir(parents=True, exist_ok=True)

V, F = synthetic_scan(300, seed=0, noise=0.004)
SWEEP = {"bend": [0.1, 1.0, 10.0, 100.0], "tilt": [0.1, 1.0, 10.0, 100.0]}
bary = bary_grid(6)  # (28, 3) samples per patch


def deviations(result) -> dict[str, float]:
    """Deviation from the true shape and from the input mesh at dense samples."""
    faces = result.surface.faces
    fi = np.repeat(np.arange(len(faces)), len(bary))
    b = np.tile(bary, (len(faces), 1))
    S = result.surface.evaluate(fi, b)                         # (n, 3) spline points
    P = np.einsum("nk,nkd->nd", b, V[faces[fi]])               # same parameters on the mesh
    local = S @ ROTATION                                       # back to the unrotated frame
    d_true = local[:, 2] - scan_height(local[:, :2])           # vertical distance to the true shape
    d_mesh = np.linalg.norm(S - P, axis=1)
    return dict(dev_true_rms=float(np.sqrt(np.mean(d_true**2))), dev_true_max=float(np.abs(d_true).max()),
                dev_mesh_rms=float(np.sqrt(np.mean(d_mesh**2))), dev_mesh_max=float(d_mesh.max()))


rows = []
zebra_panels = []  # the tilt sweep's surfaces, as zebra pictures side by side
for name, values in SWEEP.items():
    for w in values:
        t0 = time.perf_counter()
        r = fit_surface(V, F, weights=FitWeights(**{name: w}))
        row = dict(weight=name, value=w, seconds=time.perf_counter() - t0, iterations=r.iterations)
        weights = FitWeights(**{name: w})
        for term in ("bend", "tilt", "local"):
            wt = getattr(weights, term)
            row[f"energy_{term}"] = r.energies[term] / wt if wt > 0 else float("nan")
        row.update(deviations(r))
        rows.append(row)
        if name == "tilt":
            zebra_panels.append(Panel(r.surface, "zebra", title=f"tilt = {w:g}"))
        print(f"{name:>5} = {w:<6g} bend {row['energy_bend']:.4g}  tilt {row['energy_tilt']:.4g}  "
              f"local {row['energy_local']:.4g}  dev(true) rms {row['dev_true_rms']:.2e}  "
              f"dev(mesh) max {row['dev_mesh_max']:.2e}  {row['seconds']:.1f} s")

with atomic_path(out / "fairness_sweep.csv") as tmp, open(tmp, "w", newline="") as fh:
    writer = csv.DictWriter(fh, fieldnames=list(rows[0]))
    writer.writeheader()
    writer.writerows(rows)

fig = Figure(figsize=(9, 3.6), dpi=100)
FigureCanvasAgg(fig)
ax_e, ax_d = fig.subplots(1, 2)
for name, style in (("bend", "o-"), ("tilt", "s--")):
    sel = [r for r in rows if r["weight"] == name]
    x = [r["value"] for r in sel]
    ax_e.loglog(x, [r[f"energy_{name}"] for r in sel], style, label=f"{name} energy vs {name} weight")
    ax_d.loglog(x, [r["dev_true_rms"] for r in sel], style, label=f"RMS to true shape ({name} sweep)")
    ax_d.loglog(x, [r["dev_mesh_rms"] for r in sel], style, alpha=0.5, label=f"RMS to input mesh ({name} sweep)")
ax_e.set_xlabel("weight")
ax_e.set_ylabel("energy term (unweighted)")
ax_d.set_xlabel("weight")
ax_d.set_ylabel("deviation")
for ax in (ax_e, ax_d):
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7)
fig.tight_layout()
with atomic_path(out / "fairness_sweep.png") as tmp:
    fig.savefig(tmp, format="png")
pic = render_panels(zebra_panels, out / "fairness_sweep_zebra.png", view="top", size=(1600, 450))
print(f"wrote {out / 'fairness_sweep.csv'}, {out / 'fairness_sweep.png'} and {pic}")

# raising a term's weight never raises that term (weighted least squares); 1e-9 relative slack
for name in SWEEP:
    e = [r[f"energy_{name}"] for r in rows if r["weight"] == name]
    assert all(b <= a * (1 + 1e-9) for a, b in zip(e, e[1:])), (name, e)
assert all(r["dev_mesh_max"] > 0 and np.isfinite(r["dev_true_rms"]) for r in rows)
assert (out / "fairness_sweep_zebra.png").stat().st_size > 10_000
