"""trispline.spline — C1 quintic triangular splines over planar triangulations.

Pure math (numpy/scipy only): the domain triangulation, the free-to-control
propagation map, local editing, continuity checks, point location, tessellation
and the surface file format. The names below are the layer's API; the building
blocks stay importable from their modules: index tables and the sample lattice
(:mod:`.index`), the Bernstein basis (:mod:`.bernstein`), patch evaluation
(:mod:`.patches`), the control net layout (:mod:`.net`), test generators
(:mod:`.testing`), named tolerances (:mod:`.tolerances`) and plumbing (:mod:`.util`).
"""
from .continuity import continuity_report
from .edit import EditResult, SplineEditor
from .errors import InputError, OutsideDomainError, SurfaceFileError, TriangulationError
from .locate import Locator
from .polynomial import polynomial_control_net
from .propagation import SplineSpace, build_space, working_origin
from .serialize import read_surface, write_surface
from .surface import SplineSurface
from .tessellate import Tessellation, tessellate
from .topology import Triangulation

__all__ = [
    "SplineSurface", "SplineSpace", "build_space", "Triangulation", "SplineEditor", "EditResult",
    "tessellate", "Tessellation", "Locator", "continuity_report", "read_surface", "write_surface",
    "polynomial_control_net", "working_origin",
    "InputError", "TriangulationError", "OutsideDomainError", "SurfaceFileError",
]
