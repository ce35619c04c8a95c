"""Progress of one piece of work: ``report(fraction)`` callables, and the share of a bigger piece.

The layers below the fit (the parameterization, the spline core) report through these; the fit's
stages build on them (:mod:`trispline.fit.progress`).
"""
from __future__ import annotations

from typing import Callable

__all__ = ["Report", "silent", "span", "counting"]

#: ``report(fraction)``: ``fraction`` in [0, 1] of the current piece of work is done.
Report = Callable[[float], None]


def silent(fraction: float) -> None:
    """A :data:`Report` that reports nothing."""


def span(report: Report | None, lo: float, hi: float) -> Report:
    """The :data:`Report` of a piece of work that is the share ``[lo, hi]`` of ``report``'s."""
    if report is None or report is silent:
        return silent
    return lambda fraction: report(lo + (hi - lo) * min(max(fraction, 0.0), 1.0))


def counting(report: Report | None, parts: int) -> Callable[[], None]:
    """A callable that reports ``report(k / parts)`` on its ``k``-th call: for work that announces each of
    ``parts`` equal pieces as it ends (a compiled step's host solves, the steps of writing ``M``), capped at 1."""
    report = report or silent
    done = [0]

    def tick() -> None:
        done[0] += 1
        report(min(done[0] / parts, 1.0))
    return tick
