"""Robot files: a human-readable TOML description of a robot in one convention, with declared units.

Format (see docs/robot-files.md and the built-in files in ``denavit/models``)::

    name = "kr5"
    convention = "dh"            # dh | mdh | edh | poe
    [units]
    length = "mm"                # m | mm | cm | um | in
    angle = "deg"                # rad | deg
    [[joints]]                   # one per joint, base to tip
    name = "A1"
    type = "revolute"            # optional, default revolute
    d = 400                      # the convention's columns (docs/conventions.md)
    theta = 0
    a = 180
    alpha = 90
    limits = [-155, 155]         # optional
    [joints.inertia]             # optional: link i's inertial parameters in the convention's frame i
    mass = 8.39                  # [units] mass (kg | g)
    com = [-203, 0, 120]         # centre of mass, [units] length
    ixx = 0.015                  # about the centre of mass, [units] inertia (e.g. "kg m^2", "g mm^2")
    iyy = 0.134                  # ixy, ixz, iyz default to 0
    izz = 0.133
    [base]                       # optional T_world_base: xyz (length) + rpy (angle), or matrix (4x4, length)
    xyz = [0, 0, 0]
    rpy = [0, 0, 0]
    [tool]                       # optional tool in the convention's last frame (poe: home pose M)

POE joints give ``w = [wx, wy, wz]`` and ``v = [vx, vy, vz]`` (v in length units).
Inertial parameters (for the dynamics) are given per link in frame i of the file's convention (``dh``: DH frame i
at the end of link i; ``mdh``, ``edh``: frame i; ``poe``: the model's joint frame i), about the centre of mass;
a file with any ``[joints.inertia]`` declares ``[units] mass`` and ``inertia``.
``rpy`` is roll-pitch-yaw about fixed axes as in URDF: ``R = Rz(yaw) Ry(pitch) Rx(roll)``.
"""

from __future__ import annotations

import math
import os
import re
import tomllib
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from . import _core
from .errors import DenavitError
from .io.output import write_text
from .io.units import angle_scale, inertia_scale, length_scale, mass_scale

CONVENTIONS = ("dh", "mdh", "edh", "poe")


@dataclass(frozen=True)
class Robot:
    """A robot description: its table in one convention, joint names, limits and metadata.

    Attributes are SI (m, rad). ``home`` is an optional reference configuration (e.g. a measurement home).
    """

    name: str
    table: _core.Table
    names: list[str]
    lower: np.ndarray
    upper: np.ndarray
    description: str = ""
    source: str = ""
    home: np.ndarray | None = None
    path: str = ""
    extra: dict = field(default_factory=dict)
    inertials: dict | None = None
    """Link inertial parameters in frame i of the convention, SI: ``masses`` (n,) kg, ``coms`` (n, 3) m,
    ``inertias`` (n, 3, 3) kg m^2 about each centre of mass (None: massless links)."""

    @property
    def convention(self) -> str:
        return self.table.convention

    def model(self) -> _core.Model:
        """The model (docs/conventions.md), with the link inertias of the file if it gives them."""
        model = self.table.to_model(self.name, self.names, self.lower, self.upper)
        if self.inertials is None:
            return model
        return attach_inertials(model, self.table, self.inertials)


def convention_frames_in_joint_frames(model: _core.Model, table: _core.Table) -> np.ndarray:
    """(n, 4, 4) pose of the convention's frame i in the model's joint frame i (fixed: both move with link i);
    the identity except for ``dh``, whose frame i sits at the end of link i."""
    n = model.nq
    if table.convention != "dh":
        return np.tile(np.eye(4), (n, 1, 1))
    q0 = np.zeros(n)
    J = _core.joint_frames(model, q0)
    F = table.frames(q0)[1:]
    return np.linalg.inv(J) @ F


def inertials_for_table(model: _core.Model, table: _core.Table, names: list[str], lower, upper) -> dict:
    """The link inertias of ``model`` (same robot, same joint axes at q = 0) in frame i of ``table``'s
    convention, as a :attr:`Robot.inertials` dict: how a conversion carries the dynamics along."""
    target = _core.transfer_inertias(model, table.to_model("target", names, lower, upper))
    ins = target.inertias
    T = convention_frames_in_joint_frames(target, table)
    R, p = T[:, :3, :3], T[:, :3, 3]
    coms = np.einsum("nji,nj->ni", R, ins["coms"] - p)
    return {"masses": ins["masses"], "coms": coms, "inertias": R.transpose(0, 2, 1) @ ins["inertias"] @ R}


def attach_inertials(model: _core.Model, table: _core.Table, inertials: dict) -> _core.Model:
    """``model`` with inertials given in frame i of ``table``'s convention (re-expressed in the joint frames)."""
    T = convention_frames_in_joint_frames(model, table)
    R, p = T[:, :3, :3], T[:, :3, 3]
    coms = np.einsum("nij,nj->ni", R, np.asarray(inertials["coms"], dtype=float)) + p
    inertias = R @ np.asarray(inertials["inertias"], dtype=float) @ R.transpose(0, 2, 1)
    return model.with_inertias(np.asarray(inertials["masses"], dtype=float), coms, inertias)


def builtin_names() -> list[str]:
    """Names of the built-in robot files."""
    return sorted(p.name[:-5] for p in resources.files("denavit.models").iterdir() if p.name.endswith(".toml"))


def resolve(name_or_path: str | os.PathLike) -> Path:
    """The file of a built-in name or a path; a clear error listing the built-ins otherwise."""
    p = Path(name_or_path)
    if p.suffix and p.exists():
        return p
    if p.exists() and p.is_file():
        return p
    key = str(name_or_path).lower().replace("-", "_")
    if key in builtin_names():
        return Path(str(resources.files("denavit.models").joinpath(key + ".toml")))
    raise DenavitError(f"unknown model {str(name_or_path)!r}: expected a built-in name ({', '.join(builtin_names())}) or an existing robot file (.toml) or URDF (.urdf)")


def _pose(spec: dict, ls: float, as_: float, where: str) -> np.ndarray:
    if not isinstance(spec, dict):
        raise DenavitError(f"{where}: expected a table with xyz/rpy or matrix, got {spec!r}")
    _check_keys(spec, ("xyz", "rpy", "matrix"), where)
    T = np.eye(4)
    if "matrix" in spec:
        m = np.asarray(spec["matrix"], dtype=float)
        if m.shape != (4, 4):
            raise DenavitError(f"{where}: matrix must be 4x4, got shape {m.shape}")
        T = m.copy()
        T[:3, 3] *= ls
        return T
    xyz = np.asarray(spec.get("xyz", [0, 0, 0]), dtype=float)
    rpy = np.asarray(spec.get("rpy", [0, 0, 0]), dtype=float)
    if xyz.shape != (3,) or rpy.shape != (3,):
        raise DenavitError(f"{where}: xyz and rpy need 3 values each, got {xyz.tolist()} and {rpy.tolist()}")
    T[:3, :3] = Rotation.from_euler("xyz", rpy * as_).as_matrix()
    T[:3, 3] = xyz * ls
    return T


def _joint_lines(text: str) -> list[int]:
    return [i + 1 for i, line in enumerate(text.splitlines()) if re.match(r"\s*\[\[\s*joints\s*\]\]", line)]


INERTIA_KEYS = ("mass", "com", "ixx", "iyy", "izz", "ixy", "ixz", "iyz")
UNIT_KEYS = ("length", "angle", "mass", "inertia")


def _check_keys(table: dict, expected, where: str) -> None:
    """A table's keys must all be expected ones: a misspelt key must not fall back to a default."""
    unknown = [k for k in table if k not in expected]
    if unknown:
        raise DenavitError(f"{where}: unknown keys {unknown}: expected {', '.join(expected)}")


def _inertia(spec, jw: str, units: dict | None, where: str, ls: float) -> tuple[float, list[float], np.ndarray]:
    """One joint's ``inertia`` table -> (mass kg, com m, inertia about the com kg m^2), checked for form here
    and for physics (mass >= 0, positive semi-definite, triangle inequality) by the core."""
    if not isinstance(spec, dict):
        raise DenavitError(f"{jw}: inertia must be a table with mass, com, ixx, iyy, izz (ixy, ixz, iyz), got {spec!r}")
    _check_keys(spec, INERTIA_KEYS, f"{jw}: inertia")
    missing = [k for k in ("mass", "com", "ixx", "iyy", "izz") if k not in spec]
    if missing:
        raise DenavitError(f"{jw}: inertia: missing {', '.join(missing)}")
    if not isinstance(units, dict) or "mass" not in units or "inertia" not in units:
        raise DenavitError(f"{where}: [units] must declare 'mass' and 'inertia' (e.g. mass = \"kg\", inertia = \"kg m^2\") when a joint gives an inertia")
    ms = mass_scale(units["mass"], f"{where}, [units] mass")
    iscale = inertia_scale(units["inertia"], f"{where}, [units] inertia")
    try:
        vals = {k: float(spec.get(k, 0.0)) for k in INERTIA_KEYS if k != "com"}
        com = [float(c) for c in spec["com"]]
    except (TypeError, ValueError):
        raise DenavitError(f"{jw}: inertia: mass, ixx ... iyz must be numbers and com three numbers, got {spec!r}") from None
    if len(com) != 3:
        raise DenavitError(f"{jw}: inertia: com needs 3 values, got {len(com)}")
    bad = [k for k, v in vals.items() if not math.isfinite(v)] + (["com"] if not all(map(math.isfinite, com)) else [])
    if bad:
        raise DenavitError(f"{jw}: inertia: {', '.join(bad)} must be finite")
    I = np.array([[vals["ixx"], vals["ixy"], vals["ixz"]], [vals["ixy"], vals["iyy"], vals["iyz"]], [vals["ixz"], vals["iyz"], vals["izz"]]])
    return vals["mass"] * ms, [c * ls for c in com], I * iscale


def load(name_or_path: str | os.PathLike) -> Robot:
    """Read a robot file (or a built-in by name) into a :class:`Robot` (SI inside)."""
    path = resolve(name_or_path)
    if path.suffix.lower() == ".urdf":
        from .urdf import load_urdf  # noqa: PLC0415 (URDF support lives in its own module)

        return load_urdf(path)
    text = path.read_text(encoding="utf-8")
    try:
        doc = tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        raise DenavitError(f"{path}: not a valid TOML robot file: {e}") from None
    return from_dict(doc, where=str(path), joint_lines=_joint_lines(text))


def from_dict(doc: dict, where: str = "robot", joint_lines: list[int] | None = None) -> Robot:
    """Build a :class:`Robot` from the parsed TOML structure (see the module docstring)."""
    conv = str(doc.get("convention", "")).lower()
    if conv not in CONVENTIONS:
        raise DenavitError(f"{where}: 'convention' must be one of {', '.join(CONVENTIONS)}, got {doc.get('convention')!r}")
    units = doc.get("units")
    if not isinstance(units, dict) or "length" not in units or "angle" not in units:
        raise DenavitError(f"{where}: a [units] table with 'length' and 'angle' is required (e.g. length = \"mm\", angle = \"deg\"), got {units!r}")
    _check_keys(units, UNIT_KEYS, f"{where}, [units]")
    ls = length_scale(units["length"], f"{where}, [units] length")
    as_ = angle_scale(units["angle"], f"{where}, [units] angle")
    joints = doc.get("joints")
    if not isinstance(joints, list) or not joints:
        raise DenavitError(f"{where}: expected one or more [[joints]] tables, got none")
    cols = list(_core.Table(conv, np.zeros((0, len(_columns(conv))))).columns)
    angle_cols = _angle_columns(conv)
    rows, kinds, names, lower, upper = [], [], [], [], []
    inert: list[tuple[float, list[float], np.ndarray] | None] = []
    joint_where = []
    for i, j in enumerate(joints):
        line = f" (line {joint_lines[i]})" if joint_lines and i < len(joint_lines) else ""
        jw = f"{where}, joint {i + 1}{line}"
        joint_where.append(jw)
        if not isinstance(j, dict):
            raise DenavitError(f"{jw}: expected a [[joints]] table, got {j!r}")
        _check_keys(j, ["name", "type", *(["w", "v"] if conv == "poe" else cols), "limits", "inertia"], jw)
        inert.append(_inertia(j["inertia"], jw, units, where, ls) if "inertia" in j else None)
        kind = str(j.get("type", "revolute")).lower()
        if kind not in ("revolute", "prismatic"):
            raise DenavitError(f"{jw}: type must be 'revolute' or 'prismatic', got {j.get('type')!r}")
        kinds.append(kind)
        names.append(str(j.get("name", f"j{i + 1}")))
        if conv == "poe":
            w = np.asarray(j.get("w", [0, 0, 0]), dtype=float)
            v = np.asarray(j.get("v", [0, 0, 0]), dtype=float)
            if w.shape != (3,) or v.shape != (3,):
                raise DenavitError(f"{jw}: poe joints need w and v with 3 values each")
            rows.append([*w, *(v * (ls if kind == "revolute" else 1.0))])
        else:
            missing = [c for c in cols if c not in j]
            if missing:
                raise DenavitError(f"{jw}: missing parameter(s) {', '.join(missing)} of a {conv} table (columns {', '.join(cols)})")
            row = []
            for c, is_angle in zip(cols, angle_cols):
                try:
                    val = float(j[c])
                except (TypeError, ValueError):
                    raise DenavitError(f"{jw}: parameter {c} must be a number, got {j[c]!r}") from None
                if not math.isfinite(val):
                    raise DenavitError(f"{jw}: parameter {c} must be finite, got {val}")
                row.append(val * (as_ if is_angle else ls))
            rows.append(row)
        lim = j.get("limits")
        scale = as_ if kind == "revolute" else ls
        if lim is None:
            lo, hi = (-math.pi, math.pi) if kind == "revolute" else (-1.0, 1.0)
        else:
            if len(lim) != 2 or float(lim[0]) > float(lim[1]):
                raise DenavitError(f"{jw}: limits must be [lower, upper] with lower <= upper, got {lim!r}")
            lo, hi = float(lim[0]) * scale, float(lim[1]) * scale
        lower.append(lo)
        upper.append(hi)
    base = _pose(doc["base"], ls, as_, f"{where}, [base]") if "base" in doc else np.eye(4)
    tool = _pose(doc["tool"], ls, as_, f"{where}, [tool]") if "tool" in doc else np.eye(4)
    table = _core.Table(conv, np.asarray(rows, dtype=float).reshape(len(rows), len(cols)), kinds, base, tool)
    home = doc.get("home")
    if home is not None:
        home = np.asarray(home, dtype=float)
        if home.shape != (len(joints),):
            raise DenavitError(f"{where}: home must have {len(joints)} values, got {home.shape}")
        home = np.array([h * (as_ if k == "revolute" else ls) for h, k in zip(home, kinds)])
    known = {"name", "description", "source", "convention", "units", "joints", "base", "tool", "home"}
    # other tables (e.g. [urdf], written by `convert` from a URDF) are carried as extra; a stray plain key is
    # most likely a typo ("hom" for "home")
    _check_keys({k: v for k, v in doc.items() if not isinstance(v, dict)}, sorted(known), f"{where} (top level)")
    inertials = None
    if any(x is not None for x in inert):
        zero = (0.0, [0.0, 0.0, 0.0], np.zeros((3, 3)))
        full = [x if x is not None else zero for x in inert]
        inertials = {
            "masses": np.array([x[0] for x in full]),
            "coms": np.array([x[1] for x in full]),
            "inertias": np.array([x[2] for x in full]),
        }
        try:  # the core's physical checks, reported at the joint's line
            attach_inertials(table.to_model("check"), table, inertials)
        except DenavitError as e:
            m = re.search(r"of link (\d+)", str(e))
            at = joint_where[int(m.group(1)) - 1] if m else where
            raise DenavitError(f"{at}: inertia: {e}") from None
    return Robot(
        name=str(doc.get("name", Path(where).stem)),
        table=table,
        names=names,
        lower=np.array(lower),
        upper=np.array(upper),
        description=str(doc.get("description", "")),
        source=str(doc.get("source", "")),
        home=home,
        path=where,
        extra={k: v for k, v in doc.items() if k not in known},
        inertials=inertials,
    )


def _columns(conv: str) -> list[str]:
    return {"dh": ["d", "theta", "a", "alpha"], "mdh": ["alpha", "a", "theta", "d"], "edh": ["alpha", "a", "b", "c", "theta"], "poe": ["wx", "wy", "wz", "vx", "vy", "vz"]}[conv]


def _angle_columns(conv: str) -> list[bool]:
    return list(_core.Table(conv, np.zeros((0, len(_columns(conv))))).angle_columns)


def _pose_spec(T: np.ndarray, ls: float, as_: float) -> dict:
    return {"xyz": [float(v) for v in T[:3, 3] / ls], "rpy": [float(v) for v in Rotation.from_matrix(T[:3, :3]).as_euler("xyz") / as_]}


def to_dict(robot: Robot, length: str = "m", angle: str = "rad") -> dict:
    """The TOML structure of a robot in the given units."""
    ls, as_ = length_scale(length), angle_scale(angle)
    t = robot.table
    doc: dict = {"name": robot.name}
    if robot.description:
        doc["description"] = robot.description
    if robot.source:
        doc["source"] = robot.source
    doc["convention"] = t.convention
    if robot.home is not None:
        doc["home"] = [float(h / (as_ if k == "revolute" else ls)) for h, k in zip(robot.home, t.kinds)]
    doc["units"] = {"length": length, "angle": angle}
    if robot.inertials is not None:
        doc["units"].update({"mass": "kg", "inertia": "kg m^2"})
    joints = []
    for i, (row, kind) in enumerate(zip(t.params, t.kinds)):
        j: dict = {"name": robot.names[i]}
        if kind != "revolute":
            j["type"] = kind
        if t.convention == "poe":
            j["w"] = [float(v) for v in row[:3]]
            j["v"] = [float(v / (ls if kind == "revolute" else 1.0)) for v in row[3:]]
        else:
            for c, is_angle, v in zip(t.columns, t.angle_columns, row):
                j[c] = float(v / (as_ if is_angle else ls))
        scale = as_ if kind == "revolute" else ls
        j["limits"] = [float(robot.lower[i] / scale), float(robot.upper[i] / scale)]
        if robot.inertials is not None and robot.inertials["masses"][i] > 0:
            I = robot.inertials["inertias"][i]
            j["inertia"] = {
                "mass": float(robot.inertials["masses"][i]),
                "com": [float(c / ls) for c in robot.inertials["coms"][i]],
                **{k: float(I[a, b]) for k, (a, b) in zip(("ixx", "iyy", "izz", "ixy", "ixz", "iyz"), ((0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2)))},
            }
        joints.append(j)
    doc["joints"] = joints
    if not np.allclose(t.T_world_base, np.eye(4), atol=0, rtol=0):
        doc["base"] = _pose_spec(t.T_world_base, ls, as_)
    if not np.allclose(t.T_last_tool, np.eye(4), atol=0, rtol=0):
        doc["tool"] = _pose_spec(t.T_last_tool, ls, as_)
    doc.update(robot.extra)
    return doc


def dumps(robot: Robot, length: str = "m", angle: str = "rad") -> str:
    """A robot file's text."""
    import tomli_w  # noqa: PLC0415

    header = f"# {robot.description or robot.name}\n" + (f"# Source: {robot.source}\n" if robot.source else "")
    return header + tomli_w.dumps(to_dict(robot, length, angle))


def save(robot: Robot, path: str | os.PathLike, length: str = "m", angle: str = "rad") -> None:
    """Write a robot file (whole or not at all)."""
    write_text(path, dumps(robot, length, angle))
