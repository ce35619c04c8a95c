"""The arguments every generated scan takes, checked once: how many triangles, how much noise.

    n_faces = scan_arguments(n_faces, noise, least=60)    # int, or ValueError naming the argument
"""
from __future__ import annotations

import numpy as np

__all__ = ["scan_arguments"]


def scan_arguments(n_faces: int, noise: float, least: int) -> int:
    """``int(n_faces)`` if it is at least ``least`` and ``noise`` is finite and >= 0; else a ValueError."""
    n_faces = int(n_faces)
    if n_faces < least:
        raise ValueError(f"n_faces must be >= {least}, got {n_faces}")
    if not (np.isfinite(noise) and noise >= 0):
        raise ValueError(f"noise must be finite and >= 0, got {noise}")
    return n_faces
