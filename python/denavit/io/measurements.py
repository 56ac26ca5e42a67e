"""Calibration measurements in files: tool points or poses at known joint readings (CSV or JSON), in and out.

Units are the file's (a ``# units: length=mm angle=deg`` line, or ``"units"`` in JSON; what the file declares
wins over the ``length`` / ``angle`` given by the caller, which only fill in what it does not declare:
:func:`denavit.io.units.input_units`). Joint readings follow the per-joint-kind rule
(:func:`denavit.io.units.joint_scale`: revolute in the angle unit, prismatic in the length unit). Inside,
everything is SI (:class:`denavit.calibration.Measurements`).
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np

from ..calibration.measurements import Measurements, as_array, check_finite, joint_kinds
from ..errors import DenavitError
from ..geometry import matrix_rotvec, rotvec_matrix
from . import sweeps as sw
from .delimited import numeric_table, split
from .text import read_text
from .units import (
    angle_scale,
    input_units,
    joint_scale,
    length_scale,
    parse_declaration,
)


def read_measurements(path: str | os.PathLike, *, length: str | None = None, angle: str | None = None, kinds=None) -> Measurements:
    """Read measurements from a file.

    Joint readings are in the angle unit for revolute joints and in the length unit for prismatic ones:
    ``kinds`` (one ``"revolute"`` / ``"prismatic"`` per joint, e.g. the nominal robot's ``table.kinds``; a JSON
    file may state them as ``"kinds"``) says which; without them every joint is read as revolute and
    :func:`denavit.calibration.calibrate` refuses a nominal model with a prismatic joint.

    * CSV with a ``joint`` column: the long-form sweep file of :func:`denavit.io.sweeps.read_long_csv`.
    * CSV with header ``q1,...,qn,x,y,z`` (points) or ``q1,...,qn,x,y,z,rx,ry,rz`` (poses; ``rx, ry, rz`` the
      rotation vector of ``R_world_tool`` in angle units): one row per pose. Units from a
      ``# units: length=mm angle=deg`` line, else ``length`` / ``angle``.
    * JSON: ``{"units": {...}, "q": [[...]], "points": [[x, y, z]...]}`` (or ``"poses"``: 4x4 matrices with
      translations in length units), or a sweep JSON (``"sweeps"``).
    """
    p = Path(path)
    text = read_text(p, "measurement file")
    if p.suffix.lower() == ".json":
        return _read_json(p, text, length, angle, kinds)
    lines = text.splitlines()
    header = next((ln for ln in lines if ln.strip() and not ln.lstrip().startswith("#")), "")
    delim = ";" if header.count(";") > header.count(",") else ","
    cols = [c.strip().lower() for c in header.split(delim)]
    if "joint" in cols:
        return Measurements.from_sweeps(sw.read_long_csv(p, length=length, angle=angle, kinds=None if kinds is None else list(kinds)))
    units = input_units(parse_declaration(lines, str(p)), length, angle, str(p))
    ls, as_ = length_scale(units["length"], str(p)), angle_scale(units["angle"], str(p))
    qcols = sorted((c for c in cols if c[:1] == "q" and c[1:].isdigit()), key=lambda c: int(c[1:]))
    need = [f"q{i}" for i in range(1, len(qcols) + 1)] + ["x", "y", "z"]
    missing = [c for c in need if c not in cols]
    if missing or not qcols:
        raise DenavitError(f"{p}: header must be 'q1,...,qn,x,y,z' (optionally ',rx,ry,rz'), or a sweep file with a 'joint' column; missing {', '.join(missing) or 'q columns'}, got {header.strip()!r}")
    kinds = joint_kinds(kinds, len(qcols), f"{p}: kinds given") or ("revolute",) * len(qcols)
    has_rot = all(c in cols for c in ("rx", "ry", "rz"))
    q, pts, rot, where = _fast_rows(lines, delim, cols, len(qcols), has_rot, str(p))
    started = False
    for ln, line in enumerate([] if where else lines, 1):
        s = line.strip()
        if not s or s.startswith("#"):
            continue
        if not started:
            started = True
            continue
        w = f"{p}:{ln}"
        cells = split(s, delim, w)
        if len(cells) != len(cols):
            raise DenavitError(f"{w}: expected {len(cols)} values, got {len(cells)}")
        vals = {}
        for c, v in zip(cols, cells, strict=True):
            try:
                vals[c] = float(v)
            except ValueError:
                raise DenavitError(f"{w}: column {c!r} must be a number, got {v!r}") from None
        q.append([vals[f"q{i}"] for i in range(1, len(qcols) + 1)])
        pts.append([vals[c] for c in "xyz"])
        if has_rot:
            rot.append([vals[c] for c in ("rx", "ry", "rz")])
        where.append(w)
    if not len(q):
        raise DenavitError(f"{p}: no data rows after the header")
    q = np.array(q) * joint_scale(kinds, units["length"], units["angle"], str(p))
    pts = np.array(pts) * ls
    check_finite(q, "q (joint readings)", str(p), where, cols="joint")
    if has_rot:
        rv = np.array(rot) * as_
        check_finite(rv, "rotation vector", str(p), where)
        T = np.tile(np.eye(4), (len(q), 1, 1))
        T[:, :3, :3] = rotvec_matrix(rv)
        T[:, :3, 3] = pts
        return Measurements(q, None, T, str(p), where, units, kinds=kinds)
    return Measurements(q, pts, None, str(p), where, units, kinds=kinds)


def _fast_rows(lines: list[str], delim: str, cols: list[str], nq: int, has_rot: bool, where: str):
    """(q, points, rotation vectors, places) of the rows after the header, in file units, when they are a plain
    numeric table (:func:`~denavit.io.delimited.numeric_table`, numpy's C reader); else four empty lists (the rows
    are then read one by one, and errors name the line and column)."""
    h = next(k for k, ln in enumerate(lines) if ln.strip() and not ln.lstrip().startswith("#"))
    table = numeric_table("\n".join(lines[h + 1 :]).encode(), delim, len(cols))
    if table is None:
        return [], [], [], []
    col = {c: k for k, c in enumerate(cols)}  # (a name given twice: its last column, as row by row)
    rot = table[:, [col[c] for c in ("rx", "ry", "rz")]] if has_rot else []
    return table[:, [col[f"q{i}"] for i in range(1, nq + 1)]], table[:, [col[c] for c in "xyz"]], rot, [f"{where}:{h + 2 + k}" for k in range(len(table))]


def _read_json(p: Path, text: str, length: str | None, angle: str | None, kinds) -> Measurements:
    try:
        doc = json.loads(text)
    except json.JSONDecodeError as e:
        raise DenavitError(f"{p}:{e.lineno}: not valid JSON: {e.msg}") from None
    if not isinstance(doc, dict):
        raise DenavitError(f"{p}: expected a JSON object with 'q' and 'points' or 'poses', got {type(doc).__name__}")
    if "sweeps" in doc:
        return Measurements.from_sweeps(sw.read_json(p, length=length, angle=angle))  # its own "kinds"
    declared = doc.get("units") or {}
    if not isinstance(declared, dict):
        raise DenavitError(f"{p}: 'units' must be an object like {{\"length\": \"mm\", \"angle\": \"deg\"}}, got {declared!r}")
    units = input_units({k: str(v) for k, v in declared.items()}, length, angle, str(p))
    ls = length_scale(units["length"], str(p))
    if "q" not in doc:
        raise DenavitError(f"{p}: expected 'q' (joint readings, one row per pose) and 'points' or 'poses'")
    q = as_array(doc["q"], "q", str(p))
    if q.ndim != 2:
        raise DenavitError(f"{p}: q must have shape (N, n) with one row per pose, got shape {q.shape}")
    given = joint_kinds(kinds, q.shape[1], f"{p}: kinds given")
    stated = joint_kinds(doc.get("kinds"), q.shape[1], f"{p}: 'kinds'")
    if given and stated and given != stated:
        raise DenavitError(f"{p}: 'kinds' {list(stated)} differ from the kinds given {list(given)}")
    kinds = stated or given or ("revolute",) * q.shape[1]
    q = q * joint_scale(kinds, units["length"], units["angle"], str(p))
    if "poses" in doc:
        T = as_array(doc["poses"], "poses", str(p))
        if T.ndim == 3:
            T[:, :3, 3] *= ls
        return Measurements(q, None, T, str(p), [], units, kinds=kinds)
    return Measurements(q, as_array(doc.get("points"), "points", str(p)) * ls, None, str(p), [], units, kinds=kinds)


def to_csv(meas: Measurements, length: str = "mm", angle: str = "deg", comment: str = "") -> str:
    """The CSV text of measurements (``q1..qn,x,y,z`` and ``rx,ry,rz`` for poses), units declared; readings of
    prismatic joints (``meas.kinds``) in the length unit."""
    ls, as_ = length_scale(length), angle_scale(angle)
    qs = joint_scale(meas.kinds or ("revolute",) * meas.nq, length, angle)
    out = [f"# {c}" for c in comment.splitlines()] + [f"# units: length={length} angle={angle}"]
    cols = [f"q{i + 1}" for i in range(meas.nq)] + ["x", "y", "z"] + (["rx", "ry", "rz"] if meas.kind == "pose" else [])
    out.append(",".join(cols))
    rv = matrix_rotvec(meas.poses[:, :3, :3]) / as_ if meas.kind == "pose" else None
    for k in range(meas.n):
        row = [*(meas.q[k] / qs), *(meas.points[k] / ls)] + ([*rv[k]] if rv is not None else [])
        out.append(",".join(f"{v:.12g}" for v in row))
    return "\n".join(out) + "\n"


__all__ = ["read_measurements", "to_csv"]
