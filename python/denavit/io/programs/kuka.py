"""KUKA KRL programs: a ``.src`` and its ``.dat`` (the pair KUKA's controllers run), read and written back.

Positions (KUKA System Software 8.x, "Operating and Programming Instructions for System Integrators", KRL data
types POS, E6POS, AXIS, E6AXIS; the same in KSS 5.x "Expert Programming"):

- ``E6POS`` / ``POS`` ``{X, Y, Z, A, B, C, S, T, E1..E6}``: the TCP in the active BASE, mm; the orientation
  ``Rz(A) Ry(B) Rx(C)`` in degrees; external axes E1..E6 kept as they are.
- ``E6AXIS`` / ``AXIS`` ``{A1..A6, E1..E6}``: axis values, degrees.

The configuration (the same manuals, "Status" and "Turn"):

- ``S`` (Status) bit 0: the wrist root point (the intersection of the wrist axes; here the point of A5 nearest A4)
  in the A1 coordinate system (``$ROBROOT`` turned with A1): x >= 0 basic area (0), x < 0 overhead area (1);
  bit 1: the wrist root point behind (0) or in front of (1) the line through A2 and A3, the arm's own side (in
  front: the side the A1 frame's x faces when that line points up): ``A3 < phi`` (0), ``A3 >= phi`` (1), ``phi``
  the A3 value at which the wrist root point lies on that line (the arm stretched: 0 for a robot whose A3 and A4
  axes intersect, ``atan(a3 / d4)`` = 10.95 deg on the KR5);
  bit 2: ``0 <= A5 < 180`` or ``A5 < -180`` (0), ``-180 <= A5 < 0`` or ``A5 >= 180`` (1). Bits 3 and 4 (unused,
  "taught on an absolutely accurate robot") are kept and not compared.
- ``T`` (Turn) bit i (0..5): axis A(i+1) < 0 (1) or >= 0 (0): with S it picks the solution, A4 or A6 beyond
  +-180 deg included (A6 = 170 and -190 deg have the same pose and different T).

Checked against: bit 0 as KUKA's "Expert Programming" manual words it (quoted on the KUKA robot forum: "if the
x-value of the wrist root point, expressed in the A1 coordinate system, is negative, the robot is in the overhead
area"). Bit 1 as two controllers that take KUKA's Status and Turn define it: Siemens, SINUMERIK One "Programming
Manual, NC programming" 12/2019 (6FC5398-2EP40-0BA0), section 3.9 "Transformations", the STAT address (p. 710): "Bit
1 Position of axis 3 [...] The following applies to robots whose axes 3 and 4 intersect: = 0 A3 < 0 deg (elbow
down), = 1 A3 >= 0 deg (elbow up). [...] For robots with an offset between axes 3 and 4, the angle at which the
value of bit 1 changes depends on the magnitude of this offset"; ISG's CNC kernel, "Status & Turn (IS, IT)"
(isg-stuttgart.de, kernel-html en-GB/814171275.html): "If the wrist is in front of the straight line through axes A2
and A3, decimal 2 or binary 10 is added". The same sense in RoboDK's KUKA post-processor
(ros-industrial-attic/robodk_postprocessors, ``scripts/postprocessors/KUKA_KRC4_Config.py`` at
f7672aed5ae73d1fd729a0ce977f914e98ab7b4a, ``conf_2_str``: bit 1 set when its lower-arm flag is clear, the elbow up;
``'B010'`` when no configuration is given) and in programs taught on controllers (``DECL E6POS ... S 6,T 50``, the
common case: bit 1 set with T bit 2 clear, A3 >= 0). The SINUMERIK page gives bit 2 and T as above (bit 2 = 1 for A5
< 0, "handflip"; T bit i for a negative axis i+1, as ISG's page; ISG counts its legacy bit 2 for A5 > 0, in its own
axis senses). A secondary summary that gives bit 1 = 1 for "A3 below phi" (industrialmonitordirect.com) cites no
source and disagrees with all of these.

The T bits are where an axis's value lies, not branches: a position on an axis's 0 (A4 or A6 taught at 0.0) whose
compensated command crosses it, the same arm, is written with the command's T (:func:`relabel`,
:func:`denavit.io.programs.relabelled`); S is never rewritten (its bits' boundaries are the shoulder, elbow and wrist
singularities).

A point without S and T runs, as on the controller, on the configuration the previous one left (here: the
solution nearest the previous point, the first nearest ``q0``). The axes' senses: the built-in ``kr5`` turns A1,
A4 and A6 the other way from KUKA's controller (its file's header, after ROS-Industrial's ``kr5_arc`` URDF), so its
readings are ``(-q1, q2, q3, -q4, q5, -q6)``; other robots are taken as read. KUKA's FLANGE frame has its x out of
the flange: ``FLANGE = tool0 @ Ry(-90 deg)`` (ROS-Industrial's KUKA descriptions: ``tool0 = flange @ Ry(90 deg)``),
the model's flange being REP-199's tool0 (z out of the flange).

Frames: a point's TOOL and BASE are its FDAT's ``TOOL_NO`` / ``BASE_NO`` (the inline forms' ``F<name>``), else the
``.src``'s ``$TOOL = {...}`` / ``$BASE = {...}`` literal before its first use; number 0 is the flange / ``$ROBROOT``
(``$WORLD`` = ``$ROBROOT`` assumed); a number k > 0 is ``TOOL_DATA[k]`` / ``BASE_DATA[k]`` of a ``$config.dat``
beside the program, else of ``frames``; else a one-line error (unsupported, never ignored). ``IPO_FRAME #TCP``
(an external TCP) is refused.

Supported subset: DEFDAT data lists of the standard types (INT, REAL, BOOL, CHAR, FRAME, POS, E6POS, AXIS, E6AXIS,
FDAT, PDAT, LDAT, SIGNAL, STRUC, ENUM and the types they declare); positions declared in the ``.dat`` (in the frames
of the motion or FDAT that uses them; one neither uses is left as it is and listed) and inline aggregates of motion
instructions in the ``.src`` (``PTP {A1 ...}``, ``LIN {X ...}``).
Relative motions (``PTP_REL``, ``LIN_REL``) are listed, not compensated. Positions declared elsewhere (``XHOME``
in ``$config.dat``) are not part of the program: noted.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from ...errors import DenavitError
from . import Number, Point, Program, arm, read_source
from .rotations import matrix_zyx, pose_matrix, rot, zyx_matrix

KNOWN = {
    "INT",
    "REAL",
    "BOOL",
    "CHAR",
    "FRAME",
    "POS",
    "E6POS",
    "AXIS",
    "E6AXIS",
    "FDAT",
    "PDAT",
    "LDAT",
    "SIGNAL",
    "STRUC",
    "ENUM",
    "LOAD",
    "STRING",
}
POSE_KEYS = ("X", "Y", "Z", "A", "B", "C")
AXIS_KEYS = ("A1", "A2", "A3", "A4", "A5", "A6")
#: The built-in KUKA models whose A1, A4 and A6 turn the other way from the controller's (their files' headers).
SIGNS = {"kr5": (-1, 1, 1, -1, 1, -1), "kr210": (-1, 1, 1, -1, 1, -1)}
_NUMBER = r"[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?"
_ITEM = re.compile(
    r"([A-Za-z_]\w*(?:\[\])?)\s+('[^']*'|\"[^\"]*\"|#\w+|" + _NUMBER + r"|TRUE|FALSE|\w+)", re.IGNORECASE
)


def signs(robot) -> np.ndarray:
    return np.array(SIGNS.get(getattr(robot, "name", ""), (1,) * len(robot.names)), dtype=float)


def flange_rotation(robot) -> np.ndarray:
    return rot("y", -np.pi / 2)


def _aggregate(text: str, start: int, end: int) -> dict:
    """{KEY: (value text, start, end)} of the aggregate ``{KEY value, ...}`` between ``start`` and ``end``."""
    out = {}
    for m in _ITEM.finditer(text, start, end):
        out[m.group(1).upper()] = (m.group(2), m.start(2), m.end(2))
    return out


def _int(v: str) -> int:
    v = v.strip("'\"")
    if v.upper().startswith("B"):
        return int(v[1:], 2)
    return int(float(v))


def _frame(agg: dict) -> np.ndarray:
    vals = [float(agg.get(k, ("0",))[0]) for k in POSE_KEYS]
    return pose_matrix(np.array(vals[:3]) * 1e-3, zyx_matrix(*np.radians(vals[3:])))


def _frames_file(src_path: str) -> dict:
    """TOOL_DATA[k] / BASE_DATA[k] of a ``$config.dat`` beside the program."""
    out = {}
    for name in ("$config.dat", "$CONFIG.DAT", "config.dat"):
        p = Path(src_path).parent / name
        if p.is_file():
            text = read_source(p, "KUKA $config.dat").text
            for m in re.finditer(
                r"(?im)^\s*(?:DECL\s+)?(?:FRAME\s+)?(TOOL_DATA|BASE_DATA)\[(\d+)\]\s*=\s*\{([^}]*)\}", text
            ):
                out[("tool" if m.group(1).upper() == "TOOL_DATA" else "base", int(m.group(2)))] = _frame(
                    _aggregate(m.group(3), 0, len(m.group(3)))
                )
            break
    return out


def _pair(path) -> tuple[Path, Path]:
    p = Path(path)
    want = ".dat" if p.suffix.lower() == ".src" else ".src"
    for cand in p.parent.glob(p.stem + ".*"):
        if cand.suffix.lower() == want and cand.stem == p.stem:
            return (p, cand) if want == ".dat" else (cand, p)
    if want == ".dat":
        raise DenavitError(
            f"{p}:1: its data list {p.stem}.dat is missing (expected beside it: a KRL program is a .src and its .dat)"
        )
    raise DenavitError(
        f"{p}:1: its program {p.stem}.src is missing (expected beside it: a KRL program is a .src and its .dat)"
    )


def read(path, robot, *, frames: dict) -> Program:
    src_path, dat_path = _pair(path)
    src, dat = read_source(src_path), read_source(dat_path)
    known = set(KNOWN)
    for m in re.finditer(r"(?im)^\s*(?:GLOBAL\s+)?(?:STRUC|ENUM)\s+(\w+)", dat.text + "\n" + src.text):
        known.add(m.group(1).upper())
    numbered = {**frames, **_frames_file(str(src_path))}
    points: list[Point] = []
    fdat: dict = {}
    notes: list[str] = []
    text = dat.text
    if not re.search(r"(?im)^\s*DEFDAT\s+\w+", text):
        raise DenavitError(
            f"{dat.path}:1: expected 'DEFDAT name' (a KRL data list), got"
            f" {text.strip().splitlines()[0][:60] if text.strip() else 'an empty file'!r}"
        )
    for m in re.finditer(
        r"(?im)^[ \t]*(DECL[ \t]+)?(GLOBAL[ \t]+)?(CONST[ \t]+)?([A-Za-z_$]\w*)[ \t]+([A-Za-z_$]\w*(?:\[[^\]]*\])?)["
        r" \t]*(=[ \t]*(\{[^}\n]*\}|[^;\n]*))?",
        text,
    ):
        decl, typ, name = m.group(1), m.group(4).upper(), m.group(5)
        if typ in (
            "DEFDAT",
            "ENDDAT",
            "EXT",
            "EXTFCT",
            "DEF",
            "END",
            "IF",
            "ENDIF",
            "STRUC",
            "ENUM",
            "GLOBAL",
        ) or typ.startswith("&"):
            continue
        if not decl and typ not in known:
            continue  # (a statement of the data list's initialisation part)
        where = dat.where(m.start())
        if typ not in known:
            raise DenavitError(
                f"{where}: unknown declaration type {m.group(4)!r} (expected one of {', '.join(sorted(KNOWN))} or a"
                " STRUC/ENUM declared in the program)"
            )
        if typ in ("POS", "E6POS", "AXIS", "E6AXIS", "FDAT"):
            if not m.group(7) or not m.group(7).startswith("{"):
                if typ != "FDAT":
                    notes.append(f"{where}: {name}: declared without a value: nothing to compensate")
                continue
            s, e = m.start(7), m.end(7)
            agg = _aggregate(text, s, e)
            if typ == "FDAT":
                fdat[name.upper()] = (agg, where)
                continue
            points.append(_point(dat, 1, name, typ, agg, where))
    # the .src: motions (which points are used, with which frames), inline aggregates, $TOOL / $BASE literals
    cur = {"tool": None, "base": None}
    used: dict = {}
    for m in re.finditer(r"(?im)^[ \t]*([^;\n]*)", src.text):
        line = m.group(1)
        where = src.where(m.start())
        t = re.match(r"\s*\$(TOOL|BASE)\s*=\s*(.*)$", line, re.IGNORECASE)
        if t:
            kind, value = t.group(1).lower(), t.group(2).strip()
            if value.startswith("{"):
                cur[kind] = _frame(_aggregate(value, 0, len(value)))
            else:
                k = re.match(r"(TOOL_DATA|BASE_DATA)\[(\d+)\]", value, re.IGNORECASE)
                num = int(k.group(2)) if k else None
                if num is None and value.upper() not in ("$NULLFRAME", "NULLFRAME"):
                    raise DenavitError(
                        f"{where}: ${kind.upper()} = {value[:40]}: unsupported (expected a literal frame, TOOL_DATA[k]"
                        " / BASE_DATA[k] or $NULLFRAME)"
                    )
                cur[kind] = np.eye(4) if not num else _numbered(numbered, kind, num, where)
            continue
        b = re.match(r"\s*BAS\s*\(\s*#(TOOL|BASE)\s*,\s*(\d+)\s*\)", line, re.IGNORECASE)
        if b:
            kind, num = b.group(1).lower(), int(b.group(2))
            cur[kind] = np.eye(4) if num == 0 else _numbered(numbered, kind, num, where)
            continue
        mv = re.match(r"\s*(PTP|LIN|CIRC|SPTP|SLIN|SCIRC|PTP_REL|LIN_REL|CIRC_REL)\s+(.*)$", line, re.IGNORECASE)
        if not mv:
            continue
        instr, args = mv.group(1).upper(), mv.group(2)
        if instr.endswith("_REL"):
            notes.append(f"{where}: {instr}: a relative motion: not compensated (its offsets are not positions)")
            continue
        base = m.start(1) + mv.start(2)
        for a in re.finditer(r"\{[^}]*\}|[A-Za-z_$]\w*", args):
            tok = a.group(0)
            if tok.startswith("{"):
                agg = _aggregate(src.text, base + a.start(), base + a.end())
                typ = "E6POS" if "X" in agg else "E6AXIS"
                if not all(k in agg for k in (POSE_KEYS if typ == "E6POS" else AXIS_KEYS)):
                    notes.append(
                        f"{where}: {instr} {tok[:40]}: a partial aggregate (some coordinates taken from the previous"
                        " position): not compensated"
                    )
                    continue
                pt = _point(src, 0, f"{instr} (inline)", typ, agg, where)
                _frames_of(pt, cur, None, numbered)
                points.append(pt)
            elif tok.upper() not in ("C_DIS", "C_PTP", "C_VEL", "C_ORI", "C_SPL", "CONT", "CA", "WITH"):
                used.setdefault(tok.upper(), []).append((where, dict(cur)))
            if instr.startswith("CIRC") or instr.startswith("SCIRC"):
                continue
            break
    for pt in points:
        if pt.extra.get("source") != 1:
            continue
        key = pt.name.upper()
        fd = fdat.get("F" + key[1:]) if key.startswith("X") else None
        uses = used.get(key)
        if uses is None and not fd:
            pt.problem = (
                f"no motion of {src.path} uses it and it has no FDAT: its tool and base are unknown (left as it is)"
            )
            continue
        _frames_of(pt, uses[0][1] if uses else {"tool": None, "base": None}, fd, numbered)
    for name, uses in used.items():
        if not any(p.name.upper() == name for p in points):
            notes.append(
                f"{uses[0][0]}: {name}: not declared in {dat.path} (e.g. $config.dat's XHOME): not part of the program,"
                " not compensated"
            )
    return Program("kuka", [src, dat], points, notes)


def _numbered(numbered: dict, kind: str, num: int, where: str) -> np.ndarray:
    if (kind, num) in numbered:
        return numbered[(kind, num)]
    data = "TOOL_DATA" if kind == "tool" else "BASE_DATA"
    raise DenavitError(
        f"{where}: {kind.upper()} {num} is the controller's {data}[{num}] (in its $config.dat, not beside the program,"
        f" nor given): unsupported (expected a $config.dat beside the program declaring {data}[{num}], --frame '{kind}"
        f" {num}=X,Y,Z,A,B,C', or {kind} 0)"
    )


def _frames_of(pt: Point, cur: dict, fd, numbered: dict) -> None:
    if fd:
        agg, where = fd
        if "IPO_FRAME" in agg and agg["IPO_FRAME"][0].upper() == "#TCP":
            raise DenavitError(f"{where}: IPO_FRAME #TCP (an external, fixed TCP): unsupported (expected #BASE)")
        for kind, key in (("tool", "TOOL_NO"), ("base", "BASE_NO")):
            if key in agg:
                num = _int(agg[key][0])
                setattr(pt, kind, np.eye(4) if num == 0 else _numbered(numbered, kind, num, where))
        return
    for kind in ("tool", "base"):
        if cur.get(kind) is not None:
            setattr(pt, kind, cur[kind])


def _point(source, index: int, name: str, typ: str, agg: dict, where: str) -> Point:
    pose = typ in ("POS", "E6POS")
    keys = POSE_KEYS if pose else AXIS_KEYS
    missing = [k for k in keys if k not in agg]
    if missing:
        raise DenavitError(f"{where}: {name}: {typ} without {', '.join(missing)} (expected {', '.join(keys)})")
    nums = []
    for k in keys:
        v, s, e = agg[k]
        try:
            float(v)
        except ValueError:
            raise DenavitError(f"{where}: {name}: {k} {v!r}: expected a number") from None
        nums.append(Number(index, s, e, v, ("mm" if k in "XYZ" else "deg") if pose else "deg"))
    config, fields = None, []
    if pose and "S" in agg and "T" in agg:
        config = (_int(agg["S"][0]), _int(agg["T"][0]))
        fields = [Number(index, agg[k][1], agg[k][2], agg[k][0], "") for k in ("S", "T")]
    pt = Point(name, where, "pose" if pose else "joints", nums, config, config_fields=fields)
    pt.extra["source"] = index
    return pt


def to_pose(values) -> np.ndarray:
    """T_base_tool (m) of X, Y, Z, A, B, C (mm, deg)."""
    v = np.asarray(values, dtype=float)
    return pose_matrix(v[:3] * 1e-3, zyx_matrix(*np.radians(v[3:6])))


def pose_values(T: np.ndarray, point: Point) -> np.ndarray:
    old = point.values
    abc = np.degrees(matrix_zyx(T[:3, :3], np.radians(old[3:6])))
    return np.concatenate([T[:3, 3] * 1e3, abc])


def joint_values(robot, values) -> np.ndarray:
    return np.radians(np.asarray(values, dtype=float)) * signs(robot)


def joint_readings(robot, q, point: Point) -> np.ndarray:
    return np.degrees(np.asarray(q, dtype=float) * signs(robot))


def _phi(model, cache: dict) -> float:
    """phi (model joint 3, rad): the A3 value at which the wrist root point is on the line through A2 and A3, the
    arm stretched (of the two zeros of the wrist's side of that line, the one farther from A2)."""
    if "phi" not in cache:
        q = np.zeros(model.nq)
        grid = np.linspace(-np.pi, np.pi, 73)
        vals = []
        for g in grid:
            q[2] = g
            vals.append(arm(model, q).lower_arm)
        best, far = 0.0, -np.inf
        from ... import _core  # noqa: PLC0415

        for i in range(len(grid) - 1):
            if np.sign(vals[i]) != np.sign(vals[i + 1]):
                a, b = grid[i], grid[i + 1]
                for _ in range(60):
                    m = 0.5 * (a + b)
                    q[2] = m
                    fm = arm(model, q).lower_arm
                    q[2] = a
                    if np.sign(fm) == np.sign(arm(model, q).lower_arm):
                        a = m
                    else:
                        b = m
                q[2] = 0.5 * (a + b)
                ax = _core.axes(model, q)
                reach = float(np.linalg.norm(_core.fk(model, q)[:3, 3] - np.asarray(ax.points)[1]))
                if reach > far:
                    best, far = q[2], reach
        cache["phi"] = best
    return cache["phi"]


def configuration(model, q, cache: dict) -> tuple[int, int]:
    """(S bits 0-2, T) of the model's joint values ``q`` (module docstring)."""
    sg = cache.get("signs", np.ones(model.nq))
    a = np.degrees(np.asarray(q, dtype=float) * sg)
    g = arm(model, q)
    phi = np.degrees(_phi(model, cache) * sg[2])
    a5 = a[4]
    s = (1 if g.front < 0 else 0) | (2 if a[2] >= phi else 0) | (4 if (-180 <= a5 < 0 or a5 >= 180) else 0)
    t = sum(1 << i for i in range(min(6, len(a))) if a[i] < 0)
    return s, t


def matches(stated, computed) -> bool:
    return (stated[0] & 7) == (computed[0] & 7) and (stated[1] & 63) == (computed[1] & 63)


def describe(config) -> str:
    return f"the configuration S {config[0]} ('B{config[0]:03b}'), T {config[1]} ('B{config[1]:06b}')"


def relabel(stated, computed):
    """The (S, T) a position stated ``stated`` is written with for a command whose own is ``computed``, when the two
    differ only in T bits (an axis's sign: where its value is, not a branch): ``(config, fields)``, ``fields``
    [(name, axis index, 0 deg: the boundary, what it is)], S and T's bits beyond 5 as stated; None when they are
    equal or S bits 0-2 differ (overhead area, A3 against phi, A5's sign: branches; A5 crossing 0 changes S bit 2
    with its T bit 4; :func:`denavit.io.programs.relabelled`)."""
    s, t = stated[0] & 7, stated[1] & 63
    if s != computed[0] & 7 or t == computed[1] & 63:
        return None
    diff = t ^ (computed[1] & 63)
    fields = [
        (f"T bit {i} {t >> i & 1} -> {computed[1] >> i & 1}", i, 0.0, "sign boundary")
        for i in range(6)
        if diff >> i & 1
    ]
    return (stated[0], (stated[1] & ~63) | (computed[1] & 63)), fields


def config_tokens(config, point: Point) -> list[str]:
    """S and T as written: decimal (``T 35``) or binary (``T 'B100011'``, its quotes, its B's case and at least its
    digits); a field that keeps its value keeps its token."""
    out = []
    for n, v in zip(point.config_fields, config, strict=True):
        tok = n.token
        if _int(tok) == v:
            out.append(tok)
            continue
        b = re.fullmatch(r"(['\"]?)([Bb])([01]+)(['\"]?)", tok)
        out.append(f"{b.group(1)}{b.group(2)}{v:0{len(b.group(3))}b}{b.group(4)}" if b else str(int(v)))
    return out
