"""The arguments every generated scan takes, checked once: how many triangles, how much noise.

    n_faces = scan_arguments(n_faces, noise, least=60)    # int, or ValueError naming the argument
"""
from __future__ import annotations

import numpy as np

from trispline.spline.util.memory import require_memory

__all__ = ["scan_arguments"]


#: Bytes a generated scan needs per face while it is built (points, Delaunay, faces; measured ~0.4 kB).
BYTES_PER_FACE = 600


def scan_arguments(n_faces: int, noise: float, least: int) -> int:
    """``int(n_faces)`` if it is at least ``least`` and ``noise`` is finite and >= 0; else a ValueError.

    A scan too large for the available memory is refused before it is built (ResourceError).
    """
    n_faces = int(n_faces)
    if n_faces < least:
        raise ValueError(f"n_faces must be >= {least}, got {n_faces}")
    require_memory(n_faces * BYTES_PER_FACE, f"generating a scan of {n_faces} faces", "ask for fewer faces")
    if not (np.isfinite(noise) and noise >= 0):
        raise ValueError(f"noise must be finite and >= 0, got {noise}")
    return n_faces
