"""Generate the pictures of docs/cad.md.

    python examples/cad_docs.py

Writes into docs/images/:

* ``cad_split.png``    one quintic triangle split at its centroid and edge midpoints into
                       three quads (the domain, left) and the three 6 x 6 tensor control
                       nets over the triangle's own 21-point net (right);
* ``cad_readback.png`` the fitted synthetic scan exported to STEP, read back by Open
                       CASCADE and tessellated by BRepMesh (left; every B-spline face's
                       mesh, as a CAD tool shows it) next to trispline's own zebra picture.
"""
from __future__ import annotations

import tempfile
from pathlib import Path

import jax

jax.config.update("jax_enable_x64", True)  # the fit runs in float64

import matplotlib  # noqa: E402

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from trispline.fit.datasets.synthetic import synthetic_scan  # noqa: E402
from trispline.fit.io.cad import export_cad, occ_mesh, read_cad  # noqa: E402
from trispline.fit.pipeline import fit_surface  # noqa: E402
from trispline.fit.render import Panel, mean_normal_view, render_panels  # noqa: E402
from trispline.spline.index import EXPONENTS  # noqa: E402
from trispline.spline.patches import evaluate  # noqa: E402
from trispline.spline.polynomial import polynomial_control_net  # noqa: E402
from trispline.spline.tensor import QUAD_CORNERS, quad_bary, tensor_net  # noqa: E402

IMAGES = Path(__file__).resolve().parents[1] / "docs" / "images"
COLOURS = ("tab:blue", "tab:orange", "tab:green")


def split_picture(path: Path) -> None:
    """The domain split (left) and the three tensor control nets of one patch (right)."""
    uv = np.array([[0.0, 0.0], [1.0, 0.0], [0.35, 0.85]])
    faces = np.array([[0, 1, 2]])
    ctrl = polynomial_control_net(uv, faces, lambda p: np.column_stack(
        [p, 0.5 * np.sin(2.5 * p[:, 0]) * np.cos(2.0 * p[:, 1]) + 0.3 * p[:, 1] ** 2]))
    P = tensor_net(uv, faces, ctrl).patch_points()  # (3, 6, 6, 3)
    fig = plt.figure(figsize=(12, 5.2))
    ax = fig.add_subplot(1, 2, 1)
    ax.fill(*uv.T, color="0.93")
    g = np.linspace(0, 1, 6)
    for k, colour in enumerate(COLOURS):
        corners = QUAD_CORNERS[k] @ uv  # (2, 2, 2) uv of P_pq
        ax.fill(*corners[[0, 1, 1, 0], [0, 0, 1, 1]].T, color=colour, alpha=0.18)
        for a in g:  # the images of the lines s = a and t = a of the bilinear map
            for line in (np.column_stack([np.full(6, a), g]), np.column_stack([g, np.full(6, a)])):
                ax.plot(*(quad_bary(line)[k] @ uv).T, color=colour, lw=0.6)
        o, s1, t1 = corners[0, 0], corners[1, 0], corners[0, 1]
        ax.annotate("", xy=o + 0.35 * (s1 - o), xytext=o, arrowprops=dict(arrowstyle="->", color=colour, lw=2))
        ax.annotate("", xy=o + 0.35 * (t1 - o), xytext=o, arrowprops=dict(arrowstyle="->", color=colour, lw=1))
        ax.text(*(corners.reshape(4, 2).mean(0)), f"quad {k}", color=colour, ha="center", va="center")
    ax.plot(*(EXPONENTS @ uv / 5).T, "k.", ms=5, label="domain points of the 21 control points")
    for name, p in zip(("$v_0$", "$v_1$", "$v_2$", "g"), np.vstack([uv, uv.mean(0)])):
        ax.annotate(name, p, textcoords="offset points", xytext=(-14, -12) if name != "g" else (6, 4))
    ax.set_aspect("equal")
    ax.axis("off")
    ax.set_title("quads at the centroid g and edge midpoints (thick arrow s, thin t)", fontsize=10)
    ax.legend(loc="upper right", fontsize=8, frameon=False)
    ax3 = fig.add_subplot(1, 2, 2, projection="3d")
    st = np.stack(np.meshgrid(np.linspace(0, 1, 13), np.linspace(0, 1, 13), indexing="ij"), -1).reshape(-1, 2)
    for k, colour in enumerate(COLOURS):
        net = P[k]
        for i in range(6):
            ax3.plot(*net[i].T, color=colour, lw=0.9)
            ax3.plot(*net[:, i].T, color=colour, lw=0.9)
        ax3.scatter(*net.reshape(-1, 3).T, color=colour, s=7)
        pts = evaluate(uv, faces, ctrl, np.zeros(len(st), np.int64), quad_bary(st)[k]).reshape(13, 13, 3)
        ax3.plot_surface(*pts.transpose(2, 0, 1), color=colour, alpha=0.25, linewidth=0)
    ax3.scatter(*ctrl[0].T, color="k", s=16, marker="x", label="the triangle's 21 control points")
    ax3.set_box_aspect((1, 0.85, 0.55), zoom=1.6)
    ax3.view_init(32, -58)
    ax3.set_title("three exact 6 x 6 control nets (shared rows identical)", fontsize=10)
    ax3.legend(loc="upper left", fontsize=8, frameon=False)
    ax3.set_axis_off()
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def readback_picture(path: Path) -> None:
    """The fitted synthetic scan through STEP and Open CASCADE, next to trispline's picture."""
    V, F = synthetic_scan(150, seed=0)
    surface = fit_surface(V, F, param="harmonic").surface
    with tempfile.TemporaryDirectory() as folder:
        step = export_cad(surface, Path(folder) / "scan.step")
        mesh = occ_mesh(read_cad(step), deflection=5e-4)
    render_panels(
        [Panel(mesh=mesh, title=f"STEP read by Open CASCADE ({3 * surface.n_faces} faces)"),
         Panel(surface, "zebra", title=f"trispline ({surface.n_faces} triangles)")],
        path, view=mean_normal_view(V, F), size=(1200, 520))


if __name__ == "__main__":
    IMAGES.mkdir(parents=True, exist_ok=True)
    split_picture(IMAGES / "cad_split.png")
    readback_picture(IMAGES / "cad_readback.png")
    print(f"wrote {IMAGES / 'cad_split.png'} and {IMAGES / 'cad_readback.png'}")
