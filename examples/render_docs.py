"""Generate the pictures and the timing table of docs/render.md.

    python examples/render_docs.py [--timing-only] [--no-timing]

Writes into docs/images/:

* ``kink.png``        zebra of an exactly C1 surface next to the same surface with one
                      off-edge control point moved (C0 only): the stripes break at the seam;
* ``scan_vs_fit.png`` the synthetic scan (flat triangles) next to its fitted surface;
* ``real_curvature.png`` and ``real_deviation.png``: mean curvature and deviation maps of a
  fitted real mesh (``../shared/data/inspired_mesh.obj`` when present, else the synthetic scan);

and prints the timing table (100k-patch surface, each mode, PyVista and the matplotlib
fallback). The zebra pictures with and without the tilt term come from
``python examples/04_zebra_tilt.py --docs``.
"""
from __future__ import annotations

import sys
import time
from pathlib import Path

import jax

jax.config.update("jax_enable_x64", True)

import numpy as np  # noqa: E402

from trispline.fit import render as rd  # noqa: E402
from trispline.fit.pipeline import fit_surface  # noqa: E402
from trispline.fit.datasets.synthetic import synthetic_scan  # noqa: E402
from trispline.spline.index import index_of  # noqa: E402
from trispline.spline.testing.domains import grid  # noqa: E402
from trispline.spline.polynomial import polynomial_control_net  # noqa: E402
from trispline.spline.surface import SplineSurface  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
IMAGES = ROOT / "docs" / "images"
DATA = ROOT.parent / "shared" / "data"


def graph(n: int, func) -> SplineSurface:
    uv, faces = grid(n)
    return SplineSurface(uv, faces, polynomial_control_net(
        uv, faces, lambda p: np.column_stack([p[:, 0], p[:, 1], func(p[:, 0], p[:, 1])])))


def pictures() -> None:
    IMAGES.mkdir(parents=True, exist_ok=True)
    # --- a kink breaks the stripes
    s = graph(4, lambda u, v: 0.15 * (u - 0.5) ** 2 + 0.1 * (v - 0.3) ** 2 + 0.05 * u * v)
    tri = s.triangulation
    e = next(int(e) for e in tri.interior_edges
             if np.allclose(s.uv[tri.edges[e], 0], 0.5) and np.isclose(s.uv[tri.edges[e], 1].mean(), 0.625))
    f, k = int(tri.edge_faces[e, 0]), int(tri.edge_opposite[e, 0])
    ex = [0, 0, 0]
    ex[k], ex[(k + 1) % 3], ex[(k + 2) % 3] = 1, 2, 2
    ctrl = np.array(s.ctrl)
    ctrl[f, index_of(*ex), 2] += 0.01
    kinked = SplineSurface(s.uv, s.faces, ctrl)
    rd.render_panels([rd.Panel(s, "zebra", title="C1 (intact)"),
                      rd.Panel(kinked, "zebra", title="one control point moved by 0.01: C0 only")],
                     IMAGES / "kink.png", view="top", size=(1000, 520))
    # --- the scan next to its fit
    V, F = synthetic_scan(800, seed=0)
    fit = fit_surface(V, F).surface
    view = rd.mean_normal_view(V, F, elevation=45.0)
    rd.render_panels([rd.Panel(mesh=(V, F), title=f"scan: {F.shape[0]} triangles"),
                      rd.Panel(fit, "shaded", title=f"fitted C1 quintic spline ({fit.n_faces} patches)")],
                     IMAGES / "scan_vs_fit.png", view=view, size=(1200, 520))
    # --- curvature and deviation of a real mesh
    real = DATA / "inspired_mesh.obj"
    if real.exists():
        from trispline.fit.io import load_mesh

        V, F = load_mesh(real)
        name = real.name
    else:
        V, F = synthetic_scan(3000, seed=1)
        name = "synthetic scan"
    t0 = time.perf_counter()
    fit = fit_surface(V, F).surface
    print(f"fit {name}: {F.shape[0]} faces, {time.perf_counter() - t0:.1f} s")
    view = rd.mean_normal_view(V, F, elevation=50.0)
    rd.render(fit, IMAGES / "real_curvature.png", "curvature", view=view, size=(900, 600),
              title=f"mean curvature of the fit of {name}")
    rd.render(fit, IMAGES / "real_deviation.png", "deviation", mesh=(V, F), view=view, size=(900, 600),
              title=f"deviation of the fit from {name}")
    print(f"wrote pictures to {IMAGES}")


def timing() -> None:
    s = graph(224, lambda u, v: 0.2 * (u - 0.5) ** 2 - 0.15 * (v - 0.4) ** 2 + 0.3 * u**3 * v**2 - 0.2 * v**4 * u)
    tess = s.tessellate(1)
    mesh = (tess.vertices, tess.triangles)
    rd.draw(graph(2, lambda u, v: u * v), "shaded", size=(100, 100))  # import VTK before timing
    print(f"| mode | backend | samples/edge | triangles | seconds |  ({s.n_faces} patches, 800x600, "
          f"{sys.platform}, 2 cores, no GPU)")
    print("|---|---|---|---|---|")
    for backend in ("pyvista", "matplotlib"):
        for mode in rd.MODES:
            if backend == "matplotlib" and mode == "controlnet":
                continue
            t0 = time.perf_counter()
            pic = rd.draw(s, mode, mesh=mesh if mode == "deviation" else None, size=(800, 600), backend=backend)
            dt = time.perf_counter() - t0
            print(f"| {mode} | {pic.backend} | {pic.stats['resolution']} | {pic.stats['triangles']:,} | {dt:.1f} |")


if __name__ == "__main__":
    if "--timing-only" not in sys.argv:
        pictures()
    if "--no-timing" not in sys.argv:
        timing()
