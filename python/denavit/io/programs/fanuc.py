"""FANUC TP programs in their ASCII form (``.ls``), read and written back.

Positions (FANUC R-30iA/R-30iB "HandlingTool Operator's Manual", position data; the ``/POS`` section of an ``.ls``
file): ``P[n]{ GP1: UF : u, UT : t, CONFIG : '...', X = ... mm, Y, Z, W = ... deg, P, R };`` a Cartesian
position of the tool frame UT in the user frame UF, mm, its orientation ``Rz(R) Ry(P) Rx(W)`` (fixed angles W about
x, P about y, R about z), degrees; or ``J1 = ... deg, ..., J6`` axis values. Other groups (``GP2``: external axes)
are kept as they are.

The configuration (the same manual, "Configuration"; its text was not reachable here, the letters are defined as
the two independent implementations below compute them from joint values, docs/compensation.md):
``'F|N U|D T|B, t1, t4, t6'``:

- ``T`` / ``B`` (front / back): the wrist centre (the point of J5 nearest J4) in front of or behind the J1 axis (its
  x in the J1 frame, the base frame turned with J1, >= 0 / < 0); ABB's cfx 4 and KUKA's Status bit 0;
- ``U`` / ``D`` (up / down): the wrist centre in front of or behind the lower arm (the line through the J2 and J3
  axes; in front: the side the J1 frame's x faces when that line points up), the arm's own side, not the world's:
  ABB's cfx 2 and KUKA's Status bit 1 (``D`` = cfx 2 = Status bit 1 clear). At ``T`` with the wrist in front of
  the J2 axis this is the elbow above the line from the J2 axis to the wrist centre; behind the J2 axis (every
  ``B`` position) the two differ, and the lower arm's side is the one both sources write;
- ``N`` / ``F`` (no flip / flip): ``J5 < 0`` / ``J5 >= 0`` in FANUC's J5 sense (J5 = -90 deg points the faceplate
  down with the forearm level, taught ``N U T``; ROS-Industrial's FANUC descriptions turn J5 about -y);
- ``t1``, ``t4``, ``t6``: the turn numbers of J1, J4, J6: ``floor((J + 180 deg) / 360 deg)`` (0 for -180 to 180 deg,
  1 for 180 to 540); KAREL's ``CONFIG`` holds them per axis (``CFG_TURN_NO1`` .. ``CFG_TURN_NO6``). A command a hair
  past a boundary (J4 -180.01 deg in a position stated turn 0) is the same arm at 179.99 deg, turn 0, for the
  controller: kept (:func:`denavit.io.programs.compensate_program`).

Sources: RoboDK's FANUC post-processor (``Fanuc_R30iA.py``, ros-industrial-attic/robodk_postprocessors at
08ec3d305acae7155ced8cf15babf1d2c151e165, ``add_target_cartesian``: ``'F'`` for its flip flag, "F means axis 5 >= 0,
N means axis 5 < 0", ``'D'`` for its lower-arm flag, the flag its ABB post writes as cfx 2 and its KUKA post as
Status bit 1 clear, ``'B'`` for its rear flag; ``'N U T'`` the default) and visose/Robots (MIT;
``src/Robots/Manufacturers/Fanuc/FanucPostProcessor.cs`` and ``Fanuc.cs`` at
086a36a553f5168010aaa3bfc89b5b8e139f0f40: ``F`` for the OPW wrist branch, which its FANUC joint mapping makes J5 > 0
and its ABB mapping axis 5 < 0; ``D`` for the elbow branch XOR the shoulder branch, the same expression its RAPID
post writes as cfx 2; ``B`` for the shoulder branch). At J5 = 0 exactly (the wrist singularity) RoboDK's comment
says F.

The axes' senses are the model's (a model of a FANUC arm turns its joints as the controller does); a robot with a
J2/J3 coupling (a robot file's ``[couplings]``) has its J values read through it. The tool frame UT 0 is the
faceplate: the model's flange (z out of it, REP-199's tool0, which ROS-Industrial's FANUC descriptions define to
match the controller's UT 0). UF 0 is the robot's world frame (its base); UF / UT k > 0 come from ``frames`` (they
live in the controller), else a one-line error.

Supported subset: ``/PROG``, ``/ATTR``, ``/APPL``, ``/MN``, ``/POS``, ``/END`` sections; ``P[n]`` positions of group 1
(Cartesian with a CONFIG, or joint). Position registers (``PR[n]``) are not in the program: listed. A ``P[n]`` no
line of ``/MN`` names (a position taught and no longer used) is left as it is and listed.
"""

from __future__ import annotations

import re

import numpy as np

from ...errors import DenavitError
from . import Number, Point, Program, arm, read_source
from .rotations import matrix_zyx, pose_matrix, zyx_matrix

CART = ("X", "Y", "Z", "W", "P", "R")
JOINTS = ("J1", "J2", "J3", "J4", "J5", "J6")
_NUMBER = r"[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?"


def signs(robot) -> np.ndarray:
    return np.ones(len(robot.names))


def flange_rotation(robot) -> np.ndarray:
    return np.eye(3)


def read(path, robot, *, frames: dict) -> Program:
    src = read_source(path)
    text = src.text
    if not re.match(r"\s*/PROG\s+\w+", text):
        raise DenavitError(f"{path}:1: expected '/PROG name' (a FANUC TP program in ASCII)")
    for m in re.finditer(r"(?m)^/(\w+)", text):
        if m.group(1).upper() not in ("PROG", "ATTR", "APPL", "MN", "POS", "END", "APPL_DATA"):
            raise DenavitError(
                f"{src.where(m.start())}: unknown section /{m.group(1)} (expected /PROG, /ATTR, /APPL, /MN, /POS or"
                " /END)"
            )
    pos = re.search(r"(?m)^/POS\s*$", text)
    points: list[Point] = []
    notes: list[str] = []
    mn = re.search(r"(?ms)^/MN\s*$(.*?)^/(POS|END)", text)
    used = {int(m.group(1)) for m in re.finditer(r"\bP\[(\d+)", mn.group(1))} if mn else set()
    if mn:
        for m in re.finditer(r"\bPR\[(\d+)", mn.group(1)):
            notes.append(
                f"{src.where(mn.start(1) + m.start())}: PR[{m.group(1)}]: a position register (in the controller, not"
                " the program): not compensated"
            )
    if not pos:
        return Program("fanuc", [src], points, notes)
    end = re.search(r"(?m)^/END", text[pos.end() :])
    body_end = pos.end() + (end.start() if end else len(text) - pos.end())
    for m in re.finditer(r"P\[(\d+)(?::\s*\"[^\"]*\")?\]\s*\{(.*?)\};", text[pos.end() : body_end], re.DOTALL):
        s0 = pos.end() + m.start(2)
        block = m.group(2)
        where = src.where(pos.end() + m.start())
        name = f"P[{m.group(1)}]"
        g1 = re.search(r"GP1\s*:(.*?)(?=GP\d+\s*:|$)", block, re.DOTALL)
        if not g1:
            notes.append(f"{where}: {name}: no group 1: not compensated")
            continue
        gs = s0 + g1.start(1)
        g = g1.group(1)
        uf = re.search(r"UF\s*:\s*(\w+)", g)
        ut = re.search(r"UT\s*:\s*(\w+)", g)
        cfg = re.search(r"CONFIG\s*:\s*'([^']*)'", g)
        fields = {
            k.upper(): (v, gs + mm.start(2), gs + mm.end(2))
            for mm in re.finditer(r"\b(X|Y|Z|W|P|R|J\d)\s*=\s*(" + _NUMBER + r")", g)
            for k, v in [(mm.group(1), mm.group(2))]
        }
        cart = all(k in fields for k in CART)
        joint = all(k in fields for k in JOINTS)
        if not (cart or joint):
            raise DenavitError(
                f"{where}: {name}: expected X, Y, Z, W, P, R or J1..J6, got {', '.join(fields) or 'none'}"
            )
        keys = CART if cart else JOINTS
        nums = [Number(0, fields[k][1], fields[k][2], fields[k][0], ("mm" if k in "XYZ" else "deg")) for k in keys]
        config = None
        if cart:
            if not cfg:
                raise DenavitError(
                    f"{where}: {name}: a Cartesian position without CONFIG (expected CONFIG : 'N U T, 0, 0, 0')"
                )
            config = _parse_config(cfg.group(1), where, name)
        pt = Point(name, where, "pose" if cart else "joints", nums, config)
        if int(m.group(1)) not in used:
            pt.problem = "no instruction of /MN moves to it: left as it is"
        for kind, mt in (("base", uf), ("tool", ut)):
            if mt is None:
                continue
            v = mt.group(1)
            if not v.isdigit():
                raise DenavitError(
                    f"{where}: {name}: {'UF' if kind == 'base' else 'UT'} : {v}: unsupported (expected a frame number)"
                )
            k = int(v)
            if k:
                if (kind, k) not in frames:
                    raise DenavitError(
                        f"{where}: {name}: {'UF' if kind == 'base' else 'UT'} : {k} is the controller's"
                        f" {'user' if kind == 'base' else 'tool'} frame {k} (not in the program, not given):"
                        f" unsupported (expected --frame '{kind} {k}=X,Y,Z,W,P,R', or"
                        f" {'UF' if kind == 'base' else 'UT'} : 0)"
                    )
                setattr(pt, kind, frames[(kind, k)])
        points.append(pt)
    return Program("fanuc", [src], points, notes)


def _parse_config(s: str, where: str, name: str) -> tuple:
    m = re.fullmatch(r"\s*([NF])\s*([UD])\s*([TB])\s*,\s*(-?\d+)\s*,\s*(-?\d+)\s*,\s*(-?\d+)\s*", s, re.IGNORECASE)
    if not m:
        raise DenavitError(f"{where}: {name}: CONFIG '{s}': expected 'N|F U|D T|B, t1, t4, t6'")
    return (
        m.group(1).upper(),
        m.group(2).upper(),
        m.group(3).upper(),
        int(m.group(4)),
        int(m.group(5)),
        int(m.group(6)),
    )


def to_pose(values) -> np.ndarray:
    x, y, z, w, p, r = np.asarray(values, dtype=float)
    return pose_matrix(np.array([x, y, z]) * 1e-3, zyx_matrix(*np.radians([r, p, w])))


def pose_values(T: np.ndarray, point: Point) -> np.ndarray:
    old = point.values
    r, p, w = np.degrees(matrix_zyx(T[:3, :3], np.radians([old[5], old[4], old[3]])))
    return np.concatenate([T[:3, 3] * 1e3, [w, p, r]])


def joint_values(robot, values) -> np.ndarray:
    r = np.radians(np.asarray(values, dtype=float)) * signs(robot)
    return robot.joint_values(r[None])[0] if getattr(robot, "has_reading_model", False) else r


def joint_readings(robot, q, point: Point) -> np.ndarray:
    r = (
        robot.readings(np.asarray(q, dtype=float)[None])[0]
        if getattr(robot, "has_reading_model", False)
        else np.asarray(q, dtype=float)
    )
    return np.degrees(r * signs(robot))


def configuration(model, q, cache: dict) -> tuple:
    a = np.degrees(np.asarray(q, dtype=float) * cache.get("signs", np.ones(model.nq)))
    g = arm(model, q)

    def turn(v):
        return int(np.floor((v + 180.0) / 360.0))

    return (
        "F" if a[4] >= 0 else "N",
        "U" if g.lower_arm > 0 else "D",
        "T" if g.front >= 0 else "B",
        turn(a[0]),
        turn(a[3]),
        turn(a[5]),
    )


def matches(stated, computed) -> bool:
    return tuple(stated) == tuple(computed)


def describe(config) -> str:
    return f"the configuration '{config[0]} {config[1]} {config[2]}, {config[3]}, {config[4]}, {config[5]}'"


def relabel(stated, computed):
    """None: no field of a CONFIG is rewritten. F/N (J5's sign, at the wrist singularity), U/D and T/B are branches;
    the turn numbers' boundaries at +-180 deg are the same arm a whole turn away, kept as stated
    (:func:`denavit.io.programs.compensate_program`)."""
    return None
