"""The stages of :func:`~trispline.fit.pipeline.fit_surface`, in order (no heavy imports).

``fit_surface(progress=...)`` reports them and ``FitResult.timings`` has one entry each; the
command line's progress bar lists them before JAX is imported.
"""
from __future__ import annotations

FIT_STAGES: tuple[str, ...] = ("parameterize", "build", "assemble", "factor", "solve", "finish")
PARAMETERIZE, BUILD, ASSEMBLE, FACTOR, SOLVE, FINISH = FIT_STAGES
