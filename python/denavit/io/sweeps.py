"""Sweep files (docs/robot-files.md, "Sweep data"): the long-form CSV, a folder of per-joint ``jN.csv`` files, JSON;
and the long-form CSV and JSON writers. The data model is :mod:`denavit.sweeps`.

One units rule for every format (:func:`denavit.io.units.input_units`): what the file declares (a
``# units:`` line, :func:`~denavit.io.units.parse_declaration`; JSON: its ``"units"`` object) wins, the
``length`` / ``angle`` given by the caller (the command line's ``--length`` / ``--angle``) only fill what the
file does not declare. Joint values take the angle unit for a revolute joint and the length unit for a
prismatic one (:func:`~denavit.io.units.joint_scale`). Text is decoded by :mod:`denavit.io.text` and split by
the standard :mod:`csv` module.
"""

from __future__ import annotations

import csv
import io
import math
import os
import re
from collections.abc import Iterable, Iterator, Sequence
from dataclasses import replace
from pathlib import Path

import numpy as np

from ..errors import DenavitError
from ..sweeps import Sweep, SweepSet
from . import delimited as dl
from .json_values import (
    PAYLOAD_KEYS,
    check_keys,
    json_array,
    json_lengths,
    json_payload,
    json_payload_doc,
    load_json,
    show_value,
)
from .payload import PAYLOAD_COLUMNS, payload_from_columns
from .text import decode, read_bytes, read_text
from .units import input_units, joint_scale, length_scale, parse_declaration

KINDS = ("revolute", "prismatic")


def _kinds(kinds, n: int, where: str, what: str) -> list[str]:
    kinds = list(kinds) if kinds else ["revolute"] * n
    if len(kinds) != n:
        raise DenavitError(f"{where}: {n} joints in {what} but {len(kinds)} joint kinds given")
    return kinds


class FileLines(Sequence):
    """The ``"file:line"`` of each point (:attr:`denavit.sweeps.Sweep.where`) as the file name and an array of
    line numbers: a sequence of strings made when asked for, not millions of them held (a 1e6-row sweep's
    ``where`` costs 8 MB instead of 80). Slices and integer arrays give FileLines again."""

    __slots__ = ("source", "lines")

    def __init__(self, source: str, lines):
        self.source = source
        self.lines = np.asarray(lines, dtype=np.int64)

    def __len__(self) -> int:
        return len(self.lines)

    def __getitem__(self, k):
        if isinstance(k, slice) or (isinstance(k, np.ndarray) and k.ndim == 1):
            return FileLines(self.source, self.lines[k])
        return f"{self.source}:{self.lines[k]}"

    def __repr__(self) -> str:
        return f"FileLines({self.source!r}, {len(self)} lines)"


#: The orientation columns of a 6-DoF pose per row (unit quaternion, scalar first).
QUATERNION = ("qw", "qx", "qy", "qz")


def _long_header(rows: list, where: str) -> tuple[list[str], int, list[str], int, bool]:
    """(column names, number of joints, the columns needed, targets per row, whether rows carry a quaternion) of the
    long form's header row, checked."""
    hline, header = rows[0]
    cols = dl.header(header, f"{where}:{hline}")
    n = len([c for c in cols if re.fullmatch(r"q\d+", c)])
    k = 1 + len([c for c in cols if re.fullmatch(r"x\d+", c)])
    quat = any(c in cols for c in QUATERNION)
    pay = [c for c in PAYLOAD_COLUMNS if c in cols]  # a payload per point (issue 37), after everything else
    if pay and "payload_mass" not in pay:
        raise DenavitError(
            f"{where}:{hline}: {', '.join(pay)} without payload_mass: give the payload's mass (kg) with its centre of"
            " mass"
        )
    need = [
        "joint",
        *[f"q{i}" for i in range(1, n + 1)],
        "x",
        "y",
        "z",
        *[f"{a}{t}" for t in range(2, k + 1) for a in "xyz"],
        *(QUATERNION if quat else ()),
        *pay,
    ]
    missing = [c for c in need if c not in cols]
    unknown = [c for c in cols if c not in need and c != "time"]
    if missing or unknown or n == 0:
        what = (
            f"missing {', '.join(missing) or 'q columns'}"
            if missing or n == 0
            else f"unknown column(s) {', '.join(unknown)}"
        )
        raise DenavitError(
            f"{where}:{hline}: header must be 'joint,q1,...,qn,x,y,z' (optional 'time'; further targets x2,y2,z2,...; a"
            f" pose's orientation qw,qx,qy,qz; a payload payload_mass[,payload_x,payload_y,payload_z]); {what}, got"
            f" {','.join(header)!r}"
        )
    return cols, n, need, k, quat


NEST_RE = re.compile(r"^\s*#\s*nest\s*:(.*)$", re.IGNORECASE)


def parse_nest(lines, k: int, ls: float, where: str):
    """The ``# nest: x1,y1,z1; x2,y2,z2; ...`` line (the targets' positions in the tool frame, in the file's length
    unit) as (k, 3) m, or None when the file declares none."""
    for ln, line in enumerate(lines, 1):
        m = NEST_RE.match(line)
        if not m:
            continue
        here = f"{where}:{ln}"
        parts = [p for p in m.group(1).split(";") if p.strip()]
        try:
            pts = np.array([[float(v) for v in p.replace(",", " ").split()] for p in parts], dtype=float)
        except ValueError:
            raise DenavitError(
                f"{here}: nest: expected 'x1,y1,z1; x2,y2,z2; ...' (numbers, the file's length unit), got"
                f" {m.group(1).strip()[:60]!r}"
            ) from None
        if pts.shape != (k, 3) or not np.isfinite(pts).all():
            raise DenavitError(
                f"{here}: nest: expected {k} points of 3 coordinates (one per target of the header), got"
                f" {m.group(1).strip()[:60]!r}"
            )
        return pts * ls
    return None


def read_long_csv(
    path: str | os.PathLike,
    *,
    length: str | None = None,
    angle: str | None = None,
    kinds: list[str] | None = None,
    home=None,
) -> SweepSet:
    """Read the long-form CSV: header ``joint,q1,...,qn,x,y,z`` (optional ``time``), one row per point.

    ``joint`` is the moving joint's 1-based index; q1..qn every joint reading at that instant; x, y, z the
    point. Units: the file's ``# units: length=mm angle=deg`` line, else ``length`` / ``angle``. ``kinds``
    (default all revolute) say which readings are lengths. ``home`` (SI) defaults to the readings of the
    locked joints.

    The data rows are parsed at C speed, column-wise, when they are plain numbers
    (:func:`~denavit.io.delimited.plain_columns`: Arrow's CSV reader on every core, without holding the file's text;
    docs/speed.md, "Reading and writing sweep files"); otherwise, and whenever a value is wrong, row by row, each cell
    by :func:`~denavit.io.delimited.number`, the error naming the line and the column.
    """
    where = str(path)
    fast = _fast_long(path, where)
    lines = fast[0].lines if fast else _whole(path, where)
    units = input_units(parse_declaration(lines, where), length, angle, where)
    rows, _ = dl.rows(lines, where)
    if not rows:
        raise DenavitError(f"{where}: no header and no data: expected a header 'joint,q1,...,qn,x,y,z'")
    cols, n, need, k_t, quat = _long_header(rows, where)
    kinds = _kinds(kinds, n, where, "the header")
    qscale = joint_scale(kinds, units["length"], units["angle"], where)
    ls = length_scale(units["length"], where)
    npay = len([c for c in need if c in PAYLOAD_COLUMNS])
    if fast:
        got, line = fast[1], fast[0].line + np.arange(len(fast[1][0]))
    else:
        table, line = _slow_long(rows[1:], cols, need, [cols.index(c) for c in need], where)
        got = [np.ascontiguousarray(table[:, a:b]) for a, b in _groups(n, k_t, quat, len(need))]
        del table
    del fast
    joint, q, pts, quats, pays = got
    joint = joint[:, 0]
    q *= qscale  # in place: the sweeps are views of these arrays (a sweep's rows are one block in the usual layout)
    pts *= ls
    starts = _blocks(joint)
    ends = np.r_[starts[1:], len(joint)]
    if len(np.unique(joint[starts])) == len(starts):  # each joint's rows one block (the usual layout): slices
        picks = {int(joint[a]): slice(a, b) for a, b in zip(starts, ends)}
    else:
        picks = {int(j): np.flatnonzero(joint == j) for j in np.unique(joint[starts])}
    far = np.abs(pts) > dl.MAX_LENGTH  # a 1e308 mm point had overflowed the fits
    if far.any():
        r, c = np.argwhere(far)[0]
        dl.far(pts[r, c], f"{where}:{line[r]}: column {need[n + 1 + c]!r}")
    rot = None
    if quat:
        from .recordings.columns import poses_of  # noqa: PLC0415 (scipy's rotations)

        bad = np.flatnonzero(np.abs(np.linalg.norm(quats, axis=1) - 1) > 1e-6)
        if bad.size:
            raise DenavitError(
                f"{where}:{line[bad[0]]}: quaternion norm {np.linalg.norm(quats[bad[0]]):.6g}: expected a unit"
                " quaternion (qw, qx, qy, qz)"
            )
        rot = poses_of(np.zeros((len(quats), 3)), quats, "quaternion", where)[:, :3, :3]
    payload = (
        payload_from_columns(
            pays,
            {c: i for i, c in enumerate(need[len(need) - npay :])},
            ls,
            FileLines(where, line),
            units.get("mass", "kg"),
        )
        if npay
        else None
    )
    sweeps = {}
    for j, k in picks.items():
        p = pts[k]
        sweeps[j] = Sweep(
            j,
            p if k_t == 1 else np.ascontiguousarray(p[:, :3]),
            q[k],
            FileLines(where, line[k]),
            p.reshape(len(p), k_t, 3) if k_t > 1 else None,
            None if rot is None else rot[k],
            None if payload is None else payload[k],
        )
    out = [sweeps[j] for j in sorted(sweeps)]
    nest = parse_nest(lines, k_t, ls, where) if k_t > 1 else None
    every = SweepSet(out, n, np.zeros(n), kinds, where, units, nest)  # one sweep of each joint (or a one-line error)
    if home is None:
        # the locked joints' readings: the median over the sweeps in which each joint does not move
        home = np.array(
            [
                np.median(np.concatenate([s.q[:, i] for s in out if s.joint != i + 1])) if n > 1 else 0.0
                for i in range(n)
            ]
        )
    return replace(every, home=np.asarray(home, dtype=float))


def _groups(n: int, k_t: int, quat: bool, width: int) -> list[tuple[int, int]]:
    """The column ranges of the long form's needed columns (:func:`_long_header`): joint, q1..qn, the targets'
    x, y, z, the quaternion, the payload."""
    cut = [0, 1, n + 1, n + 1 + 3 * k_t, n + 1 + 3 * k_t + 4 * quat, width]
    return list(zip(cut[:-1], cut[1:]))


def _fast_long(path, where: str):
    """(the file's :class:`~denavit.io.delimited.Head`, its needed columns by :func:`_groups`, in file units) of a
    long-form sweep file whose header is right and whose rows are plain numbers with valid joint indices, read at C
    speed (:func:`~denavit.io.delimited.plain_columns`); None for anything else (the whole-file reader's errors)."""
    head = dl.plain_head(path, "sweep file")
    if head is None:
        return None
    try:
        rows, delim = dl.rows(head.lines, where)
        cols, n, need, k_t, quat = _long_header(rows, where)
    except (DenavitError, IndexError):
        return None
    take = [cols.index(c) for c in need]
    got = dl.plain_columns(path, head, delim, len(cols), [take[a:b] for a, b in _groups(n, k_t, quat, len(need))])
    if got is None:
        return None
    jv = got[0][_blocks(got[0][:, 0]), 0]  # every row's joint value is one of its block's
    if not np.all((jv == np.round(jv)) & (jv >= 1) & (jv <= n)):  # the row-by-row reader names the row
        return None
    return head, got


def _whole(path, where: str) -> list[str]:
    """The lines of a sweep file read whole (its size and line lengths checked, decoded: one-line errors)."""
    return decode(read_bytes(path, "sweep file", lines=True), where).splitlines()


def _blocks(joint: np.ndarray) -> np.ndarray:
    """The first row of each run of equal values of ``joint`` (none when there are no rows)."""
    return np.r_[0, np.flatnonzero(joint[1:] != joint[:-1]) + 1] if len(joint) else np.zeros(0, dtype=int)


def _columns(idx: list[int]):
    """Column indices as a slice when consecutive (a view, not a copy)."""
    return slice(idx[0], idx[-1] + 1) if idx == list(range(idx[0], idx[-1] + 1)) else idx


def _slow_long(
    rows: list, cols: list[str], names: list[str], take: list[int], where: str
) -> tuple[np.ndarray, np.ndarray]:
    """The data rows cell by cell: (m, len(names)) [joint, q, xyz, ...] in file units and the line numbers; the first
    wrong cell is an error naming its line and column."""
    table = np.empty((len(rows), len(take)))
    line = np.empty(len(rows), dtype=np.int64)
    n = len([c for c in names if re.fullmatch(r"q\d+", c)])
    for r, (ln, cells) in enumerate(rows):
        at = f"{where}:{ln}"
        if len(cells) != len(cols):
            raise DenavitError(f"{at}: expected {len(cols)} values, got {len(cells)}")
        jtext = cells[take[0]]
        if not (dl.is_number(jtext) or dl.NON_FINITE.fullmatch(jtext)):  # inf, nan: out of range below
            raise DenavitError(f"{at}: column 'joint' must be a joint index 1..{n}, got {jtext[:40]!r}")
        jv = float(jtext)
        if not (math.isfinite(jv) and jv == round(jv) and 1 <= jv <= n):
            raise DenavitError(f"{at}: joint index out of range: expected 1..{n}, got {jtext}")
        table[r, 0] = jv
        table[r, 1:] = [dl.number(cells[i], at, c) for i, c in zip(take[1:], names[1:])]
        line[r] = ln
    return table, line


_JOINT_FILE = re.compile(r"j(\d+)\.csv", re.IGNORECASE)


def _joint_file(f: Path, length: str | None) -> tuple[np.ndarray, list[str]]:
    """The points (m) of one ``jN.csv``: columns x, y, z (and an optional time), by header names if the file
    has a header (a first line of names), else by position (x,y,z or time,x,y,z)."""
    where = str(f)
    lines = read_text(f, "sweep file", lines=True).splitlines()
    ls = length_scale(
        input_units(parse_declaration(lines, where), length, None, where, need=("length",))["length"], where
    )
    rows, delim = dl.rows(lines, where)
    cols = None
    if rows and not any(dl.is_number(c) for c in rows[0][1]):
        ln, header = rows.pop(0)
        cols = dl.header(header, f"{where}:{ln}")
        unknown = [c for c in cols if c not in ("time", "x", "y", "z")]
        if unknown or not all(c in cols for c in "xyz"):
            raise DenavitError(
                f"{where}:{ln}: header must name x, y, z (and optionally time), got {','.join(header)!r}"
            )
    pts, at = [], []
    for ln, cells in rows:
        names = cols or (["x", "y", "z"] if len(cells) == 3 else ["time", "x", "y", "z"])
        if len(cells) != len(names) or len(cells) not in (3, 4):
            expected = f"{len(names)} values ({','.join(names)})" if cols else "3 values (x,y,z) or 4 (time,x,y,z)"
            raise DenavitError(
                f"{where}:{ln}: expected {expected} separated by {delim!r}, got {len(cells)}: {delim.join(cells)!r}"
            )
        vals = {
            name: dl.length(c, f"{where}:{ln}", name, ls if name in "xyz" else 1.0) for c, name in zip(cells, names)
        }
        pts.append([vals[c] for c in "xyz"])
        at.append(f"{where}:{ln}")
    return np.array(pts, dtype=float).reshape(-1, 3), at


def read_joint_files(
    folder: str | os.PathLike,
    *,
    home,
    length: str | None,
    angle: str | None = "deg",
    direction=1,
    kinds: list[str] | None = None,
) -> SweepSet:
    """Read one file per joint (``j1.csv`` ... ``jN.csv``): x,y,z per row, optionally a time column.

    Only files named exactly ``j<N>.csv`` count (``j1_old.csv`` is not a sweep). Comma or semicolon separated
    (the first line that is not a ``#`` comment decides), optional header (a line of names, none of them a
    number: then its names say which column is which). A file's ``# units:`` line gives its length unit, else
    ``length``. Without joint readings, the sweep direction gives the axis orientation: ``direction`` (+1 or
    -1, or one per joint) says whether the joint value increased over the recording. ``home`` is in ``angle``
    units (revolute) / ``length`` units (prismatic), as ``kinds`` say (default all revolute).
    """
    folder = Path(folder)
    files: dict[int, Path] = {}
    for f in sorted(folder.iterdir()):
        m = _JOINT_FILE.fullmatch(f.name)
        if m and f.is_file():
            j = int(m.group(1))
            if j in files:
                raise DenavitError(
                    f"{folder}: two files for joint {j}: {files[j].name} and {f.name}: expected one j{j}.csv"
                )
            files[j] = f
    if not files:
        raise DenavitError(f"{folder}: no per-joint files j1.csv ... jN.csv found")
    try:
        home = np.atleast_1d(np.asarray(home, dtype=float))
    except (TypeError, ValueError):
        raise DenavitError(f"--home: expected one number per joint, got {home!r}") from None
    if home.ndim != 1 or not np.all(np.isfinite(home)):
        raise DenavitError(f"--home: expected one finite number per joint, got {home.tolist()}")
    n = len(home)
    kinds = _kinds(kinds, n, str(folder), "--home")
    units = input_units(
        {}, length, angle, str(folder), need=("length", "angle") if "revolute" in kinds else ("length",)
    )
    homes = home * joint_scale(kinds, units["length"], units.get("angle", "rad"), "--home")
    try:
        dirs = np.atleast_1d(np.asarray(direction, dtype=float))
    except (TypeError, ValueError):
        raise DenavitError(
            f"--direction: expected +1 or -1, one for all joints or one per joint, got {direction!r}"
        ) from None
    if dirs.ndim != 1 or dirs.size not in (1, n) or not np.all(np.abs(dirs) == 1):
        raise DenavitError(
            f"--direction: expected +1 or -1, one for all joints or {n} (one per joint, from --home), got"
            f" {dirs.tolist()}"
        )
    dirs = np.broadcast_to(dirs, (n,))
    sweeps = {}
    for j, f in sorted(files.items()):
        if not 1 <= j <= n:
            raise DenavitError(f"{f}: joint index out of range: expected 1..{n} (from --home), got {j}")
        pts, at = _joint_file(f, units["length"])
        if dirs[j - 1] < 0:
            pts, at = pts[::-1], at[::-1]
        sweeps[j] = Sweep(j, pts, None, at)
    return SweepSet([sweeps[j] for j in sorted(sweeps)], n, homes, kinds, str(folder), units)


def read_json(path: str | os.PathLike, *, length: str | None = None, angle: str | None = None) -> SweepSet:
    """Read sweeps from JSON: ``{"units": {"length": "mm", "angle": "deg"}, "home": [...], "kinds": [...] (optional),
    "nest": [[x, y, z], ...] (optional), "sweeps": [{"joint": 1, "points": [[x, y, z], ...] or "targets": [[[x1, y1,
    z1],
    [x2, y2, z2], ...], ...], "q": [[q1..qn], ...] (optional), "quaternions": [[qw, qx, qy, qz], ...] (optional)}]}``.

    One sweep per joint; ``"targets"`` instead of ``"points"`` when 2-4 targets are measured per pose (the same number
    in every sweep; ``"nest"`` their positions in the tool frame, one per target), ``"quaternions"`` a 6-DoF pose's
    orientation per row (unit, scalar first; in every sweep or in none): what the long-form CSV carries as x2..zk,
    ``# nest:`` and qw..qz. The payload (the CSV's payload_mass, payload_x..z; in every sweep or in none):
    ``"payload_mass"`` in ``"units"``' ``"mass"`` and ``"payload_com"`` in the length unit, for the sweep or per point
    (:func:`json_payload`). Every number finite; errors name the file and the place (e.g. ``sweeps[2].q[3][1]``).
    ``"units"`` wins; ``length`` / ``angle`` fill what it does not give.
    """
    where = str(path)
    doc = load_json(read_text(path, "sweep file"), where)
    if not isinstance(doc, dict):
        raise DenavitError(
            f'{where}: expected a JSON object {{"units": ..., "home": [...], "sweeps": [...]}}, got {show_value(doc)}'
        )
    check_keys(doc, ("units", "home", "kinds", "nest", "sweeps"), where)
    declared = doc.get("units") or {}
    if not isinstance(declared, dict) or not all(isinstance(v, str) for v in declared.values()):
        raise DenavitError(
            f'{where}: units: expected an object such as {{"length": "mm", "angle": "deg"}}, got {show_value(declared)}'
        )
    units = input_units(declared, length, angle, where)
    ls = length_scale(units["length"], where)
    if doc.get("home") is None:
        raise DenavitError(f"{where}: 'home' (the locked configuration) is required")
    home = json_array(doc["home"], None, 1, f"{where}: home")
    n = len(home)
    kinds = doc.get("kinds") or ["revolute"] * n
    if not isinstance(kinds, list) or len(kinds) != n or any(k not in KINDS for k in kinds):
        raise DenavitError(
            f"{where}: kinds: expected {n} of 'revolute' / 'prismatic' (one per joint of home), got {show_value(kinds)}"
        )
    qscale = joint_scale(kinds, units["length"], units["angle"], where)
    sweeps = doc.get("sweeps")
    if not isinstance(sweeps, list) or not sweeps:
        raise DenavitError(
            f'{where}: sweeps: expected a list of sweeps {{"joint": 1, "points": [[x, y, z], ...]}}, got'
            f" {show_value(sweeps)}"
        )
    rows: dict[int, Sweep] = {}
    first: dict[int, int] = {}
    k_first = poses_first = pay_first = None  # (targets per pose / has quaternions / has a payload, sweep index)
    for k, s in enumerate(sweeps):
        at = f"{where}: sweeps[{k}]"
        if not isinstance(s, dict):
            raise DenavitError(f'{at}: expected an object {{"joint": ..., "points": ...}}, got {show_value(s)}')
        check_keys(s, ("joint", "points", "targets", "q", "quaternions"), at, PAYLOAD_KEYS)
        j = s.get("joint")
        if isinstance(j, bool) or not isinstance(j, int) or not 1 <= j <= n:
            raise DenavitError(f"{at}: joint index out of range: expected an integer 1..{n}, got {show_value(j)}")
        if j in rows:
            raise DenavitError(
                f"{at}: a second sweep of joint {j} (the first is sweeps[{first[j]}]): expected one sweep per joint"
            )
        if ("points" in s) == ("targets" in s):
            raise DenavitError(
                f"{at}: expected 'points' (one target per pose) or 'targets' (several: per pose a list of [x, y, z]), "
                f"got {'both' if 'points' in s else 'neither'}"
            )
        key = "points" if "points" in s else "targets"
        tg = json_array(s[key], 3, 2 if key == "points" else 3, f"{at}.{key}")
        tg = tg[:, None, :] if key == "points" else tg
        k_first = (tg.shape[1], k) if k_first is None else k_first
        if tg.shape[1] != k_first[0]:
            raise DenavitError(
                f"{at}.{key}: {tg.shape[1]} target(s) per pose, but sweeps[{k_first[1]}] has {k_first[0]}: expected the"
                " same targets at every pose"
            )
        tg = tg * ls
        far = np.argwhere(np.abs(tg[:, 0] if key == "points" else tg) > dl.MAX_LENGTH)
        if far.size:
            dl.far(
                tg[:, 0][tuple(far[0])] if key == "points" else tg[tuple(far[0])],
                f"{at}.{key}" + "".join(f"[{i}]" for i in far[0]),
            )
        m = len(tg)
        q = s.get("q")
        if q is not None:
            q = json_array(q, n, 2, f"{at}.q")
            if len(q) != m:
                raise DenavitError(f"{at}: q must have one row per point: expected {m} rows, got {len(q)}")
            q = q * qscale
        poses_first = ("quaternions" in s, k) if poses_first is None else poses_first
        if ("quaternions" in s) != poses_first[0]:
            has, hasnt = (k, poses_first[1]) if "quaternions" in s else (poses_first[1], k)
            raise DenavitError(
                f"{at}: sweeps[{has}] has 'quaternions', sweeps[{hasnt}] has none: expected 6-DoF poses in every sweep"
                " or in none"
            )
        rot = None
        if "quaternions" in s:
            quat = json_array(s["quaternions"], 4, 2, f"{at}.quaternions")
            if len(quat) != m:
                raise DenavitError(f"{at}: quaternions must have one row per point: expected {m} rows, got {len(quat)}")
            bad = np.flatnonzero(np.abs(np.linalg.norm(quat, axis=1) - 1) > 1e-6)
            if bad.size:
                raise DenavitError(
                    f"{at}.quaternions[{bad[0]}]: quaternion norm {np.linalg.norm(quat[bad[0]]):.6g}: expected a unit"
                    " quaternion (qw, qx, qy, qz)"
                )
            from .recordings.columns import poses_of  # noqa: PLC0415 (scipy's rotations)

            rot = poses_of(np.zeros((m, 3)), quat, "quaternion", at)[:, :3, :3]
        pay_first = ("payload_mass" in s, k) if pay_first is None else pay_first
        if ("payload_mass" in s) != pay_first[0]:
            has, hasnt = (k, pay_first[1]) if "payload_mass" in s else (pay_first[1], k)
            raise DenavitError(
                f"{at}: sweeps[{has}] has 'payload_mass', sweeps[{hasnt}] has none: "
                "expected the payload in every sweep or in none"
            )
        payload = json_payload(s, m, units, ls, f"{at}.", "point")
        pts = np.ascontiguousarray(tg[:, 0])
        where_k = [f"{at}.{key}[{i}]" for i in range(m)]
        rows[j] = Sweep(j, pts, q, where_k, tg if tg.shape[1] > 1 else None, rot, payload)
        first[j] = k
    nest = None
    if doc.get("nest") is not None:
        nest = json_lengths(json_array(doc["nest"], 3, 2, f"{where}: nest"), ls, f"{where}: nest")
        if len(nest) != k_first[0]:
            raise DenavitError(
                f"{where}: nest: expected {k_first[0]} points [x, y, z] (one per target of the sweeps), got {len(nest)}"
            )
    return SweepSet([rows[j] for j in sorted(rows)], n, home * qscale, kinds, where, units, nest)


def read(path: str | os.PathLike, **kw) -> SweepSet:
    """Read sweeps from a long-form CSV, a JSON file, or a folder of per-joint files (by what ``path`` is)."""
    p = Path(path)
    if not p.exists():
        raise DenavitError(f"{p}: no such file or folder")
    if p.is_dir():
        return read_joint_files(p, **kw)
    if p.suffix.lower() == ".json":
        return read_json(p, length=kw.get("length"), angle=kw.get("angle"))
    return read_long_csv(p, **{k: v for k, v in kw.items() if k in ("length", "angle", "kinds")})


#: Rows formatted per piece of the long-form writer (by Arrow, on a thread of the writer, a few pieces at a time).
WRITE_ROWS = 50_000


def to_long_csv(sweeps: SweepSet, length: str = "mm", angle: str = "deg", header_comment: str = "") -> str:
    """The long-form CSV text of a sweep set (units declared in a comment line; several targets per pose as
    columns x2, y2, z2, ... and their nest as a ``# nest:`` line; 6-DoF poses as a unit quaternion qw, qx, qy, qz;
    a payload on every sweep as payload_mass (kg), payload_x, payload_y, payload_z).

    Numbers are written in the shortest form that reads back as the same double (in the file's units; Arrow's
    formatting, at C speed, :func:`write_long_csv`)."""
    return b"".join(_long_csv(sweeps, None, length, angle, header_comment)).decode()


def write_long_csv(
    path: str | os.PathLike,
    sweeps: SweepSet,
    length: str = "mm",
    angle: str = "deg",
    header_comment: str = "",
    pieces: Iterable[Sweep] | None = None,
) -> None:
    """Write :func:`to_long_csv`'s text to ``path`` whole or not at all (:func:`denavit.io.output.atomic_path`), a
    piece at a time as it is formatted: the sweeps of ``sweeps``, or, given, ``pieces`` (sweeps of consecutive rows in
    file order, e.g. :func:`denavit.sweeps.simulation`'s, ``sweeps`` then giving the set's shape), never holding
    the whole text."""
    from .output import atomic_path  # noqa: PLC0415

    with atomic_path(path) as tmp, open(tmp, "wb") as f:
        for text in _long_csv(sweeps, pieces, length, angle, header_comment):
            f.write(text)


def _long_csv(sweeps: SweepSet, pieces, length: str, angle: str, header_comment: str) -> Iterator:
    """The long-form CSV's bytes (bytes-like pieces): its head, then its rows a piece of up to :data:`WRITE_ROWS` at a
    time, formatted
    on a pool of threads (one per core) a few pieces ahead of the one written."""
    from concurrent.futures import ThreadPoolExecutor  # noqa: PLC0415

    ls = length_scale(length)
    qscale = joint_scale(sweeps.kinds, length, angle)
    k, rot = sweeps.n_targets, sweeps.has_rotations
    out = io.StringIO()
    for line in header_comment.splitlines():
        out.write(f"# {line}\n")
    out.write(f"# units: length={length} angle={angle}\n")
    if sweeps.nest is not None:
        out.write("# nest: " + "; ".join(",".join(f"{v:.17g}" for v in p / ls) for p in sweeps.nest) + "\n")
    pay = bool(sweeps.sweeps) and all(s.payload is not None for s in sweeps.sweeps)  # kg: the declared default
    extra = [f"{a}{t}" for t in range(2, k + 1) for a in "xyz"] + list(QUATERNION if rot else ())
    extra += list(PAYLOAD_COLUMNS if pay else ())
    csv.writer(out, lineterminator="\n").writerow(
        ["joint", *[f"q{i}" for i in range(1, sweeps.n_joints + 1)], "x", "y", "z", *extra]
    )
    yield out.getvalue().encode()
    threads = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1
    with ThreadPoolExecutor(max(1, min(8, threads))) as pool:
        ahead = []
        for s in sweeps.sweeps if pieces is None else pieces:
            if s.q is None:
                raise DenavitError("long-form CSV needs joint readings; this sweep set has none")
            for a in range(0, len(s.points), WRITE_ROWS):
                q = s.q[a : a + WRITE_ROWS]
                p = s.targets[a : a + WRITE_ROWS].reshape(len(q), 3 * k) if k > 1 else s.points[a : a + WRITE_ROWS]
                quat = _quaternions(s.rotations[a : a + WRITE_ROWS]) if rot else np.zeros((len(q), 0))
                if pay:  # the payload's columns after the quaternion's
                    pl = s.payload[a : a + WRITE_ROWS]
                    quat = np.hstack([quat, pl[:, :1], pl[:, 1:] / ls])
                ahead.append(pool.submit(_rows_text, s.joint, q / qscale, p / ls, quat))
                while len(ahead) > threads:
                    yield ahead.pop(0).result()
        for done in ahead:
            yield done.result()


def _rows_text(joint: int, q: np.ndarray, p: np.ndarray, quat: np.ndarray):
    """The CSV rows (joint, q..., x, y, z..., quaternion) of one piece, each number in its shortest form that reads
    back as the same double, by Arrow's CSV writer (its float formatting, the shortest round trip)."""
    import pyarrow as pa  # noqa: PLC0415 (loaded with the first rows written)
    from pyarrow import csv as pacsv  # noqa: PLC0415

    cols = [pa.array(np.full(len(q), joint, dtype=np.int64))]
    cols += [pa.array(np.ascontiguousarray(c[:, i])) for c in (q, p, quat) for i in range(c.shape[1])]
    sink = pa.BufferOutputStream()
    pacsv.write_csv(
        pa.table(cols, names=[f"c{i}" for i in range(len(cols))]),
        sink,
        pacsv.WriteOptions(include_header=False, quoting_style="none"),
    )
    return sink.getvalue()  # a buffer of the bytes (not copied)


def _quaternions(R: np.ndarray) -> np.ndarray:
    """(m, 4) unit quaternions (qw, qx, qy, qz) of (m, 3, 3) rotations."""
    from ..geometry import _rotation  # noqa: PLC0415 (scipy's rotations)

    return _rotation().from_matrix(R).as_quat()[:, [3, 0, 1, 2]]


def to_json(sweeps: SweepSet, length: str = "mm", angle: str = "deg") -> dict:
    """The sweep JSON document of a sweep set (:func:`read_json`; write it with ``json.dumps``, whose numbers read back
    as the same doubles in the file's units): its units, home, kinds, nest; per sweep the points (several targets per
    pose: ``"targets"``), the joint readings when recorded, a 6-DoF pose's orientation as ``"quaternions"``, the
    payload as ``"payload_mass"`` (kg, declared) and ``"payload_com"`` (:func:`json_payload_doc`)."""
    ls = length_scale(length)
    qscale = joint_scale(sweeps.kinds, length, angle)
    doc = {
        "units": {"length": length, "angle": angle},
        "home": (np.asarray(sweeps.home, dtype=float) / qscale).tolist(),
        "kinds": list(sweeps.kinds),
    }
    if sweeps.nest is not None:
        doc["nest"] = (np.asarray(sweeps.nest, dtype=float) / ls).tolist()
    out = []
    for s in sweeps.sweeps:
        d = {"joint": int(s.joint)}
        if s.n_targets > 1:
            d["targets"] = (s.targets / ls).tolist()
        else:
            d["points"] = (s.points / ls).tolist()
        if s.q is not None:
            d["q"] = (s.q / qscale).tolist()
        if s.rotations is not None:
            d["quaternions"] = _quaternions(s.rotations).tolist()
        if s.payload is not None:
            d.update(json_payload_doc(s.payload, ls))
            doc["units"]["mass"] = "kg"
        out.append(d)
    doc["sweeps"] = out
    return doc
