"""The interpolating fit's memory need, known from the mesh's size before any work (no heavy imports:
the command line checks it before JAX starts and before the parameterization)."""
from __future__ import annotations

from trispline.spline.util.memory import available_memory, format_bytes

from .errors import FactorMemoryError

__all__ = ["FIT_BYTES_PER_FACE", "FIT_BASE_BYTES", "estimate_fit_bytes", "check_fit_memory", "refuse_above"]

#: The interpolating fit's peak memory: a base (the runtime) plus this much per face, fitted to
#: ``bench_fit_speed.py``'s in-process peaks: 2,406 MiB at 99,458 faces, 4,549-4,635 MiB at 199,712,
#: 11,161 MiB at 500,000 (22.9 kB a face between the first and the last, 0.24 GB left at none).
FIT_BYTES_PER_FACE = 22_000
FIT_BASE_BYTES = 250_000_000


def estimate_fit_bytes(n_faces: int) -> int:
    """Bytes an interpolating fit of ``n_faces`` faces needs at its peak (:data:`FIT_BYTES_PER_FACE`)."""
    return int(FIT_BASE_BYTES + FIT_BYTES_PER_FACE * n_faces)


def check_fit_memory(n_faces: int, max_bytes: int | str | None = "available") -> None:
    """Refuse (:class:`FactorMemoryError`) an interpolating fit of ``n_faces`` faces whose peak
    (:func:`estimate_fit_bytes`) exceeds ``max_bytes`` (as :func:`trispline.fit.solve.check_memory`), before any work: a
    1M-face scan needs ~22 GB, and its parameterization alone can take minutes."""
    refuse_above(estimate_fit_bytes(n_faces), available_memory() if max_bytes == "available" else max_bytes,
                 f"an interpolating fit of {n_faces:,} faces", f" (about {format_bytes(FIT_BYTES_PER_FACE)} a face)")


def refuse_above(estimate: int, limit: int | None, what: str, why: str = "") -> None:
    """:class:`FactorMemoryError` when ``estimate`` bytes exceed ``limit`` (None: no limit known), naming
    ``what`` needs them (``why``: how they were estimated) and the way out: the approximation's fewer patches."""
    if limit is None or estimate <= limit:
        return
    raise FactorMemoryError(
        f"{what} needs about {format_bytes(estimate)}{why}, but only {format_bytes(limit)} of memory are available; "
        "approximate it with fewer patches: trispline fit --tolerance TOL (approximation mode), or fit a "
        "smaller mesh", estimate=estimate, available=limit)
