"""The surface file format, version 1 (DESIGN.md §6): NPZ and JSON.

Keys (both variants)::

    format          "trispline.surface"
    version         1
    degree          5
    uv              (V, 2) float64
    faces           (F, 3) int64, counter-clockwise in uv
    control_points  (F, 21, 3) float64, storage order of DESIGN.md §1

Any other key is optional: writers may add them, readers keep them as
``extras`` and never fail on a key they do not know. Files are written
atomically (:func:`~trispline.spline.util.atomic.atomic_path`: a temporary file in
the target folder, then :func:`os.replace`), so a failed write never leaves a
partial file behind, and with the permissions of any other output (``0o666``
minus the umask, or those of the file it replaces).
"""
from __future__ import annotations

import json
import os
import zipfile
from pathlib import Path
from typing import Any, Callable, Mapping

import numpy as np

from .checks import as_array, check_ids
from .errors import InputError, OutputError, SurfaceFileError, first_few
from .index import DEGREE, NCTRL
from .util.atomic import atomic_path

__all__ = [
    "FORMAT",
    "VERSION",
    "SurfaceFileError",
    "read_surface",
    "validate_surface_arrays",
    "write_surface",
]

FORMAT = "trispline.surface"
VERSION = 1
_REQUIRED = ("format", "version", "degree", "uv", "faces", "control_points")


def _suffix(path: Path) -> str:
    s = path.suffix.lower()
    if s not in (".npz", ".json"):
        raise SurfaceFileError(f"{path}: unknown surface file suffix {path.suffix!r}; use .npz or .json")
    return s


def validate_surface_arrays(
    uv: Any, faces: Any, ctrl: Any, *, source: str = "surface", error: type[InputError] = SurfaceFileError
) -> tuple[np.ndarray, ...]:
    """Check shapes, dtypes and values of the three core arrays; return them converted.

    Returns ``uv (V, 2) float64``, ``faces (F, 3) int64``, ``ctrl (F, 21, 3) float64``.
    Raises ``error`` (default :class:`SurfaceFileError`) naming the problem.
    """
    uv = as_array(uv, f"{source}: uv", ("V", 2), error=error)
    faces = as_array(faces, f"{source}: faces", ("F", 3), integer=True, min_rows=1, error=error)
    nf = faces.shape[0]
    ctrl = as_array(ctrl, f"{source}: control_points", (nf, NCTRL, 3), error=error)
    bad = np.flatnonzero(~np.isfinite(uv).all(1))
    if bad.size:
        raise error(f"{source}: NaN or infinite uv at vertices {first_few(bad)}")
    bad = np.flatnonzero(~np.isfinite(ctrl).all((1, 2)))
    if bad.size:
        raise error(f"{source}: NaN or infinite control points in faces {first_few(bad)}")
    check_ids(faces, f"{source}: faces", uv.shape[0], error=error)
    return uv, faces, ctrl


def _check_header(get, source: str) -> None:
    fmt = get("format")
    if fmt != FORMAT:
        raise SurfaceFileError(f"{source}: not a trispline surface (format {fmt!r}, expected {FORMAT!r})")
    try:
        version = int(get("version"))
    except (TypeError, ValueError):
        raise SurfaceFileError(f"{source}: version must be an integer, got {get('version')!r}") from None
    if version != VERSION:
        raise SurfaceFileError(f"{source}: unsupported surface file version {version} (this reader knows {VERSION})")
    try:
        degree = int(get("degree"))
    except (TypeError, ValueError):
        raise SurfaceFileError(f"{source}: degree must be an integer, got {get('degree')!r}") from None
    if degree != DEGREE:
        raise SurfaceFileError(f"{source}: degree {degree} is not supported (only quintic, degree {DEGREE})")


def _write_atomically(path: Path, write: Callable[[Any], None]) -> None:
    """``write(binary file)`` into ``path``, all or nothing; an unwritable path is a :class:`SurfaceFileError`."""
    try:
        with atomic_path(path) as tmp, open(tmp, "wb") as fh:
            write(fh)
    except OutputError as exc:
        raise SurfaceFileError(str(exc)) from None


def _jsonable(value: Any) -> Any:
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, Mapping):
        return {str(k): _jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_jsonable(v) for v in value]
    return value


def write_surface(
    path: str | os.PathLike, uv: np.ndarray, faces: np.ndarray, ctrl: np.ndarray,
    extras: Mapping[str, Any] | None = None,
) -> Path:
    """Write a surface file; NPZ or JSON chosen by the suffix (``.npz`` / ``.json``).

    ``extras`` are optional keys written beside the required ones (they may not
    reuse a required key's name).
    """
    path = Path(path)
    kind = _suffix(path)
    uv, faces, ctrl = validate_surface_arrays(uv, faces, ctrl, source="surface to save")
    extras = dict(extras or {})
    clash = sorted(set(extras) & set(_REQUIRED))
    if clash:
        raise SurfaceFileError(f"extras may not use the reserved keys {clash}")
    data: dict[str, Any] = {
        "format": FORMAT, "version": VERSION, "degree": DEGREE,
        "uv": uv, "faces": faces, "control_points": ctrl,
    }
    if kind == ".npz":
        arrays = {k: np.asarray(v) for k, v in {**data, **extras}.items()}
        bad = sorted(k for k, v in arrays.items() if v.dtype == object)
        if bad:
            raise SurfaceFileError(f"extras {bad} are not numeric or string arrays; NPZ cannot store them")
        _write_atomically(path, lambda fh: np.savez_compressed(fh, **arrays))
    else:
        try:
            text = json.dumps(_jsonable({**data, **extras}), allow_nan=False)
        except (TypeError, ValueError) as exc:
            raise SurfaceFileError(f"extras cannot be written as JSON: {exc}") from None
        _write_atomically(path, lambda fh: fh.write(text.encode("utf-8")))
    return path


def read_surface(path: str | os.PathLike) -> tuple[np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
    """Read and validate a surface file.

    Returns
    -------
    uv (V, 2), faces (F, 3), ctrl (F, 21, 3), extras (dict of the optional keys)
    """
    path = Path(path)
    kind = _suffix(path)
    if not path.is_file():
        raise SurfaceFileError(f"{path}: no such surface file")
    src = str(path)
    if kind == ".npz":
        if not zipfile.is_zipfile(path):
            raise SurfaceFileError(f"{src}: not an NPZ archive (no zip structure)")
        try:
            with np.load(path, allow_pickle=False) as z:
                raw = {k: z[k] for k in z.files}
        except (zipfile.BadZipFile, OSError, EOFError) as exc:
            raise SurfaceFileError(f"{src}: not an NPZ archive ({exc})") from None
        except ValueError as exc:  # object arrays would need pickle
            raise SurfaceFileError(f"{src}: unreadable NPZ entry ({exc})") from None

        def get(k: str) -> Any:
            v = raw[k]
            return v.item() if v.ndim == 0 else v
    else:
        try:
            raw = json.loads(path.read_text(encoding="utf-8"))
        except (UnicodeDecodeError, json.JSONDecodeError) as exc:
            raise SurfaceFileError(f"{src}: not a JSON file ({exc})") from None
        if not isinstance(raw, dict):
            raise SurfaceFileError(f"{src}: JSON top level must be an object, got {type(raw).__name__}")
        get = raw.__getitem__
    missing = [k for k in _REQUIRED if k not in raw]
    if "format" in missing:
        raise SurfaceFileError(f"{src}: not a trispline surface (no 'format' key)")
    if missing:
        raise SurfaceFileError(f"{src}: missing required keys {missing}")
    _check_header(get, src)
    uv, faces, ctrl = validate_surface_arrays(get("uv"), get("faces"), get("control_points"), source=src)
    extras = {k: get(k) for k in raw if k not in _REQUIRED}
    return uv, faces, ctrl, extras
