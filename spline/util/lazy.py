"""Lazy re-exports for package ``__init__`` modules: heavy sub-modules load on first use.

    __getattr__, __dir__, __all__ = lazy_exports(__name__, {"fit_surface": "pipeline", ...})

keeps ``import trispline.fit`` (and ``trispline --help``) fast: JAX, trimesh and libigl are
imported only when a name that needs them is first used.
"""
from __future__ import annotations

import importlib
from typing import Any, Callable


def lazy_exports(package: str, exports: dict[str, str]
                 ) -> tuple[Callable[[str], Any], Callable[[], list[str]], list[str]]:
    """``(__getattr__, __dir__, __all__)`` for ``package``; ``exports`` maps name -> relative module."""
    names = sorted(exports)

    def getattr_(name: str) -> Any:
        if name in exports:
            return getattr(importlib.import_module(f".{exports[name]}", package), name)
        raise AttributeError(f"module {package!r} has no attribute {name!r}")

    def dir_() -> list[str]:
        return sorted(set(names) | set(vars(importlib.import_module(package))))

    return getattr_, dir_, names
