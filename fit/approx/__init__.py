"""Approximation of dense scans by a coarse, fair C1 spline within a tolerance.

    from trispline.fit.approx import approximate_surface
    res = approximate_surface(V, F, tolerance_rel=1e-3)   # ApproxResult: surface, domain, deviation, stats
    res.surface.save("scan.npz")

The steps, each usable alone::

    dom = coarse_domain(V, F, uv, n_vertices=2000)     # CoarseDomain: uv, faces, vertices (scan ids), stats
    hit = dom.locate_scan()                            # every scan vertex in the coarse domain
    fit = fit_domain(dom, V, loss="l2")                # CoarseFit: the spline over dom fitted to every scan vertex
    dev = surface_deviation(fit.surface, V)            # closest points ON the surface: distance, face, bary
    back = mesh_deviation(fit.surface, V, F)           # dense surface samples to the scan
    dom = insert(dom, ids)                             # refinement: more scan vertices

Modules, in the order the approximation uses them: :mod:`.analysis` (robust local
quadrics of the scan: residuals, noise, curvature), :mod:`.boundary` (which outline
vertices stay), :mod:`.domain` (the sizing field, the snap to scan vertices,
:func:`insert`), :mod:`.cdt` (every call of Triangle), :mod:`.quality` (face angles, moving vertices off
slivers), :mod:`.locate` (point location that clamps points outside the domain to
its boundary), :mod:`.problem` and :mod:`.fit` (the least-squares problem over the
coarse domain and its solve), :mod:`.deviation` (distances both ways), :mod:`.refine`
(where to insert vertices, what is rejected) and :mod:`.pipeline`
(:func:`approximate_surface`). Names load on first use (JAX only with the fit).
"""
from trispline.spline.util.lazy import lazy_exports

_EXPORTS = {
    "ScanAnalysis": "analysis", "analyse_scan": "analysis",
    "CoarseDomain": "domain", "DomainStats": "domain", "coarse_domain": "domain", "insert": "domain",
    "face_angles": "quality", "ClampedLocator": "locate", "Located": "locate",
    "Deviation": "deviation", "surface_deviation": "deviation", "mesh_deviation": "deviation", "summary": "deviation",
    "CoarseFit": "fit", "fit_domain": "fit", "scan_parameters": "fit", "APPROX_WEIGHTS": "fit",
    "ApproxResult": "pipeline", "approximate_surface": "pipeline",
}

__getattr__, __dir__, __all__ = lazy_exports(__name__, _EXPORTS)
