"""Progress within a stage of the fit: the fraction of its work done, reported as chunks finish.

A long stage's work functions take a ``report(fraction)`` callable (:data:`Report`) and
call it from the calling thread as their chunks complete; :func:`span` maps a piece of
a stage onto its share of the stage, :func:`map_reporting` (from
:mod:`trispline.spline.util.parallel`) runs chunks on a thread per core and reports as they
finish. :func:`stage_reporter` turns the fit's ``progress(stage, seconds, fraction)`` callback
into the stage's ``report``.
"""
from __future__ import annotations

import inspect
import time
from typing import Any, Callable

from trispline.spline.util.parallel import map_reporting  # re-exported: the fit's stages report through it

__all__ = ["Report", "silent", "span", "map_reporting", "accepts_fraction", "stage_reporter", "counting"]

#: ``report(fraction)``: ``fraction`` in [0, 1] of the current piece of work is done.
Report = Callable[[float], None]


def silent(fraction: float) -> None:
    """A :data:`Report` that reports nothing."""


def span(report: Report | None, lo: float, hi: float) -> Report:
    """The :data:`Report` of a piece of work that is the share ``[lo, hi]`` of ``report``'s."""
    if report is None or report is silent:
        return silent
    return lambda fraction: report(lo + (hi - lo) * min(max(fraction, 0.0), 1.0))


def accepts_fraction(progress: Callable[..., Any]) -> bool:
    """Whether ``progress`` takes a third positional argument (the per-chunk form)."""
    try:
        params = inspect.signature(progress).parameters.values()
    except (TypeError, ValueError):  # pragma: no cover - builtins without a signature
        return False
    if any(p.kind is p.VAR_POSITIONAL for p in params):
        return True
    return sum(p.kind in (p.POSITIONAL_ONLY, p.POSITIONAL_OR_KEYWORD) for p in params) >= 3


def stage_reporter(progress: Callable[..., Any] | None, stage: str) -> Report:
    """The :data:`Report` of ``stage``: ``progress(stage, seconds since now, fraction)``, when
    ``progress`` takes the per-chunk form, else :func:`silent`."""
    if progress is None or not accepts_fraction(progress):
        return silent
    start = time.perf_counter()
    return lambda fraction: progress(stage, time.perf_counter() - start, fraction)


def counting(report: Report | None, parts: int) -> Callable[[], None]:
    """A callable that reports ``report(k / parts)`` on its ``k``-th call: for work that announces each of
    ``parts`` equal pieces as it ends (a compiled step's host solves), capped at 1."""
    report = report or silent
    done = [0]

    def tick() -> None:
        done[0] += 1
        report(min(done[0] / parts, 1.0))
    return tick
