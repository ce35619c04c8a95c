"""Double-double arrays: about 106 bits of precision from pairs of float64, vectorised.

A value is the unevaluated sum ``hi + lo`` with ``|lo| <= ulp(hi) / 2`` (so ``hi`` is
the value rounded to double). The arithmetic is built from the error-free
transformations ``two_sum`` (Knuth) and ``two_prod`` (Dekker's split: numpy has no
fused multiply-add); each operation has a relative error of a few ``2**-104``
(Hida, Li and Bailey, "Library for double-double and quad-double arithmetic").
Numbers must stay below ``2**996`` in magnitude (the split's headroom).

Why: the propagation's near-singular vertex systems cancel O(1) coefficients down
to O(eps); in double their rows are off by ``1e-16 / eps`` relative, in
double-double by ``1e-32 / eps`` (``trispline.spline.propagation.elimination``).

:class:`DD` supports ``+ - * /`` (with DD, arrays or scalars, broadcast as numpy
does), unary minus, ``abs()``, indexing and indexed assignment, and the in-place
operators (which write into the array). The module functions :func:`stack`,
:func:`where`, :func:`rows` and :func:`magnitude` take DD or plain arrays alike, so
one formula serves both precisions.
"""
from __future__ import annotations

from typing import Sequence, Union

import numpy as np

from . import gather as _gather

#: Dekker's splitter ``2**27 + 1``: ``a = hi + lo`` with both halves on 26 bits.
_SPLITTER = 134217729.0


def two_sum(a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``s + e = a + b`` exactly, ``s = fl(a + b)`` (any magnitudes)."""
    s = a + b
    bb = s - a
    return s, (a - (s - bb)) + (b - bb)


def _quick_two_sum(a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``s + e = a + b`` exactly for ``|a| >= |b|`` (or ``a == 0``)."""
    s = a + b
    return s, b - (s - a)


def _split(a: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``a = hi + lo`` exactly, each half with at most 26 significant bits."""
    t = _SPLITTER * a
    hi = t - (t - a)
    return hi, a - hi


def two_prod(a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``p + e = a * b`` exactly, ``p = fl(a * b)``."""
    p = a * b
    ah, al = _split(a)
    bh, bl = _split(b)
    return p, ((ah * bh - p) + ah * bl + al * bh) + al * bl


Operand = Union["DD", np.ndarray, float]


class DD:
    """An array of double-double numbers (``hi``, ``lo``: float64 arrays of one shape)."""

    __slots__ = ("hi", "lo")
    __array_ufunc__ = None  # numpy defers to DD's reflected operators (ndarray * DD -> DD.__rmul__)

    def __init__(self, hi: np.ndarray | float, lo: np.ndarray | float | None = None) -> None:
        self.hi = np.asarray(hi, dtype=np.float64)
        self.lo = np.zeros_like(self.hi) if lo is None else np.asarray(lo, dtype=np.float64)

    @classmethod
    def zeros(cls, shape: tuple[int, ...]) -> "DD":
        return cls(np.zeros(shape), np.zeros(shape))

    @property
    def shape(self) -> tuple[int, ...]:
        return self.hi.shape

    @property
    def ndim(self) -> int:
        return self.hi.ndim

    def __len__(self) -> int:
        return len(self.hi)

    def __repr__(self) -> str:
        return f"DD(hi={self.hi!r}, lo={self.lo!r})"

    def copy(self) -> "DD":
        return DD(self.hi.copy(), self.lo.copy())

    def reshape(self, *shape) -> "DD":
        return DD(self.hi.reshape(*shape), self.lo.reshape(*shape))

    # ------------------------------------------------------------ indexing
    def __getitem__(self, key) -> "DD":
        return DD(self.hi[key], self.lo[key])

    def __setitem__(self, key, value: Operand) -> None:
        if isinstance(value, DD):
            self.hi[key] = value.hi
            self.lo[key] = value.lo
        else:
            self.hi[key] = value
            self.lo[key] = 0.0

    # ---------------------------------------------------------- arithmetic
    def __neg__(self) -> "DD":
        return DD(-self.hi, -self.lo)

    def __abs__(self) -> "DD":
        sign = np.where(self.hi < 0, -1.0, 1.0)
        return DD(sign * self.hi, sign * self.lo)

    def __add__(self, other: Operand) -> "DD":
        b = _as_dd(other)
        s, e = two_sum(self.hi, b.hi)
        t, f = two_sum(self.lo, b.lo)
        s, e = _quick_two_sum(s, e + t)
        return DD(*_quick_two_sum(s, e + f))

    __radd__ = __add__

    def __sub__(self, other: Operand) -> "DD":
        return self + (-_as_dd(other))

    def __rsub__(self, other: Operand) -> "DD":
        return _as_dd(other) + (-self)

    def __mul__(self, other: Operand) -> "DD":
        b = _as_dd(other)
        p, e = two_prod(self.hi, b.hi)
        return DD(*_quick_two_sum(p, e + (self.hi * b.lo + self.lo * b.hi)))

    __rmul__ = __mul__

    def __truediv__(self, other: Operand) -> "DD":
        b = _as_dd(other)
        q1 = self.hi / b.hi
        r = self - b * q1
        q2 = r.hi / b.hi
        r = r - b * q2
        q3 = r.hi / b.hi
        return DD(*_quick_two_sum(q1, q2)) + q3

    def __rtruediv__(self, other: Operand) -> "DD":
        return _as_dd(other) / self

    # in place: the result is written into this array (views and the caller's name see it)
    def _assign(self, value: "DD") -> "DD":
        self.hi[...] = value.hi
        self.lo[...] = value.lo
        return self

    def __iadd__(self, other: Operand) -> "DD":
        return self._assign(self + other)

    def __isub__(self, other: Operand) -> "DD":
        return self._assign(self - other)

    def __imul__(self, other: Operand) -> "DD":
        return self._assign(self * other)

    def __itruediv__(self, other: Operand) -> "DD":
        return self._assign(self / other)


def _as_dd(x: Operand) -> DD:
    return x if isinstance(x, DD) else DD(x)


def stack(arrays: Sequence[Operand], axis: int = 0) -> DD | np.ndarray:
    """``np.stack`` of plain arrays, or of DD arrays (a DD when any input is one)."""
    if not any(isinstance(a, DD) for a in arrays):
        return np.stack(arrays, axis=axis)
    dd = [_as_dd(a) for a in arrays]
    return DD(np.stack([a.hi for a in dd], axis=axis), np.stack([a.lo for a in dd], axis=axis))


def where(cond: np.ndarray, x: Operand, y: Operand) -> DD | np.ndarray:
    """``np.where`` of plain arrays, or of DD arrays (a DD when either input is one)."""
    if not isinstance(x, DD) and not isinstance(y, DD):
        return np.where(cond, x, y)
    x, y = _as_dd(x), _as_dd(y)
    return DD(np.where(cond, x.hi, y.hi), np.where(cond, x.lo, y.lo))


def rows(a: DD | np.ndarray, idx: np.ndarray) -> DD | np.ndarray:
    """``a[idx]`` along the first axis (:func:`trispline.spline.util.gather.rows`), DD or plain."""
    if isinstance(a, DD):
        return DD(_gather.rows(a.hi, idx), _gather.rows(a.lo, idx))
    return _gather.rows(a, idx)


def magnitude(a: DD | np.ndarray) -> np.ndarray:
    """``|a|`` rounded to double (a plain float64 array): for pivot searches and bounds."""
    return np.abs(a.hi if isinstance(a, DD) else a)


def to_double(a: DD | np.ndarray) -> np.ndarray:
    """The nearest double of each value (``hi`` of a normalised DD)."""
    return a.hi if isinstance(a, DD) else a
