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

import importlib

_EXPORTS = {
    "fit_surface": "pipeline", "FitResult": "pipeline", "FitWeights": "weights", "FitError": "errors",
    "DataPoints": "energy.data",
    "load_mesh": "io", "read_mesh": "io", "MeshData": "io",
}

__all__ = sorted(_EXPORTS)


def __getattr__(name: str):
    if name in _EXPORTS:
        return getattr(importlib.import_module(f".{_EXPORTS[name]}", __name__), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(list(globals()) + __all__)
