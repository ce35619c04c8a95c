"""Validation of array arguments at public entry points: one message style everywhere.

    uv = as_array(uv, "uv", ("V", 2))                   # float64, shape (V, 2), any V
    faces = as_array(faces, "faces", ("F", 3), integer=True, min_rows=1)
    check_ids(faces, "faces", uv.shape[0])              # every id in [0, V)

Every failure raises :class:`~trispline.spline.errors.InputError` (or the subclass
passed as ``error``) naming the argument, the expected shape or dtype and what was given.
"""
from __future__ import annotations

from typing import Sequence, Union

import numpy as np

from .errors import InputError, first_few


#: One axis of an expected shape: a length, ``None`` (any length, shown as ``n``) or a
#: name for any length (``"V"``, shown as it is).
Axis = Union[int, str, None]


def _shape_text(shape: Sequence[Axis]) -> str:
    return "(" + ", ".join("n" if s is None else str(s) for s in shape) + ("," if len(shape) == 1 else "") + ")"


def as_array(a, name: str, shape: Sequence[Axis], *, integer: bool = False, whole_floats: bool = True,
             finite: bool = False, min_rows: int = 0, error: type[InputError] = InputError) -> np.ndarray:
    """``a`` as a float64 (or, with ``integer``, int64) array of ``shape`` (see :data:`Axis`).

    With ``integer``, floats with whole values are converted unless ``whole_floats`` is false
    (then only an integer dtype passes). ``finite`` also refuses NaN and infinite entries;
    ``min_rows`` a first axis shorter than that. Failures raise ``error``.
    """
    try:
        arr = np.asarray(a)
    except (TypeError, ValueError) as exc:
        raise error(f"{name} must be an array of shape {_shape_text(shape)}: {exc}") from None
    if arr.ndim != len(shape) or any(s is not None and not isinstance(s, str) and s != n
                                       for s, n in zip(shape, arr.shape)):
        raise error(f"{name} must have shape {_shape_text(shape)}, got {arr.shape}")
    if arr.ndim and arr.shape[0] < min_rows:
        rows = f"{min_rows} row" + ("s" if min_rows != 1 else "")
        raise error(f"{name} must have shape {_shape_text(shape)} with at least {rows}, got {arr.shape}")
    kind = arr.dtype.kind  # "i", "u" integers, "f" floats (a dtype kind test: ~10x cheaper than issubdtype)
    if integer:
        if arr.size and kind not in "iu":
            if whole_floats and kind == "f" and np.isfinite(arr).all() and (arr == np.round(arr)).all():
                return arr.astype(np.int64)
            raise error(f"{name} must hold integers, got dtype {arr.dtype}")
        return arr.astype(np.int64, copy=False)
    if arr.size and kind not in "iuf":
        raise error(f"{name} must hold real numbers, got dtype {arr.dtype}")
    arr = arr.astype(np.float64, copy=False)
    if finite and not np.isfinite(arr).all():
        bad = np.flatnonzero(~np.isfinite(arr.reshape(arr.shape[0], -1)).all(1)) if arr.ndim else [0]
        raise error(f"{name} has non-finite entries in {first_few(bad)} rows")
    return arr


def check_ids(ids: np.ndarray, name: str, n: int, *, error: type[InputError] = InputError) -> np.ndarray:
    """Refuse ids outside ``[0, n)`` in ``ids: (k,)`` or ``(k, m)`` (rows named); returns ``ids``."""
    if ids.size == 0 or (ids.min() >= 0 and ids.max() < n):  # the usual case: two reductions, no masks
        return ids
    bad = np.flatnonzero((ids < 0) | (ids >= n)) if ids.ndim == 1 else np.flatnonzero(((ids < 0) | (ids >= n)).any(1))
    if bad.size:
        raise error(f"{name} refer to ids outside [0, {n}): {first_few(bad)}")
    return ids
