"""Calibration measurements in files: tool points or poses at known joint readings (CSV or JSON), in and out.

Units are the file's (a ``# units: length=mm angle=deg`` line, or ``"units"`` in JSON; what the file declares
wins over the ``length`` / ``angle`` given by the caller, which only fill in what it does not declare:
:func:`denavit.io.units.input_units`). Joint readings follow the per-joint-kind rule
(:func:`denavit.io.units.joint_scale`: revolute in the angle unit, prismatic in the length unit). Inside,
everything is SI (:class:`denavit.calibration.Measurements`).
"""

from __future__ import annotations

import os
from pathlib import Path
from types import SimpleNamespace

import numpy as np

from ..calibration.measurements import Measurements, joint_kinds
from ..errors import DenavitError
from ..geometry import matrix_rotvec, rotvec_matrix
from . import delimited as dl
from . import json_values as jv
from . import sweeps as sw
from .payload import PAYLOAD_COLUMNS, payload_from_columns
from .text import decode, read_bytes, read_text
from .units import (
    angle_scale,
    input_units,
    joint_scale,
    length_scale,
    parse_declaration,
)


def read_measurements(
    path: str | os.PathLike, *, length: str | None = None, angle: str | None = None, kinds=None
) -> Measurements:
    """Read measurements from a file.

    Joint readings are in the angle unit for revolute joints and in the length unit for prismatic ones:
    ``kinds`` (one ``"revolute"`` / ``"prismatic"`` per joint, e.g. the nominal robot's ``table.kinds``; a JSON
    file may state them as ``"kinds"``) says which; without them every joint is read as revolute and
    :func:`denavit.calibration.calibrate` refuses a nominal model with a prismatic joint.

    * CSV with a ``joint`` column: the long-form sweep file of :func:`denavit.io.sweeps.read_long_csv`.
    * CSV with header ``q1,...,qn,x,y,z`` (points) or ``q1,...,qn,x,y,z,rx,ry,rz`` (poses; ``rx, ry, rz`` the
      rotation vector of ``R_world_tool`` in angle units): one row per pose. Units from a
      ``# units: length=mm angle=deg`` line, else ``length`` / ``angle``. Several targets per pose (a marker
      cluster, SMRs on a nest): ``q1,...,qn,x,y,z,x2,y2,z2[,x3,y3,z3,...]``, optionally their positions in the tool
      frame on a ``# nest: x1,y1,z1; x2,y2,z2; ...`` line (length unit), read as a
      :class:`~denavit.calibration.targets.TargetMeasurements` (calibrate fits them in one, validate scores them).
    * JSON: ``{"units": {...}, "q": [[...]], "points": [[x, y, z]...]}`` (or ``"poses"``: 4x4 matrices with
      translations in length units), or a sweep JSON (``"sweeps"``). A payload (the CSV's payload columns):
      ``"payload_mass"`` (one number, or one per pose, in ``"units"``' ``"mass"``, which must then be declared) and
      ``"payload_com"`` (``[x, y, z]`` in the flange frame, or one per pose, length unit):
      :func:`denavit.io.json_values.json_payload`.
    """
    p = Path(path)
    if p.suffix.lower() == ".json":
        return _read_json(p, read_text(p, "measurement file"), length, angle, kinds)
    head, got = dl.plain_head(p, "measurement file"), None
    if head is not None:  # plain numbers at C speed, column-wise, the rows never split in Python (else row by row)
        try:
            lay = _layout(p, head.lines, length, angle, kinds)
        except DenavitError:  # said by the whole-file reader, in its order
            lay = None
        if lay is not None and lay.joint_file:
            return _from_sweep_file(p, length, angle, kinds)
        got = lay and dl.plain_columns(p, head, lay.delim, len(lay.cols), [[lay.idx[c] for c in lay.need]])
    if got is None:
        lay = _layout(
            p, decode(read_bytes(p, "measurement file", lines=True), str(p)).splitlines(), length, angle, kinds
        )
        if lay.joint_file:
            return _from_sweep_file(p, length, angle, kinds)
    ls, as_, need, idx, hline = lay.ls, lay.as_, lay.need, lay.idx, lay.hline
    qn, rot, extra, pay = lay.qn, lay.rot, lay.extra, lay.pay
    mu = lay.units.get("mass", "kg")  # the payload's mass unit: the file's declared, else kg
    if got is not None:
        table = got[0]  # the columns of `need`, in its order
        where = sw.FileLines(str(p), head.line + np.arange(len(table)))
        at = {c: k for k, c in enumerate(need)}
        q = table[:, :qn]
        pts = table[:, qn : qn + 3] * ls
        far = np.abs(pts) > dl.MAX_LENGTH
        if far.any():
            r, c = np.argwhere(far)[0]
            dl.far(pts[r, c], f"{where[r]}: column {'xyz'[c]!r}")
        rv = table[:, [at[c] for c in ("rx", "ry", "rz")]] * as_ if rot else []
        more = table[:, [at[c] for c in extra]] * ls if extra else None
        payload = payload_from_columns(table, {c: at[c] for c in pay}, ls, where, mu) if pay else None
        if extra and (np.abs(more) > dl.MAX_LENGTH).any():
            r, c = np.argwhere(np.abs(more) > dl.MAX_LENGTH)[0]
            dl.far(more[r, c], f"{where[r]}: column {extra[c]!r}")
    else:  # row by row: errors name the line and the column
        q, pts, rv, where, more, pays = [], [], [], [], [], []
        cols, delim = lay.cols, lay.delim
        for ln, cells in lay.data[1:]:
            w = f"{p}:{ln}"
            if len(cells) != len(cols):
                raise DenavitError(f"{w}: expected {len(cols)} values ({delim.join(cols)}), got {len(cells)}")
            vals = {c: dl.number(cells[k], w, c) for c, k in idx.items() if c not in "xyz"}
            q.append([vals[f"q{i}"] for i in range(1, qn + 1)])
            pts.append([dl.length(cells[idx[c]], w, c, ls) for c in "xyz"])
            if rot:
                rv.append([vals[c] * as_ for c in ("rx", "ry", "rz")])
            if extra:
                more.append([dl.length(cells[idx[c]], w, c, ls) for c in extra])
            if pay:
                pays.append([vals[c] for c in pay])
            where.append(w)
        payload = (
            payload_from_columns(
                np.asarray(pays, dtype=float).reshape(len(pays), len(pay)),
                {c: k for k, c in enumerate(pay)},
                ls,
                where,
                mu,
            )
            if pay and pays
            else None
        )
    units, kinds, k_t, lines = lay.units, lay.kinds, lay.k_t, lay.lines
    if not len(q):
        raise DenavitError(f"{p}: no data rows after the header")
    q = np.asarray(q, dtype=float) * joint_scale(kinds, units["length"], units["angle"], str(p))
    pts = np.asarray(pts, dtype=float)
    if extra:
        from ..calibration.targets import TargetMeasurements  # noqa: PLC0415

        targets = np.concatenate([pts[:, None], np.asarray(more, dtype=float).reshape(len(q), k_t - 1, 3)], axis=1)
        if pay:
            raise DenavitError(
                f"{p}:{hline}: payload columns with several targets per pose are not supported: give one target (x,y,z)"
                " per pose"
            )
        return TargetMeasurements(q, targets, sw.parse_nest(lines, k_t, ls, str(p)), str(p), where, units, kinds=kinds)
    if rot:
        T = np.tile(np.eye(4), (len(q), 1, 1))
        T[:, :3, :3] = rotvec_matrix(np.asarray(rv, dtype=float))
        T[:, :3, 3] = pts
        return Measurements(q, None, T, str(p), where, units, kinds=kinds, payload=payload)
    return Measurements(q, pts, None, str(p), where, units, kinds=kinds, payload=payload)


def _from_sweep_file(p: Path, length, angle, kinds) -> Measurements:
    """The measurements of a long-form sweep file (a ``joint`` column)."""
    return Measurements.from_sweeps(
        sw.read_long_csv(p, length=length, angle=angle, kinds=None if kinds is None else list(kinds))
    )


class _Layout(SimpleNamespace):
    """What a measurement CSV's lines up to its header say (:func:`_layout`)."""


def _layout(p: Path, lines: list[str], length, angle, kinds) -> _Layout:
    """A measurement CSV's units, columns and kinds from its ``lines`` (the whole file's, or those up to the header):
    the columns needed in order (``need``: q1..qn, x, y, z, then rx, ry, rz, further targets or the payload) and
    their indices in the file (``idx``); ``joint_file`` when it is a long-form sweep file. Header errors are one line
    naming it."""
    data, delim = dl.rows(lines, str(p))
    if data and "joint" in [c.lower() for c in data[0][1]]:
        return _Layout(joint_file=True)
    units = input_units(parse_declaration(lines, str(p)), length, angle, str(p))
    ls, as_ = length_scale(units["length"], str(p)), angle_scale(units["angle"], str(p))
    if not data:
        raise DenavitError(
            f"{p}: no header and no data: expected a header 'q1,...,qn,x,y,z' (optionally ',rx,ry,rz'), or a sweep file"
            " with a 'joint' column"
        )
    hline, names = data[0]
    cols = dl.header(names, f"{p}:{hline}")
    qcols = sorted((c for c in cols if c[:1] == "q" and c[1:].isdigit()), key=lambda c: int(c[1:]))
    rot = [c for c in ("rx", "ry", "rz") if c in cols]
    k_t = 1 + len([c for c in cols if c[:1] == "x" and c[1:].isdigit() and int(c[1:]) >= 2])  # targets per pose
    extra = [f"{a}{t}" for t in range(2, k_t + 1) for a in "xyz"]
    pay = [
        c for c in PAYLOAD_COLUMNS if c in cols
    ]  # a payload per row (issue 37): mass in kg, its centre of mass in the length unit
    if pay and "payload_mass" not in pay:
        raise DenavitError(
            f"{p}:{hline}: {', '.join(pay)} without payload_mass: give the payload's mass (kg) with its centre of mass"
        )
    need = (
        [f"q{i}" for i in range(1, len(qcols) + 1)]
        + ["x", "y", "z"]
        + (["rx", "ry", "rz"] if rot else [])
        + extra
        + pay
    )
    missing = [c for c in need if c not in cols]
    unknown = [c for c in cols if c not in need]
    if missing or unknown or not qcols:
        what = (
            f"missing {', '.join(missing) or 'q columns'}"
            if missing or not qcols
            else f"unknown column(s) {', '.join(unknown)}"
        )
        raise DenavitError(
            f"{p}:{hline}: header must be 'q1,...,qn,x,y,z' (optionally ',rx,ry,rz', or further targets"
            f" ',x2,y2,z2,...'), or a sweep file with a 'joint' column; {what}, got {delim.join(names)!r}"
        )
    if rot and extra:
        raise DenavitError(
            f"{p}:{hline}: a pose's rotation (rx,ry,rz) and further targets (x2,y2,z2,...) in one file: give one or the"
            f" other, got {delim.join(names)!r}"
        )
    kinds = joint_kinds(kinds, len(qcols), f"{p}: kinds given") or ("revolute",) * len(qcols)
    return _Layout(
        joint_file=False,
        data=data,
        delim=delim,
        lines=lines,
        units=units,
        ls=ls,
        as_=as_,
        hline=hline,
        cols=cols,
        qn=len(qcols),
        rot=rot,
        k_t=k_t,
        extra=extra,
        pay=pay,
        need=need,
        idx={c: cols.index(c) for c in need},
        kinds=kinds,
    )


#: The keys of a measurement JSON file (:func:`read_measurements`).
JSON_KEYS = ("units", "kinds", "q", "points", "poses", *jv.PAYLOAD_KEYS)


def _read_json(p: Path, text: str, length: str | None, angle: str | None, kinds) -> Measurements:
    doc = jv.load_json(text, str(p))
    if not isinstance(doc, dict):
        raise DenavitError(f"{p}: expected a JSON object with 'q' and 'points' or 'poses', got {type(doc).__name__}")
    if "sweeps" in doc:
        return Measurements.from_sweeps(sw.read_json(p, length=length, angle=angle))  # its own "kinds"
    unknown = [k for k in doc if k not in JSON_KEYS]
    if unknown:
        pay = ", payload_mass, payload_com" if jv.about_payload(doc, unknown) else ""
        raise DenavitError(
            f"{p}: unknown key(s) {', '.join(map(repr, unknown))[:80]}: "
            f"expected units, kinds, q, and points or poses{pay}"
        )
    declared = doc.get("units") or {}
    if not isinstance(declared, dict):
        raise DenavitError(
            f'{p}: \'units\' must be an object like {{"length": "mm", "angle": "deg"}}, got {declared!r}'
        )
    if not all(isinstance(v, str) for v in declared.values()):
        raise DenavitError(f"{p}: 'units' values must be unit names such as \"mm\", got {jv.show_value(declared)}")
    units = input_units(declared, length, angle, str(p))
    ls = length_scale(units["length"], str(p))
    if "q" not in doc:
        raise DenavitError(f"{p}: expected 'q' (joint readings, one row per pose) and 'points' or 'poses'")
    q = jv.json_array(doc["q"], None, 2, f"{p}: q")
    given = joint_kinds(kinds, q.shape[1], f"{p}: kinds given")
    stated = joint_kinds(doc.get("kinds"), q.shape[1], f"{p}: 'kinds'")
    if given and stated and given != stated:
        raise DenavitError(f"{p}: 'kinds' {list(stated)} differ from the kinds given {list(given)}")
    kinds = stated or given or ("revolute",) * q.shape[1]
    q = q * joint_scale(kinds, units["length"], units["angle"], str(p))
    if "poses" in doc:
        T = jv.json_array(doc["poses"], 4, 3, f"{p}: poses")
        T[:, :3, 3] = jv.json_lengths(T[:, :3, 3], ls, f"{p}: poses' translations")
        pts = None
    else:
        T, pts = None, jv.json_lengths(jv.json_array(doc.get("points"), 3, 2, f"{p}: points"), ls, f"{p}: points")
    payload = jv.json_payload(doc, len(q), units, ls, f"{p}: ")
    return Measurements(q, pts, T, str(p), [], units, kinds=kinds, payload=payload)


def to_json(meas: Measurements, length: str = "mm", angle: str = "deg") -> dict:
    """The JSON document of measurements (:func:`read_measurements`; write it with ``json.dumps``, whose numbers read
    back as the same doubles in the file's units): units, kinds, ``q`` (prismatic joints' readings in the length
    unit), ``points`` or ``poses`` (4x4, translations in the length unit), the payload as ``payload_mass`` (kg,
    declared) and ``payload_com`` (length unit; :func:`denavit.io.json_values.json_payload_doc`)."""
    if meas.kind not in ("point", "pose") or getattr(meas, "targets", None) is not None:
        raise DenavitError(
            f"{meas.source}: measurements of several targets per pose have no JSON form: write them with to_csv"
        )
    ls = length_scale(length)
    qs = joint_scale(meas.kinds or ("revolute",) * meas.nq, length, angle)
    doc: dict = {"units": {"length": length, "angle": angle}, "kinds": list(meas.kinds or ("revolute",) * meas.nq)}
    doc["q"] = (np.asarray(meas.q) / qs).tolist()
    if meas.kind == "pose":
        T = np.array(meas.poses, dtype=float)
        T[:, :3, 3] /= ls
        doc["poses"] = T.tolist()
    else:
        doc["points"] = (np.asarray(meas.points) / ls).tolist()
    pl = getattr(meas, "payload", None)
    if pl is not None:
        doc["units"]["mass"] = "kg"
        doc.update(jv.json_payload_doc(pl, ls))
    return doc


def to_csv(meas: Measurements, length: str = "mm", angle: str = "deg", comment: str = "") -> str:
    """The CSV text of measurements (``q1..qn,x,y,z`` and ``rx,ry,rz`` for poses), units declared; readings of
    prismatic joints (``meas.kinds``) in the length unit."""
    ls, as_ = length_scale(length), angle_scale(angle)
    qs = joint_scale(meas.kinds or ("revolute",) * meas.nq, length, angle)
    out = [f"# {c}" for c in comment.splitlines()] + [f"# units: length={length} angle={angle}"]
    pl = getattr(meas, "payload", None)
    cols = (
        [f"q{i + 1}" for i in range(meas.nq)]
        + ["x", "y", "z"]
        + (["rx", "ry", "rz"] if meas.kind == "pose" else [])
        + (list(PAYLOAD_COLUMNS) if pl is not None else [])
    )
    out.append(",".join(cols))
    rv = matrix_rotvec(meas.poses[:, :3, :3]) / as_ if meas.kind == "pose" else None
    for k in range(meas.n):
        row = (
            [*(meas.q[k] / qs), *(meas.points[k] / ls)]
            + ([*rv[k]] if rv is not None else [])
            + ([pl[k, 0], *(pl[k, 1:] / ls)] if pl is not None else [])
        )
        out.append(",".join(f"{v:.12g}" for v in row))
    return "\n".join(out) + "\n"


__all__ = ["read_measurements", "to_csv", "to_json"]
