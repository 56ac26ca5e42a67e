"""Universal Robots RTDE logs, as written by UR's RTDE client ``record.py``.

Format (UR's RTDE Python client library, ``rtde/csv_writer.py``, github.com/UniversalRobots/RTDE_Python_Client_Library,
and the RTDE guide, universal-robots.com/articles/ur/interface-communication/real-time-data-exchange-rtde-guide/):
one header line of the recipe's output names, a vector of size k written as ``name_0 .. name_{k-1}``; then
one row per sample; cells separated by a single space (``csv.writer(delimiter=" ")``, lines ended by CRLF).
This reader uses ``timestamp`` (s since the controller started), ``actual_q_0 .. actual_q_5`` (joint
positions, rad) and, when present, ``actual_TCP_pose_0 .. actual_TCP_pose_5`` (TCP position, m, and
orientation as a rotation vector, rad, in the base frame). Other columns are ignored. A comma or semicolon
separated file with the same names is read as well.
"""

from __future__ import annotations

import os
import re
from pathlib import Path

from ...errors import DenavitError
from ..text import read_text
from .columns import data_lines, delimiter_of, numbers, poses_of, split


def is_rtde(header: str) -> bool:
    cells = split(header, delimiter_of(header))
    return "timestamp" in cells and ("actual_q_0" in cells or "actual_TCP_pose_0" in cells)


def read(path: str | os.PathLike, *, text: str | None = None, joints: str = "actual_q", pose: str = "actual_TCP_pose"):
    """Read an RTDE log: a Recording with time (s), readings (rad) and TCP poses (m) when the log has them.

    joints / pose : the recipe fields to read (e.g. ``target_q``).
    """
    from ...recording import Recording, check_time  # noqa: PLC0415

    path = Path(path)
    text = read_text(path, "recording", lines=True) if text is None else text
    lines = data_lines(text)
    if not lines:
        raise DenavitError(f"{path}: empty: expected an RTDE header 'timestamp actual_q_0 ... actual_TCP_pose_5'")
    hln, header = lines[0]
    delim = delimiter_of(header)
    names = split(header, delim)
    col = {c: i for i, c in enumerate(names)}
    qn = sorted((c for c in names if re.fullmatch(rf"{joints}_\d+", c)), key=lambda c: int(c.rsplit("_", 1)[1]))
    need = ["timestamp", *(qn or [f"{joints}_0"])]
    missing = [c for c in need if c not in col]
    if missing:
        shown = " ".join(names)[:80]
        raise DenavitError(
            f"{path}:{hln}: RTDE header lacks {', '.join(missing)}: expected 'timestamp {joints}_0 .. {joints}_5' (got"
            f" {shown!r})"
        )
    pn = [f"{pose}_{i}" for i in range(6)]
    has_pose = all(c in col for c in pn)
    rows = [(ln, split(line, delim)) for ln, line in lines[1:]]
    for ln, cells in rows:
        if len(cells) != len(names):
            raise DenavitError(f"{path}:{ln}: expected {len(names)} values (as the header), got {len(cells)}")
    if not rows:
        raise DenavitError(f"{path}: an RTDE header but no samples")
    where = [f"{path}:{ln}" for ln, _ in rows]
    t = numbers(rows, [col["timestamp"]], ["timestamp"], str(path))[:, 0]
    check_time(t, where, "timestamp")
    q = numbers(rows, [col[c] for c in qn], qn, str(path))
    points = poses = None
    if has_pose:
        p = numbers(rows, [col[c] for c in pn], pn, str(path))
        poses = poses_of(p[:, :3], p[:, 3:], "rotvec", str(path))
        points = p[:, None, :3]
    notes = [f"{path}: RTDE fields {joints}_0..{len(qn) - 1}" + (f" and {pose}_0..5" if has_pose else " (no TCP pose)")]
    return Recording(
        t,
        q,
        points,
        where,
        str(path),
        "rtde",
        {"length": "m", "angle": "rad", "time": "s"},
        poses,
        ["revolute"] * len(qn),
        notes=notes,
    )
