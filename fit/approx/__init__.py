"""Approximation of dense scans by a coarse spline: the coarse domain and the true deviation.

    from trispline.fit.approx import coarse_domain, insert, surface_deviation, mesh_deviation, summary
    dom = coarse_domain(V, F, uv, n_vertices=2000)     # CoarseDomain: uv, faces, vertices (scan ids), stats
    hit = dom.locate_scan()                            # every scan vertex in the coarse domain
    dom = insert(dom, ids)                             # refinement: more scan vertices
    dev = surface_deviation(surface, V)                # closest points ON the surface: distance, face, bary
    back = mesh_deviation(surface, V, F)               # dense surface samples to the scan

Modules, in the order the approximation uses them: :mod:`.analysis` (robust local
quadrics of the scan: residuals, noise, curvature), :mod:`.boundary` (which outline
vertices stay), :mod:`.domain` (the sizing field, the snap to scan vertices,
:func:`insert`), :mod:`.cdt` (every call of Triangle), :mod:`.quality` (face angles, moving vertices off
slivers), :mod:`.locate` (point location that clamps points outside the domain to
its boundary) and :mod:`.deviation` (distances both ways).
"""
from .analysis import ScanAnalysis, analyse_scan
from .deviation import Deviation, mesh_deviation, summary, surface_deviation
from .domain import CoarseDomain, DomainStats, coarse_domain, insert
from .locate import ClampedLocator, Located
from .quality import face_angles

__all__ = [
    "ScanAnalysis", "analyse_scan", "CoarseDomain", "DomainStats", "coarse_domain", "insert", "face_angles",
    "ClampedLocator", "Located", "Deviation", "surface_deviation", "mesh_deviation", "summary",
]
