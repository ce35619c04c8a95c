"""Validation of array arguments at public entry points: one message style everywhere.

    uv = as_array(uv, "uv", ("V", 2))                   # float64, shape (V, 2), any V
    faces = as_array(faces, "faces", ("F", 3), integer=True, min_rows=1)
    check_ids(faces, "faces", uv.shape[0])              # every id in [0, V)
    k = whole_number(resolution, "resolution", least=1)  # scalars too: real_number, flag, callback

Every failure raises :class:`~trispline.spline.errors.InputError` (or the subclass
passed as ``error``) naming the argument, the expected shape or dtype and what was given.
"""
from __future__ import annotations

from typing import Any, Sequence, Union

import numpy as np

from .errors import InputError, first_few
from .tolerances import MAX_MAGNITUDE


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
    out = (ids < 0) | (ids >= n)
    bad = np.flatnonzero(out) if ids.ndim == 1 else np.flatnonzero(out.any(1))
    if bad.size:
        values = ids[out][:5]
        raise error(f"{name} refer to ids outside [0, {n}): {', '.join(str(int(v)) for v in values)}"
                    f"{', ...' if out.sum() > values.size else ''} (row{'s' if bad.size > 1 else ''} "
                    f"{', '.join(str(int(r)) for r in bad[:5])}{', ...' if bad.size > 5 else ''})")
    return ids


def real_number(v: Any, name: str, *, least: float | None = None, positive: bool = False,
                error: type[InputError] = InputError) -> float:
    """``v`` as a finite float: a real scalar (not a bool, a string, a complex or an array), at least ``least``
    and, with ``positive``, above 0."""
    if isinstance(v, (bool, np.bool_)) or not isinstance(v, (int, float, np.integer, np.floating)):
        raise error(f"{name} must be a real number, got {v!r}")
    x = float(v)
    if not np.isfinite(x) or (least is not None and x < least) or (positive and x <= 0):
        bound = " and > 0" if positive else f" and >= {least:g}" if least is not None else ""
        raise error(f"{name} must be finite{bound}, got {x!r}")
    return x


def whole_number(v: Any, name: str, *, least: int | None = None, most: int | None = None,
                 error: type[InputError] = InputError) -> int:
    """``v`` as an int: an integer scalar or a float with a whole value (not a bool or a string), within
    ``[least, most]``."""
    span = ("" if least is None and most is None else f" >= {least}" if most is None
            else f" <= {most}" if least is None else f" in [{least}, {most}]")
    if isinstance(v, (bool, np.bool_)) or not isinstance(v, (int, float, np.integer, np.floating)) \
            or (isinstance(v, (float, np.floating)) and (not np.isfinite(v) or int(v) != v)):
        raise error(f"{name} must be an integer{span}, got {v!r}")
    k = int(v)
    if (least is not None and k < least) or (most is not None and k > most):
        raise error(f"{name} must be an integer{span}, got {v!r}")
    return k


def flag(v: Any, name: str, *, error: type[InputError] = InputError) -> bool:
    """``v`` as a bool: only True or False (a string such as ``"no"`` would read as true)."""
    if not isinstance(v, (bool, np.bool_)):
        raise error(f"{name} must be True or False, got {v!r}")
    return bool(v)


def callback(v: Any, name: str, *, error: type[InputError] = InputError) -> Any:
    """``v`` if it is None or callable."""
    if v is not None and not callable(v):
        raise error(f"{name} must be a function or None, got {type(v).__name__}")
    return v


#: Barycentric coordinates whose sum is further from 1 than this (relative to their size) are refused: the
#: patch's Bernstein basis is homogeneous of degree 5, so coordinates summing to 1.5 gave points 1.5^5 times
#: too far from the origin without a word.
BARY_SUM_TOL = 1e-8


def check_bary(bary: np.ndarray, name: str, *, error: type[InputError] = InputError) -> np.ndarray:
    """Refuse rows of ``bary (n, 3)`` (finite floats) that do not sum to 1; returns ``bary``."""
    off = np.abs(bary.sum(1) - 1.0) > BARY_SUM_TOL * np.maximum(1.0, np.abs(bary).max(1, initial=0.0))
    if off.any():
        k = int(np.argmax(off))
        raise error(f"{name} rows must sum to 1 (barycentric coordinates): {int(off.sum())} do not, row {k} "
                    f"sums to {bary[k].sum():.6g}")
    return bary


def check_magnitude(arr: np.ndarray, name: str, *, hint: str = "", error: type[InputError] = InputError) -> np.ndarray:
    """Refuse entries of ``arr`` beyond :data:`~trispline.spline.tolerances.MAX_MAGNITUDE` (their squares overflow
    double precision); ``hint``: what to do, appended. Returns ``arr``."""
    big = float(np.abs(arr).max()) if arr.size else 0.0
    if big > MAX_MAGNITUDE:
        raise error(f"{name} reach {big:.3g}: beyond {MAX_MAGNITUDE:g} their squares overflow double precision{hint}")
    return arr
