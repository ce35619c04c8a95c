"""Where the real meshes are: ``../shared/data`` next to the checkout, or a copy of it in a cache folder.

    python -m trispline.fit.datasets.cache [SOURCE] [--to FOLDER]   # copy the shared meshes to the cache

    from trispline.fit.datasets.cache import find_data, MISSING_DATA
    path = find_data("snail.obj")        # a Path, or None when no folder has it

The real meshes (``snail.obj``, ``beetle.off``, ...; see ``../shared/data/README.md``)
are public meshes the project does not redistribute, so a user's clone does not
have them. Where a checkout has ``../shared/data`` beside it, the command above
copies its meshes into the cache folder (``$TRISPLINE_DATA``, else
``$XDG_CACHE_HOME/trispline/data``, else ``~/.cache/trispline/data``), where tests,
benchmarks and examples then find them from any checkout or installation. Without
them the tests run on the generated :func:`~trispline.fit.datasets.face.face_scan`,
and the tests that need a particular shared mesh are skipped with
:data:`MISSING_DATA` as the reason (``pytest -ra`` lists them).
"""
from __future__ import annotations

import argparse
import os
import shutil
import sys
from pathlib import Path
from typing import Sequence

__all__ = ["MESH_SUFFIXES", "MISSING_DATA", "cache_folder", "shared_folder", "data_folders", "find_data",
           "copy_shared", "main"]

#: The files copied: meshes and the folder's README (its sources and terms).
MESH_SUFFIXES = (".obj", ".off", ".ply", ".stl")
#: Why a test that needs a shared mesh did not run, and how to make it run.
MISSING_DATA = ("shared data not present: run 'python -m trispline.fit.datasets.cache' in a checkout with "
                "../shared/data beside it (or set TRISPLINE_DATA to a folder holding the meshes)")


def cache_folder() -> Path:
    """``$TRISPLINE_DATA``, else ``$XDG_CACHE_HOME/trispline/data``, else ``~/.cache/trispline/data``."""
    if os.environ.get("TRISPLINE_DATA"):
        return Path(os.environ["TRISPLINE_DATA"]).expanduser()
    base = os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache"
    return Path(base) / "trispline" / "data"


def shared_folder() -> Path:
    """``$TRISPLINE_SHARED_DATA``, else ``../shared/data`` beside the checkout this package runs from
    (an editable install)."""
    if os.environ.get("TRISPLINE_SHARED_DATA"):
        return Path(os.environ["TRISPLINE_SHARED_DATA"]).expanduser()
    return Path(__file__).resolve().parents[3] / "shared" / "data"


def data_folders() -> list[Path]:
    """The folders searched for a mesh, in order: the checkout's ``../shared/data``, then the cache."""
    return [shared_folder(), cache_folder()]


def find_data(name: str) -> Path | None:
    """The first ``folder / name`` of :func:`data_folders` that exists, else None."""
    for folder in data_folders():
        if (folder / name).is_file():
            return folder / name
    return None


def copy_shared(source: str | os.PathLike, dest: str | os.PathLike | None = None) -> list[Path]:
    """Copy the meshes (:data:`MESH_SUFFIXES`) and ``README.md`` of ``source`` into ``dest``
    (default :func:`cache_folder`); returns the files written. Files already there with the
    same size are kept."""
    src = Path(source)
    if not src.is_dir():
        raise FileNotFoundError(f"no data folder at {src}")
    out = Path(dest) if dest is not None else cache_folder()
    out.mkdir(parents=True, exist_ok=True)
    written = []
    for f in sorted(src.iterdir()):
        if not (f.is_file() and (f.suffix.lower() in MESH_SUFFIXES or f.name == "README.md")):
            continue
        target = out / f.name
        if not (target.is_file() and target.stat().st_size == f.stat().st_size):
            tmp = out / f".{f.name}.part"
            shutil.copyfile(f, tmp)
            os.replace(tmp, target)  # atomic: a half-copied mesh is never found
        written.append(target)
    return written


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m trispline.fit.datasets.cache [SOURCE] [--to FOLDER]``: copy the shared meshes."""
    ap = argparse.ArgumentParser(prog="python -m trispline.fit.datasets.cache",
                                 description="Copy the real meshes of ../shared/data into trispline's cache folder, "
                                             "where tests, benchmarks and examples find them.")
    ap.add_argument("source", nargs="?", default=None,
                    help=f"folder with the meshes (default: the checkout's ../shared/data, {shared_folder()})")
    ap.add_argument("--to", default=None, help=f"cache folder (default: $TRISPLINE_DATA or {cache_folder()})")
    args = ap.parse_args(argv)
    source = Path(args.source) if args.source else shared_folder()
    try:
        files = copy_shared(source, args.to)
    except FileNotFoundError as exc:
        print(f"error: {exc}; give the folder holding the meshes as SOURCE", file=sys.stderr)
        return 2
    dest = Path(args.to) if args.to else cache_folder()
    print(f"{len(files)} files in {dest}: {', '.join(f.name for f in files)}")
    return 0


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main())
