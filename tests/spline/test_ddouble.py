"""Double-double arithmetic (spline/util/ddouble.py) against exact rational arithmetic."""
from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest

from trispline.spline.topology import triangle_areas
from trispline.spline.util import ddouble
from trispline.spline.util.ddouble import DD, two_prod, two_sum

N = 300


def exact(x: DD, i: int) -> Fraction:
    return Fraction(float(x.hi[i])) + Fraction(float(x.lo[i]))


def random_dd(rng: np.random.Generator) -> DD:
    hi = rng.normal(size=N) * 10.0 ** rng.integers(-6, 6, N)
    return DD(hi) + DD(hi * rng.uniform(-1, 1, N) * 2.0**-53)


def test_error_free_transformations_are_exact():
    rng = np.random.default_rng(0)
    a, b = rng.normal(size=N) * 1e3, rng.normal(size=N) * 1e-5
    for (s, e), op in ((two_sum(a, b), lambda x, y: x + y), (two_prod(a, b), lambda x, y: x * y)):
        for i in range(N):
            assert Fraction(float(s[i])) + Fraction(float(e[i])) == op(Fraction(float(a[i])), Fraction(float(b[i])))


@pytest.mark.parametrize("op", ["add", "sub", "mul", "div"])
def test_operations_round_to_about_2_to_the_minus_104(op):
    rng = np.random.default_rng(1)
    a, b = random_dd(rng), random_dd(rng)
    fn = {"add": lambda x, y: x + y, "sub": lambda x, y: x - y, "mul": lambda x, y: x * y,
          "div": lambda x, y: x / y}[op]
    r = fn(a, b)
    for i in range(N):
        want = fn(exact(a, i), exact(b, i))
        assert abs(exact(r, i) - want) <= 2.0**-102 * abs(want)
        assert abs(r.lo[i]) <= 0.5 * np.spacing(abs(r.hi[i]))  # normalised: hi is the value in double


def test_in_place_operators_write_into_the_array_and_mixed_operands_broadcast():
    a = DD(np.arange(6.0).reshape(2, 3))
    view = a
    a -= np.array([1.0, 2.0, 3.0])  # broadcast over rows
    assert view is a and np.array_equal(a.hi, [[-1, -1, -1], [2, 2, 2]])
    a[0, 1] = DD(0.5, 2.0**-60)
    b = 2.0 * a[:, 1]  # a plain scalar on the left
    assert np.array_equal(b.hi, [1.0, 4.0]) and b.lo[0] == 2.0**-59
    assert isinstance(np.ones(2) * a[:, 1], DD)  # numpy defers to DD


def test_helpers_take_plain_and_dd_arrays():
    x = np.array([1.0, -2.0])
    assert np.array_equal(ddouble.stack([x, x]), np.stack([x, x]))
    assert isinstance(ddouble.stack([x, DD(x)]), DD)
    assert np.array_equal(ddouble.where(x > 0, x, 0.0), [1.0, 0.0])
    assert np.array_equal(ddouble.where(x > 0, DD(x), 0.0).hi, [1.0, 0.0])
    assert np.array_equal(ddouble.magnitude(DD(x)), [1.0, 2.0])
    assert np.array_equal(ddouble.rows(DD(np.eye(3)), np.array([2, 0])).hi, np.eye(3)[[2, 0]])
    assert np.array_equal(abs(DD(x)).hi, [1.0, 2.0])


def test_near_collinear_areas_keep_their_digits():
    """The cancellation that breaks the double propagation: areas of nearly collinear triples."""
    rng = np.random.default_rng(2)
    p, q = rng.uniform(0, 1, (N, 2)), rng.uniform(0, 1, (N, 2))
    s = p + rng.uniform(0, 1, N)[:, None] * (q - p) + 1e-13 * rng.normal(size=(N, 2))
    dd, dbl = triangle_areas(DD(p), DD(q), DD(s)), triangle_areas(p, q, s)
    worst_dd = worst_double = 0.0
    for i in range(N):
        P, Q, S = ([Fraction(float(v)) for v in w[i]] for w in (p, q, s))
        want = ((Q[0] - P[0]) * (S[1] - P[1]) - (Q[1] - P[1]) * (S[0] - P[0])) / 2
        worst_dd = max(worst_dd, float(abs(exact(dd, i) - want) / abs(want)))
        worst_double = max(worst_double, float(abs(Fraction(float(dbl[i])) - want) / abs(want)))
    assert worst_dd < 1e-16 < 1e-5 < worst_double
