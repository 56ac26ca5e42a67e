"""Point lists exported by laser-tracker software (SpatialAnalyzer, PolyWorks, Leica Tracker Pilot style).

A delimited table (comma, semicolon, tab or whitespace) with a header naming the columns, case-insensitive:
``Collection``, ``Group``, ``Point`` / ``Name`` / ``Point Name`` / ``Target`` (one of these at least), ``X``,
``Y``, ``Z``, optionally a time (``Time`` / ``Timestamp`` / ``t``) and a 6-DoF probe's orientation (``Qw Qx Qy
Qz`` / ``Q0 Q1 Q2 Q3``, scalar first, or a rotation vector ``Rx Ry Rz``). Units: a ``# units: length=mm``
line, a unit in the column name (``X [mm]``, ``X (mm)``, ``Time [s]``), or the ``length`` / ``angle``
arguments (the file wins).

The sweep of each point (which joint moved) comes from, in this order: ``sweep="group"`` (the group
column: ``J1``, ``A2``, ``Joint 3``, ``Axis4``, ``5``), a regular expression with a named group ``joint``
(and optionally ``index``, the pose's number, and ``target``, the SMR on the nest) matched against the point
name, or, when not given, a guess: the group column if every group names a joint, else the point names by
:data:`NAME_PATTERN` (``J1_001``, ``A2-17``, ``J1_001_B``). Rows with the same joint and index but
different targets are one pose with several targets (2-4 SMRs on a nest). The choice is echoed in the
Recording's notes.
"""

from __future__ import annotations

import os
import re
from pathlib import Path

import numpy as np

from ...errors import DenavitError
from ..text import read_text
from ..units import input_units, length_scale, parse_declaration, time_scale
from .columns import data_lines, numbers, poses_of, split

#: Point names such as ``J1_001``, ``A2-17``, ``Joint3.5``, ``J1_001_B`` (joint, pose index, target).
NAME_PATTERN = (
    r"(?i)^(?:j|a|joint|axis)\s*[_-]?(?P<joint>\d+)[\s_.:-]+(?P<index>\d+)(?:[\s_.:-]+(?P<target>[A-Za-z0-9]+))?$"
)
GROUP_PATTERN = re.compile(r"(?i)^(?:j|a|joint|axis)?\s*[_-]?(\d+)$")
NAMES = {
    "point": "name",
    "name": "name",
    "point name": "name",
    "pointname": "name",
    "target": "name",
    "label": "name",
    "group": "group",
    "collection": "collection",
    "time": "time",
    "timestamp": "time",
    "t": "time",
    "x": "x",
    "y": "y",
    "z": "z",
    "qw": "qw",
    "qx": "qx",
    "qy": "qy",
    "qz": "qz",
    "q0": "qw",
    "q1": "qx",
    "q2": "qy",
    "q3": "qz",
    "rx": "rx",
    "ry": "ry",
    "rz": "rz",
}
UNIT_IN_NAME = re.compile(r"^(.*?)\s*[\[(]\s*([A-Za-z]+)\s*[\])]\s*$")


def _header(cells: list[str]) -> tuple[dict[str, int], dict[str, str]]:
    """Column roles (name -> index) and the units the names carry."""
    roles, units = {}, {}
    for i, c in enumerate(cells):
        m = UNIT_IN_NAME.match(c)
        base, unit = (m.group(1), m.group(2)) if m else (c, None)
        role = NAMES.get(base.strip().lower())
        if role and role not in roles:
            roles[role] = i
            if unit:
                units[role] = unit
    return roles, units


def is_tracker(header: str) -> bool:
    delim = "\t" if "\t" in header else ";" if ";" in header else "," if "," in header else None
    roles, _ = _header(split(header, delim))
    return all(r in roles for r in "xyz") and any(r in roles for r in ("name", "group", "collection"))


def read(
    path: str | os.PathLike,
    *,
    sweep: str | None = None,
    length: str | None = None,
    angle: str | None = None,
    time: str | None = None,
    text: str | None = None,
):
    """Read a tracker point list: a Recording with points (N, k, 3) m, the joint of each row, time when given."""
    from ...recording import Recording, check_time  # noqa: PLC0415

    path = Path(path)
    text = read_text(path, "recording", lines=True) if text is None else text
    lines = data_lines(text)
    if not lines:
        raise DenavitError(f"{path}: empty: expected a header such as 'Collection,Group,Point,X,Y,Z'")
    hln, header = lines[0]
    delim = "\t" if "\t" in header else ";" if ";" in header else "," if "," in header else None
    roles, named = _header(split(header, delim))
    missing = [c.upper() for c in "xyz" if c not in roles]
    if missing or not any(r in roles for r in ("name", "group")):
        raise DenavitError(
            f"{path}:{hln}: tracker header lacks {', '.join(missing) or 'a Point/Name or Group column'}: expected e.g."
            f" 'Collection,Group,Point,X,Y,Z' (got {header.strip()[:80]!r})"
        )
    lunits = {named[r] for r in "xyz" if r in named}
    if len(lunits) > 1:
        raise DenavitError(f"{path}:{hln}: X, Y, Z carry different units {sorted(lunits)}: expected one length unit")
    declared = parse_declaration(text.splitlines(), str(path))
    if lunits and "length" not in declared:
        declared["length"] = lunits.pop().lower()
    rot = [r for r in ("rx", "ry", "rz") if r in roles]
    units = input_units(declared, length, angle, str(path), ("length", "angle") if rot else ("length",))
    ts = time_scale(time or named.get("time") or declared.get("time", "s"), str(path))
    rows = [(ln, split(line, delim)) for ln, line in lines[1:]]
    width = len(split(header, delim))
    for ln, cells in rows:
        if len(cells) != width:
            raise DenavitError(f"{path}:{ln}: expected {width} values (as the header), got {len(cells)}")
    if not rows:
        raise DenavitError(f"{path}: a header but no points")
    xyz = numbers(rows, [roles[c] for c in "xyz"], ["X", "Y", "Z"], str(path)) * length_scale(
        units["length"], str(path)
    )
    names = [cells[roles["name"]] for _, cells in rows] if "name" in roles else None
    groups = [cells[roles["group"]] for _, cells in rows] if "group" in roles else None
    notes = []
    joint, index, target = _labels(path, rows, names, groups, sweep, notes)
    # poses: rows sharing (joint, index) are the targets of one pose
    keys = list(dict.fromkeys(zip(joint, index)))
    targets = sorted(set(target))
    k = len(targets)
    pos = {key: i for i, key in enumerate(keys)}
    P = np.full((len(keys), k, 3), np.nan)
    first = [None] * len(keys)
    tcol = numbers(rows, [roles["time"]], ["Time"], str(path))[:, 0] * ts if "time" in roles else None
    tt = np.zeros(len(keys))
    for r, (key, tg) in enumerate(zip(zip(joint, index), target)):
        i, c = pos[key], targets.index(tg)
        if not np.isnan(P[i, c, 0]):
            raise DenavitError(
                f"{path}:{rows[r][0]}: a second point for joint {key[0]} pose {key[1]} target {tg or '-'}: expected one"
            )
        P[i, c] = xyz[r]
        if first[i] is None:
            first[i] = r
        if tcol is not None:
            tt[i] += tcol[r] / k
    incomplete = [i for i in range(len(keys)) if np.isnan(P[i]).any()]
    if incomplete:
        i = incomplete[0]
        raise DenavitError(
            f"{path}:{rows[first[i]][0]}: joint {keys[i][0]} pose {keys[i][1]} lacks target(s)"
            f" {', '.join(t for c, t in enumerate(targets) if np.isnan(P[i, c, 0]))}: expected all of"
            f" {', '.join(targets)}"
        )
    where = [f"{path}:{rows[r][0]}" for r in first]
    if k > 1:
        notes.append(f"{path}: {k} targets per pose ({', '.join(targets)})")
    poses = None
    kind = "quaternion" if all(r in roles for r in ("qw", "qx", "qy", "qz")) else "rotvec" if len(rot) == 3 else None
    if kind:
        if k != 1:
            raise DenavitError(f"{path}: a 6-DoF probe has one position per pose, got {k} targets")
        cols = ["qw", "qx", "qy", "qz"] if kind == "quaternion" else rot
        o = numbers(rows, [roles[c] for c in cols], cols, str(path))[[first[i] for i in range(len(keys))]]
        if kind == "rotvec":
            from ..units import angle_scale  # noqa: PLC0415

            o = o * angle_scale(units["angle"], str(path))
        poses = poses_of(P[:, 0], o, kind, str(path))
    t = None
    if tcol is not None:
        t = tt
        check_time(t, where)
    return Recording(
        t, None, P, where, str(path), "tracker", units, poses, joint=np.array([key[0] for key in keys]), notes=notes
    )


def _labels(path, rows, names, groups, sweep, notes):
    """(joint, index, target) of every row, from ``sweep`` or a guess; the choice goes to ``notes``."""
    n = len(rows)
    if sweep == "group" or (sweep is None and groups is not None and all(GROUP_PATTERN.match(g) for g in groups)):
        if groups is None:
            raise DenavitError(f"{path}: sweep='group' but the file has no Group column")
        joint = []
        for (ln, _), g in zip(rows, groups):
            m = GROUP_PATTERN.match(g)
            if not m:
                raise DenavitError(f"{path}:{ln}: group {g[:40]!r} names no joint: expected e.g. J1, A2, Joint 3")
            joint.append(int(m.group(1)))
        # within a group, a point name's trailing target letter (J1_001_B) or nothing
        index, target = [], []
        for r in range(n):
            m = re.match(NAME_PATTERN, names[r]) if names else None
            index.append(int(m.group("index")) if m else r)
            target.append((m.group("target") or "") if m else "")
        notes.append(f"{path}: sweeps from the Group column{' (guessed)' if sweep is None else ''}")
        return joint, index, target
    if names is None:
        raise DenavitError(
            f"{path}: no point names to take the sweeps from and the groups name no joint: expected a Point column such"
            " as J1_001 or groups J1, J2, ..."
        )
    pattern = sweep or NAME_PATTERN
    try:
        rx = re.compile(pattern)
    except re.error as e:
        raise DenavitError(f"--sweep: not a regular expression: {pattern[:60]!r}: {e}") from None
    if "joint" not in rx.groupindex:
        raise DenavitError(
            f"--sweep: the pattern {pattern[:60]!r} has no group (?P<joint>...): expected e.g."
            " 'J(?P<joint>\\d+)_(?P<index>\\d+)'"
        )
    joint, index, target = [], [], []
    for r, ((ln, _), name) in enumerate(zip(rows, names)):
        m = rx.match(name)
        if not m:
            raise DenavitError(
                f"{path}:{ln}: point name {name[:40]!r} does not match the sweep pattern {pattern[:60]!r}: expected"
                " e.g. J1_001 or A2-17"
            )
        joint.append(int(m.group("joint")))
        index.append(int(m.group("index")) if "index" in rx.groupindex and m.group("index") else r)
        target.append((m.group("target") or "") if "target" in rx.groupindex else "")
    notes.append(
        f"{path}: sweeps from the point names by the pattern {pattern!r}{' (guessed)' if sweep is None else ''}"
    )
    return joint, index, target
