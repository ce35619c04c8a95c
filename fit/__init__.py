"""trispline.fit — fitting, mesh I/O, export and the command line.

Heavy modules (JAX, optimistix, trimesh) load on first use, so ``trispline --help``
and ``import trispline.fit`` stay fast::

    import jax
    jax.config.update("jax_enable_x64", True)   # fits run in float64
    from trispline.fit import fit_surface, load_mesh
    V, F = load_mesh("scan.ply")
    result = fit_surface(V, F, param="harmonic")
"""
from __future__ import annotations

from trispline.spline.util.lazy import lazy_exports

_EXPORTS = {
    "fit_surface": "pipeline", "FitResult": "pipeline", "FitWeights": "weights", "FitError": "errors",
    "DataPoints": "energy.data",
    "load_mesh": "io", "read_mesh": "io", "MeshData": "io",
}

__getattr__, __dir__, __all__ = lazy_exports(__name__, _EXPORTS)
