"""The two ways to turn scenes into pixels, and the choice between them.

    plan = choose("auto")                        # Plan: use "pyvista" or "matplotlib", and why
    image, used = draw_scenes(scenes, (800, 600), plan, caption="2025-06-01, trispline 0.1.0")

``auto`` draws with PyVista/VTK (:mod:`.pyvista`) and falls back to matplotlib
(:mod:`.matplotlib`) with a :class:`~trispline.fit.errors.RenderFallbackWarning`
when VTK cannot be imported or fails while drawing; ``pyvista`` raises instead,
``matplotlib`` never tries VTK. ``$TRISPLINE_RENDER_BACKEND`` is the default choice.
"""
from __future__ import annotations

import os
import warnings
from dataclasses import dataclass
from typing import Sequence

import numpy as np

from ...errors import RenderError, RenderFallbackWarning
from ..scene import Scene
from . import matplotlib as matplotlib_backend
from . import pyvista as pyvista_backend

__all__ = ["BACKENDS", "Plan", "choose", "draw_scenes", "pyvista_unusable"]

BACKENDS = ("auto", "pyvista", "matplotlib")


@dataclass(frozen=True)
class Plan:
    """The backend to draw with; ``strict``: PyVista was asked for by name (no fallback);
    ``reason``: why ``auto`` will not use PyVista (None when it will)."""

    use: str
    strict: bool
    reason: str | None


def pyvista_unusable() -> str | None:
    """None if PyVista and VTK import, else the reason."""
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            import pyvista  # noqa: F401
            import vtkmodules.vtkCommonCore  # noqa: F401
    except Exception as exc:  # noqa: BLE001 - any import failure means: use the fallback
        return f"{type(exc).__name__}: {exc}"
    return None


def choose(backend: str | None) -> Plan:
    """The :class:`Plan` for ``backend`` (one of :data:`BACKENDS`; None: the environment's, else auto)."""
    want = (backend or os.environ.get("TRISPLINE_RENDER_BACKEND", "auto") or "auto").strip().lower()
    if want not in BACKENDS:
        raise RenderError(f"unknown render backend {want!r}: use one of {', '.join(BACKENDS)}")
    if want == "matplotlib":
        return Plan("matplotlib", False, None)
    reason = pyvista_unusable()
    if want == "pyvista" and reason is not None:
        raise RenderError(f"the pyvista backend is not usable here ({reason}); install trispline[render] "
                          f"or use backend='matplotlib'")
    return Plan("matplotlib" if reason is not None else "pyvista", want == "pyvista", reason)


def draw_scenes(scenes: Sequence[Scene], size: tuple[int, int], plan: Plan, caption: str | None = None
                ) -> tuple[np.ndarray, str]:
    """``(image (h, w, 3) uint8, backend used)`` of ``scenes`` side by side, following ``plan``,
    with ``caption`` (if any) in the bottom right corner."""
    reason = plan.reason
    if plan.use == "pyvista":
        try:
            return pyvista_backend.draw(scenes, size, caption), "pyvista"
        except Exception as exc:  # noqa: BLE001 - VTK failed at run time (no OpenGL context, ...)
            if plan.strict:
                raise
            reason = f"{type(exc).__name__}: {exc}"
    if reason is not None:
        warnings.warn(f"PyVista/VTK rendering is not available ({reason.splitlines()[0][:200]}); "
                      f"drawing with matplotlib instead (coarser; for PyVista: pip install 'trispline[render]')",
                      RenderFallbackWarning, stacklevel=3)
    return matplotlib_backend.draw(scenes, size, caption), "matplotlib"
