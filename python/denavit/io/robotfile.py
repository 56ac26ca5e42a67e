"""Robot files: a human-readable TOML description of a robot in one convention, with declared units.

Format (see docs/robot-files.md and the built-in files in ``denavit/models``)::

    name = "kr5"
    convention = "dh"            # dh | mdh | edh | poe (or any name of _core.convention_info: sdh, craig, ...)
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
    [couplings]                  # optional: joint values from the controller's readings (parse_coupling)
    q3 = "r3 + r2"               # a Fanuc reads J3 relative to the horizontal
    [readings]                   # optional (written by identify/calibrate --save): the readings' scale errors
    scale = [0, 2.1e-4, ...]     # joint i turns 1 + scale[i] times its reading's motion from reference[i]
    reference = [90, -90, ...]   # where joint value = reading (angle / length units; default 0)
    [compliance]                 # optional (issue 37; needs [joints.inertia]): joint i sits at q_i - k_i tau_i under
    unit = "urad/(N m)"          # its gravity torque tau_i; revolute joints' unit (prismatic_unit = "um/N" if any)
    values = [0, 1.5, ...]       # k_i >= 0 (denavit.io.payload); optional covariance, cross_covariance
    [prior]                      # optional: calibrate's prior widths (--prior's grammar; --prior wins): a kind
    length = "0.5 mm"            # (length, angle, offset, scale, compliance) or a parameter name or pattern =
    a_5 = "2 mm"                 # a width with its unit, or a number in [units] (kinds only; scale a ratio)
    [covariance]                 # optional (written by identify, calibrate --save): of the joints' parameters, row by
    matrix = [[...], ...]        # row in column order, then the tool's x, y, z, then [readings] scale (if
                                 # given); in [units] (products per cell; scales unitless)

POE joints give ``w = [wx, wy, wz]`` (unitless) and ``v = [vx, vy, vz]`` (length units for a revolute joint,
v = -w x p; a unitless direction for a prismatic one). Joint values (``home``, ``limits``) are in the angle
unit for a revolute joint and in the length unit for a prismatic one (:func:`denavit.io.units.joint_scale`).
Inertial parameters (for the dynamics) are given per link in frame i of the file's convention (``dh``: DH frame i
at the end of link i; ``mdh``, ``edh``: frame i; ``poe``: the model's joint frame i), about the centre of mass;
a file with any ``[joints.inertia]`` declares ``[units] mass`` and ``inertia``.
``rpy`` is roll-pitch-yaw about fixed axes as in URDF: ``R = Rz(yaw) Ry(pitch) Rx(roll)``.
"""

from __future__ import annotations

import os
import re
import sys
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

if sys.version_info >= (3, 11):
    import tomllib
else:  # Python 3.10: the same parser, from PyPI (pyproject's tomli marker)
    import tomli as tomllib

from .. import _core, limits
from ..errors import DenavitError
from ..geometry import matrix_rpy, rpy_matrix
from ..robot import Robot, attach_inertials
from .delimited import as_number
from .output import write_text
from .payload import compliance_spec, read_compliance
from .text import read_text
from .units import angle_scale, cell_scale, inertia_scale, joint_scale, length_scale, mass_scale


def _pose(spec: dict, ls: float, as_: float, where: str) -> np.ndarray:
    if not isinstance(spec, dict):
        raise DenavitError(f"{where}: expected a table with xyz/rpy or matrix, got {spec!r}")
    _check_keys(spec, ("xyz", "rpy", "matrix"), where)
    T = np.eye(4)
    if "matrix" in spec:
        rows = spec["matrix"]
        if not isinstance(rows, list) or len(rows) != 4:
            raise DenavitError(f"{where}: matrix must be 4x4 (4 rows of 4 numbers), got {_show(rows)}")
        T = np.array([_numbers(r, 4, f"{where}: matrix row {i + 1}") for i, r in enumerate(rows)])
        T[:3, 3] *= ls
        limits.check_lengths(T[:3, 3], f"{where}: matrix, translation", _unit(ls), ls)
        return T
    xyz = np.array(_numbers(spec.get("xyz", [0, 0, 0]), 3, f"{where}: xyz"))
    rpy = np.array(_numbers(spec.get("rpy", [0, 0, 0]), 3, f"{where}: rpy"))
    _plausible_angles(rpy, as_, f"{where}: rpy")
    T[:3, :3] = rpy_matrix(rpy * as_)
    T[:3, 3] = xyz * ls
    limits.check_lengths(T[:3, 3], f"{where}: xyz", _unit(ls), ls)
    return T


def _plausible_angles(values, as_: float, where: str, joint: bool = False) -> None:
    """Angles written in a robot file (its angle unit: ``as_`` rad each), finite ones within the turns allowed
    (:func:`denavit.limits.check_angles`; ``joint``: joint values, limits or home); in a file that declares radians, a
    value beyond 2 pi is degrees written
    under ``angle = "rad"``: an error that says so."""
    v = np.asarray(values, dtype=float).ravel()
    v = v[np.isfinite(v)]
    if not v.size:
        return
    worst = float(v[np.argmax(np.abs(v))])
    if as_ == 1.0 and abs(worst) > 2 * np.pi + 1e-9:
        raise DenavitError(
            f'{where}: {worst:.6g} is beyond 2 pi, yet [units] angle = "rad": degrees written? (declare angle = "deg",'
            " or give radians)"
        )
    limits.check_angles(v * as_, where, "rad" if as_ == 1.0 else "deg", as_, joint)


def _plausible_table(raw: _core.Table, si: list, as_: float, joint_where: list[str]) -> None:
    """Every parameter of the table (file units; ``si`` SI per file unit, cell by cell) physically plausible: a
    length within 1 km, an angle as :func:`_plausible_angles` (degrees under ``angle = "rad"`` named as such)."""
    angles = raw.angle_columns
    for i, row in enumerate(raw.params):
        for k, value in enumerate(row):
            what = f"{joint_where[i]}: parameter {raw.columns[k]}"
            if angles[k]:
                _plausible_angles([value], as_, what)
            elif not (raw.convention == "poe" and (k < 3 or raw.kinds[i] == "prismatic")):
                limits.check_lengths([value * si[i][k]], what, _unit(si[i][k]), si[i][k])


def _unit(ls: float) -> str:
    """The name of the length unit of ``ls`` metres (for a message)."""
    from .units import LENGTH  # noqa: PLC0415

    return next((u for u, v in LENGTH.items() if v == ls), "m")


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
        raise DenavitError(
            f"{where}: [units] must declare 'mass' and 'inertia' (e.g. mass = \"kg\", inertia = \"kg m^2\") when a"
            " joint gives an inertia"
        )
    ms = mass_scale(units["mass"], f"{where}, [units] mass")
    iscale = inertia_scale(units["inertia"], f"{where}, [units] inertia")
    vals = {k: _number(spec.get(k, 0.0), f"{jw}: inertia: {k}") for k in INERTIA_KEYS if k != "com"}
    com = _numbers(spec["com"], 3, f"{jw}: inertia: com")
    I = np.array(
        [
            [vals["ixx"], vals["ixy"], vals["ixz"]],
            [vals["ixy"], vals["iyy"], vals["iyz"]],
            [vals["ixz"], vals["iyz"], vals["izz"]],
        ]
    )
    limits.check_lengths([c * ls for c in com], f"{jw}: inertia: com", _unit(ls), ls)
    return vals["mass"] * ms, [c * ls for c in com], I * iscale


def _core_error_place(e: DenavitError, where: str, joint_where: list[str]) -> str:
    """Where in the file a core error about the whole table is: the joint it is about (its ``joint`` field), the
    [tool] or [base] pose (the transform it names, ``what``), else the file."""
    if e.joint is not None and 1 <= e.joint <= len(joint_where):
        return joint_where[e.joint - 1]
    if e.what == "T_last_tool":
        return f"{where}, [tool]"
    if e.what == "T_world_base":
        return f"{where}, [base]"
    return where


def read(path: str | os.PathLike) -> Robot:
    """Read a TOML robot file into a :class:`~denavit.robot.Robot` (SI inside); built-in names and URDFs go
    through :func:`denavit.io.robots.load`."""
    text = read_text(path, "robot file")
    # the joints counted before the TOML parser reads them all (10^6 joints had taken it minutes)
    limits.check_size(len(re.findall(r"(?m)^[ \t]*\[\[[ \t]*joints[ \t]*\]\]", text)), "joints", str(path), "joints")
    try:
        doc = tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        raise DenavitError(f"{path}: not a valid TOML robot file: {e}") from None
    except ValueError:  # tomllib's int() of an integer of over 4300 digits (Python's conversion limit)
        raise DenavitError(f"{path}: not a readable TOML robot file: an integer of over 4300 digits") from None
    except RecursionError:
        raise DenavitError(f"{path}: not a readable TOML robot file: arrays or tables nested too deeply") from None
    return from_dict(doc, where=str(path), joint_lines=_joint_lines(text))


#: The robot-file table ``calibrate --save`` writes the training poses' joint ranges to (the file's joint units).
TRAINING_TABLE = "training"


def training_table(q, kinds, length: str, angle: str) -> dict:
    """The ``[training]`` table of a robot file: the joint ranges of the poses a calibration was fitted on (``lower``,
    ``upper`` in the file's joint units: ``angle`` for a revolute joint, ``length`` for a prismatic one) and their
    count, so that :func:`denavit.validate` flags poses outside them."""
    q = np.asarray(q, dtype=float)
    s = joint_scale(list(kinds), length, angle)
    return {
        "poses": len(q),
        "lower": [float(v) for v in q.min(axis=0) / s],
        "upper": [float(v) for v in q.max(axis=0) / s],
    }


def _training(spec, kinds, units: dict, where: str) -> np.ndarray | None:
    """(2, n) the lower and upper training joint values (SI) of a ``[training]`` table in the file's ``units``."""
    if not isinstance(spec, dict):
        return None
    try:
        s = joint_scale(list(kinds), units.get("length", "m"), units.get("angle", "rad"), where)
        lo, hi = (np.asarray(spec[k], dtype=float) for k in ("lower", "upper"))
    except (ValueError, TypeError, KeyError) as e:
        raise DenavitError(
            f"{where}: expected lower = [...] and upper = [...], one joint value each in the file's units ({e})"
        ) from None
    if lo.shape != (len(s),) or hi.shape != (len(s),) or not (np.all(np.isfinite(lo)) and np.all(np.isfinite(hi))):
        raise DenavitError(
            f"{where}: expected lower and upper of {len(s)} finite joint values each, got {lo.tolist()} and"
            f" {hi.tolist()}"
        )
    return np.vstack([lo * s, hi * s])


#: The top-level keys of a robot file: its other tables (e.g. [urdf], written by `convert` from a URDF) are carried
#: as :attr:`~denavit.robot.Robot.extra`.
_TOP_KEYS = frozenset(
    {
        "name",
        "description",
        "source",
        "convention",
        "units",
        "joints",
        "base",
        "tool",
        "home",
        "couplings",
        "readings",
        "covariance",
        "compliance",
        "prior",
    }
)


def from_dict(doc: dict, where: str = "robot", joint_lines: list[int] | None = None) -> Robot:
    """Build a :class:`Robot` from the parsed TOML structure (see the module docstring): one step per table, in
    the order their errors are said."""
    info = _convention(doc, where)
    units, ls, as_ = _units(doc, where)
    joints = _joints(doc, info, units, ls, where, joint_lines)
    kinds, names = joints.kinds, joints.names
    base = _pose(doc["base"], ls, as_, f"{where}, [base]") if "base" in doc else np.eye(4)
    tool = _pose(doc["tool"], ls, as_, f"{where}, [tool]") if "tool" in doc else np.eye(4)
    table = _table(info, joints, units, as_, base, tool, where)
    home = _home(doc.get("home"), kinds, units, ls, as_, where)
    coupling = parse_coupling(doc["couplings"], kinds, f"{where}, [couplings]") if "couplings" in doc else None
    scale, reference = (
        _readings(doc["readings"], kinds, units, f"{where}, [readings]") if "readings" in doc else (None, None)
    )
    covariance, entries = (  # (and SI per file unit of each entry: [compliance] cross_covariance's rows)
        _covariance(doc["covariance"], table, units, f"{where}, [covariance]", scale is not None)
        if "covariance" in doc
        else (None, None)
    )
    # a stray plain key is most likely a typo ("hom" for "home")
    _check_keys({k: v for k, v in doc.items() if not isinstance(v, dict)}, sorted(_TOP_KEYS), f"{where} (top level)")
    inertials = _inertials(joints, table, where)
    geometry = None if covariance is None else (covariance, entries)
    compliance, compliance_cov, compliance_cross, compliance_flange = (
        _compliance(doc["compliance"], kinds, names, inertials is not None, ls, as_, where, geometry)
        if "compliance" in doc
        else (None, None, None, None)
    )
    prior = _prior(doc["prior"], units, f"{where}, [prior]") if "prior" in doc else None
    training = _training(doc.get(TRAINING_TABLE), kinds, units, f"{where}, [{TRAINING_TABLE}]")
    return Robot(
        name=_text(doc.get("name", Path(where).stem), f"{where}: name"),
        table=table,
        names=names,
        lower=np.array(joints.lower),
        upper=np.array(joints.upper),
        description=_text(doc.get("description", ""), f"{where}: description"),
        source=_text(doc.get("source", ""), f"{where}: source"),
        home=home,
        path=where,
        extra={k: v for k, v in doc.items() if k not in _TOP_KEYS},
        training=training,
        inertials=inertials,
        coupling=coupling,
        covariance=covariance,
        reading_scale=scale,
        reading_reference=reference,
        compliance=compliance,
        compliance_covariance=compliance_cov,
        compliance_cross=compliance_cross,
        compliance_flange=compliance_flange,
        prior=prior,
    )


def _convention(doc: dict, where: str) -> dict:
    """The core's description of the file's ``convention`` (its one parser of convention names: dh, sdh, mdh, craig,
    modified-dh, edh, poe; any case)."""
    try:
        info = _core.convention_info(doc["convention"]) if isinstance(doc.get("convention"), str) else None
    except DenavitError:
        info = None
    if info is None:
        raise DenavitError(
            f"{where}: 'convention' must be one of {', '.join(_core.conventions())}, got {doc.get('convention')!r} "
            "(aliases: sdh, craig, modified-dh, in any case)"
        )
    return info


def _units(doc: dict, where: str) -> tuple[dict, float, float]:
    """The ``[units]`` table, its length and angle scales (SI per file unit)."""
    units = doc.get("units")
    if not isinstance(units, dict) or "length" not in units or "angle" not in units:
        raise DenavitError(
            f"{where}: a [units] table with 'length' and 'angle' is required "
            f'(e.g. length = "mm", angle = "deg"), got {units!r}'
        )
    _check_keys(units, UNIT_KEYS, f"{where}, [units]")
    ls = length_scale(units["length"], f"{where}, [units] length")
    as_ = angle_scale(units["angle"], f"{where}, [units] angle")
    return units, ls, as_


@dataclass
class _Joints:
    """The ``[[joints]]`` tables read, one entry per joint: its row of parameters (file units), type, name, limits
    (SI), inertia (SI, or None) and place in the file."""

    rows: list[list[float]] = field(default_factory=list)
    kinds: list[str] = field(default_factory=list)
    names: list[str] = field(default_factory=list)
    lower: list[float] = field(default_factory=list)
    upper: list[float] = field(default_factory=list)
    inertia: list[tuple[float, list[float], np.ndarray] | None] = field(default_factory=list)
    where: list[str] = field(default_factory=list)


def _joints(doc: dict, info: dict, units: dict, ls: float, where: str, joint_lines: list[int] | None) -> _Joints:
    """The ``[[joints]]`` tables, each checked for its keys, type, parameters and limits, and their names unique."""
    joints = doc.get("joints")
    if not isinstance(joints, list) or not joints:
        raise DenavitError(f"{where}: expected one or more [[joints]] tables, got none")
    limits.check_size(len(joints), "joints", where, "joints")
    conv, cols = info["name"], list(info["columns"])
    out = _Joints()
    for i, j in enumerate(joints):
        line = f" (line {joint_lines[i]})" if joint_lines and i < len(joint_lines) else ""
        jw = f"{where}, joint {i + 1}{line}"
        out.where.append(jw)
        if not isinstance(j, dict):
            raise DenavitError(f"{jw}: expected a [[joints]] table, got {j!r}")
        _check_keys(j, ["name", "type", *(["w", "v"] if conv == "poe" else cols), "limits", "inertia"], jw)
        out.inertia.append(_inertia(j["inertia"], jw, units, where, ls) if "inertia" in j else None)
        kind = _text(j.get("type", "revolute"), f"{jw}: type").lower()
        if kind not in ("revolute", "prismatic"):
            raise DenavitError(f"{jw}: type must be 'revolute' or 'prismatic', got {j.get('type')!r}")
        out.kinds.append(kind)
        out.names.append(_text(j.get("name", f"j{i + 1}"), f"{jw}: name"))
        out.rows.append(_joint_row(j, conv, cols, jw))
        lo, hi = _joint_limits(j.get("limits"), kind, units, jw)
        out.lower.append(lo)
        out.upper.append(hi)
    first = {}
    for i, nm in enumerate(out.names):  # (the core refuses it too, but without the file's place)
        if nm in first:
            raise DenavitError(
                f"{out.where[i]}: name {nm!r} is joint {first[nm] + 1}'s already: "
                "expected names unique within the robot"
            )
        first[nm] = i
    return out


def _joint_row(j: dict, conv: str, cols: list[str], jw: str) -> list[float]:
    """A joint's row of parameters in the file's units: ``w``, ``v`` of a POE joint, else the convention's columns."""
    if conv == "poe":
        w = np.array(_numbers(j.get("w", [0, 0, 0]), 3, f"{jw}: w (poe joints need w and v with 3 values each)"))
        v = np.array(_numbers(j.get("v", [0, 0, 0]), 3, f"{jw}: v (poe joints need w and v with 3 values each)"))
        return [*w, *v]
    missing = [c for c in cols if c not in j]
    if missing:
        raise DenavitError(
            f"{jw}: missing parameter(s) {', '.join(missing)} of a {conv} table (columns {', '.join(cols)})"
        )
    return [_number(j[c], f"{jw}: parameter {c}") for c in cols]


def _joint_limits(lim, kind: str, units: dict, jw: str) -> tuple[float, float]:
    """A joint's ``limits`` (SI; the core's defaults for its type when not given)."""
    scale = joint_scale([kind], units["length"], units["angle"], jw)[0]
    if lim is None:
        return _core.default_limits(kind)
    raw_lim = _numbers(lim, 2, f"{jw}: limits", finite=False)
    if kind == "revolute":
        _plausible_angles(raw_lim, scale, f"{jw}: limits", joint=True)
    else:
        limits.check_lengths([v * scale for v in raw_lim if np.isfinite(v)], f"{jw}: limits", _unit(scale), scale)
    lo, hi = (v * scale for v in raw_lim)
    if lo > hi:
        raise DenavitError(f"{jw}: limits must be [lower, upper] with lower <= upper, got {lim!r}")
    return lo, hi


def _table(
    info: dict, joints: _Joints, units: dict, as_: float, base: np.ndarray, tool: np.ndarray, where: str
) -> _core.Table:
    """The joints' rows in SI with ``base`` and ``tool``, checked by the core (a POE screw, a non-rigid tool) and
    its errors said at their place in the file."""
    conv, cols, rows, kinds = info["name"], list(info["columns"]), joints.rows, joints.kinds
    # the rows in the file's units -> SI, cell by cell (io.units.cell_scale: angles, lengths, unitless POE directions)
    raw = _core.Table(conv, np.asarray(rows, dtype=float).reshape(len(rows), len(cols)), kinds)
    si = [
        [cell_scale(raw, i, k, units["length"], units["angle"])[0] for k in range(len(cols))] for i in range(len(rows))
    ]
    _plausible_table(raw, si, as_, joints.where)
    try:
        table = _core.Table(conv, raw.params * np.asarray(si).reshape(raw.params.shape), kinds, base, tool)
        table.to_model("check")
    except DenavitError as e:
        raise DenavitError(f"{_core_error_place(e, where, joints.where)}: {e}") from None
    return table


def _home(home, kinds: list[str], units: dict, ls: float, as_: float, where: str) -> np.ndarray | None:
    """The ``home`` joint values (SI), or None when not given."""
    if home is None:
        return None
    home = np.asarray(_numbers(home, len(kinds), f"{where}: home"))
    rev = np.array([k == "revolute" for k in kinds])
    _plausible_angles(home[rev], as_, f"{where}: home", joint=True)
    home = home * joint_scale(kinds, units["length"], units["angle"], where)
    limits.check_lengths(home[~rev], f"{where}: home", _unit(ls), ls)
    return home


def _inertials(joints: _Joints, table: _core.Table, where: str) -> dict | None:
    """The links' inertial parameters (a link without ``inertia`` has none) checked by the core for physics and its
    errors said at the joint's line; None when no joint gives one."""
    if all(x is None for x in joints.inertia):
        return None
    zero = (0.0, [0.0, 0.0, 0.0], np.zeros((3, 3)))
    full = [x if x is not None else zero for x in joints.inertia]
    inertials = {
        "masses": np.array([x[0] for x in full]),
        "coms": np.array([x[1] for x in full]),
        "inertias": np.array([x[2] for x in full]),
    }
    try:
        attach_inertials(table.to_model("check"), table, inertials)
    except DenavitError as e:
        joint = getattr(e, "joint", None)  # the core error names the link it is about
        at = joints.where[joint - 1] if joint else where
        raise DenavitError(f"{at}: inertia: {e}") from None
    return inertials


def _compliance(spec, kinds: list, names: list, inertial: bool, ls: float, as_: float, where: str, geometry=None):
    """(compliance, its covariance, its cross-covariance with the ``[covariance]``'s entries, the flange pose or None)
    of a ``[compliance]`` table (:mod:`denavit.io.payload`; ``geometry``: :func:`~.payload.read_compliance`'s)."""
    flange = None
    if isinstance(spec, dict) and "flange" in spec:
        flange = _pose(spec["flange"], ls, as_, f"{where}, [compliance] flange")
        spec = {k: v for k, v in spec.items() if k != "flange"}
    return (*read_compliance(spec, kinds, names, inertial, f"{where}, [compliance]", geometry), flange)


def _prior(spec, units: dict, where: str) -> str:
    """A ``[prior]`` table as ``calibrate --prior``'s grammar with explicit units: each key a kind (length, angle,
    offset, scale, compliance) or a parameter name or pattern, each value a width with its unit ("1 mm", "0.1 deg",
    "100 ppm") or, for a kind, a number in the file's [units] (a scale's: a ratio)."""
    from ..calibration.priors import parse_prior  # noqa: PLC0415 (the grammar's one parser)

    if not isinstance(spec, dict) or not spec:
        raise DenavitError(
            f'{where}: expected a table of KIND or parameter = WIDTH (e.g. length = "0.5 mm"), got {spec!r:.60}'
        )
    bare = {"length": units["length"], "angle": units["angle"], "offset": units["angle"], "scale": ""}
    items = []
    for key, v in spec.items():
        if isinstance(v, str):
            items.append(f"{key}={v.replace(' ', '')}")
        elif isinstance(v, (int, float)) and not isinstance(v, bool) and key in bare:
            items.append(f"{key}={v!r}{bare[key]}")
        else:
            raise DenavitError(
                f'{where}: {key} = {v!r}: expected a width with its unit, e.g. "2 mm" or "0.05 deg" (a bare number '
                f"only for a kind: {', '.join(bare)}, in the file's [units])"
            )
    text = ", ".join(items)
    parse_prior(text, 1.0, 1.0, where)  # its one-line errors, at this table
    return text


def _readings(spec, kinds: list[str], units: dict, where: str) -> tuple[np.ndarray, np.ndarray | None]:
    """(scale, reference in SI) of a ``[readings]`` table."""
    if not isinstance(spec, dict):
        raise DenavitError(f"{where}: expected a table with 'scale' (and 'reference'), got {_show(spec)}")
    _check_keys(spec, ["scale", "reference"], where)
    n = len(kinds)
    if "scale" not in spec:
        raise DenavitError(f"{where}: missing 'scale' (one reading scale error per joint, unitless)")
    scale = np.array(_numbers(spec["scale"], n, f"{where}: scale"))
    bad = np.flatnonzero(np.abs(scale) >= 0.1)
    if len(bad):
        raise DenavitError(
            f"{where}: scale: joint {bad[0] + 1}'s scale error {scale[bad[0]]:.6g} is not a small correction (expected"
            " |scale| < 0.1: the joint turns 1 + scale times its reading)"
        )
    ref = None
    if "reference" in spec:
        ref = np.array(_numbers(spec["reference"], n, f"{where}: reference")) * joint_scale(
            kinds, units["length"], units["angle"], where
        )
    return scale, ref


def _covariance_scales(table: _core.Table, length: str, angle: str, scales: bool = False) -> np.ndarray:
    """SI per file unit of each entry of a ``[covariance]`` (the table's cells row by row, then the tool's x, y, z,
    then, with ``scales``, the unitless reading scales)."""
    n, k = table.params.shape
    cells = [cell_scale(table, i, c, length, angle)[0] for i in range(n) for c in range(k)]
    return np.array(cells + [length_scale(length)] * 3 + ([1.0] * n if scales else []))


def _covariance(
    spec, table: _core.Table, units: dict, where: str, scales: bool = False
) -> tuple[np.ndarray, np.ndarray]:
    if not isinstance(spec, dict):
        raise DenavitError(f"{where}: expected a table with 'matrix', got {spec!r}")
    _check_keys(spec, ["matrix"], where)
    s = _covariance_scales(table, units["length"], units["angle"], scales)
    rows = spec.get("matrix")
    if not isinstance(rows, list) or len(rows) != len(s):
        what = (
            "the joints' parameters, the tool's x, y, z, then the [readings] scales"
            if scales
            else "the joints' parameters, then the tool's x, y, z"
        )
        raise DenavitError(
            f"{where}: matrix: expected {len(s)} rows ({what}), got {len(rows) if isinstance(rows, list) else rows!r}"
        )
    C = np.array([_numbers(r, len(s), f"{where}: matrix row {i + 1}") for i, r in enumerate(rows)]) * np.outer(s, s)
    # symmetric and positive semi-definite to round-off of the largest variance (an element-wise relative test
    # refused the round-off of the near-zero covariances of exact data)
    scale = max(np.abs(np.diag(C)).max(), 1e-300)
    if np.abs(C - C.T).max() > 1e-9 * scale or np.linalg.eigvalsh((C + C.T) / 2).min() < -1e-9 * scale:
        raise DenavitError(f"{where}: matrix: expected a symmetric positive semi-definite covariance")
    return C, s


_TERM = re.compile(r"\s*([+-]?)\s*(?:(\d+(?:\.\d*)?(?:[eE][+-]?\d+)?|\.\d+(?:[eE][+-]?\d+)?)\s*\*?\s*)?r(\d+)\s*")


def parse_coupling(spec, kinds: list[str], where: str) -> np.ndarray:
    """The (n, n) matrix ``C`` of ``q = C @ reading`` from equations of joint values in readings.

    ``spec``: a string ``"q3 = r3 + r2; q5 = r5 - 0.5 r4"`` (``;`` or ``,`` between equations; the CLI's
    ``--coupling``), or a table ``{"q3": "r3 + r2"}`` (a robot file's ``[couplings]``). A joint not given reads its
    own value (``qi = ri``). Coefficients are unitless: readings of joints of one kind only.
    """
    n = len(kinds)
    if isinstance(spec, str):
        eqs = {}
        for part in re.split(r"[;,]", spec):
            if not part.strip():
                continue
            lhs, eq, rhs = part.partition("=")
            if not eq:
                raise DenavitError(f"{where}: expected equations such as 'q3 = r3 + r2', got {part.strip()!r}")
            eqs[lhs.strip()] = rhs
    elif isinstance(spec, dict):
        eqs = spec
    else:
        raise DenavitError(f'{where}: expected equations such as q3 = "r3 + r2", got {spec!r}')
    C = np.eye(n)
    for lhs, rhs in eqs.items():
        m = re.fullmatch(r"q(\d+)", str(lhs).strip())
        i = int(m.group(1)) - 1 if m else -1
        if not 0 <= i < n:
            raise DenavitError(f"{where}: expected a joint q1..q{n} on the left, got {lhs!r}")
        if not isinstance(rhs, str) or not rhs.strip():
            raise DenavitError(f'{where}: {lhs}: expected readings such as "r3 + r2", got {rhs!r}')
        row, pos, text = np.zeros(n), 0, rhs.strip()
        while pos < len(text):
            t = _TERM.match(text, pos)
            if t is None or t.end() == pos or (pos > 0 and not t.group(1)):
                raise DenavitError(f"{where}: {lhs}: expected terms such as '+ 0.5 r2', got {text[pos:]!r} in {rhs!r}")
            k = int(t.group(3)) - 1
            if not 0 <= k < n:
                raise DenavitError(f"{where}: {lhs}: reading r{k + 1} of a robot with {n} joints")
            if kinds[k] != kinds[i]:
                raise DenavitError(
                    f"{where}: {lhs}: reading r{k + 1} is of a {kinds[k]} joint, q{i + 1} of a {kinds[i]} one"
                    " (coefficients are unitless)"
                )
            row[k] += (-1.0 if t.group(1) == "-" else 1.0) * (float(t.group(2)) if t.group(2) else 1.0)
            pos = t.end()
        C[i] = row
    if abs(np.linalg.det(C)) < 1e-9:
        raise DenavitError(f"{where}: the coupling is singular (readings do not determine the joint values): {eqs}")
    return C


def coupling_text(C: np.ndarray) -> dict:
    """The ``[couplings]`` table of ``C`` (rows that differ from the identity), the inverse of
    :func:`parse_coupling`."""
    out = {}
    for i, row in enumerate(np.asarray(C)):
        if np.array_equal(row, np.eye(len(row))[i]):
            continue
        terms = [
            ("-" if v < 0 else "+") + ("" if abs(v) == 1 else f" {abs(v):.12g}") + f" r{k + 1}"
            for k, v in enumerate(row)
            if v != 0
        ]
        out[f"q{i + 1}"] = " ".join(terms).lstrip("+ ")
    return out


def _number(value, where: str) -> float:
    """A TOML number as a float (:func:`denavit.io.delimited.as_number`: not a boolean nor a string that looks
    like a number, within the float range, finite)."""
    return as_number(value, where)


def _numbers(value, n: int, where: str, finite: bool = True) -> list[float]:
    """``n`` numbers (TOML integers or floats; not booleans, not strings), finite unless ``finite`` is False
    (limits: a continuous joint's are -inf, inf)."""
    if not isinstance(value, list) or len(value) != n:
        raise DenavitError(f"{where}: expected a list of {n} numbers, got {_show(value)}")
    return [as_number(v, f"{where}[{i}]", finite=finite) for i, v in enumerate(value)]


def _text(value, where: str) -> str:
    """A TOML string (a name, a type, a description): not a number or a list that would print as one."""
    if not isinstance(value, str):
        raise DenavitError(f"{where}: expected a string, got {_show(value)}")
    return value


def _show(value) -> str:
    """A short rendering of a TOML value for messages."""
    if isinstance(value, list):
        return f"a list of {len(value)}" if len(value) > 6 else f"[{', '.join(_show(v) for v in value)}]"
    text = repr(value) if isinstance(value, str) else "a table" if isinstance(value, dict) else str(value)
    return text if len(text) <= 40 else text[:37] + "..."


def _unit_value(si: float, scale: float) -> float:
    """``si`` in a unit of ``scale`` SI, as the shortest decimal that the reader (value x ``scale``) turns back into
    ``si`` exactly: a limit of -15 deg is written -15, not -14.999999999999998 (the division's rounding); else the
    quotient itself."""
    x = float(si) / scale
    for digits in (15, 16):
        d = float(f"{x:.{digits}g}")
        if d * scale == si:
            return d
    return x


def _pose_spec(T: np.ndarray, ls: float, as_: float) -> dict:
    return {"xyz": [_unit_value(v, ls) for v in T[:3, 3]], "rpy": [_unit_value(v, as_) for v in matrix_rpy(T[:3, :3])]}


def to_dict(robot: Robot, length: str = "m", angle: str = "rad") -> dict:
    """The TOML structure of a robot in the given units."""
    ls, as_ = length_scale(length), angle_scale(angle)
    t = robot.table
    js = joint_scale(t.kinds, length, angle)
    doc: dict = {"name": robot.name}
    if robot.description:
        doc["description"] = robot.description
    if robot.source:
        doc["source"] = robot.source
    doc["convention"] = t.convention
    if robot.home is not None:
        doc["home"] = [_unit_value(v, s) for v, s in zip(robot.home, js)]
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
            j["v"] = [_unit_value(v, cell_scale(t, i, 3 + k, length, angle)[0]) for k, v in enumerate(row[3:])]
        else:
            for k, (c, v) in enumerate(zip(t.columns, row)):
                j[c] = _unit_value(v, cell_scale(t, i, k, length, angle)[0])
        j["limits"] = [_unit_value(robot.lower[i], js[i]), _unit_value(robot.upper[i], js[i])]
        # a link with inertia but no mass (the Puma 560's link 1: its motor's rotor) keeps its inertia
        if robot.inertials is not None and (
            robot.inertials["masses"][i] > 0 or np.any(robot.inertials["inertias"][i] != 0)
        ):
            I = robot.inertials["inertias"][i]
            j["inertia"] = {
                "mass": float(robot.inertials["masses"][i]),
                "com": [_unit_value(c, ls) for c in robot.inertials["coms"][i]],
                **{
                    k: float(I[a, b])
                    for k, (a, b) in zip(
                        ("ixx", "iyy", "izz", "ixy", "ixz", "iyz"), ((0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2))
                    )
                },
            }
        joints.append(j)
    doc["joints"] = joints
    if not np.allclose(t.T_world_base, np.eye(4), atol=0, rtol=0):
        doc["base"] = _pose_spec(t.T_world_base, ls, as_)
    if not np.allclose(t.T_last_tool, np.eye(4), atol=0, rtol=0):
        doc["tool"] = _pose_spec(t.T_last_tool, ls, as_)
    if robot.reading_scale is not None:
        doc["readings"] = {"scale": [float(v) for v in robot.reading_scale]}
        if robot.reading_reference is not None:
            doc["readings"]["reference"] = [_unit_value(v, s) for v, s in zip(robot.reading_reference, js)]
    if robot.covariance is not None:
        s = _covariance_scales(t, length, angle, robot.reading_scale is not None)
        if np.shape(robot.covariance) != (len(s), len(s)):
            raise DenavitError(
                f"{robot.name}: covariance of shape {np.shape(robot.covariance)}, expected ({len(s)}, {len(s)}) for its"
                " table" + (" and reading scales" if robot.reading_scale is not None else "")
            )
        doc["covariance"] = {
            "matrix": [[float(v) for v in row] for row in np.asarray(robot.covariance) / np.outer(s, s)]
        }
    if robot.compliance is not None:
        cross = None
        if robot.compliance_cross is not None and robot.covariance is not None:
            cross = (robot.compliance_cross, _covariance_scales(t, length, angle, robot.reading_scale is not None))
        doc["compliance"] = compliance_spec(robot.compliance, robot.compliance_covariance, list(t.kinds), cross=cross)
        if robot.compliance_flange is not None:
            doc["compliance"]["flange"] = _pose_spec(np.asarray(robot.compliance_flange), ls, as_)
    if robot.prior:
        doc["prior"] = {k.strip(): v.strip() for k, v in (item.split("=", 1) for item in robot.prior.split(","))}
    if robot.coupling is not None and coupling_text(robot.coupling):
        doc["couplings"] = coupling_text(robot.coupling)
    doc.update(robot.extra)
    return doc


def dumps(robot: Robot, length: str = "m", angle: str = "rad") -> str:
    """A robot file's text."""
    import tomli_w  # noqa: PLC0415

    header = f"# {robot.description or robot.name}\n" + (f"# Source: {robot.source}\n" if robot.source else "")
    return header + _inline_arrays(tomli_w.dumps(to_dict(robot, length, angle)))


#: An array tomli_w wrote one item a line, whose items are plain values (no nested array or table).
_ARRAY_BLOCK = re.compile(r"\[\n((?:[ \t]+[^\[\]{}\n]+,\n)+)[ \t]*\]")


def _inline_arrays(text: str) -> str:
    """tomli_w's arrays, one item a line, written inline (``limits = [-155.0, 155.0]``; issue 40); a matrix keeps a
    row a line. The same TOML values: only whitespace between the items changes (strings hold no newline here)."""
    return _ARRAY_BLOCK.sub(
        lambda m: "[" + ", ".join(x.strip().rstrip(",") for x in m.group(1).splitlines()) + "]", text
    )


def save(robot: Robot, path: str | os.PathLike, length: str = "m", angle: str = "rad", *, force: bool = False) -> None:
    """Write a robot file (whole or not at all; ``force``: replace a read-only file, write through one with several hard
    links (:func:`denavit.io.output.write_text`))."""
    write_text(path, dumps(robot, length, angle), force=force)
