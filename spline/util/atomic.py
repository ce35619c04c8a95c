"""Atomic output files: write to a temporary file in the target folder, then rename.

    with atomic_path("scan.npz") as tmp:        # tmp: ".scan.npz.<random>.tmp.npz"
        surface.save(tmp)                       # any writer that takes a path
    # now scan.npz exists, complete; on any exception nothing is left behind

    with AtomicOutputs() as out:                # several files: all or nothing
        surface.save(out.path("scan.npz"))
        mesh.export(out.path("scan.ply"))
    # every file is renamed into place only after all were written

The temporary name keeps the target's suffix (writers such as trimesh and
:meth:`SplineSurface.save` choose the format by it) and starts with a dot, so a
half-written file never looks like a result; its copy of the target's name is cut so
that it never grows past the file system's name limit (``NAME_MAX``, 255 bytes).
:func:`os.replace` is atomic on POSIX and Windows when source and target are in the
same folder, so of two writers racing for one path the last rename wins and neither
leaves a partial file. While a group is open in the main thread, SIGTERM raises
:class:`Terminated` (a ``SystemExit`` with code 143) instead of killing the process
at once, so the temporary files are deleted on the way out (SIGINT already raises
``KeyboardInterrupt``); the renames themselves run with both signals blocked.
"""
from __future__ import annotations

import contextlib
import os
import signal
import tempfile
import threading
from contextlib import contextmanager
from pathlib import Path
from types import TracebackType
from typing import Callable, Iterator

from trispline.spline.errors import OutputError

__all__ = ["OutputError", "Terminated", "AtomicOutputs", "atomic_path", "check_writable", "same_file",
           "write_with", "write_bytes", "write_text"]

#: Characters :func:`tempfile.mkstemp` adds to a name (its random part).
_RANDOM_CHARS = 8
#: The longest suffix a temporary name keeps (a real format's suffix is a few characters).
_MAX_SUFFIX = 32


class Terminated(SystemExit):
    """SIGTERM arrived while an :class:`AtomicOutputs` group was open (exit code ``128 + 15``)."""


def _name_max(folder: Path) -> int:
    """The longest file name (bytes) ``folder``'s file system allows; 255 when it does not say."""
    try:
        return int(os.pathconf(folder, "PC_NAME_MAX"))
    except (OSError, ValueError, AttributeError):  # pragma: no cover - not POSIX
        return 255


def _temp_affixes(path: Path, name_max: int) -> tuple[str, str]:
    """``(prefix, suffix)`` of a temporary name for ``path`` that stays within ``name_max`` bytes.

    The suffix ``.tmp<ext>`` keeps the target's extension; the prefix ``.<name>.`` keeps as
    much of the target's name as fits beside mkstemp's random characters.
    """
    ext = path.suffix if len(os.fsencode(path.suffix)) <= _MAX_SUFFIX else ""
    suffix = f".tmp{ext}"
    room = name_max - 2 - _RANDOM_CHARS - len(os.fsencode(suffix))
    name = os.fsencode(path.name)[:max(room, 0)]
    return "." + os.fsdecode(name) + ".", suffix


def check_writable(target: str | os.PathLike, what: str = "", *, probe: bool = True) -> Path:
    """``Path(target)`` if an output can be written there, else :class:`OutputError` saying why.

    Checks, before any work: the folder exists and is writable (for the effective user),
    the target is not a folder, and its name fits the file system (``NAME_MAX`` bytes).
    ``what`` names the output in messages (``"the output"``, ``"--mesh-out"``). ``probe``: also create and
    remove a file there (:func:`_probe`; not where a temporary file is made next anyway).
    """
    path = Path(target)
    label = f"{what} {path}" if what else str(path)
    folder = path.parent
    try:
        name_max = _name_max(folder) if folder.is_dir() else None
        size = len(os.fsencode(path.name))
        if name_max is not None and size > name_max:
            raise OutputError(f"cannot write {label}: the file name has {size} bytes, more than the "
                              f"{name_max} the file system allows")
        if name_max is None:
            raise OutputError(f"cannot write {label}: folder {folder} does not exist")
        if path.is_dir():
            raise OutputError(f"cannot write {label}: it is a folder")
    except OSError as exc:  # e.g. a folder name past the limit
        raise OutputError(f"cannot write {label}: {exc.strerror or exc}") from None
    effective = os.access in os.supports_effective_ids
    if not os.access(folder, os.W_OK | os.X_OK, effective_ids=effective):
        raise OutputError(f"cannot write {label}: folder {folder} is not writable")
    if probe:
        _probe(folder, label)
    return path


def _probe(folder: Path, label: str) -> None:
    """Create and remove an empty file in ``folder``: permissions alone do not tell a read-only or
    pseudo file system (``/proc``, a read-only mount seen by root), which would refuse the output
    only after the work."""
    try:
        fd, tmp = tempfile.mkstemp(prefix=".trispline-probe-", dir=folder)
    except OSError as exc:
        raise OutputError(f"cannot write {label}: no file can be created in folder {folder} "
                          f"({exc.strerror or exc})") from None
    os.close(fd)
    with contextlib.suppress(OSError):
        os.unlink(tmp)


def _temp_for(path: Path) -> Path:
    """Create (empty) and return a fresh temporary file beside ``path`` with the same suffix."""
    check_writable(path, probe=False)  # the temporary file below is the probe
    prefix, suffix = _temp_affixes(path, _name_max(path.parent))
    try:
        fd, tmp = tempfile.mkstemp(prefix=prefix, suffix=suffix, dir=path.parent)
    except OSError as exc:
        raise OutputError(f"cannot write {path}: {exc.strerror or exc}") from None
    os.close(fd)
    return Path(tmp)


def same_file(a: str | os.PathLike, b: str | os.PathLike) -> bool:
    """Whether paths ``a`` and ``b`` name one file (links followed); False when either is missing."""
    try:
        return os.path.samefile(a, b)
    except OSError:
        return False


class _SigtermGuard:
    """SIGTERM raises :class:`Terminated` while at least one group is open (main thread only), and is
    remembered: raised where Python swallows exceptions (a garbage-collector callback such as JAX's), it is
    raised again when a group commits, which then writes nothing."""

    depth = 0
    previous: object = None
    pending = False

    @classmethod
    def enter(cls) -> None:
        if threading.current_thread() is not threading.main_thread():
            return
        if cls.depth == 0:
            if signal.getsignal(signal.SIGTERM) is not signal.SIG_DFL:
                return  # the program handles (or ignores) SIGTERM itself
            cls.pending = False
            cls.previous = signal.signal(signal.SIGTERM, _raise_terminated)
        cls.depth += 1

    @classmethod
    def exit(cls) -> None:
        if threading.current_thread() is not threading.main_thread() or cls.depth == 0:
            return
        cls.depth -= 1
        if cls.depth == 0:
            signal.signal(signal.SIGTERM, cls.previous)


def _raise_terminated(signum: int, frame: object) -> None:
    _SigtermGuard.pending = True
    raise Terminated(128 + signum)


#: Callables run just before a group's files are renamed onto their targets (inside the signal block); one
#: that raises stops the commit and the group writes nothing (:func:`add_commit_check`).
_COMMIT_CHECKS: list[Callable[[], None]] = []


def add_commit_check(check: Callable[[], None]) -> Callable[[], None]:
    """Run ``check()`` before every commit (e.g. raise an interrupt that a library swallowed, so that a
    command cut short writes nothing); returns the undo."""
    _COMMIT_CHECKS.append(check)
    return lambda: _COMMIT_CHECKS.remove(check) if check in _COMMIT_CHECKS else None


@contextmanager
def _signals_blocked() -> Iterator[None]:
    """SIGINT and SIGTERM held back (delivered on exit): renames are not cut in half."""
    if not hasattr(signal, "pthread_sigmask"):  # pragma: no cover - not POSIX
        yield
        return
    old = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT, signal.SIGTERM})
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, old)


def _file_mode(target: Path) -> int:
    """Permissions for a new output: the target's if it exists, else 0o666 minus the umask."""
    try:
        return target.stat().st_mode & 0o7777
    except OSError:
        mask = os.umask(0)
        os.umask(mask)
        return 0o666 & ~mask


def _unlink_quietly(path: Path) -> None:
    try:
        os.unlink(path)
    except FileNotFoundError:
        pass


class AtomicOutputs:
    """A group of output files committed together (all or nothing).

    :meth:`path` hands out a temporary path for each target; leaving the ``with``
    block normally renames every temporary file onto its target, leaving it by an
    exception (``KeyboardInterrupt`` included) deletes them all.
    """

    def __init__(self) -> None:
        self._pending: list[tuple[Path, Path]] = []

    def path(self, target: str | os.PathLike) -> Path:
        """A temporary path to write ``target``'s content to (same folder, same suffix)."""
        target = Path(target)
        if any(t.resolve() == target.resolve() for t, _ in self._pending):
            raise OutputError(f"{target} is named as more than one output")
        tmp = _temp_for(target)
        self._pending.append((target, tmp))
        return tmp

    @property
    def targets(self) -> list[Path]:
        return [t for t, _ in self._pending]

    def commit(self) -> list[Path]:
        """Rename every temporary file onto its target; returns the targets."""
        done = []
        with _signals_blocked():
            if _SigtermGuard.pending:  # a SIGTERM swallowed while the files were written
                self.discard()
                raise Terminated(128 + signal.SIGTERM)
            for check in list(_COMMIT_CHECKS):
                try:
                    check()
                except BaseException:
                    self.discard()
                    raise
            try:
                for target, tmp in self._pending:
                    os.chmod(tmp, _file_mode(target))  # mkstemp creates 0o600
                    os.replace(tmp, target)
                    done.append(target)
            except OSError as exc:
                self.discard()
                raise OutputError(f"cannot write {target}: {exc.strerror or exc}") from None
            self._pending = []
        return done

    def discard(self) -> None:
        """Delete every temporary file not yet committed."""
        with _signals_blocked():
            for _, tmp in self._pending:
                _unlink_quietly(tmp)
            self._pending = []

    def __enter__(self) -> "AtomicOutputs":
        _SigtermGuard.enter()
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        try:
            if exc_type is None:
                try:
                    self.commit()
                except BaseException:
                    self.discard()
                    raise
            else:
                self.discard()
        finally:
            _SigtermGuard.exit()


@contextmanager
def atomic_path(target: str | os.PathLike) -> Iterator[Path]:
    """Context manager yielding a temporary path that replaces ``target`` on success."""
    with AtomicOutputs() as out:
        yield out.path(target)


def write_with(target: str | os.PathLike, write: Callable[[Path], None],
               outputs: AtomicOutputs | None = None) -> Path:
    """Run ``write(tmp)`` for ``target``: inside the group ``outputs`` (committed by its owner),
    or atomically on its own when ``outputs`` is None. Returns ``Path(target)``."""
    if outputs is not None:
        write(outputs.path(target))
    else:
        with atomic_path(target) as tmp:
            write(tmp)
    return Path(target)


def write_bytes(target: str | os.PathLike, data: bytes) -> Path:
    """Write ``data`` to ``target`` atomically."""
    with atomic_path(target) as tmp:
        tmp.write_bytes(data)
    return Path(target)


def write_text(target: str | os.PathLike, text: str) -> Path:
    """Write UTF-8 ``text`` to ``target`` atomically."""
    return write_bytes(target, text.encode("utf-8"))
