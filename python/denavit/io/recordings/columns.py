"""A generic delimited file with a column map (``--columns "t,q1..q6,x,y,z"``), and the table parsing the
text readers share.

Cells are separated by whitespace, commas or semicolons (the first data line decides; a tab counts as
whitespace); ``#`` lines are comments (a ``# units:`` line declares units, :mod:`denavit.io.units`); a first
line none of whose cells is a number is a header and skipped (the map, not the header, names the columns).

Column map: comma-separated names, ``a..b`` ranges of numbered names (``q1..q6``, ``x1..x3``):

- ``t`` / ``time``: time (``time`` unit, default s);
- ``q1`` .. ``qn``: joint readings (``angle`` unit for revolute joints, ``length`` for prismatic);
- ``x, y, z`` (one target) or ``x1, y1, z1, x2, ...`` (several targets per row): measured points (``length``);
- ``qw, qx, qy, qz`` (unit quaternion, scalar first) or ``rx, ry, rz`` (rotation vector, ``angle``): with
  ``x, y, z``, a 6-DoF pose per row;
- ``-`` or ``_``: a column to skip.
"""

from __future__ import annotations

import os
import re
from pathlib import Path

import numpy as np

from ...errors import DenavitError
from ..delimited import number, numeric_table
from ..text import read_text
from ..units import input_units, joint_scale, length_scale, parse_declaration, time_scale


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def delimiter_of(line: str) -> str | None:
    """';' or ',' when the line holds one, else None (whitespace)."""
    if ";" in line:
        return ";"
    if "," in line:
        return ","
    return None


def split(line: str, delim: str | None) -> list[str]:
    cells = [c.strip() for c in (line.split(delim) if delim else line.split())]
    if delim and cells and cells[-1] == "":
        cells.pop()  # a trailing separator
    if len(cells) > 64:
        from ...limits import check_size  # noqa: PLC0415

        check_size(len(cells), "columns", f"recording line {line[:40]!r}...", "columns")
    return cells


def data_lines(text: str) -> list[tuple[int, str]]:
    """(1-based line number, line) of the lines that are neither blank nor ``#`` comments."""
    return [
        (i, line) for i, line in enumerate(text.splitlines(), 1) if line.strip() and not line.lstrip().startswith("#")
    ]


def numbers(rows: list[tuple[int, list[str]]], cols: list[int], names: list[str], path: str) -> np.ndarray:
    """(m, len(cols)) floats of the given columns: column-wise at C speed when every cell is a plain number
    (:func:`~denavit.io.delimited.numeric_table`, the values :func:`~denavit.io.delimited.number` gives), else row by
    row, the first bad cell naming the file, line and column."""
    out = np.empty((len(rows), len(cols)))
    for c, k in enumerate(cols):
        fast = numeric_table("\n".join(cs[k] for _, cs in rows).encode(), ",", 1) if rows else None
        if fast is None or len(fast) != len(rows):
            break
        out[:, c] = fast[:, 0]
    else:
        return out
    for r, (ln, cells) in enumerate(rows):
        for c, (k, name) in enumerate(zip(cols, names)):
            out[r, c] = number(cells[k], f"{path}:{ln}", name)
    return out


def expand(spec: str, where: str = "--columns") -> list[str]:
    """The column names of a map: ``"t,q1..q3,x,y,z"`` -> ``["t", "q1", "q2", "q3", "x", "y", "z"]``."""
    out = []
    for part in (p.strip().lower() for p in spec.split(",")):
        m = re.fullmatch(r"([a-z]+)(\d+)\.\.([a-z]+)?(\d+)", part)
        if m:
            a, b = int(m.group(2)), int(m.group(4))
            if (m.group(3) and m.group(3) != m.group(1)) or b < a:
                raise DenavitError(f"{where}: bad range {part!r}: expected e.g. q1..q6")
            out += [f"{m.group(1)}{i}" for i in range(a, b + 1)]
        elif part:
            out.append(part)
        else:
            raise DenavitError(f"{where}: empty column name in {spec[:80]!r}: expected e.g. 't,q1..q6,x,y,z'")
    known = re.compile(r"t|time|q\d+|[xyz]\d*|qw|qx|qy|qz|rx|ry|rz|-|_")
    bad = [c for c in out if not known.fullmatch(c)]
    if bad:
        raise DenavitError(
            f"{where}: unknown column name {bad[0]!r}: expected t, q1..qn, x,y,z (or x1,y1,z1,...), qw,qx,qy,qz or"
            " rx,ry,rz, or - to skip"
        )
    dup = sorted({c for c in out if out.count(c) > 1 and c not in "-_"})
    if dup:
        raise DenavitError(f"{where}: column {dup[0]!r} given twice in {spec[:80]!r}")
    return out


def pose_columns(names: list[str], where: str) -> str | None:
    """ "quaternion", "rotvec" or None from the orientation columns present (all of one kind or none)."""
    quat = [c for c in ("qw", "qx", "qy", "qz") if c in names]
    rv = [c for c in ("rx", "ry", "rz") if c in names]
    if quat and rv:
        raise DenavitError(f"{where}: both a quaternion and a rotation vector: expected one orientation")
    if quat and len(quat) != 4:
        raise DenavitError(
            f"{where}: a quaternion needs qw, qx, qy, qz: missing"
            f" {', '.join(c for c in ('qw', 'qx', 'qy', 'qz') if c not in quat)}"
        )
    if rv and len(rv) != 3:
        raise DenavitError(
            f"{where}: a rotation vector needs rx, ry, rz: missing"
            f" {', '.join(c for c in ('rx', 'ry', 'rz') if c not in rv)}"
        )
    return "quaternion" if quat else "rotvec" if rv else None


def poses_of(p: np.ndarray, orientation: np.ndarray, kind: str, where: str) -> np.ndarray:
    """(m, 4, 4) poses from positions (m, 3) m and quaternions (m, 4) w-first or rotation vectors (m, 3) rad."""
    from scipy.spatial.transform import Rotation  # noqa: PLC0415

    if kind == "quaternion":
        norm = np.linalg.norm(orientation, axis=1)
        if np.any(np.abs(norm - 1.0) > 1e-3):
            k = int(np.argmax(np.abs(norm - 1.0)))
            raise DenavitError(
                f"{where}: row {k + 1}: quaternion norm {norm[k]:.6g}: expected a unit quaternion (qw, qx, qy, qz)"
            )
        R = Rotation.from_quat(orientation[:, [1, 2, 3, 0]]).as_matrix()
    else:
        R = Rotation.from_rotvec(orientation).as_matrix()
    T = np.tile(np.eye(4), (len(p), 1, 1))
    T[:, :3, :3], T[:, :3, 3] = R, p
    return T


def read(
    path: str | os.PathLike,
    *,
    columns: str,
    length: str | None = None,
    angle: str | None = None,
    time: str | None = None,
    kinds: list[str] | None = None,
    text: str | None = None,
):
    """Read a delimited file whose columns ``columns`` names (see the module docstring): a Recording."""
    from ...recording import Recording, check_time  # noqa: PLC0415

    path = Path(path)
    text = read_text(path, "recording", lines=True) if text is None else text
    names = expand(columns)
    declared = parse_declaration(text.splitlines(), str(path))
    qcols = sorted((c for c in names if re.fullmatch(r"q\d+", c)), key=lambda c: int(c[1:]))
    n = len(qcols)
    if qcols and qcols != [f"q{i}" for i in range(1, n + 1)]:
        raise DenavitError(f"--columns: joint columns must be q1..q{n} without gaps, got {', '.join(qcols)}")
    pts = [c for c in names if re.fullmatch(r"[xyz]\d*", c)]
    need = ["length"] if pts else []
    if qcols and "angle" not in need:
        need.append("angle")
    units = input_units(declared, length, angle, str(path), need)
    ts = time_scale(time or declared.get("time", "s"), "--time")
    lines = data_lines(text)
    if not lines:
        raise DenavitError(f"{path}: no data rows: expected rows of {len(names)} values ({columns[:60]})")
    delim = delimiter_of(lines[0][1])
    rows = [(ln, split(line, delim)) for ln, line in lines]
    if not any(_is_number(c) for c in rows[0][1]):
        rows = rows[1:]  # a header
    for ln, cells in rows:
        if len(cells) != len(names):
            raise DenavitError(
                f"{path}:{ln}: expected {len(names)} values ({columns[:60]}) separated by {delim or 'whitespace'!r},"
                f" got {len(cells)}"
            )
    if not rows:
        raise DenavitError(f"{path}: a header but no data rows")
    where = [f"{path}:{ln}" for ln, _ in rows]
    col = {c: i for i, c in enumerate(names)}
    get = lambda cs: numbers(rows, [col[c] for c in cs], cs, str(path))  # noqa: E731
    t = None
    tname = "t" if "t" in col else "time" if "time" in col else None
    if tname:
        t = get([tname])[:, 0] * ts
        check_time(t, where)
    q = None
    kinds = kinds or ["revolute"] * n
    if n:
        if len(kinds) != n:
            raise DenavitError(f"{path}: {n} joint columns but {len(kinds)} joint kinds given")
        q = get(qcols) * joint_scale(kinds, units.get("length", "m"), units["angle"], str(path))
    points = poses = None
    if pts:
        targets = sorted({c[1:] for c in pts})
        for k in targets:
            miss = [f"{a}{k}" for a in "xyz" if f"{a}{k}" not in col]
            if miss:
                raise DenavitError(
                    f"{path}: --columns: target {k or 1} lacks {', '.join(miss)}: expected x{k}, y{k}, z{k}"
                )
        ls = length_scale(units["length"], str(path))
        points = np.stack([get([f"x{k}", f"y{k}", f"z{k}"]) * ls for k in targets], axis=1)
        kind = pose_columns(names, f"{path}: --columns")
        if kind:
            if len(targets) != 1:
                raise DenavitError(
                    f"{path}: --columns: an orientation needs exactly one position x, y, z, got {len(targets)} targets"
                )
            o = get(["qw", "qx", "qy", "qz"] if kind == "quaternion" else ["rx", "ry", "rz"])
            if kind == "rotvec":
                o = o * joint_scale(["revolute"], "m", units.get("angle", "rad"))[0]
            poses = poses_of(points[:, 0], o, kind, str(path))
    if q is None and points is None:
        raise DenavitError(f"--columns: {columns[:60]!r} names neither joint readings (q1..qn) nor points (x, y, z)")
    return Recording(t, q, points, where, str(path), "columns", units, poses, kinds if n else None)
