"""Plumbing shared by every ``trispline`` subcommand: output, progress, option types, paths, errors.

A subcommand module registers itself with ``add_parser(subparsers)`` (setting
``func(args, ui) -> exit code``) and uses :class:`UI` for everything it prints;
:func:`run_cli` parses, runs and turns exceptions into one-line messages and exit codes.
Nothing here imports JAX.
"""
from __future__ import annotations

import argparse
import contextlib
import json
import os
import sys
import threading
import traceback
import warnings
from pathlib import Path
from typing import Any, Callable, Iterator, NoReturn, Sequence

import numpy as np

from trispline.spline.errors import InputError
from trispline.spline.util import atomic

from ..errors import CommandFailed, ResultRejected, UsageError

__all__ = [
    "PROG", "EXIT_OK", "EXIT_FAILURE", "EXIT_INPUT", "EXIT_CHECK", "EXIT_INTERRUPTED", "EXIT_TERMINATED",
    "Parser", "UI", "Stages", "one_line", "fmt", "positive_int", "nonneg_float", "positive_float",
    "finite_float", "add_common", "check_output", "distinct", "load_surface", "version", "run_cli", "leave",
    "prefetch",
]

PROG = "trispline"
EXIT_OK = 0
EXIT_FAILURE = 1
EXIT_INPUT = 2
EXIT_CHECK = 3
EXIT_INTERRUPTED = 130
EXIT_TERMINATED = 128 + 15
#: stdout closed by its reader (SIGPIPE's conventional status).
EXIT_BROKEN_PIPE = 128 + 13


class Parser(argparse.ArgumentParser):
    """An argument parser whose errors raise :class:`UsageError` (exit 2, one line) instead of exiting."""

    def error(self, message: str) -> None:  # type: ignore[override]
        raise UsageError(f"{message} (see '{self.prog} --help')")

    def parse_args(self, args=None, namespace=None) -> argparse.Namespace:  # type: ignore[override]
        """argparse's, but a lone unexpected file name where the command's ``-o`` was left out says that the
        output goes after ``-o`` (``trispline export s.npz s.step`` is a natural first try)."""
        parsed, extras = self.parse_known_args(args, namespace)
        if extras:
            hint = ""
            if len(extras) == 1 and Path(extras[0]).suffix and getattr(parsed, "output", "") is None:
                hint = f"; an output is named with -o: -o {extras[0]}"
            self.error(f"unrecognized arguments: {' '.join(extras)}{hint}")
        return parsed


# ============================================================================ output
class UI:
    """Where things go: results on stdout, progress / warnings / errors on stderr."""

    def __init__(self, args: argparse.Namespace) -> None:
        self.json = bool(getattr(args, "json", False))
        self.quiet = bool(getattr(args, "quiet", False))
        self.warnings: list[str] = []

    def warn(self, message: str) -> None:
        """A warning on stderr, once per distinct message; also listed in the JSON result."""
        message = one_line(message)
        if message not in self.warnings:
            self.warnings.append(message)
            print(f"{PROG}: warning: {message}", file=sys.stderr, flush=True)

    def result(self, data: dict, text: Callable[[dict], str]) -> None:
        """The command's result: JSON or text on stdout (text silenced by --quiet)."""
        if self.json:
            data = dict(data, warnings=list(self.warnings))
            print(json.dumps(_jsonable(data), indent=2, allow_nan=False))
        elif not self.quiet:
            print(text(data))

    def stages(self, names: Sequence[str], title: str) -> "Stages":
        """A progress bar over ``names`` (silenced by --quiet)."""
        return Stages(names, title, disable=self.quiet)


class Interrupts:
    """Ctrl-C that cannot be lost: while a command runs, SIGINT raises ``KeyboardInterrupt`` as Python's own
    handler does, and is remembered. Raised where Python swallows exceptions -- a garbage-collector
    callback (JAX's ``_xla_gc_callback``: "Exception ignored in ..."), a ``__del__`` -- it is raised again at
    the next progress report in the main thread (:meth:`check`) or when the command returns; the swallowed
    one prints nothing. Measured before: a SIGINT landing in JAX's start-up under load let the fit finish
    (exit 0, a traceback on stderr) in 4 of 8 tries. Inside :meth:`held` (the progress bar's own updates) it
    is only remembered, and raised when the block ends: raised inside tqdm, between its lock's acquisitions,
    it left the lock held, and the bar's ticker thread waited for it for ever (the command hung at exit)."""

    pending = False
    holding = 0

    @classmethod
    def handler(cls, signum: int, frame: object) -> None:
        cls.pending = True
        if cls.holding and threading.current_thread() is threading.main_thread():
            return
        raise KeyboardInterrupt

    @classmethod
    @contextlib.contextmanager
    def held(cls) -> Iterator[None]:
        """A block of the main thread that an interrupt must not cut (it is raised when the block ends)."""
        if threading.current_thread() is not threading.main_thread():
            yield
            return
        cls.holding += 1
        try:
            yield
        finally:
            cls.holding -= 1
        cls.check()

    @classmethod
    def check(cls) -> None:
        """Raise the remembered interrupt (main thread only; other threads report too)."""
        if cls.pending and threading.current_thread() is threading.main_thread():
            raise KeyboardInterrupt

    @classmethod
    def install(cls) -> Callable[[], None]:
        """Take SIGINT (unless the program handles it itself or not in the main thread) and silence the
        swallowed interrupts' report; returns the undo."""
        import signal

        cls.pending = False
        if (threading.current_thread() is not threading.main_thread()
                or signal.getsignal(signal.SIGINT) is not signal.default_int_handler):
            return lambda: None
        previous_hook = sys.unraisablehook

        def hook(unraisable: Any) -> None:  # raised again at the next check, or before any output is committed
            if not isinstance(unraisable.exc_value, (KeyboardInterrupt, atomic.Terminated)):
                previous_hook(unraisable)

        signal.signal(signal.SIGINT, cls.handler)
        sys.unraisablehook = hook
        undo_check = atomic.add_commit_check(cls.check)

        def undo() -> None:
            signal.signal(signal.SIGINT, signal.default_int_handler)
            sys.unraisablehook = previous_hook
            undo_check()

        return undo


class Stages:
    """A tqdm bar over named stages on stderr; appears only for work taking over ~1 s.

    Each stage is :data:`UNITS` steps of the bar: :meth:`done` completes the current (or the
    named) stage, :meth:`at` moves within a stage as its chunks of work finish, so a long
    stage shows live progress. The elapsed time ticks on every :data:`TICK` seconds also through
    work that reports nothing until it ends (PARDISO's numerical factorisation, a compiled step).
    """

    #: Bar steps per stage.
    UNITS = 100
    #: Seconds between redraws of the elapsed time.
    TICK = 0.5

    def __init__(self, names: Sequence[str], title: str, disable: bool) -> None:
        from tqdm import tqdm

        self.names = list(names)
        self.title = title
        self.i = 0  # the current stage
        self.position = 0  # bar steps done
        self.bar = tqdm(total=len(self.names) * self.UNITS, desc=self._desc(), file=sys.stderr, disable=disable,
                        delay=1.0, leave=False, bar_format="{desc} {bar:20} {percentage:3.0f}% [{elapsed}]")
        self._stop = threading.Event()
        self._shown = False  # drawn by the ticker (tqdm's own draws it knows of)
        self._ticker = None if disable else threading.Thread(target=self._tick, name="trispline-bar", daemon=True)
        if self._ticker is not None:
            self._ticker.start()

    def _tick(self) -> None:
        """Redraw the bar (its elapsed time) every :data:`TICK` seconds once it is due to show."""
        bar = self.bar
        while not self._stop.wait(self.TICK):
            if bar._time() - bar.start_t >= bar.delay:
                bar.refresh()
                self._shown = True

    def _desc(self) -> str:
        name = self.names[self.i] if self.i < len(self.names) else "done"
        return f"{self.title}: {name}"

    def _move(self, position: int) -> None:
        Interrupts.check()
        if position > self.position:
            with Interrupts.held():
                self.bar.set_description_str(self._desc(), refresh=False)
                self.bar.update(position - self.position)
                self.position = position

    def done(self, name: str | None = None) -> None:
        """Mark the current (or the named) stage finished."""
        if name is not None and name in self.names:
            self.i = max(self.i, self.names.index(name) + 1)
        else:
            self.i += 1
        self._move(self.i * self.UNITS)

    def at(self, name: str, fraction: float) -> None:
        """Stage ``name`` is ``fraction`` (0..1) done (earlier stages count as finished)."""
        if name not in self.names:
            return
        self.i = max(self.i, self.names.index(name))
        self._move(int(self.names.index(name) * self.UNITS + min(max(fraction, 0.0), 1.0) * (self.UNITS - 1)))

    def close(self) -> None:
        self._stop.set()
        with Interrupts.held():
            if self._ticker is not None:
                self._ticker.join(self.TICK + 1.0)  # bounded: a daemon thread, never a reason to hang
            if self._shown:  # tqdm clears only a bar its own updates drew: else an interrupt's line ends the bar's
                self.bar.last_print_t = max(self.bar.last_print_t, self.bar.start_t + self.bar.delay)
            self.bar.close()

    def __enter__(self) -> "Stages":
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def one_line(message: str) -> str:
    """Collapse a multi-line message ("problems:\\n  - a\\n  - b") into one line."""
    lines = [ln.strip() for ln in str(message).splitlines() if ln.strip()]
    if not lines:
        return "(no message)"
    rest = [ln[2:] if ln.startswith("- ") else ln for ln in lines[1:]]
    return " ".join([lines[0], "; ".join(rest)]) if rest else lines[0]


def _jsonable(value: Any) -> Any:
    if isinstance(value, dict):
        return {str(k): _jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_jsonable(v) for v in value]
    if isinstance(value, np.ndarray):
        return _jsonable(value.tolist())
    if isinstance(value, np.generic):
        return _jsonable(value.item())
    if isinstance(value, Path):
        return str(value)
    if isinstance(value, float) and not np.isfinite(value):
        return None
    return value


def fmt(x: Any) -> str:
    """A float to 3 significant digits, anything else as ``str``."""
    return f"{x:.3g}" if isinstance(x, float) else str(x)


# ============================================================================ options
def _number(text: str) -> float:
    try:
        return float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None


def stored_deviation(extras: dict) -> dict[str, float] | None:
    """An approximation's stored deviation statistics by name (the surface file's ``approx_deviation_names`` and
    ``approx_deviation``: :func:`trispline.fit.approx.pipeline.surface_extras`), or None without them."""
    if "approx_deviation_names" not in extras or "approx_deviation" not in extras:
        return None
    names = [str(s) for s in np.atleast_1d(extras["approx_deviation_names"])]
    return dict(zip(names, [float(v) for v in np.atleast_1d(extras["approx_deviation"])]))


def _integer(text: str, least: int, what: str) -> int:
    """argparse type: an integer >= ``least`` (``what`` names it in the message)."""
    try:
        v = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected {what}, got {text!r}") from None
    if v < least:
        raise argparse.ArgumentTypeError(f"expected {what}, got {v}")
    return v


def nonnegative_int(text: str) -> int:
    """argparse type: an integer >= 0."""
    return _integer(text, 0, "an integer >= 0")


def positive_int(text: str) -> int:
    """argparse type: an integer >= 1."""
    return _integer(text, 1, "a positive integer")


def int_at_least(least: int) -> Callable[[str], int]:
    """argparse type: an integer >= ``least``."""
    return lambda text: _integer(text, least, f"an integer >= {least}")


def nonneg_float(text: str) -> float:
    """argparse type: a finite number >= 0."""
    v = _number(text)
    if not (np.isfinite(v) and v >= 0):
        raise argparse.ArgumentTypeError(f"expected a finite number >= 0, got {text}")
    return v


def positive_float(text: str) -> float:
    """argparse type: a finite number > 0."""
    v = _number(text)
    if not (np.isfinite(v) and v > 0):
        raise argparse.ArgumentTypeError(f"expected a finite number > 0, got {text}")
    return v


def finite_float(text: str) -> float:
    """argparse type: any finite number."""
    v = _number(text)
    if not np.isfinite(v):
        raise argparse.ArgumentTypeError(f"expected a finite number, got {text}")
    return v


def add_common(p: argparse.ArgumentParser) -> None:
    """The options every subcommand takes: --json, --quiet, --debug."""
    g = p.add_argument_group("output control")
    g.add_argument("--json", action="store_true", help="print the result as JSON on stdout (nothing else there)")
    g.add_argument("-q", "--quiet", action="store_true", help="no progress bars and no summary")
    g.add_argument("--debug", action="store_true", default=argparse.SUPPRESS,
                   help="show the full traceback of internal failures")


# ============================================================================ files
def check_output(path: str | None, formats: tuple[str, ...], what: str,
                 inputs: Sequence[str | os.PathLike | None] = ()) -> Path | None:
    """Validate an output path before any work: a known suffix, then
    :func:`~trispline.spline.util.atomic.check_writable` (the one home of the output-path
    checks: existing writable folder, not a folder, a name the file system allows), and not
    one of ``inputs`` (an output is never written onto the file it is made from)."""
    if path is None:
        return None
    from trispline.spline.util.atomic import check_writable, same_file

    from ..io.formats import check_export_path

    check_export_path(path, formats)
    p = check_writable(path, what)
    for source in inputs:
        if source is not None and same_file(p, source):
            raise UsageError(f"cannot write {what} {p}: it is the input {source}; choose another name")
    return p


def distinct(paths: Sequence[Path | None]) -> None:
    """Refuse one file named as two outputs."""
    seen: dict[Path, Path] = {}
    for p in paths:
        if p is None:
            continue
        key = p.resolve()
        if key in seen:
            raise UsageError(f"{p} is named as two different outputs")
        seen[key] = p


def load_surface(path: str) -> Any:
    """The :class:`~trispline.spline.surface.SplineSurface` in ``path`` (SurfaceFileError if unreadable)."""
    from trispline.spline.surface import SplineSurface

    return SplineSurface.load(path)


def version() -> str:
    """The installed package's version, or ``"unknown"`` in a bare source checkout
    (:func:`trispline.fit.render.caption.package_version`, the one home of it)."""
    from ..render.caption import package_version

    return package_version()


# ============================================================================ running
def run_cli(make_parser: Callable[[], argparse.ArgumentParser], argv: Sequence[str] | None = None) -> int:
    """Parse ``argv`` with ``make_parser()`` and run the chosen command with the CLI's
    error handling: one-line messages, exit 2 for bad input, 1 for internal failures."""
    argv = list(sys.argv[1:] if argv is None else argv)
    debug = "--debug" in argv
    ui = UI(argparse.Namespace())
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("always", UserWarning)
            shown = warnings.showwarning

            def show(message, category, filename, lineno, file=None, line=None):
                if issubclass(category, UserWarning):
                    ui.warn(str(message))
                elif issubclass(category, RuntimeWarning) and not debug:
                    pass  # floating-point noise (an overflow in a discarded branch): nothing a user can act on
                else:  # pragma: no cover - third-party warnings keep their usual form
                    shown(message, category, filename, lineno, file, line)

            warnings.showwarning = show
            undo = Interrupts.install()
            try:
                args = make_parser().parse_args(argv)
                ui.json, ui.quiet = bool(getattr(args, "json", False)), bool(getattr(args, "quiet", False))
                code = int(args.func(args, ui))
                if Interrupts.pending:  # swallowed where nothing reported since: the outputs are whole or absent
                    raise KeyboardInterrupt
                return code
            finally:
                warnings.showwarning = shown
                undo()
    except atomic.Terminated as exc:  # SIGTERM while outputs were open: their temporaries are gone
        print(f"{PROG}: terminated", file=sys.stderr)
        return int(exc.code)
    except SystemExit as exc:  # --help, --version
        return int(exc.code or 0) if not isinstance(exc.code, str) else EXIT_INPUT
    except KeyboardInterrupt:
        print(f"{PROG}: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    except BrokenPipeError:  # the reader of stdout closed it (`trispline ... --json | head`): no error of ours
        try:  # nor one at the interpreter's exit, when it flushes stdout
            os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        except (OSError, ValueError, AttributeError):  # a stdout without a file descriptor
            pass
        return EXIT_BROKEN_PIPE
    except (InputError, CommandFailed, ResultRejected) as exc:
        if debug:
            traceback.print_exc()
        print(f"{PROG}: error: {one_line(str(exc))}", file=sys.stderr)
        return (EXIT_INPUT if isinstance(exc, InputError) else EXIT_CHECK if isinstance(exc, ResultRejected)
                else EXIT_FAILURE)
    except Exception as exc:  # noqa: BLE001 - the CLI's last line of defence
        if Interrupts.pending and not debug:  # an interrupt that a library turned into its own error
            print(f"{PROG}: interrupted", file=sys.stderr)
            return EXIT_INTERRUPTED
        if debug:
            traceback.print_exc()
        hint = "" if debug else " (run with --debug for the traceback)"
        print(f"{PROG}: internal error: {type(exc).__name__}: {one_line(str(exc))}{hint}", file=sys.stderr)
        return EXIT_FAILURE


def prefetch(*modules: str) -> threading.Thread:
    """Import ``modules`` in a thread beside the caller's work; returns the (started) thread.

    The fit's first second is reading, checking and mapping the mesh on one core, and JAX's import
    (~1-1.7 s, pure import work) waited behind it; now it runs on the other core meanwhile. A later
    ``import`` of the same module in any thread simply waits for this one (Python's per-module import
    locks). Not a daemon: a normal interpreter exit (an in-process ``main(argv)``'s caller) waits for it
    instead of ending an import midway; the program itself ends through :func:`leave` (``os._exit``),
    which does not wait. numpy and scipy
    are imported here first, so the two threads share no package being imported at once.
    """
    import importlib

    import scipy  # noqa: F401 - cheap (its submodules load lazily); see the docstring

    def run() -> None:
        for name in modules:
            try:
                importlib.import_module(name)
            except Exception:  # noqa: BLE001 - the caller's own import reports it where it matters
                return

    thread = threading.Thread(target=run, name="trispline-prefetch")
    thread.start()
    return thread


def leave(code: int) -> NoReturn:
    """End the program with ``code`` at once with :func:`os._exit`, streams flushed first: after a failure,
    an interrupt or a termination, a normal interpreter exit would wait for (and abort in) the threads a
    cut-short fit leaves running ("FATAL: exception not rethrown", exit -6); after a success it spent
    0.3-0.5 s of a 100k-face fit's command line tearing down what the process is about to lose anyway
    (JAX's backends, the thread pools, the arrays). Every output is complete and closed by then
    (written atomically); only the command line calls this, never an in-process ``main(argv)``."""
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError):  # pragma: no cover - a closed pipe
            pass
    os._exit(code)
