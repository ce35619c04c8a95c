"""The surface file format, version 1 (docs/design.md §6): NPZ and JSON.

Keys (both variants)::

    format          "trispline.surface"
    version         1
    degree          5
    uv              (V, 2) float64
    faces           (F, 3) int64, counter-clockwise in uv
    control_points  (F, 21, 3) float64, storage order of docs/design.md §1

Any other key is optional: writers may add them, readers keep them as
``extras`` and never fail on a key they do not know. Files are written
atomically (:func:`~trispline.spline.util.atomic.atomic_path`: a temporary file in
the target folder, then :func:`os.replace`), so a failed write never leaves a
partial file behind, and with the permissions of any other output (``0o666``
minus the umask, or those of the file it replaces). Reading trusts nothing: an NPZ
file's member headers are checked against the format and against the members' sizes
before any data is read (:mod:`~trispline.spline.util.npz`), and a JSON file's version
and degree must be true integers, its integers fit int64 and its nesting Python's stack.
"""
from __future__ import annotations

import json
import math
import os
import zipfile
from pathlib import Path
from typing import Any, Callable, Mapping

import numpy as np

from .checks import as_array, check_ids, check_magnitude
from .errors import InputError, OutputError, SurfaceFileError, first_few
from .index import DEGREE, NCTRL
from .util.atomic import atomic_path
from .util.npz import NpyHeader, npz_headers, read_npz

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
#: Largest ``format`` / ``version`` / ``degree`` member of an NPZ file (a short string or an integer).
MAX_SCALAR_BYTES = 1024
#: Longest integer literal a JSON surface file may hold (int64 has 19 digits).
MAX_INT_DIGITS = 19


def _as_path(path: Any) -> Path:
    """``Path(path)``; anything but a string or path-like object is a :class:`SurfaceFileError`."""
    if not isinstance(path, (str, os.PathLike)):
        raise SurfaceFileError(f"a surface file path must be a str or os.PathLike, got {type(path).__name__}")
    return Path(path)


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
    for name, arr in (("uv", uv), ("control points", ctrl)):
        check_magnitude(arr, f"{source}: {name}", hint=" (rescale the surface)", error=error)
    check_ids(faces, f"{source}: faces", uv.shape[0], error=error)
    return uv, faces, ctrl


def _short(value: Any) -> str:
    """``repr(value)`` cut to 60 characters (a file may hold anything)."""
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


def _integer(raw: Mapping[str, Any], key: str, source: str) -> int:
    """``raw[key]`` as an int: only a true integer (not a bool, a string or 1.9) passes."""
    value = raw[key]
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)):
        raise SurfaceFileError(f"{source}: {key} must be an integer, got {_short(value)}")
    return int(value)


def _check_header(raw: Mapping[str, Any], source: str) -> None:
    """The ``format``, ``version`` and ``degree`` keys of a file just read."""
    fmt = raw["format"]
    if not isinstance(fmt, str) or fmt != FORMAT:
        raise SurfaceFileError(f"{source}: not a trispline surface (format {_short(fmt)}, expected {FORMAT!r})")
    version = _integer(raw, "version", source)
    if version != VERSION:
        raise SurfaceFileError(f"{source}: unsupported surface file version {_short(version)} "
                               f"(this reader knows {VERSION})")
    degree = _integer(raw, "degree", source)
    if degree != DEGREE:
        raise SurfaceFileError(f"{source}: degree {_short(degree)} is not supported (only quintic, degree {DEGREE})")


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
    path = _as_path(path)
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
        _write_atomically(path, lambda fh: np.savez(fh, **arrays))  # stored: see docs/surface.md
    else:
        try:
            text = json.dumps(_jsonable({**data, **extras}), allow_nan=False)
        except (TypeError, ValueError) as exc:
            raise SurfaceFileError(f"extras cannot be written as JSON: {exc}") from None
        _write_atomically(path, lambda fh: fh.write(text.encode("utf-8")))
    return path


def read_surface(path: str | os.PathLike) -> tuple[np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
    """Read and validate a surface file; memory stays bounded by what the file really holds.

    An NPZ file's member headers (shape, dtype) are checked against the format before any
    data is read (:mod:`trispline.spline.util.npz`: no pickles, no zip bombs, no header
    claiming more than its member holds); a JSON file may not hold integers beyond int64 or
    nest deeper than Python's recursion limit.

    Returns
    -------
    uv (V, 2), faces (F, 3), ctrl (F, 21, 3), extras (dict of the optional keys)

    Raises
    ------
    SurfaceFileError
        Naming the file, the key and the problem.
    """
    path = _as_path(path)
    kind = _suffix(path)
    src = str(path)
    if not path.is_file():
        raise SurfaceFileError(f"{src}: no such surface file" if not path.is_dir() else f"{src}: is a folder")
    try:
        with open(path, "rb") as fh:
            fh.read(1)
    except OSError as exc:
        raise SurfaceFileError(f"{src}: cannot read ({exc.strerror or exc})") from None
    raw = _read_npz(path, src) if kind == ".npz" else _read_json(path, src)
    missing = [k for k in _REQUIRED if k not in raw]
    if "format" in missing:
        raise SurfaceFileError(f"{src}: not a trispline surface (no 'format' key)")
    if missing:
        raise SurfaceFileError(f"{src}: missing required keys {missing}")
    _check_header(raw, src)
    uv, faces, ctrl = validate_surface_arrays(raw["uv"], raw["faces"], raw["control_points"], source=src)
    extras = {k: v for k, v in raw.items() if k not in _REQUIRED}
    return uv, faces, ctrl, extras


def _read_npz(path: Path, src: str) -> dict[str, Any]:
    """The members of an NPZ surface file, 0-d arrays as Python scalars; headers checked first."""
    if not zipfile.is_zipfile(path):
        raise SurfaceFileError(f"{src}: not an NPZ archive (no zip structure)")
    headers = npz_headers(path, src, error=SurfaceFileError)
    _check_npz_headers(headers, src)
    arrays = read_npz(path, headers, src, error=SurfaceFileError)
    return {k: v.item() if v.ndim == 0 else v for k, v in arrays.items()}


def _check_npz_headers(headers: Mapping[str, NpyHeader], src: str) -> None:
    """Refuse core members of the wrong shape or dtype from their headers alone (no data read)."""
    for key in ("format", "version", "degree"):
        h = headers.get(key)
        if h is not None and (h.shape != () or h.nbytes > MAX_SCALAR_BYTES):
            raise SurfaceFileError(f"{src}: {key} must be a single value, got shape {h.shape} of {h.dtype}")
    kinds = {"uv": ("V", 2), "faces": ("F", 3), "control_points": (None, NCTRL, 3)}
    if "faces" in headers and len(headers["faces"].shape) == 2:
        kinds["control_points"] = (headers["faces"].shape[0], NCTRL, 3)
    for key, shape in kinds.items():
        h = headers.get(key)
        if h is None:
            continue
        if len(h.shape) != len(shape) or any(isinstance(n, int) and n != m for n, m in zip(shape, h.shape)):
            want = "(" + ", ".join(str(n) for n in shape) + ")"
            raise SurfaceFileError(f"{src}: {key} must have shape {want}, got {h.shape}")
        allowed = "iu" if key == "faces" else "iuf"
        if h.dtype.kind not in allowed and math.prod(h.shape):
            what = "integers" if key == "faces" else "real numbers"
            raise SurfaceFileError(f"{src}: {key} must hold {what}, got dtype {h.dtype}")


def _read_json(path: Path, src: str) -> dict[str, Any]:
    """The top-level object of a JSON surface file; integers beyond int64 are refused."""

    def parse_int(text: str) -> int:
        if len(text.lstrip("-")) > MAX_INT_DIGITS:
            raise SurfaceFileError(f"{src}: integer of {len(text)} digits (more than int64 holds)")
        return int(text)

    try:
        raw = json.loads(path.read_text(encoding="utf-8"), parse_int=parse_int)
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise SurfaceFileError(f"{src}: not a JSON file ({exc})") from None
    except SurfaceFileError:
        raise
    except RecursionError:
        raise SurfaceFileError(f"{src}: JSON nested too deeply (a surface file nests 3 levels)") from None
    except (ValueError, OverflowError) as exc:
        raise SurfaceFileError(f"{src}: unreadable JSON number ({exc})") from None
    if not isinstance(raw, dict):
        raise SurfaceFileError(f"{src}: JSON top level must be an object, got {type(raw).__name__}")
    return raw
