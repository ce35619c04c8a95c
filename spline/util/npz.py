"""Reading an untrusted NPZ archive with bounded memory: every member's header first, data after.

    members = npz_headers(path, "scan.npz", error=SurfaceFileError)   # {key: NpyHeader}
    # ... compare shapes and dtypes with what the caller expects ...
    arrays = read_npz(path, members, "scan.npz", error=SurfaceFileError)

:func:`npz_headers` reads the zip directory and the few bytes of each ``.npy`` header
(shape, dtype), never the data, and refuses what :func:`numpy.load` would turn into a
huge allocation or a pickle: object arrays, a header claiming more (or fewer) bytes than
its member holds (an array "of 1e13 elements" in a small file), and zip bombs (a member
that inflates more than :data:`MAX_RATIO` times once it is large). Members whose name
does not end in ``.npy`` are not arrays and are skipped.
"""
from __future__ import annotations

import math
import os
import zipfile
from dataclasses import dataclass
from typing import Mapping

import numpy as np

from trispline.spline.errors import InputError

__all__ = ["NpyHeader", "MAX_MEMBERS", "MAX_RATIO", "RATIO_FROM_BYTES", "npz_headers", "read_npz"]

#: An archive with more members than this is refused (their headers alone cost time and memory).
MAX_MEMBERS = 10_000
#: A member that inflates more than this many times is refused as a zip bomb once it is
#: larger than :data:`RATIO_FROM_BYTES`. Deflate reaches ~1000:1 on constant data; the
#: float64 coordinates and int64 ids of a real surface compress about 1.1:1 to 10:1.
MAX_RATIO = 100
#: Members (and archives) below this many uncompressed bytes are never refused for their
#: ratio (tiny arrays and strings compress well).
RATIO_FROM_BYTES = 16 << 20
#: Longest ``.npy`` header accepted (numpy's own default).
MAX_HEADER = 10_000


@dataclass(frozen=True)
class NpyHeader:
    """What an ``.npy`` member of an archive claims, read without its data.

    Attributes
    ----------
    shape : tuple of int
    dtype : numpy.dtype
    nbytes : int, bytes of the array's data (``prod(shape) * itemsize``)
    stored : int, bytes of the member in the archive (compressed)
    """

    shape: tuple[int, ...]
    dtype: np.dtype
    nbytes: int
    stored: int


def _check_ratio(size: int, stored: int, where: str, error: type[InputError]) -> None:
    """Refuse ``size`` uncompressed bytes stored in ``stored`` bytes beyond :data:`MAX_RATIO`."""
    if size > RATIO_FROM_BYTES and size > MAX_RATIO * max(stored, 1):
        raise error(f"{where} inflates from {stored} to {size} bytes (more than {MAX_RATIO}:1): "
                    "refused as a zip bomb")


def _header(zf: zipfile.ZipFile, info: zipfile.ZipInfo, where: str, error: type[InputError]) -> NpyHeader:
    """The header of one member, checked against the member's size (no data read)."""
    with zf.open(info) as fh:
        try:
            version = np.lib.format.read_magic(fh)
            read = np.lib.format.read_array_header_1_0 if version == (1, 0) else np.lib.format.read_array_header_2_0
            shape, _, dtype = read(fh, max_header_size=MAX_HEADER)
        except (ValueError, EOFError, zipfile.BadZipFile, OSError) as exc:
            raise error(f"{where}: not a numpy array ({exc})") from None
        header_bytes = fh.tell()
    if dtype.hasobject:
        raise error(f"{where}: holds Python objects (dtype {dtype}); pickled arrays are refused")
    if any(n < 0 for n in shape):
        raise error(f"{where}: header claims the negative shape {shape}")
    nbytes = math.prod(shape) * dtype.itemsize
    held = info.file_size - header_bytes
    if nbytes != held:
        raise error(f"{where}: header claims shape {shape} of {dtype} ({nbytes} bytes) but the member "
                    f"holds {max(held, 0)} bytes of data")
    _check_ratio(info.file_size, info.compress_size, where, error)
    return NpyHeader(shape=tuple(int(n) for n in shape), dtype=dtype, nbytes=nbytes, stored=info.compress_size)


def npz_headers(path: str | os.PathLike, source: str, *, error: type[InputError] = InputError) -> dict[str, NpyHeader]:
    """``{key: NpyHeader}`` of every ``.npy`` member of the archive ``path``; nothing else is read.

    ``source`` names the file in messages; every problem raises ``error``.
    """
    try:
        with zipfile.ZipFile(path) as zf:
            infos = zf.infolist()
            if len(infos) > MAX_MEMBERS:
                raise error(f"{source}: {len(infos)} archive members (at most {MAX_MEMBERS} are read)")
            _check_ratio(sum(i.file_size for i in infos), sum(i.compress_size for i in infos),
                         f"{source}: the archive", error)
            return {info.filename[:-4]: _header(zf, info, f"{source}: member {info.filename[:-4]!r}", error)
                    for info in infos if info.filename.endswith(".npy")}
    except error:
        raise
    except (zipfile.BadZipFile, zipfile.LargeZipFile, OSError, EOFError, ValueError, NotImplementedError) as exc:
        raise error(f"{source}: not an NPZ archive ({exc})") from None


def read_npz(path: str | os.PathLike, headers: Mapping[str, NpyHeader], source: str, *,
             error: type[InputError] = InputError) -> dict[str, np.ndarray]:
    """The arrays ``{key: array}`` of the members named in ``headers`` (from :func:`npz_headers`)."""
    out: dict[str, np.ndarray] = {}
    try:
        with zipfile.ZipFile(path) as zf:
            for key in headers:
                with zf.open(f"{key}.npy") as fh:
                    out[key] = np.lib.format.read_array(fh, allow_pickle=False, max_header_size=MAX_HEADER)
    except (zipfile.BadZipFile, OSError, EOFError, ValueError, KeyError, NotImplementedError) as exc:
        raise error(f"{source}: damaged NPZ archive ({exc})") from None
    return out
