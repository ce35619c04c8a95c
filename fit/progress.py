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
import threading
import time
from typing import Any, Callable

from trispline.spline.util.parallel import map_reporting  # re-exported: the fit's stages report through it
from trispline.spline.util.progress import Report, counting, silent, span  # re-exported likewise

__all__ = ["Report", "silent", "span", "map_reporting", "accepts_fraction", "stage_reporter", "counting",
           "watching", "WATCH_INTERVAL"]

#: Seconds between two looks at a long library call's progress (:func:`watching`).
WATCH_INTERVAL = 0.1


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


def watching(work: Callable[[], Any], done: Callable[[], float], report: Report | None) -> Any:
    """``work()``, run in a thread while this one reports ``done()`` (a fraction) every
    :data:`WATCH_INTERVAL` seconds: for one long library call that releases the GIL and reports nothing
    itself (PARDISO's numerical factorisation), whose progress can be read from outside it.

    The reports come from the calling thread, never decrease, and stay below 1 until ``work`` ends;
    ``work``'s exception is re-raised here. The calling thread stays responsive: an interrupt (Ctrl-C)
    ends the wait at once, leaving ``work`` to finish in its daemon thread.
    """
    if report is None or report is silent:
        return work()
    result: list[Any] = []
    error: list[BaseException] = []

    def run() -> None:
        try:
            result.append(work())
        except BaseException as exc:  # noqa: BLE001 - re-raised in the calling thread
            error.append(exc)

    thread = threading.Thread(target=run, name="trispline-watched", daemon=True)
    thread.start()
    shown = 0.0
    while True:
        thread.join(WATCH_INTERVAL)
        if not thread.is_alive():
            break
        fraction = min(max(done(), shown), 0.99)
        if fraction > shown:
            shown = fraction
            report(fraction)
    if error:
        raise error[0]
    return result[0]
