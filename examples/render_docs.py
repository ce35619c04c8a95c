"""Generate the pictures and the timing table of docs/render.md.

    python examples/render_docs.py [--timing-only] [--no-timing]

Writes into docs/images/:

* ``kink.png``        zebra of an exactly C1 surface next to the same surface with one
                      off-edge control point moved (C0 only): the stripes break at the seam;
* ``scan_vs_fit.png`` the synthetic scan (flat triangles) next to its fitted surface;
* ``real_curvature.png`` and ``real_deviation.png``: mean curvature and deviation maps of a
  fitted real mesh with the default view (``inspired_mesh.obj`` from ../shared/data or the
  cache folder when present, else the generated face scan);
* ``default_view.png`` a real mesh that faces away from the old default camera (``mountain.obj``,
  a y-up height field, else the face scan turned upside down): the ``iso`` view sees its back
  (tan), the default ``auto`` view its front;
* ``zebra_auto.png``  the old default of 12 zebra stripes next to the automatic count on a
  34k-patch fit (``face_gpjs.obj``, else ``face_scan(30000)``) at 800 x 600 per panel;

and prints the timing table (100k-patch surface, each mode, PyVista and the matplotlib
fallback). The zebra pictures with and without the tilt term come from
``python examples/04_zebra_tilt.py --docs``. The captions carry the date of
``$SOURCE_DATE_EPOCH`` when it is set.
"""
from __future__ import annotations

import sys
import time
from pathlib import Path

import jax

jax.config.update("jax_enable_x64", True)

import numpy as np  # noqa: E402

from trispline.fit import render as rd  # noqa: E402
from trispline.fit.datasets.cache import find_data  # noqa: E402
from trispline.fit.datasets.face import face_scan  # noqa: E402
from trispline.fit.datasets.synthetic import synthetic_scan  # noqa: E402
from trispline.fit.io import load_mesh  # noqa: E402
from trispline.fit.pipeline import fit_surface  # noqa: E402
from trispline.spline.index import index_of  # noqa: E402
from trispline.spline.testing.domains import grid  # noqa: E402
from trispline.spline.polynomial import polynomial_control_net  # noqa: E402
from trispline.spline.surface import SplineSurface  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
IMAGES = ROOT / "docs" / "images"


def graph(n: int, func) -> SplineSurface:
    uv, faces = grid(n)
    return SplineSurface(uv, faces, polynomial_control_net(
        uv, faces, lambda p: np.column_stack([p[:, 0], p[:, 1], func(p[:, 0], p[:, 1])])))


def real_mesh(name: str, faces: int) -> tuple[np.ndarray, np.ndarray, str]:
    """``V, F`` and a label: the shared mesh ``name`` where present, else ``face_scan(faces)``."""
    path = find_data(name)
    if path is not None:
        V, F = load_mesh(path)
        return V, F, name
    V, F = face_scan(faces, seed=0)
    return V, F, f"face_scan({faces})"


def fitted(V: np.ndarray, F: np.ndarray, label: str) -> SplineSurface:
    t0 = time.perf_counter()
    surface = fit_surface(V, F).surface
    print(f"fit {label}: {F.shape[0]} faces, {time.perf_counter() - t0:.1f} s")
    return surface


def kink() -> None:
    """An exactly C1 surface and the same with one off-edge control point moved: C0 only."""
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


def pictures() -> None:
    IMAGES.mkdir(parents=True, exist_ok=True)
    kink()
    # --- the scan next to its fit
    V, F = synthetic_scan(800, seed=0)
    fit = fit_surface(V, F).surface
    view = rd.mean_normal_view(V, F, elevation=45.0)
    rd.render_panels([rd.Panel(mesh=(V, F), title=f"scan: {F.shape[0]} triangles"),
                      rd.Panel(fit, "shaded", title=f"fitted C1 quintic spline ({fit.n_faces} patches)")],
                     IMAGES / "scan_vs_fit.png", view=view, size=(1200, 520))
    # --- curvature and deviation of a real mesh, default view
    V, F, name = real_mesh("inspired_mesh.obj", 4000)
    fit = fitted(V, F, name)
    rd.render(fit, IMAGES / "real_curvature.png", "curvature", size=(900, 600),
              title=f"mean curvature of the fit of {name}")
    rd.render(fit, IMAGES / "real_deviation.png", "deviation", mesh=(V, F), size=(900, 600),
              title=f"deviation of the fit from {name}")
    # --- a mesh facing away from the old default camera
    V, F, name = real_mesh("mountain.obj", 4000)
    if name != "mountain.obj":
        V = V * [1.0, -1.0, -1.0]  # turned upside down (180 degrees about x)
        name += ", upside down"
    fit = fitted(V, F, name)
    rd.render_panels([rd.Panel(fit, "shaded", title="--view iso (the old default)", options=dict(view="iso")),
                      rd.Panel(fit, "shaded", title="--view auto (the default)")],
                     IMAGES / "default_view.png", size=(1200, 520))
    # --- zebra stripes: 12 alias, the automatic count does not
    V, F, name = real_mesh("face_gpjs.obj", 30000)
    fit = fitted(V, F, name)
    pic = rd.draw_panels([rd.Panel(fit, "zebra", title="--stripes 12 (the old default)", options=dict(stripes=12)),
                          rd.Panel(fit, "zebra", title="automatic stripe count (the default)")], size=(1600, 600))
    rd.write_png(pic.image, IMAGES / "zebra_auto.png")
    print(f"zebra of {name}: " + "; ".join(f"{p['stripes']:g} stripes, pairs >= {p['stripe_pixels']:.3g} px"
                                            for p in pic.stats["panels"]))
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
