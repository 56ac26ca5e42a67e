"""Positions files for compensation: tool poses and/or joint rows, one row per position.

CSV (``,`` or ``;``), a header and a ``# units: length=mm angle=deg`` line (else the caller's units)::

    # units: length=mm angle=deg
    x,y,z,rx,ry,rz            # tool poses T_base_tool: position and rotation vector (as calibrate's pose files)
    q1,...,qn                 # or joint rows computed offline with the nominal model
    x,y,z,rx,ry,rz,q1,...,qn  # or both (the rows' nominal joint values keep the program's branches)

and optionally a payload per row (issue 37): ``payload_mass`` (kg, or the file's declared ``mass`` unit) and
``payload_x,payload_y,payload_z`` (its centre of mass in the flange frame, in the file's length unit; default 0), as
calibrate's pose files carry it.

Joint values follow the per-joint-kind rule (angle unit for revolute joints, length unit for prismatic ones).
:func:`write_compensated` writes the compensated program in the same form, with per-row flags and errors.
"""

from __future__ import annotations

import os
from dataclasses import dataclass

import numpy as np

from ..errors import DenavitError
from ..geometry import matrix_rotvec, rotvec_matrix
from . import delimited as dl
from .output import write_text
from .payload import PAYLOAD_COLUMNS, payload_from_columns
from .text import read_text
from .units import angle_scale, input_units, joint_scale, length_scale, parse_declaration

POSE = ("x", "y", "z", "rx", "ry", "rz")


@dataclass(frozen=True)
class Positions:
    """A positions file's rows: ``poses`` (N, 4, 4) (m) or None, ``q`` (N, n) nominal joint values (rad / m) or None,
    ``where`` (N,) "file:line" of each row, ``units`` the file's units, ``payload`` (N, 4) ``[mass kg, x, y, z m]`` of
    each row's payload (its columns) or None."""

    poses: np.ndarray | None
    q: np.ndarray | None
    where: list
    units: dict
    payload: np.ndarray | None = None

    def __repr__(self) -> str:
        what = " and ".join(w for w, a in (("poses", self.poses), ("joint rows", self.q)) if a is not None)
        return (
            f"Positions({len(self.where)} rows of {what}, file units"
            f" {' '.join(f'{k}={v}' for k, v in self.units.items())})"
        )


def read_positions(path: str | os.PathLike, kinds, *, length: str | None = None, angle: str | None = None) -> Positions:
    """Read a positions file (module docstring) for a robot with joint ``kinds``."""
    where = str(path)
    lines = read_text(path, "positions file", lines=True).splitlines()
    units = input_units(parse_declaration(lines, where), length, angle, where)
    data, _ = dl.rows(lines, where)
    if not data:
        raise DenavitError(
            f"{where}: no header and no rows: expected a header 'x,y,z,rx,ry,rz' and/or 'q1,...,q{len(kinds)}'"
        )
    hline, hcells = data[0]
    cols = dl.header(hcells, f"{where}:{hline}")
    n = len(kinds)
    qcols = [f"q{i}" for i in range(1, n + 1)]
    has_pose = all(c in cols for c in POSE)
    has_q = all(c in cols for c in qcols)
    pay = [c for c in PAYLOAD_COLUMNS if c in cols]
    extra = [c for c in cols if c not in POSE and c not in qcols and c not in pay]
    if (
        not (has_pose or has_q)
        or extra
        or (pay and "payload_mass" not in pay)
        or (any(c in cols for c in POSE) and not has_pose)
        or (any(c in cols for c in qcols) and not has_q)
    ):
        raise DenavitError(
            f"{where}:{hline}: header must be 'x,y,z,rx,ry,rz' and/or 'q1,...,q{n}' ({n} joints), optionally with"
            f" {','.join(PAYLOAD_COLUMNS)} (payload_mass with any of them), got"
            f" {','.join(hcells)[:200]!r}"
        )
    if len(data) < 2:
        raise DenavitError(f"{where}: no rows after the header")
    ls, as_ = length_scale(units["length"], where), angle_scale(units["angle"], where)
    vals = np.empty((len(data) - 1, len(cols)))
    places = []
    for r, (ln, cells) in enumerate(data[1:]):
        w = f"{where}:{ln}"
        if len(cells) != len(cols):
            raise DenavitError(f"{w}: expected {len(cols)} values ({','.join(cols)}), got {len(cells)}")
        vals[r] = [
            dl.length(c, w, name, ls) if name in "xyz" else dl.number(c, w, name)
            for c, name in zip(cells, cols, strict=True)
        ]  # x, y, z in m
        places.append(w)
    col = {c: k for k, c in enumerate(cols)}
    poses = None
    if has_pose:
        poses = np.tile(np.eye(4), (len(vals), 1, 1))
        poses[:, :3, 3] = vals[:, [col[c] for c in "xyz"]]
        poses[:, :3, :3] = rotvec_matrix(vals[:, [col[c] for c in ("rx", "ry", "rz")]] * as_)
    q = vals[:, [col[c] for c in qcols]] * joint_scale(kinds, units["length"], units["angle"], where) if has_q else None
    payload = payload_from_columns(vals, {c: col[c] for c in pay}, ls, places, units.get("mass", "kg")) if pay else None
    return Positions(poses, q, places, units, payload)


def write_compensated(
    path,
    comp,
    kinds,
    *,
    length: str = "mm",
    angle: str = "deg",
    comment: str = "",
    predicted_after=None,
    force: bool = False,
    q0=None,
) -> None:
    """Write a :class:`denavit.compensation.Compensation` as a program: the commands ``T'`` (x, y, z, rx, ry,
    rz), the joint values ``q1..qn`` of the commands on the nominal model (``T' = FK_nominal(q)``: the joint rows
    to send; the identified model's own unless its readings differ), and per row ``ok`` (1: send it), ``reached``,
    ``branch_changed``, ``path_jump`` (0/1), ``before`` (the position error the robot makes without compensation,
    by the identified model), ``residual`` (of the identified solve) and, when ``predicted_after`` (N,) is given
    (or the compensation has it), ``predicted_after`` (the predicted position error after compensation, 1 sigma,
    from the identified parameters' covariance), in the length unit (a ``# columns:`` line says so). Whole or not at
    all;
    ``force``: replace a read-only file, write through one with several hard links
    (:func:`denavit.io.output.write_text`).
    Rows that came without a configuration (``comp.assumed``) are said on the first comment line: their q1..qn are
    on the nominal's solution nearest ``q0`` (SI, for the line)."""
    ls, as_ = length_scale(length), angle_scale(angle)
    js = joint_scale(kinds, length, angle)
    n = len(kinds)
    pred = predicted_after if predicted_after is not None else comp.predicted_after
    head = [
        *POSE,
        *(f"q{i}" for i in range(1, n + 1)),
        "ok",
        "reached",
        "branch_changed",
        "path_jump",
        "before",
        "residual",
        *(["predicted_after"] if pred is not None else []),
    ]
    assumed = getattr(comp, "assumed", None)
    if assumed is not None and assumed.any():  # (on the comment line: the file keeps its lines)
        at = "" if q0 is None else f" ({', '.join(f'{v:.6g}' for v in np.asarray(q0) / js)})"
        which = (
            "every row"
            if assumed.all()
            else (
                f"{int(assumed.sum())} rows"
                f" ({', '.join(str(k + 1) for k in np.flatnonzero(assumed)[:20])}"
                f"{' ...' if assumed.sum() > 20 else ''})"
            )
        )
        comment = (
            (f"{comment}; " if comment else "")
            + f"configuration: {which} without one in the program: assumed the nominal's solution nearest q0{at}, "
            f"the branch of the row's q1..q{n}"
        )
    out = [f"# {comment}"] if comment else []
    out += [
        f"# units: length={length} angle={angle}",
        (
            f"# columns: x,y,z {length}, rx,ry,rz (rotation vector) {angle}, q1..q{n} in {angle} (revolute) / {length}"
            f" (prismatic); before, residual{', predicted_after (1 sigma)' if pred is not None else ''}: tool-position"
            f" errors in {length}"
        ),
    ]
    out.append(",".join(head))
    rv = matrix_rotvec(comp.commands[:, :3, :3]) / as_
    for k in range(len(comp)):
        cells = [*(comp.commands[k, :3, 3] / ls), *rv[k], *(comp.q_command[k] / js)]
        flags = [int(comp.ok[k]), int(comp.reached[k]), int(comp.branch_changed[k]), int(comp.path_jump[k])]
        errs = [comp.before[k], comp.residual[k], *([pred[k]] if pred is not None else [])]
        out.append(",".join([*(repr(float(v)) for v in cells), *map(str, flags), *(repr(float(e / ls)) for e in errs)]))
    write_text(path, "\n".join(out) + "\n", force=force)
