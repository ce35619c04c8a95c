"""Pictures of a spline surface, rendered headless: shaded, zebra, curvature, deviation, control net.

    from trispline.fit.render import render, draw
    render(surface, "zebra.png", mode="zebra")                      # seen along the mean normal
    render(surface, "zebra.png", mode="zebra", view="iso", size=(800, 600), stripes=12)
    render(surface, "dev.png", mode="deviation", mesh=(V, F))       # against the data mesh
    pic = draw(surface, mode="curvature")                           # Picture: image (h, w, 3) uint8, stats

Every scalar is computed from the analytic surface, sampled per patch on a
barycentric lattice of ``resolution`` steps per edge (each patch keeps its own
samples, so a jump across a patch boundary stays a jump in the picture):

* **zebra** -- highlight lines (Beier and Chen 1994) of the analytic unit normals
  (:mod:`.zebra`): a C1 surface has continuous stripes, a kink breaks them.
* **curvature** -- mean ``H = (k1 + k2) / 2`` or Gaussian ``K = k1 k2`` from the
  analytic first and second derivatives (:mod:`.geometry`); the sign of ``H``
  follows the normal ``F_u x F_v``.
* **deviation** -- signed distance from each sampled surface point to the data
  mesh (surface -> data; ``+`` on the side the data face's normal points to),
  exact point-to-triangle distances (:mod:`.deviation`).

The defaults are chosen from the surface: the view looks along its mean normal
(``view="auto"``), the zebra stripe count keeps stripes wider than a few pixels
(``stripes=None``), the curvature colour range is a percentile of a fixed sample
(the same at every resolution), and a dated caption names the picture's origin.

The modules, in the order a picture is made: :mod:`.view` (camera directions,
the default view, sizes, framing), :mod:`.sampling` (the per-patch lattice, the
fixed reference sample and the patch-boundary curves), :mod:`.geometry`,
:mod:`.zebra`, :mod:`.deviation` (what is shown), :mod:`.scene` (layers, legends
and statistics per mode), :mod:`.caption`, :mod:`.backends` (PyVista/VTK
off-screen, or matplotlib with a :class:`RenderFallbackWarning` when VTK cannot be
imported or fails; ``TRISPLINE_RENDER_BACKEND=matplotlib`` or ``backend=`` picks
one) and :mod:`.picture` (draw, render, write_png).
"""
from ..errors import RenderError, RenderFallbackWarning
from .backends import BACKENDS
from .caption import caption_text
from .deviation import deviation
from .geometry import CURVATURES, curvatures, surface_curvatures, unit_normals
from .picture import draw, draw_panels, render, render_panels, write_png
from .sampling import SurfaceSample, reference_sample, sample_surface
from .scene import MODES, Panel, Picture
from .view import (AUTO, VIEWS, View, check_view, facing_view, mean_normal, mean_normal_view, parse_size,
                   parse_view, resolve_view)
from .zebra import ZebraLight, auto_stripes, stripe_function, stripe_pattern, stripe_pixels, zebra_light

__all__ = [
    "MODES", "AUTO", "VIEWS", "BACKENDS", "CURVATURES", "RenderError", "RenderFallbackWarning",
    "View", "parse_view", "check_view", "resolve_view", "parse_size", "mean_normal", "facing_view",
    "mean_normal_view", "SurfaceSample", "sample_surface", "reference_sample", "unit_normals",
    "curvatures", "surface_curvatures", "ZebraLight", "zebra_light", "stripe_function",
    "stripe_pattern", "stripe_pixels", "auto_stripes", "deviation", "Panel", "Picture", "caption_text",
    "draw", "draw_panels", "render", "render_panels", "write_png",
]
