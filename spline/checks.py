"""Validation of array arguments at public entry points: one message style everywhere.

    uv = as_array(uv, "uv", (None, 2))                  # float64, shape (n, 2)
    faces = as_array(faces, "faces", (None, 3), integer=True, min_rows=1)

Every failure raises :class:`~trispline.spline.errors.InputError` naming the argument,
the expected shape or dtype and what was given.
"""
from __future__ import annotations

from typing import Sequence

import numpy as np

from .errors import InputError, first_few


def _shape_text(shape: Sequence[int | None]) -> str:
    return "(" + ", ".join("n" if s is None else str(s) for s in shape) + ("," if len(shape) == 1 else "") + ")"


def as_array(a, name: str, shape: Sequence[int | None], *, integer: bool = False, finite: bool = False,
             min_rows: int = 0) -> np.ndarray:
    """``a`` as a float64 (or, with ``integer``, int64) array of ``shape`` (``None``: any length).

    ``finite`` also refuses NaN and infinite entries; ``min_rows`` a first axis shorter than that.
    """
    try:
        arr = np.asarray(a)
    except (TypeError, ValueError) as exc:
        raise InputError(f"{name} must be an array of shape {_shape_text(shape)}: {exc}") from None
    if arr.ndim != len(shape) or any(s is not None and s != n for s, n in zip(shape, arr.shape)):
        raise InputError(f"{name} must have shape {_shape_text(shape)}, got {arr.shape}")
    if arr.shape[0] < min_rows:
        raise InputError(f"{name} needs at least {min_rows} rows, got {arr.shape[0]}")
    if integer:
        if arr.size and not np.issubdtype(arr.dtype, np.integer):
            if np.issubdtype(arr.dtype, np.floating) and np.isfinite(arr).all() and (arr == np.round(arr)).all():
                return arr.astype(np.int64)
            raise InputError(f"{name} must hold integers, got dtype {arr.dtype}")
        return arr.astype(np.int64, copy=False)
    if arr.size and not (np.issubdtype(arr.dtype, np.floating) or np.issubdtype(arr.dtype, np.integer)):
        raise InputError(f"{name} must hold real numbers, got dtype {arr.dtype}")
    arr = arr.astype(np.float64, copy=False)
    if finite:
        bad = np.flatnonzero(~np.isfinite(arr.reshape(arr.shape[0], -1)).all(1)) if arr.ndim else []
        if len(bad):
            raise InputError(f"{name} has non-finite entries in {first_few(bad)} rows")
    return arr


def check_ids(ids: np.ndarray, name: str, n: int) -> np.ndarray:
    """Refuse ids outside ``[0, n)``; returns ``ids``."""
    bad = np.flatnonzero((ids < 0) | (ids >= n)) if ids.ndim == 1 else np.flatnonzero(((ids < 0) | (ids >= n)).any(1))
    if bad.size:
        raise InputError(f"{name} refer to ids outside [0, {n}): {first_few(bad)}")
    return ids
