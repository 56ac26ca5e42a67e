"""What a data file is, from a look at its head: our sweep formats, our measurement formats, or a recording
(read by :mod:`denavit.io.recordings`). The one place that decides it, for :mod:`denavit.api` and the command
line alike."""

from __future__ import annotations

import os
from pathlib import Path

from ..errors import DenavitError


def input_path(data) -> Path:
    """``data`` (str or os.PathLike) as a Path that exists, or a one-line error naming it."""
    p = Path(os.fspath(data))
    if not p.exists():
        raise DenavitError(f"{p}: no such file or folder")
    return p


def header(path: Path) -> list[str] | None:
    """The lower-case column names of a delimited file's header (None: binary, or no header)."""
    from .delimited import rows  # noqa: PLC0415
    from .text import decode, read_bytes  # noqa: PLC0415

    try:
        lines = decode(read_bytes(path, "data file", head=65536), str(path)).splitlines()
    except DenavitError:  # a binary bag, or UTF-8 cut mid-character by the 64 kB window: not a delimited file of ours
        return None
    first = next((k for k, ln in enumerate(lines[:50]) if ln.strip() and not ln.lstrip().startswith("#")), None)
    if first is None:
        return None
    found, _ = rows(lines[: first + 1], str(path))  # the header alone: the 64 kB window may cut the next line
    return [c.lower() for c in found[0][1]] if found else None


def is_sweep_file(p: Path) -> bool:
    """Our own sweep formats (read by :mod:`denavit.io.sweeps`): a folder of ``jN.csv`` (no ROS 2 bag's
    ``metadata.yaml``), JSON, or a delimited file whose header has a ``joint`` column; anything else is a recording."""
    return (
        p.suffix.lower() == ".json"
        or (p.is_dir() and not (p / "metadata.yaml").exists())
        or (p.is_file() and "joint" in (header(p) or []))
    )


def is_measurement_file(p: Path) -> bool:
    """Our own measurement formats (read by :func:`denavit.io.measurements.read_measurements`): JSON, or a
    delimited file whose header has ``q1`` and ``x`` (or a sweep file's ``joint``); anything else is a recording."""
    if p.suffix.lower() == ".json":
        return True
    cols = None if p.is_dir() else (header(p) or [])
    return cols is not None and (("q1" in cols and "x" in cols) or "joint" in cols)
