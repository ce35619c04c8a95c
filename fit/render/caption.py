"""The dated caption in a picture's corner: when it was drawn, from which file, by which trispline.

    caption_text("scan.npz")          # "2025-06-01, scan.npz, trispline 0.1.0"
    caption_text()                    # "2025-06-01, trispline 0.1.0"
    package_version()                 # "0.1.0" ("unknown" in a bare source checkout)

The date is today's, or that of ``$SOURCE_DATE_EPOCH`` (seconds since 1970, UTC)
when it is set, so that pictures regenerated for the documentation can be
reproduced bit for bit.
"""
from __future__ import annotations

import datetime as _dt
import os

__all__ = ["caption_text", "package_version", "picture_date"]


def package_version() -> str:
    """The installed trispline's version, or ``"unknown"`` in a bare source checkout."""
    try:
        from importlib.metadata import version

        return version("trispline")
    except Exception:  # noqa: BLE001 - not installed (source checkout)
        return "unknown"


def picture_date() -> str:
    """Today as ``YYYY-MM-DD``, or the UTC date of ``$SOURCE_DATE_EPOCH`` when it is set."""
    epoch = os.environ.get("SOURCE_DATE_EPOCH", "").strip()
    if epoch.isdigit():
        return _dt.datetime.fromtimestamp(int(epoch), _dt.timezone.utc).date().isoformat()
    return _dt.date.today().isoformat()


def caption_text(source: str | os.PathLike | None = None) -> str:
    """``"date, source, trispline version"`` (no source part when ``source`` is None; no ``|``,
    which VTK's text drops)."""
    parts = [picture_date()] + ([os.path.basename(os.fspath(source))] if source is not None else [])
    return ", ".join(parts + [f"trispline {package_version()}"])
