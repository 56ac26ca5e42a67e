"""URScript programs (``.script``), read and written back.

Positions (Universal Robots, "The URScript Programming Language", ``movej``, ``movel``, ``movep``, ``movec``,
``set_tcp``; poses ``p[x, y, z, rx, ry, rz]``): a pose is the TCP in the robot's base frame, m, its orientation a
rotation vector (rad); a joint position ``[q1, ..., q6]`` rad. The base frame is the frame of UR's published DH
table (the built-in ``ur5``'s world); the TCP is the tool flange (tool0, the DH table's frame 6) unless ``set_tcp``
set one (each move at the TCP set last before it in the text).

The configuration: a pose has none; the controller moves to the inverse kinematics solution nearest the joint
position it starts from (``movel``, ``movep``, and ``movej`` of a pose alike), here the previous position of the
script (in the text's order), the first nearest ``q0``. Joint positions are the configuration. PolyScope writes a
MoveJ waypoint as ``movej(get_inverse_kin(Waypoint_1_p, qnear=Waypoint_1_q), ...)`` (``get_inverse_kin(x, qnear,
maxPositionError, maxOrientationError, tcp)``: the solution of ``x`` nearest ``qnear``): the pose is the position,
solved nearest its ``qnear``, the configuration the program states (kept as written: a hint of the branch, not a
target); without ``qnear``, or with ``get_actual_joint_positions()``, nearest the previous position.

Supported subset: moves whose position is a literal (``movel(p[...], a=1.2, v=0.25)``, ``movej([...])``) or a
variable assigned a literal (``p1 = p[...]``, ``global p1 = p[...]``), or ``get_inverse_kin`` of such a pose with
such a ``qnear``, compensated where the literal is written; ``set_tcp(p[...])`` or of such a variable. A position
computed by a function (``pose_trans``, ``pose_add``, ...), a ``get_inverse_kin`` of one or with a computed
``qnear``, or whose ``tcp=`` is not the TCP set, is listed, not compensated; a ``set_tcp`` of a computed pose is a
one-line error (the frame of every move after it would be unknown); a feature frame is not supported (poses are in
the base frame).
"""

from __future__ import annotations

import re

import numpy as np

from ...errors import DenavitError
from ...geometry import matrix_rotvec, rotvec_matrix
from . import Number, Point, Program, blank_comments, read_source
from .rotations import pose_matrix

_NUMBER = r"[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?"
_NUM = re.compile(_NUMBER)
_LIST = re.compile(r"(p?)\[\s*(" + _NUMBER + r"(?:\s*,\s*" + _NUMBER + r")*)\s*\]")
_MOVE = re.compile(r"\b(movej|movel|movep|movec|servoj|speedj)\s*\(")
_ASSIGN = re.compile(r"(?m)^[ \t]*(?:global[ \t]+|local[ \t]+)?([A-Za-z_]\w*)[ \t]*=[ \t]*(?!=)")


def signs(robot) -> np.ndarray:
    return np.ones(len(robot.names))


def flange_rotation(robot) -> np.ndarray:
    return np.eye(3)


def _literal_point(src, clean: str, m: re.Match, name: str, where: str, n: int) -> Point:
    pose = m.group(1) == "p"
    nums = [
        Number(0, mm.start(), mm.end(), mm.group(0), ("m" if (pose and k < 3) else "rad"))
        for k, mm in enumerate(_NUM.finditer(clean, m.start(2), m.end(2)))
    ]
    if len(nums) != (6 if pose else n):
        raise DenavitError(
            f"{where}: {name}: expected {'p[x, y, z, rx, ry, rz]' if pose else f'{n} joint values'}, got {len(nums)}"
            " values"
        )
    return Point(name, where, "pose" if pose else "joints", nums)


def _first_arg(clean: str, start: int) -> tuple[int, int]:
    depth, i = 0, start
    while i < len(clean):
        c = clean[i]
        if c in "([":
            depth += 1
        elif c in ")]":
            if depth == 0:
                return start, i
            depth -= 1
        elif c == "," and depth == 0:
            return start, i
        i += 1
    return start, i


_IK = re.compile(r"get_inverse_kin\s*\(")


def _resolve(text: str, variables: dict, pose: bool):
    """The numbers of a literal list (``p[...]`` when ``pose``) or of a variable assigned one once; None: neither."""
    lit = _LIST.fullmatch(text)
    if lit is None and text in variables and len(variables[text]) == 1:
        lit = variables[text][0][0]
    if lit is None or (lit.group(1) == "p") != pose:
        return None
    return np.array([float(x) for x in re.findall(_NUMBER, lit.group(2))])


def _ik_call(clean: str, start: int, variables: dict, where: str):
    """The arguments of ``get_inverse_kin(x, qnear, maxPositionError, maxOrientationError, tcp)`` ("The URScript
    Programming Language", get_inverse_kin) from ``start`` (after its parenthesis): (x as written, the joint values
    of qnear (rad) or None, the tcp's 4x4 or None), or why it is not compensated."""
    args, i = [], start
    while True:
        s, e = _first_arg(clean, i)
        if clean[s:e].strip():
            args.append(clean[s:e].strip())
        if e >= len(clean) or clean[e] == ")":
            break
        i = e + 1
    names = ["x", "qnear", "maxPositionError", "maxOrientationError", "tcp"]
    given: dict = {}
    for k, a in enumerate(args):
        kw = re.match(r"([A-Za-z_]\w*)\s*=(?!=)\s*", a)
        if kw and kw.group(1) in names:
            given[kw.group(1)] = a[kw.end() :].strip()
        elif k < len(names):
            given[names[k]] = a
    x = given.get("x", "")
    if _resolve(x, variables, pose=True) is None:
        return f"{x} is assigned several times" if len(variables.get(x, [])) > 1 else "a computed pose"
    hint = None
    if "qnear" in given and given["qnear"] != "get_actual_joint_positions()":
        hint = _resolve(given["qnear"], variables, pose=False)
        if hint is None:
            return f"qnear={given['qnear'][:40]}: a computed joint position"
    tool = None
    if "tcp" in given:
        v = _resolve(given["tcp"], variables, pose=True)
        if v is None:
            return f"tcp={given['tcp'][:40]}: a computed TCP"
        tool = pose_matrix(v[:3], rotvec_matrix(v[3:][None])[0])
    return x, hint, tool


def read(path, robot, *, frames: dict) -> Program:
    src = read_source(path)
    clean = blank_comments(src.text, "\"'", "#")
    n = len(robot.names)
    variables: dict = {}
    for m in _ASSIGN.finditer(clean):
        lit = _LIST.match(clean, m.end())
        if lit:
            variables.setdefault(m.group(1), []).append((lit, src.where(m.start())))
    events = []  # (position, kind, data) in the text's order
    for m in re.finditer(r"\bset_tcp\s*\(", clean):
        s, e = _first_arg(clean, m.end())
        events.append((m.start(), "tcp", (s, e)))
    for m in _MOVE.finditer(clean):
        events.append((m.start(), m.group(1), m.end()))
    events.sort()
    tcp = np.eye(4)
    points: list[Point] = []
    notes: list[str] = []
    seen: dict = {}
    for pos, kind, data in events:
        where = src.where(pos)
        if kind == "tcp":
            s, e = data
            arg = clean[s:e].strip()
            lit = _LIST.fullmatch(arg)
            if lit is None and arg in variables and len(variables[arg]) == 1:
                lit = variables[arg][0][0]
            if lit is None or lit.group(1) != "p":
                raise DenavitError(
                    f"{where}: set_tcp({arg[:40]}): unsupported (expected a literal pose p[...] or a variable assigned"
                    " one once)"
                )
            v = [float(x) for x in re.findall(_NUMBER, lit.group(2))]
            tcp = pose_matrix(np.array(v[:3]), rotvec_matrix(np.array(v[3:])[None])[0])
            continue
        if kind in ("servoj", "speedj"):
            notes.append(f"{where}: {kind}: a servo or speed command: not compensated")
            continue
        start = data
        args = [_first_arg(clean, start)]
        if kind == "movec":
            args.append(_first_arg(clean, args[0][1] + 1))
        for s, e in args:
            arg = clean[s:e].strip()
            off = s + (len(clean[s:e]) - len(clean[s:e].lstrip()))
            lit = _LIST.match(clean, off)
            ik = _IK.match(clean, off)
            hint = None
            if ik:  # Polyscope's waypoint: movej(get_inverse_kin(Waypoint_1_p, qnear=Waypoint_1_q), ...)
                call = _ik_call(clean, ik.end(), variables, where)
                if isinstance(call, str):
                    notes.append(f"{where}: {kind}({arg[:60]}): {call}: not compensated")
                    continue
                arg, hint, tool = call
                if tool is not None and not np.allclose(tool, tcp):
                    notes.append(
                        f"{where}: {kind}({arg[:40]}): get_inverse_kin(..., tcp=) other than the active TCP: not"
                        " compensated (expected the TCP set by set_tcp)"
                    )
                    continue
                lit = _LIST.fullmatch(arg) if arg not in variables else None
                if lit is not None:
                    off = clean.index(arg, off)
                    lit = _LIST.match(clean, off)
            if lit and (ik or lit.end() - off == len(arg)):
                pt = _literal_point(src, clean, lit, f"{kind} (inline)", where, n)
                if pt.kind != "pose" and ik:
                    notes.append(f"{where}: {kind}: get_inverse_kin of a joint list: not compensated")
                    continue
            elif arg in variables:
                if len(variables[arg]) > 1:
                    notes.append(f"{where}: {kind}({arg}): {arg} is assigned several times: not compensated")
                    continue
                key = arg
                if key in seen:
                    if not np.allclose(seen[key].tool, tcp):
                        raise DenavitError(
                            f"{where}: {arg} is moved to at two different TCPs: unsupported (expected one TCP per pose)"
                        )
                    continue
                lit, at = variables[arg][0]
                pt = _literal_point(src, clean, lit, arg, at, n)
                if ik and pt.kind != "pose":
                    notes.append(f"{where}: {kind}: get_inverse_kin of the joint list {arg}: not compensated")
                    continue
                seen[key] = pt
            else:
                notes.append(f"{where}: {kind}({arg[:40]}): a computed position: not compensated")
                continue
            pt.tool = tcp.copy()
            if kind in ("movej",) and pt.kind == "pose":
                pt.extra["movej"] = True
            if hint is not None:
                pt.extra["qnear"] = hint
            points.append(pt)
    return Program("urscript", [src], points, notes)


def to_pose(values) -> np.ndarray:
    v = np.asarray(values, dtype=float)
    return pose_matrix(v[:3], rotvec_matrix(v[3:6][None])[0])


def pose_values(T: np.ndarray, point: Point) -> np.ndarray:
    old = point.values[3:6]
    r = matrix_rotvec(T[:3, :3][None])[0]
    a = np.linalg.norm(r)
    if a > 1e-9:  # the equivalent rotation vector nearest the original (they differ near half a turn)
        alt = r * (1 - 2 * np.pi / a)
        if np.linalg.norm(alt - old) < np.linalg.norm(r - old):
            r = alt
    return np.concatenate([T[:3, 3], r])


def joint_values(robot, values) -> np.ndarray:
    return np.asarray(values, dtype=float) * signs(robot)


def joint_readings(robot, q, point: Point) -> np.ndarray:
    return np.asarray(q, dtype=float) * signs(robot)


def configuration(model, q, cache: dict):
    return None


def matches(stated, computed) -> bool:
    return True


def describe(config) -> str:
    return "the pose (nearest the previous position)"


def relabel(stated, computed):
    """None: a URScript pose has no configuration to rewrite."""
    return None
