"""ABB RAPID program modules (``.mod``), read and written back.

Positions (ABB, "Technical reference manual - RAPID Instructions, Functions and Data types", data types
robtarget, jointtarget, confdata, tooldata, wobjdata):

- ``robtarget`` ``[[x, y, z], [q1, q2, q3, q4], [cf1, cf4, cf6, cfx], [eax_a, ..., eax_f]]``: the TCP of the
  instruction's tool in its work object, mm; the orientation a unit quaternion ``q1 + q2 i + q3 j + q4 k``; the
  external axes kept as they are.
- ``jointtarget`` ``[[rax_1, ..., rax_6], [eax_a, ..., eax_f]]``: axis values, degrees.

The configuration (confdata, "Robot configuration"): ``cf1``, ``cf4``, ``cf6`` the quadrants of axes 1, 4 and 6,
``floor(angle / 90 deg)`` (0: 0 to 90 deg, -1: -90 to 0, 4: 360 to 450: a turn beyond +-180 deg is its own
quadrant); ``cfx`` for a serial six-axis robot, 0-7: ``4 * behind + 2 * below + negative`` with ``behind`` the
wrist centre behind axis 1 (its x in the axis-1 frame, the base frame turned with axis 1, < 0), ``below`` the
wrist centre behind the lower arm (on the other side of the line through axes 2 and 3 from the side the axis-1
frame's x faces when that line points up) and ``negative`` axis 5 < 0 (the manual's table: 0 in front of axis 1,
in front of the lower arm, axis 5 positive; 1 the same with axis 5 negative; ...; 7 behind, behind, negative).
The axes' senses are the model's (ABB's tool0: z out of the flange, the model's flange). The quadrants are checked
against the older "RAPID Reference Manual", data type confdata ("quadrant 0 is the first quarter revolution, 0-90
deg, in a positive direction from the zero position; quadrant 1 is the next revolution, 90-180 deg, etc. Quadrant -1
is the revolution 0 deg - (-90 deg)"). The cfx table (columns "wrist center relative to axis 1", "wrist center
relative to lower arm", "axis 5 angle"; rows 0 in front of, in front of, positive to 7 behind, behind, negative) as
CEAD-group/py-opw-kinematics reproduces it (``AXIS_CONFIGURATION.md`` at 2f70958369876562a7d75cfe9a2e0a49040ef903):
weights 4, 2 and 1 as coded; the same weights in RoboDK's ABB post-processor (ros-industrial-attic/
robodk_postprocessors, ``ABB_RAPID_IRC5.py`` at 05c5ca88b1d12518013610edece30d07cb82c919: ``cfx = 4*REAR +
2*LOWERARM + FLIP``) and in visose/Robots (MIT, ``src/Robots/Manufacturers/ABB/Rapid.cs`` at
086a36a553f5168010aaa3bfc89b5b8e139f0f40: 1 its wrist branch, axis 5 negative in its ABB joint mapping; 2 its elbow
branch XOR its shoulder branch, the lower arm's own side; 4 its shoulder branch). py-opw-kinematics' IRB 1660ID cases
(``src/axis_configuration.rs``, same commit: behind axis 1 and in front of the lower arm, the elbow below the line
from axis 2 to the wrist centre in the world) give its cfx 4 and 5 here (tests/test_program_conventions.py). The
confdata RobotStudio wrote for a real module's seven robtargets (tests/data/programs/real/abb_robot_client) is the
configuration of one inverse kinematics solution of each on the IRB 1200 it was taught on, and no other solution's:
cf1, cf4, cf6 and cfx's axis-5 bit checked (its other two bits 0 in all seven; tests/test_programs_real.py).

cf1, cf4 and cf6 are where an axis's value lies, not branches: a position on a quadrant boundary (the tool straight
down, axis 4 at -0.0000 deg, cf4 -1) whose compensated command crosses it, the same arm, is written with the
command's quadrant (:func:`relabel`, :func:`denavit.io.programs.relabelled`); cfx is never rewritten.

Frames: a named position's tool and work object are those of the move instructions that use it (MoveJ, MoveL,
MoveC, MoveAbsJ and their DO/AO/GO/Sync forms; EGMMoveL and EGMMoveC, the moves of EGM path correction, ABB's
"Application manual - Externally Guided Motion" (3HAC073318-001, its text not reachable here): the EGM identity,
then MoveL's or MoveC's arguments, as RobotStudio programs write them, ``EGMMoveL egmID1,Target_60,v10,z100,tool0``;
the sensor corrects the path to the programmed position, compensated as a MoveL's; ``tool0`` the flange, ``wobj0``
the world frame, RAPID's default work object: the model's world, the robot's base where the model's ``T_world_base``
puts it, the base itself for the built-in models); a
``tooldata`` (``robhold`` TRUE) or ``wobjdata`` (``robhold`` FALSE, ``ufprog`` TRUE, no ``ufmec``: user frame then
object frame) declared in the module is honoured; one declared elsewhere, a stationary tool, a moving work
object, or a position used with two different frames is a one-line error. A named position no move uses is left as
it is (its frames unknown) and listed.

Supported subset: CONST, PERS, VAR, LOCAL and TASK declarations of robtarget and jointtarget (one value each;
arrays are listed, not compensated); positions named or written inline in the move instructions above; functions of
positions (``Offs(p10, ...)``) are not rewritten, the positions they name are.
"""

from __future__ import annotations

import re

import numpy as np

from ...errors import DenavitError
from . import Number, Point, Program, arm, blank_comments, read_source
from .rotations import matrix_quaternion, pose_matrix, quaternion_matrix

_NUMBER = re.compile(r"[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?")
MOVES = re.compile(r"\b((?:EGM)?Move(?:J|L|C|AbsJ)(?:DO|AO|GO|Sync)?)\b", re.IGNORECASE)


def signs(robot) -> np.ndarray:
    return np.ones(len(robot.names))


def flange_rotation(robot) -> np.ndarray:
    return np.eye(3)


def _literal(text: str, start: int, where: str):
    """The bracketed value starting at ``start``: a nested list of (token, start, end) leaves, and its end."""
    if text[start] != "[":
        raise DenavitError(f"{where}: expected '[', got {text[start : start + 20]!r}")
    stack, cur, i = [], [], start + 1
    root = cur
    while i < len(text):
        c = text[i]
        if c == "[":
            stack.append(cur)
            new: list = []
            cur.append(new)
            cur = new
            i += 1
        elif c == "]":
            if not stack:
                return root, i + 1
            cur = stack.pop()
            i += 1
        elif c in ", \t\r\n":
            i += 1
        else:
            m = re.compile(r"[^,\[\]\s]+").match(text, i)
            cur.append((m.group(0), m.start(), m.end()))
            i = m.end()
    raise DenavitError(f"{where}: unclosed '[' (expected ']' before the end of the file)")


def _num(leaf, where: str, what: str) -> float:
    if not isinstance(leaf, tuple) or not _NUMBER.fullmatch(leaf[0]):
        raise DenavitError(
            f"{where}: {what}: expected a number, got {leaf[0] if isinstance(leaf, tuple) else '[...]'!r}"
        )
    return float(leaf[0])


def _shape(v, shape, where: str, what: str) -> None:
    ok = (
        isinstance(v, list)
        and len(v) == len(shape)
        and all(
            (isinstance(x, list) and len(x) == s) if s else isinstance(x, tuple) for x, s in zip(v, shape, strict=False)
        )
    )
    if not ok:
        raise DenavitError(f"{where}: {what}: expected {_expected(shape)}")


def _expected(shape) -> str:
    return "[" + ",".join("[" + ",".join(["n"] * s) + "]" if s else "x" for s in shape) + "]"


ROBTARGET = (3, 4, 4, 6)
JOINTTARGET = (6, 6)


def _pose_point(name, where, lit, src_index) -> Point:
    _shape(lit, ROBTARGET, where, f"robtarget {name}")
    nums = [Number(src_index, s, e, t, "mm") for t, s, e in lit[0]] + [
        Number(src_index, s, e, t, "quaternion") for t, s, e in lit[1]
    ]
    for n in nums:
        _num((n.token, 0, 0), where, f"robtarget {name}")
    cf = tuple(int(_num(x, where, f"robtarget {name} confdata")) for x in lit[2])
    return Point(name, where, "pose", nums, cf, config_fields=[Number(src_index, s, e, t, "") for t, s, e in lit[2]])


def _joint_point(name, where, lit, src_index) -> Point:
    _shape(lit, JOINTTARGET, where, f"jointtarget {name}")
    nums = [Number(src_index, s, e, t, "deg") for t, s, e in lit[0]]
    for n in nums:
        _num((n.token, 0, 0), where, f"jointtarget {name}")
    return Point(name, where, "joints", nums)


def _frame(lit, where, what) -> np.ndarray:
    p = np.array([_num(x, where, what) for x in lit[0]]) * 1e-3
    q = np.array([_num(x, where, what) for x in lit[1]])
    return pose_matrix(p, quaternion_matrix(q))


def read(path, robot, *, frames: dict) -> Program:
    src = read_source(path)
    text = src.text
    clean = blank_comments(text, '"', "!")
    if not re.search(r"(?im)^\s*MODULE\s+\w+", clean):
        raise DenavitError(f"{path}:1: expected 'MODULE name' (a RAPID program module)")
    points: list[Point] = []
    named: dict = {}
    tools = {"TOOL0": np.eye(4)}
    wobjs = {"WOBJ0": np.eye(4)}
    notes: list[str] = []
    decl = re.compile(
        r"(?im)^[ \t]*(?:(?:LOCAL|TASK)[ \t]+)?(CONST|PERS|VAR)[ \t]+(\w+)[ \t]+(\w+)[ \t]*(\{[^}]*\})?[ \t]*(:=)?"
    )
    for m in decl.finditer(clean):
        typ, name = m.group(2).lower(), m.group(3)
        where = src.where(m.start())
        if typ not in ("robtarget", "jointtarget", "tooldata", "wobjdata"):
            continue
        if m.group(4):
            notes.append(f"{where}: {typ} {name}{m.group(4)}: an array: not compensated")
            continue
        if not m.group(5):
            if typ in ("robtarget", "jointtarget"):
                notes.append(f"{where}: {typ} {name}: declared without a value: nothing to compensate")
            continue
        i = m.end()
        while i < len(clean) and clean[i] in " \t\r\n":
            i += 1
        if i >= len(clean) or clean[i] != "[":
            notes.append(f"{where}: {typ} {name}: its value is not a literal: not compensated")
            continue
        lit, _ = _literal(clean, i, where)
        if typ == "robtarget":
            pt = _pose_point(name, where, lit, 0)
        elif typ == "jointtarget":
            pt = _joint_point(name, where, lit, 0)
        elif typ == "tooldata":
            if not (
                isinstance(lit, list)
                and len(lit) == 3
                and isinstance(lit[0], tuple)
                and isinstance(lit[1], list)
                and len(lit[1]) == 2
            ):
                raise DenavitError(f"{where}: tooldata {name}: expected [robhold,[[x,y,z],[q1,q2,q3,q4]],[load]]")
            if lit[0][0].upper() != "TRUE":
                tools[name.upper()] = ("stationary", where)
            else:
                tools[name.upper()] = _frame(lit[1], where, f"tooldata {name}")
            continue
        else:
            if not (isinstance(lit, list) and len(lit) == 5):
                raise DenavitError(f"{where}: wobjdata {name}: expected [robhold,ufprog,ufmec,[uframe],[oframe]]")
            robhold, ufprog, ufmec = (x[0].upper() if isinstance(x, tuple) else "" for x in lit[:3])
            if robhold != "FALSE" or ufprog != "TRUE" or ufmec not in ('""', ""):
                wobjs[name.upper()] = ("moving", where)
            else:
                wobjs[name.upper()] = _frame(lit[3], where, f"wobjdata {name}") @ _frame(
                    lit[4], where, f"wobjdata {name}"
                )
            continue
        named[name.upper()] = pt
        points.append(pt)
    used: dict = {}
    for m in MOVES.finditer(clean):
        instr = m.group(1)
        end = clean.find(";", m.end())
        if end < 0:
            raise DenavitError(f"{src.where(m.start())}: {instr}: expected ';' at the end of the instruction")
        where = src.where(m.start())
        args = _split(clean, m.end(), end)
        args = [
            a for a in args if not clean[a[0] : a[1]].strip().startswith("\\")
        ] or args  # (\Conc and other switches first)
        kind = instr.upper()
        if kind.startswith("EGM"):  # EGMMoveL / EGMMoveC: the EGM identity first, then as MoveL / MoveC
            if kind not in ("EGMMOVEL", "EGMMOVEC"):
                continue
            kind, args = kind[3:], args[1:]
        n_targets = 2 if kind.startswith("MOVEC") else 1
        if len(args) < n_targets + 3:
            raise DenavitError(
                f"{where}: {instr}: expected {'EGMid, ' if kind != instr.upper() else ''}"
                f"{'CirPoint, ToPoint' if n_targets == 2 else 'ToPoint'}, Speed, Zone, Tool; got"
                f" {len(args) + (kind != instr.upper())} arguments"
            )
        tool_arg = clean[args[n_targets + 2][0] : args[n_targets + 2][1]]
        tool_name = re.match(r"\s*(\w+)", tool_arg)
        rest = clean[args[n_targets + 2][0] : end]
        wobj = re.search(r"\\WObj\s*:=\s*(\w+)", rest, re.IGNORECASE)
        frames_of = (
            _lookup(tools, tool_name.group(1) if tool_name else "", "tooldata", where),
            _lookup(wobjs, wobj.group(1) if wobj else "wobj0", "wobjdata", where),
            (tool_name.group(1) if tool_name else "?", wobj.group(1) if wobj else "wobj0"),
        )
        for a in args[:n_targets]:
            s, e = a
            while s < e and clean[s] in " \t\r\n":
                s += 1
            if s < e and clean[s] == "[":
                lit, _ = _literal(clean, s, where)
                pt = (
                    _joint_point(f"{instr} (inline)", where, lit, 0)
                    if kind.startswith("MOVEABSJ")
                    else _pose_point(f"{instr} (inline)", where, lit, 0)
                )
                pt.tool, pt.base = frames_of[0], frames_of[1]
                points.append(pt)
                continue
            for ident in re.findall(r"[A-Za-z_]\w*", clean[s:e]):
                if ident.upper() in named:
                    used.setdefault(ident.upper(), []).append((where, frames_of))
    for key, pt in named.items():
        uses = used.get(key)
        if not uses:
            pt.problem = (
                "no move instruction of the module uses it: its tool and work object are unknown (left as it is)"
            )
            continue
        names = {u[1][2] for u in uses}
        if len(names) > 1:
            raise DenavitError(
                f"{uses[0][0]}: {pt.name} is used with {' and '.join('/'.join(n) for n in sorted(names))}: "
                "a position taught in several frames is unsupported (expected one tool and work object per position)"
            )
        pt.tool, pt.base = uses[0][1][0], uses[0][1][1]
    points.sort(key=lambda p: (int(p.where.rsplit(":", 1)[1]), p.numbers[0].start))
    return Program("abb", [src], points, notes)


def _lookup(table: dict, name: str, what: str, where: str) -> np.ndarray:
    v = table.get(name.upper())
    if v is None:
        raise DenavitError(
            f"{where}: {what} {name} is not declared in the module: unsupported (expected it declared in the program"
            f" module, or {'tool0' if what == 'tooldata' else 'wobj0'})"
        )
    if isinstance(v, tuple):
        kind, at = v
        why = (
            "a stationary tool (robhold FALSE)"
            if kind == "stationary"
            else "a work object moved by the robot or a mechanical unit"
        )
        raise DenavitError(f"{where}: {what} {name} (declared at {at}) is {why}: unsupported")
    return v


def _split(text: str, start: int, end: int) -> list[tuple[int, int]]:
    """Spans of the top-level comma-separated arguments of ``text[start:end]``."""
    out, depth, s = [], 0, start
    for i in range(start, end):
        c = text[i]
        if c in "[(":
            depth += 1
        elif c in "])":
            depth -= 1
        elif c == "," and depth == 0:
            out.append((s, i))
            s = i + 1
    out.append((s, end))
    return [(a, b) for a, b in out if text[a:b].strip()]


def to_pose(values) -> np.ndarray:
    v = np.asarray(values, dtype=float)
    return pose_matrix(v[:3] * 1e-3, quaternion_matrix(v[3:7]))


def pose_values(T: np.ndarray, point: Point) -> np.ndarray:
    old = point.values
    return np.concatenate([T[:3, 3] * 1e3, matrix_quaternion(T[:3, :3], old[3:7])])


def joint_values(robot, values) -> np.ndarray:
    return np.radians(np.asarray(values, dtype=float)) * signs(robot)


def joint_readings(robot, q, point: Point) -> np.ndarray:
    return np.degrees(np.asarray(q, dtype=float) * signs(robot))


def configuration(model, q, cache: dict) -> tuple[int, int, int, int]:
    """(cf1, cf4, cf6, cfx) of the model's joint values ``q`` (module docstring)."""
    a = np.degrees(np.asarray(q, dtype=float) * cache.get("signs", np.ones(model.nq)))
    g = arm(model, q)
    cfx = 4 * (g.front < 0) + 2 * (g.lower_arm < 0) + (a[4] < 0)
    return int(np.floor(a[0] / 90)), int(np.floor(a[3] / 90)), int(np.floor(a[5] / 90)), int(cfx)


def matches(stated, computed) -> bool:
    return tuple(stated) == tuple(computed)


def describe(config) -> str:
    return f"the configuration [{','.join(str(c) for c in config)}] (cf1, cf4, cf6, cfx)"


#: The confdata fields that are boundaries of an axis's value: (index, name, axis index).
QUADRANTS = ((0, "cf1", 0), (1, "cf4", 3), (2, "cf6", 5))


def relabel(stated, computed):
    """The confdata a position stated ``stated`` is written with for a command whose own is ``computed``, when the
    two differ only in quadrants (cf1, cf4, cf6: where an axis's value is, not a branch): ``(confdata, fields)``,
    ``fields`` [(name, axis index, the boundary between the stated quadrant and the command's (deg), what it is)];
    None when they are equal or cfx differs (behind axis 1, behind the lower arm, axis 5's sign: branches;
    :func:`denavit.io.programs.relabelled`)."""
    if tuple(stated) == tuple(computed) or stated[3] != computed[3]:
        return None
    fields = [
        (
            f"{name} {stated[i]} -> {computed[i]}",
            j,
            90.0 * (stated[i] + 1 if computed[i] > stated[i] else stated[i]),
            "quadrant boundary",
        )
        for i, name, j in QUADRANTS
        if stated[i] != computed[i]
    ]
    return (computed[0], computed[1], computed[2], stated[3]), fields


def config_tokens(config, point: Point) -> list[str]:
    """The confdata's four integers as written: a field that keeps its value keeps its token."""
    return [n.token if float(n.token) == c else str(int(c)) for n, c in zip(point.config_fields, config, strict=True)]
