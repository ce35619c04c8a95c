"""Progress within a stage of the fit: the fraction of its work done, reported as chunks finish.

A long stage's work functions take a ``report(fraction)`` callable (:data:`Report`) and
call it from the calling thread as their chunks complete; :func:`span` maps a piece of
a stage onto its share of the stage, :func:`map_reporting` runs chunks on a thread per
core in batches and reports after each batch. :func:`stage_reporter` turns the fit's
``progress(stage, seconds, fraction)`` callback into the stage's ``report``.
"""
from __future__ import annotations

import inspect
import time
from typing import Any, Callable

from trispline.spline.util.parallel import Workers, ranges

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


def map_reporting(work: Workers, fn: Callable[[int, int], Any], n: int, chunk: int,
                  report: Report | None = None) -> list[Any]:
    """``work.map(fn, n, chunk)``, ``report(done / n)`` as the ranges finish in order.

    Every range is queued at once, so a thread never waits for the other's last range of a batch
    (waiting for batches of two ranges per thread left ~1.3 core-seconds idle in a 100k-face fit's
    assembly); the pool runs a range per thread at a time, so no more temporaries are alive."""
    report = report or silent
    parts = ranges(n, chunk)
    out: list[Any] = []
    for (_, hi), job in zip(parts, work.start(fn, n, chunk)):
        out.append(job.result())
        report(hi / max(n, 1))
    return out


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
