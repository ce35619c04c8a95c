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
half-written file never looks like a result. :func:`os.replace` is atomic on
POSIX and Windows when source and target are in the same folder.
"""
from __future__ import annotations

import os
import tempfile
from contextlib import contextmanager
from pathlib import Path
from types import TracebackType
from typing import Callable, Iterator

from trispline.spline.errors import OutputError

__all__ = ["OutputError", "AtomicOutputs", "atomic_path", "write_with", "write_bytes", "write_text"]


def _temp_for(path: Path) -> Path:
    """Create (empty) and return a fresh temporary file beside ``path`` with the same suffix."""
    folder = path.parent
    if not folder.is_dir():
        raise OutputError(f"cannot write {path}: folder {folder} does not exist")
    if path.is_dir():
        raise OutputError(f"cannot write {path}: it is a folder")
    suffix = "".join(path.suffixes[-1:])
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=f".tmp{suffix}", dir=folder)
    except OSError as exc:
        raise OutputError(f"cannot write {path}: {exc.strerror or exc}") from None
    os.close(fd)
    return Path(tmp)


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
        for _, tmp in self._pending:
            _unlink_quietly(tmp)
        self._pending = []

    def __enter__(self) -> "AtomicOutputs":
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        if exc_type is None:
            try:
                self.commit()
            except BaseException:
                self.discard()
                raise
        else:
            self.discard()


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
