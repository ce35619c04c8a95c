"""The propagation scheme as a sparse linear map ``P = M @ free`` (docs/design.md §3).

Free variables (``nfree`` of them, each a point in R^3):

* per vertex ``v``: the corner point ``z_v`` and two *frame points*
  ``h_v(v + d_v e_x / 5)``, ``h_v(v + d_v e_y / 5)`` of the corner region's affine
  map ``h_v`` (``d_v`` = mean length of the edges at ``v``, so frames are
  well-conditioned); every star point ``f(v^4 w) = h_v(v + (w - v)/5)`` is an
  affine combination of these three;
* the near-corner inner points and middle edge points that the per-vertex
  ``i = 1`` systems leave free (normally all inner points);
* one flip point per interior edge, both middle points and the flip point of
  each boundary edge.

Propagation order: corner regions, then edges, then flips. The modules follow
the build's stages:

* :mod:`.diamonds` -- each interior edge's C1 relation, the weak-pivot test, which
  flip of a diamond is computed, the star points' frame weights;
* :mod:`.elimination` -- the ``i = 1`` vertex systems with weak equations, reduced
  by batched Gauss--Jordan elimination with weighted complete pivoting (a singular
  vertex keeps one more free point);
* :mod:`.assembly` -- ``M``'s CSR arrays written class by class;
* :mod:`.build` -- :func:`build_space`, the stages in order;
* :mod:`.space` -- :class:`SplineSpace`, the result: ``M``, the global point ids
  and what each free variable is.

Every surface ``M @ free`` is exactly C1.
"""
from .build import build_space
from .diamonds import diamond_coefficients
from .space import KIND_CORNER, KIND_FLIP, KIND_FRAME, KIND_INNER, KIND_MID, KIND_NAMES, SplineSpace, working_origin

__all__ = [
    "KIND_CORNER", "KIND_FLIP", "KIND_FRAME", "KIND_INNER", "KIND_MID", "KIND_NAMES",
    "SplineSpace", "build_space", "diamond_coefficients", "working_origin",
]
