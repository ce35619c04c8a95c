"""The interpolating fit's memory need, known from the mesh's size before any work (no heavy imports:
the command line checks it before JAX starts and before the parameterization)."""
from __future__ import annotations

from trispline.spline.util.memory import available_memory, format_bytes, resident_memory

from .errors import FactorMemoryError

__all__ = ["FIT_BYTES_PER_FACE", "FIT_BASE_BYTES", "estimate_fit_bytes", "check_fit_memory", "refuse_above",
           "APPROX_BASE_BYTES", "APPROX_BYTES_PER_FACE", "APPROX_BYTES_PER_VERTEX", "estimate_approx_bytes",
           "approx_vertex_room"]

#: The interpolating fit's peak memory: a base (the runtime) plus this much per face, fitted to
#: ``bench_fit_speed.py``'s in-process peaks: 2,406 MiB at 99,458 faces, 4,549-4,635 MiB at 199,712,
#: 11,161 MiB at 500,000 (22.9 kB a face between the first and the last, 0.24 GB left at none), and the
#: command line's 22,722 MiB at 1,000,270 faces (a noisy scan whose map SLIM repaired: 23.6 kB a face; the
#: factor's fill grows a little faster than the faces). 22 kB a face let that fit start with 22 GiB
#: available and peak above it; 24 kB refuses it there.
FIT_BYTES_PER_FACE = 24_000
FIT_BASE_BYTES = 250_000_000


#: The approximation's peak: a base, per scan face (the located scan, its deviation) and per coarse vertex (about
#: two patches each: their normal equations and the factorisations of the data weight's cross-validation), fitted
#: to ``bench_approximate.py``'s peaks: 0.62 GB at 100k faces (304 vertices), 1.93 GB at 1M faces (2,511), and
#: ``--vertices`` 2,000 / 10,000 / 25,000 on the 100k scan: 0.92 / 2.39 / 3.96 GB.
APPROX_BASE_BYTES = 500_000_000
APPROX_BYTES_PER_FACE = 1_500
APPROX_BYTES_PER_VERTEX = 150_000


def estimate_approx_bytes(n_faces: int, n_vertices: int) -> int:
    """Bytes an approximation of a scan of ``n_faces`` faces needs at most with ``n_vertices`` coarse vertices."""
    return int(APPROX_BASE_BYTES + APPROX_BYTES_PER_FACE * n_faces + APPROX_BYTES_PER_VERTEX * n_vertices)


def approx_vertex_room(n_faces: int, max_bytes: int | str | None = "available") -> int | None:
    """The most coarse vertices an approximation of ``n_faces`` faces can grow to within ``max_bytes`` (None: no
    limit known; ``"available"``: the memory available now plus what this process holds already, as the peaks
    the estimate is fitted to include the runtime and the scan). Refuses (:class:`FactorMemoryError`) a scan
    whose own share (:func:`estimate_approx_bytes` at no vertex) does not fit, before any work."""
    if max_bytes == "available":
        free = available_memory()
        limit = None if free is None else free + resident_memory()
    else:
        limit = max_bytes
    if limit is None:
        return None
    scan = estimate_approx_bytes(n_faces, 0)
    if scan > limit:
        raise FactorMemoryError(
            f"approximating a scan of {n_faces:,} faces needs about {format_bytes(scan)} (about "
            f"{format_bytes(APPROX_BYTES_PER_FACE)} a face) before any coarse vertex, but only {format_bytes(limit)} "
            "of memory are available: decimate or split the scan first", estimate=scan, available=limit)
    return int((limit - scan) // APPROX_BYTES_PER_VERTEX)


def estimate_fit_bytes(n_faces: int) -> int:
    """Bytes an interpolating fit of ``n_faces`` faces needs at its peak (:data:`FIT_BYTES_PER_FACE`)."""
    return int(FIT_BASE_BYTES + FIT_BYTES_PER_FACE * n_faces)


#: The way out of a fit too large for the memory, as :func:`refuse_above` says it by default.
APPROXIMATE_INSTEAD = ("approximate it with fewer patches: trispline fit --tolerance TOL (approximation mode), or fit a "
                       "smaller mesh")


def check_fit_memory(n_faces: int, max_bytes: int | str | None = "available", *, advice: str = APPROXIMATE_INSTEAD
                     ) -> None:
    """Refuse (:class:`FactorMemoryError`) an interpolating fit of ``n_faces`` faces whose peak
    (:func:`estimate_fit_bytes`) exceeds ``max_bytes`` (as :func:`trispline.fit.solve.check_memory`), before any work: a
    1M-face scan needs ~24 GB, and its parameterization alone can take minutes. ``advice``: the way out."""
    refuse_above(estimate_fit_bytes(n_faces), available_memory() if max_bytes == "available" else max_bytes,
                 f"an interpolating fit of {n_faces:,} faces", f" (about {format_bytes(FIT_BYTES_PER_FACE)} a face)",
                 advice)


def refuse_above(estimate: int, limit: int | None, what: str, why: str = "", advice: str = APPROXIMATE_INSTEAD) -> None:
    """:class:`FactorMemoryError` when ``estimate`` bytes exceed ``limit`` (None: no limit known), naming
    ``what`` needs them (``why``: how they were estimated) and the way out (``advice``: by default the
    approximation's fewer patches)."""
    if limit is None or estimate <= limit:
        return
    raise FactorMemoryError(
        f"{what} needs about {format_bytes(estimate)}{why}, but only {format_bytes(limit)} of memory are available; "
        f"{advice}", estimate=estimate, available=limit)
