"""The README's pictures for choosing the parameterization and the weights.

    python examples/choosing_docs.py [OUT_DIR]      # default: docs/images

* ``param_choice.png``  mean curvature of a rectangular scan with a hole (the ``bumps``
  ground truth, 3,000 vertices, no noise) fitted with the default ``--param spectral`` and
  ``--param harmonic``: harmonic maps the rectangle's outline onto a circle, and the
  squeezed corners show as curvature spikes;
* ``weights_choice.png`` zebra stripes of a sparse scan of the same surface (150
  vertices) fitted with the bending term alone (``--tilt 0 --local 0``) and with the
  default weights: the local
  targets and the frame tilt pull the surface toward local fits of the data;
* ``approx_choice.png`` mean curvature of the built-in noisy scan (4,000 faces) interpolated
  and approximated within 1% of its diagonal (data weight 1e4): the interpolant follows the
  scanner noise, the approximation (a few dozen patches) the shape.

Each fit's RMS distance to the true surface ("error") or its largest mean curvature is
printed and drawn into the panel titles, so the picture states what it shows.
"""
from __future__ import annotations

import dataclasses
import sys
from pathlib import Path

import jax

jax.config.update("jax_enable_x64", True)  # the fit runs in float64

import numpy as np  # noqa: E402

from trispline.fit import render as rd  # noqa: E402
from trispline.fit.approx import APPROX_WEIGHTS, approximate_surface  # noqa: E402
from trispline.fit.datasets.synthetic import synthetic_scan  # noqa: E402
from trispline.fit.datasets.truth import truth_scan  # noqa: E402
from trispline.fit.pipeline import FitWeights, fit_surface  # noqa: E402
from trispline.fit.render.sampling import sample_surface  # noqa: E402

SIZE = (1200, 560)


def rms_to_truth(truth, surface) -> float:
    """RMS distance of the surface's lattice samples (8 steps per edge) to the true surface."""
    points = sample_surface(surface, 8).points
    return float(np.sqrt(np.mean(truth.distance_to_truth(points) ** 2)))


def max_curvature(surface) -> float:
    """Largest |H| on the lattice samples (8 steps per edge)."""
    return float(np.abs(sample_surface(surface, 8, curvature=True).mean_curvature).max())


def side_by_side(titled: dict, mode: str, path: Path) -> None:
    """Draw ``{title: surface}`` side by side in ``mode`` into ``path``; print the titles."""
    for title in titled:
        print(title)
    rd.write_png(rd.draw_panels([rd.Panel(s, mode, title=t) for t, s in titled.items()], size=SIZE).image, path)


def param_picture(out: Path) -> None:
    truth = truth_scan("bumps", 3000, sigma=0.0)
    fits = {m: fit_surface(truth.V, truth.F, param=m).surface for m in ("spectral", "harmonic")}
    side_by_side({f"{m}: max curvature {max_curvature(s):.2g}, error {rms_to_truth(truth, s):.1e}": s
                  for m, s in fits.items()}, "curvature", out / "param_choice.png")


def weights_picture(out: Path) -> None:
    truth = truth_scan("bumps", 150, sigma=0.0)
    weights = {"bend only": FitWeights(tilt=0.0, local=0.0), "default weights": FitWeights()}
    fits = {n: fit_surface(truth.V, truth.F, weights=w).surface for n, w in weights.items()}
    side_by_side({f"{n}: error {rms_to_truth(truth, s):.1e}": s for n, s in fits.items()}, "zebra",
                 out / "weights_choice.png")


def approx_picture(out: Path) -> None:
    V, F = synthetic_scan(4000, seed=0)
    # data weight 1e4: smoother than the cross-validated one (1e5 on this scan: max |H| 119 against 22, on the
    # hole's outline)
    smooth = dataclasses.replace(APPROX_WEIGHTS, data=1e4)
    fits = {"interpolated": fit_surface(V, F).surface,
            "approximated": approximate_surface(V, F, tolerance_rel=1e-2, weights=smooth).surface}
    side_by_side({f"{n}: {s.faces.shape[0]} patches, max |H| {max_curvature(s):.2g}": s
                  for n, s in fits.items()}, "curvature", out / "approx_choice.png")


if __name__ == "__main__":
    out = Path(sys.argv[1]) if len(sys.argv) > 1 else Path(__file__).resolve().parents[1] / "docs" / "images"
    out.mkdir(parents=True, exist_ok=True)
    param_picture(out)
    weights_picture(out)
    approx_picture(out)
    print(f"wrote {out / 'param_choice.png'}, {out / 'weights_choice.png'}, {out / 'approx_choice.png'}")
