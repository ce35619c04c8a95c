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
atomically (a temporary file in the target folder, then :func:`os.replace`), so
a failed write never leaves a partial file behind.
"""
from __future__ import annotations

import json
import os
import tempfile
import zipfile
from pathlib import Path
from typing import Any, Mapping

import numpy as np

from .index import DEGREE, NCTRL
from .errors import InputError, first_few
from .errors import SurfaceFileError

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
    try:
        uv = np.asarray(uv, dtype=np.float64)
        ctrl = np.asarray(ctrl, dtype=np.float64)
        faces_raw = np.asarray(faces)
    except (TypeError, ValueError) as exc:
        raise error(f"{source}: arrays are not numeric ({exc})") from None
    if uv.ndim != 2 or uv.shape[1] != 2:
        raise error(f"{source}: uv must have shape (V, 2), got {uv.shape}")
    if faces_raw.ndim != 2 or faces_raw.shape[1] != 3 or faces_raw.shape[0] == 0:
        raise error(f"{source}: faces must have shape (F, 3) with F > 0, got {faces_raw.shape}")
    if faces_raw.dtype.kind == "f":
        if not np.all(np.isfinite(faces_raw)) or np.any(faces_raw != np.round(faces_raw)):
            raise error(f"{source}: faces must hold integer vertex ids")
    elif faces_raw.dtype.kind not in "iu":
        raise error(f"{source}: faces must hold integer vertex ids, got dtype {faces_raw.dtype}")
    faces = faces_raw.astype(np.int64)
    nf = faces.shape[0]
    if ctrl.shape != (nf, NCTRL, 3):
        raise error(f"{source}: control_points must have shape ({nf}, {NCTRL}, 3), got {ctrl.shape}")
    bad = np.flatnonzero(~np.isfinite(uv).all(1))
    if bad.size:
        raise error(f"{source}: NaN or infinite uv at vertices {first_few(bad)}")
    bad = np.flatnonzero(~np.isfinite(ctrl).all((1, 2)))
    if bad.size:
        raise error(f"{source}: NaN or infinite control points in faces {first_few(bad)}")
    bad = np.flatnonzero(((faces < 0) | (faces >= uv.shape[0])).any(1))
    if bad.size:
        raise error(f"{source}: faces with vertex ids outside [0, {uv.shape[0]}): {first_few(bad)}")
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


def _atomic_write(path: Path, write) -> None:
    folder = path.parent if str(path.parent) else Path(".")
    if not folder.is_dir():
        raise SurfaceFileError(f"{path}: folder {folder} does not exist")
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=folder)
    try:
        with os.fdopen(fd, "wb") as fh:
            write(fh)
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except FileNotFoundError:
            pass
        raise


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
        _atomic_write(path, lambda fh: np.savez_compressed(fh, **arrays))
    else:
        try:
            text = json.dumps(_jsonable({**data, **extras}), allow_nan=False)
        except (TypeError, ValueError) as exc:
            raise SurfaceFileError(f"extras cannot be written as JSON: {exc}") from None
        _atomic_write(path, lambda fh: fh.write(text.encode("utf-8")))
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
