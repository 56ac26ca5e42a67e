"""Readers of what comes out of the instruments: tracker exports, controller logs, ROS bags, delimited files.

:func:`read_recording` picks the reader from the content (or ``format``), says which it used (the
Recording's ``format`` and first note), and returns a :class:`denavit.recording.Recording` (SI inside).
One module per format: :mod:`.tracker`, :mod:`.rtde`, :mod:`.rsi`, :mod:`.bag`, :mod:`.columns`.
"""

from __future__ import annotations

import os
import re
from pathlib import Path

from ...errors import DenavitError

FORMATS = ("auto", "tracker", "rtde", "rsi", "bag", "columns")
BAG_MAGIC = {
    b"#ROSBAG V2.0": "a ROS 1 bag",
    b"\x89MCAP0\r\n": "an MCAP file",
    b"SQLite format 3\x00": "a ROS 2 sqlite3 bag",
}


def detect(path: str | os.PathLike, *, columns: str | None = None) -> tuple[str, str]:
    """(format, why) of the file at ``path``, from its content; a one-line error when nothing fits."""
    from ..text import decode, read_bytes  # noqa: PLC0415
    from .columns import data_lines  # noqa: PLC0415
    from .rsi import is_rsi  # noqa: PLC0415
    from .rtde import is_rtde  # noqa: PLC0415
    from .tracker import is_tracker  # noqa: PLC0415

    p = Path(path)
    if p.is_dir():
        if (p / "metadata.yaml").exists():
            return "bag", "a ROS 2 bag folder (metadata.yaml)"
        raise DenavitError(f"{p}: a folder without metadata.yaml: expected a recording file or a ROS 2 bag folder")
    head = read_bytes(p, "recording", head=64)
    for magic, what in BAG_MAGIC.items():
        if head.startswith(magic):
            return "bag", what
    data = read_bytes(p, "recording", lines=True)
    text = decode(data, str(p))
    lines = data_lines(text)
    if not lines:
        raise DenavitError(
            f"{p}: an empty file (no data lines): expected a recording (a tracker export, a UR RTDE log, a KUKA RSI"
            " log, a ROS bag, or a delimited file with --columns)"
        )
    header = lines[0][1]
    if re.search(r"(^|[\s,;])joint([\s,;]|$)", header.strip().lower()) and not columns:
        raise DenavitError(
            f"{p}: a sweep file (denavit's long-form CSV with a 'joint' column, as `denavit simulate` writes), not a "
            f"recording: `denavit identify {p} --nominal MODEL` reads it as it is"
        )
    if is_rtde(header):
        return "rtde", "header 'timestamp actual_q_0 ...' (UR RTDE)"
    if is_rsi(text):
        return "rsi", "<Rob> records with AIPos / RIst (KUKA RSI)"
    if is_tracker(header):
        return "tracker", "a header with point names or groups and X, Y, Z (tracker export)"
    if columns:
        return "columns", f"the column map {columns!r}"
    raise DenavitError(
        f"{p}: unknown recording format: expected a tracker export (header with Point/Group and X, Y, Z), a UR RTDE log"
        " (header 'timestamp actual_q_0 ...'), a KUKA RSI log (<Rob> records), a ROS bag, or a delimited file with"
        f" --columns (first line {header.strip()[:60]!r})"
    )


def read_recording(
    path: str | os.PathLike,
    format: str = "auto",
    *,
    columns: str | None = None,
    length: str | None = None,
    angle: str | None = None,
    time: str | None = None,
    sweep: str | None = None,
    kinds: list[str] | None = None,
    **bag_options,
):
    """Read a recording with the reader of ``format`` ("auto": detected from the content, see :func:`detect`).

    columns : the column map of a delimited file (:mod:`.columns`). length / angle / time : units for what
    the file does not declare. sweep : a tracker export's sweep source ("group" or a name pattern).
    bag_options : ``joint_topic``, ``point_topic``, ``child_frame``, ``joint_names`` (:mod:`.bag`).
    """
    from ...recording import Recording  # noqa: PLC0415

    if format not in FORMATS:
        raise DenavitError(f"unknown format {format!r}: expected one of {', '.join(FORMATS)}")
    p = Path(path)
    if not p.exists():
        raise DenavitError(f"{p}: no such file or folder")
    if format == "auto":
        format, why = detect(p, columns=columns)
        said = f"{p}: format {format} (detected: {why})"
    else:
        said = f"{p}: format {format} (given)"
    if format == "bag":
        from .bag import read  # noqa: PLC0415

        rec = read(p, **bag_options)
    elif format == "columns":
        if not columns:
            raise DenavitError(f"{p}: format 'columns' needs a column map, e.g. --columns \"t,q1..q6,x,y,z\"")
        from .columns import read  # noqa: PLC0415

        rec = read(p, columns=columns, length=length, angle=angle, time=time, kinds=kinds)
    elif format == "tracker":
        from .tracker import read  # noqa: PLC0415

        rec = read(p, sweep=sweep, length=length, angle=angle, time=time)
    elif format == "rtde":
        from .rtde import read  # noqa: PLC0415

        rec = read(p)
    else:
        from .rsi import read  # noqa: PLC0415

        rec = read(p)
    return Recording(
        rec.time,
        rec.q,
        rec.points,
        rec.where,
        rec.source,
        rec.format,
        rec.units,
        rec.poses,
        rec.kinds,
        rec.joint,
        rec.names,
        [said, *rec.notes],
    )
