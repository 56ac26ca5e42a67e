"""Robot programs in controller languages: read, compensate, write back the same program with only its positions
changed.

One module per vendor: :mod:`.kuka` (KRL ``.src`` / ``.dat`` pairs), :mod:`.abb` (RAPID ``.mod``), :mod:`.fanuc`
(TP ``.ls``), :mod:`.urscript` (URScript ``.script``). Each reads a program into a :class:`Program`: its texts, as
bytes decoded once (the encoding, a byte-order mark and the line endings kept), and its :class:`Point` s, each a
position in the program with the spans of its numbers in the text, its values in the program's units, its
configuration (the controller's own convention, defined in the vendor's module with the documentation it follows)
and the frames it is taught in (base and tool, honoured or refused with a one-line error, never ignored).

:func:`compensate_program` compensates every point on its own configuration (:func:`denavit.compensation.compensate`
with the configuration's nominal solution as ``q_nominal``) and :func:`render` writes the program back: every byte
but the compensated position fields as it was, each rewritten number in its original form (sign, leading zero,
exponent) with its original decimals or, when fewer, enough to carry the compensation (``MIN_DECIMALS``: 1 um,
1e-3 deg). A point that cannot be compensated (unreachable, a branch change near a singularity, a shoulder, elbow
or wrist-flip configuration the compensated command would leave) is left as it was and listed with its line. A
command that leaves its stated configuration only across the boundary of an axis's value (ABB's cf1, cf4, cf6
quadrants, KUKA's T bits: the sign of an axis), the same arm a hair from the nominal solution, is compensated with
its configuration written as the command's (:func:`relabelled`) and listed as such. Reading with the nominal model
as the identified one writes the program byte-identical: a number is rewritten only when the compensation moves it
by more than its resolution.
"""

from __future__ import annotations

import os
import re
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from ... import _core
from ...errors import DenavitError
from ...geometry import closest_point
from ..output import atomic_path
from ..text import read_bytes

#: The fewest decimals a rewritten number gets, by unit (its original decimals when more).
MIN_DECIMALS = {"mm": 3, "m": 6, "deg": 3, "rad": 6, "quaternion": 6, "": 6}

#: An axis this close to a boundary of its value (a quadrant's, a sign's; deg) is on it: either side's configuration
#: states it (a position taught at A4 = 0.000 deg and written with T bit 3 clear solves, from its rounded numbers, at
#: -1e-6 deg as often as at +1e-6). The resolution a rewritten angle keeps (:data:`MIN_DECIMALS`).
ON_BOUNDARY_DEG = 1e-3

FORMATS = ("kuka", "abb", "fanuc", "urscript")


@dataclass
class Source:
    """One file of a program: ``path``, its ``text`` (decoded), ``encoding``, ``bom`` (bytes before the text)."""

    path: str
    text: str
    encoding: str = "utf-8"
    bom: bytes = b""

    def line_of(self, pos: int) -> int:
        return self.text.count("\n", 0, pos) + 1

    def where(self, pos: int) -> str:
        return f"{self.path}:{self.line_of(pos)}"


@dataclass
class Number:
    """A number in a source: ``source`` index, ``start``/``end`` of its token, ``token`` as written, ``unit``."""

    source: int
    start: int
    end: int
    token: str
    unit: str

    @property
    def value(self) -> float:
        return float(self.token)


@dataclass
class Point:
    """A position of the program.

    ``name`` (its declaration's, or the instruction's for an inline one), ``where`` (file:line), ``kind`` "pose"
    (a Cartesian pose in the program's base frame at its tool) or "joints" (the controller's axis values),
    ``numbers`` its position fields (pose: position then orientation, the vendor's order; joints: one per axis),
    ``config`` the configuration it states (the vendor's, or None: nearest the previous point, URScript), ``base``
    and ``tool`` (4x4, m) the frames it is taught in, ``problem`` why it is not compensated (kept, listed),
    ``config_fields`` the tokens (:class:`Number`) its configuration is written in (ABB's cf1, cf4, cf6, cfx; KUKA's
    S and T), rewritten when its configuration is (:func:`relabelled`)."""

    name: str
    where: str
    kind: str
    numbers: list
    config: object = None
    base: np.ndarray = field(default_factory=lambda: np.eye(4))
    tool: np.ndarray = field(default_factory=lambda: np.eye(4))
    problem: str | None = None
    extra: dict = field(default_factory=dict)
    config_fields: list = field(default_factory=list)

    @property
    def values(self) -> np.ndarray:
        return np.array([n.value for n in self.numbers])


@dataclass
class Program:
    """A program: ``format`` (a :data:`FORMATS` name), ``sources`` (its files), ``points`` (in the order they
    are declared or appear), ``notes`` (what the reader left alone and why, one line each)."""

    format: str
    sources: list
    points: list
    notes: list = field(default_factory=list)

    @property
    def vendor(self):
        return vendor(self.format)

    def __repr__(self) -> str:
        kinds = {k: sum(p.kind == k for p in self.points) for k in ("pose", "joints")}
        return (
            f"Program({self.format}, {', '.join(s.path for s in self.sources)}: {kinds['pose']} poses,"
            f" {kinds['joints']} joint positions)"
        )


def vendor(fmt: str):
    """The module of format ``fmt``."""
    import importlib  # noqa: PLC0415

    return importlib.import_module(f"{__name__}.{fmt}")


EXTENSIONS = {
    ".src": "kuka",
    ".dat": "kuka",
    ".mod": "abb",
    ".modx": "abb",
    ".prg": "abb",
    ".ls": "fanuc",
    ".script": "urscript",
    ".urscript": "urscript",
}


def detect(path: str | os.PathLike) -> str | None:
    """The program format of ``path`` by its extension, else by its first bytes; None: not a program (a CSV)."""
    ext = Path(path).suffix.lower()
    if ext in EXTENSIONS:
        return EXTENSIONS[ext]
    if ext in (".csv", ".txt", ".tsv"):
        return None
    try:
        head = read_bytes(path, "program", head=4096).decode("latin-1")
    except DenavitError:
        return None
    h = re.sub(r"(?m)^\s*[;!#&].*$", "", head)
    if re.search(r"(?im)^\s*(GLOBAL\s+)?DEF(DAT)?\s+\w+", h):
        return "kuka"
    if re.search(r"(?im)^\s*MODULE\s+\w+", h):
        return "abb"
    if re.search(r"(?m)^/PROG\s+\w+", head):
        return "fanuc"
    if re.search(r"(?m)^\s*def\s+\w+\s*\(\s*\)\s*:", head) or re.search(r"\bmove[jlp]\s*\(", head):
        return "urscript"
    return None


def blank_comments(text: str, quotes: str, comment: str) -> str:
    """``text`` with its strings (between any of ``quotes``) and its comments (``comment`` to the end of the line,
    outside strings) blanked, every position and line break kept: the text a program's statements are searched in."""
    out = list(text)
    i, n = 0, len(text)
    while i < n:
        c = text[i]
        if c in quotes:
            j = text.find(c, i + 1)
            j = n - 1 if j < 0 else j
            for k in range(i + 1, j):
                if out[k] != "\n":
                    out[k] = " "
            i = j + 1
        elif c == comment:
            j = text.find("\n", i)
            j = n if j < 0 else j
            for k in range(i, j):
                out[k] = " "
            i = j
        else:
            i += 1
    return "".join(out)


def read_source(path: str | os.PathLike, what: str = "program") -> Source:
    """A file's text decoded once (UTF-8, else Latin-1 as KRL and RAPID files often are), its BOM kept aside."""
    data = read_bytes(path, what)
    bom = b""
    if data.startswith(b"\xef\xbb\xbf"):
        bom, data = data[:3], data[3:]
    try:
        return Source(str(path), data.decode("utf-8"), "utf-8", bom)
    except UnicodeDecodeError:
        return Source(str(path), data.decode("latin-1"), "latin-1", bom)


def read_program(path: str | os.PathLike, robot, *, fmt: str | None = None, frames: dict | None = None) -> Program:
    """Read the program at ``path`` (format by extension or content, or ``fmt``) for ``robot`` (a Robot: the
    vendor's axis senses may depend on it). ``frames``: {("tool" | "base", number): 4x4 (m)} for the numbered
    frames a program refers to that live in the controller (KUKA TOOL_DATA/BASE_DATA, FANUC UT/UF)."""
    fmt = fmt or detect(path)
    if fmt is None:
        raise DenavitError(
            f"{path}: not a robot program: expected a KUKA .src/.dat, an ABB .mod, a FANUC .ls or a URScript .script"
        )
    return vendor(fmt).read(path, robot, frames=frames or {})


# -- numbers ------------------------------------------------------------------------------------------------

_NUM = re.compile(r"^([+-]?)(\d*)(?:\.(\d*))?(?:([eE])([+-]?\d+))?$")


def format_like(value: float, token: str, unit: str) -> str:
    """``value`` written as ``token`` was: its sign style, leading zero, exponent form; its decimals or, when fewer,
    :data:`MIN_DECIMALS` of ``unit``."""
    m = _NUM.match(token.strip())
    if m is None:
        return repr(float(value))
    plus, whole, frac, e, _ = m.groups()
    dec = max(len(frac or ""), MIN_DECIMALS.get(unit, 6))
    if e:
        s = f"{value:.{dec}{e}}"
    else:
        s = f"{value:.{dec}f}"
        if whole == "" and frac is not None:  # ".5", "-.5": no leading zero
            s = re.sub(r"^(-?)0\.", r"\1.", s)
    if re.fullmatch(r"-0?\.?0*(e[+-]?0+)?", s, re.IGNORECASE):
        s = s[1:]
    if plus == "+" and not s.startswith("-"):
        s = "+" + s
    return s


def resolution(token: str, unit: str) -> float:
    """Half the last digit a rewrite of ``token`` would carry: a change below it leaves the token as it was."""
    m = _NUM.match(token.strip())
    dec = max(len((m.group(3) if m else "") or ""), MIN_DECIMALS.get(unit, 6))
    scale = 10.0 ** int(m.group(5)) if m and m.group(4) else 1.0
    return 0.5 * 10.0 ** (-dec) * scale


class Rewrites(dict):
    """{point index: values in the program's units}, the points a compensation rewrites, with ``configs`` ({point
    index: the vendor's configuration}) those whose configuration is written with them: passed alone to
    :func:`render` / :func:`write_program`, they carry their configurations along."""

    configs: dict

    def __init__(self, values=(), configs=None):
        super().__init__(values)
        self.configs = dict(configs or {})


def render(program: Program, new_values: dict, configs: dict | None = None) -> list[bytes]:
    """The program's files as bytes with the points in ``new_values`` ({point index: values in the program's
    units}) rewritten, and the configurations in ``configs`` ({point index: the vendor's configuration},
    :attr:`ProgramCompensation.configs`; default a :class:`Rewrites`' own) written in their fields' own number forms;
    every other byte as read."""
    configs = getattr(new_values, "configs", None) if configs is None else configs
    edits: dict[int, list] = {}
    for k, vals in new_values.items():
        for num, v in zip(program.points[k].numbers, vals, strict=True):
            if abs(v - num.value) > resolution(num.token, num.unit):
                edits.setdefault(num.source, []).append((num.start, num.end, format_like(v, num.token, num.unit)))
    for k, config in (configs or {}).items():
        p = program.points[k]
        for num, token in zip(p.config_fields, program.vendor.config_tokens(config, p), strict=True):
            if token != num.token:
                edits.setdefault(num.source, []).append((num.start, num.end, token))
    out = []
    for i, src in enumerate(program.sources):
        text = src.text
        for start, end, s in sorted(edits.get(i, []), reverse=True):
            text = text[:start] + s + text[end:]
        out.append(src.bom + text.encode(src.encoding))
    return out


def check_output_name(path: str | os.PathLike, fmt: str, output: str | os.PathLike) -> None:
    """Refuse an ``output`` name for the program at ``path`` of format ``fmt`` that does not end as the program's
    (the controller reads a program by its extension): a single file's own extension; a KUKA pair's .src, .dat or
    none (its .src there, the .dat beside it). ``-`` (standard output) passes."""
    given = Path(output).suffix.lower()
    if str(output) == "-":
        return
    if fmt == "kuka":
        if given not in ("", ".src", ".dat"):
            raise DenavitError(
                f"{output}: expected an output name ending in .src (the .dat is written beside it) or without an"
                f" extension for a KUKA .src / .dat pair, got {given}"
            )
        return
    ext = Path(path).suffix
    if given != ext.lower():
        raise DenavitError(
            f"{output}: expected an output name ending in {ext or 'no extension'} (a compensated {fmt} program, read"
            f" by its extension on the controller), got {given or 'no extension'}"
        )


def output_paths(program: Program, output: str | os.PathLike) -> list[str]:
    """Where each of the program's files goes for ``output`` (:func:`check_output_name`): a single-file program
    there; a KUKA pair at ``output`` (its .src) and beside it with the .dat's suffix."""
    check_output_name(program.sources[0].path, program.format, output)
    out = Path(output)
    if len(program.sources) == 1:
        return [str(out)]
    return [str(out.with_suffix(Path(src.path).suffix)) for src in program.sources]


def write_program(
    program: Program, output: str | os.PathLike, new_values: dict, *, configs: dict | None = None, force: bool = False
) -> list[str]:
    """Write the program with ``new_values`` and ``configs`` (:func:`render`; a compensation's are
    :meth:`ProgramCompensation.write`'s) to ``output`` (:func:`output_paths`): every file made whole in memory first,
    each written whole or not at all. Returns the paths written."""
    data = render(program, new_values, configs)
    paths = output_paths(program, output)
    for p, src in zip(paths, program.sources, strict=True):
        if Path(p).resolve() == Path(src.path).resolve():
            raise DenavitError(
                f"{output}: would replace {src.path}, the program read; write the compensated program to another path"
                " (input files are never modified)"
            )
    for p, b in zip(paths, data, strict=True):
        with atomic_path(p, force=force) as tmp:
            tmp.write_bytes(b)
    return paths


# -- configurations -----------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Arm:
    """What a vendor's configuration needs of a model's geometry at ``q`` (world frame, m): ``wrist`` the wrist
    centre (the point of axis 5 nearest axis 4), ``front`` its x in the axis-1 frame (the world frame turned with
    joint 1: > 0 in front of axis 1), ``lower_arm`` the wrist's side of the line through axes 2 and 3 (> 0 in front
    of it: the side the axis-1 frame's x faces when that line points up), ``elbow_up`` the elbow's side of the line
    from axis 2 to the wrist centre (> 0 above it: the line's normal in the arm plane with a positive world z)."""

    front: float
    lower_arm: float
    elbow_up: float


def arm(model, q) -> Arm:
    ax = _core.axes(model, np.asarray(q, dtype=float))
    P, D = np.asarray(ax.points), np.asarray(ax.directions)
    w = closest_point(P[4], D[4], P[3], D[3])
    w = 0.5 * (w + closest_point(P[3], D[3], P[4], D[4]))
    x1 = _turn(D[0], q[0]) @ np.array([1.0, 0.0, 0.0])  # the axis-1 frame: the world's at joint 1 = 0, turned with it
    front = float((w - P[0]) @ x1)
    # the line through axes 2 and 3 (parallel): p2 the foot of axis 2 nearest axis 3's point, u along it
    d2 = D[1] / np.linalg.norm(D[1])
    p2 = P[1]
    u = (P[2] - p2) - ((P[2] - p2) @ d2) * d2
    u /= np.linalg.norm(u)
    nf = np.cross(d2, u)
    ref = np.cross(d2, np.array([0, 0, 1.0]))
    if ref @ x1 < 0:
        nf = -nf
    wp = (w - p2) - ((w - p2) @ d2) * d2
    lower = float(wp @ nf)
    v = wp / np.linalg.norm(wp)
    up = np.cross(d2, v)
    if up[2] < 0:
        up = -up
    e = (P[2] - p2) - ((P[2] - p2) @ d2) * d2
    return Arm(front, lower, float(e @ up))


def _turn(axis, angle) -> np.ndarray:
    from ...geometry import rotvec_matrix  # noqa: PLC0415

    a = np.asarray(axis, dtype=float) / np.linalg.norm(axis)
    return rotvec_matrix((a * angle)[None])[0]


def candidates(model, T: np.ndarray, seeds: int = 32) -> list[np.ndarray]:
    """Every distinct inverse kinematics solution of ``T`` on ``model`` found from the home, zeros and ``seeds``
    fixed configurations (local solves, one per branch they fall into), within the joint limits, each revolute
    joint also at the values whole turns away within its limits."""
    n = model.nq
    lo, hi = np.asarray(model.lower, dtype=float), np.asarray(model.upper, dtype=float)
    rev = np.array([k == "revolute" for k in model.kinds])
    lo2, hi2 = np.where(rev, np.maximum(lo, -np.pi), lo), np.where(rev, np.minimum(hi, np.pi), hi)
    S = np.vstack([np.zeros(n), lo2 + (hi2 - lo2) * np.random.default_rng(20260538).random((seeds, n))])
    r = _core.ik_batch(model, np.repeat(np.asarray(T, dtype=float)[None], len(S), axis=0), S, restarts=0)
    sols: list[np.ndarray] = []
    for q, ok in zip(r.q, r.success, strict=True):
        if not ok:
            continue
        base = (q + np.pi) % (2 * np.pi) - np.pi
        base = np.where(rev, base, q)
        if any(np.abs((base - s + np.pi) % (2 * np.pi) - np.pi).max() < 1e-6 for s in sols):
            continue
        sols.append(base)
    out = []
    for s in sols:
        choices = []
        for j in range(n):
            if rev[j]:
                vals = [
                    s[j] + 2 * np.pi * k for k in range(-3, 4) if lo[j] - 1e-9 <= s[j] + 2 * np.pi * k <= hi[j] + 1e-9
                ]
            else:
                vals = [s[j]] if lo[j] - 1e-9 <= s[j] <= hi[j] + 1e-9 else []
            choices.append(vals)
        if any(not c for c in choices):
            continue
        grids = np.meshgrid(*choices, indexing="ij")
        out.extend(np.stack([g.ravel() for g in grids], axis=1))
    return out


def flange_pose(point: Point, T_program: np.ndarray, flange_rot: np.ndarray) -> np.ndarray:
    """The model's flange pose (world = the program's robot base frame, m) of a program pose ``T_program``
    (``T_base_tool``): ``BASE @ T @ inv(TOOL) @ inv(R)`` with ``R`` the vendor flange's rotation from the model's."""
    F = np.eye(4)
    F[:3, :3] = flange_rot
    return point.base @ T_program @ np.linalg.inv(point.tool) @ np.linalg.inv(F)


def program_pose(point: Point, T_flange: np.ndarray, flange_rot: np.ndarray) -> np.ndarray:
    """The inverse of :func:`flange_pose`."""
    F = np.eye(4)
    F[:3, :3] = flange_rot
    return np.linalg.inv(point.base) @ T_flange @ F @ point.tool


# -- compensation -------------------------------------------------------------------------------------------


@dataclass
class ProgramCompensation:
    """The compensation of a program: ``program``, ``new_values`` (:class:`Rewrites`: {point index: values}, the points
    rewritten, with their configurations), ``compensation`` (:class:`denavit.compensation.Compensation` of the points
    compensated, in ``rows``'s order), ``rows`` (point indices), ``q_program`` (N, n) each row's configuration on the
    nominal, ``left`` [(where, why)] the points left as they were, ``relabelled`` [(where, why)] the points whose
    configuration is rewritten with their position (:func:`relabelled`), listed; :attr:`configs` those."""

    program: Program
    new_values: Rewrites
    compensation: object
    rows: list
    q_program: np.ndarray
    left: list
    positions: np.ndarray
    relabelled: list = field(default_factory=list)

    @property
    def configs(self) -> dict:
        """{point index: the vendor's configuration} of the points whose configuration is rewritten."""
        return self.new_values.configs

    def write(self, output: str | os.PathLike, *, force: bool = False) -> list[str]:
        """Write the program compensated to ``output`` (:func:`write_program`)."""
        return write_program(self.program, output, self.new_values, force=force)


def configuration_solution(
    v, model, point: Point, T_flange: np.ndarray, q_near: np.ndarray, arm_cache: dict
) -> np.ndarray | None:
    """The nominal solution of a pose on the configuration ``point`` states (the vendor's ``matches``, or an axis the
    configuration puts on one side of a boundary of its value within :data:`ON_BOUNDARY_DEG` of it on the other),
    nearest ``q_near``; None when no solution has it."""
    best, dist = None, np.inf
    for q in candidates(model, T_flange):
        if states(v, model, point.config, q, arm_cache):
            d = float(np.linalg.norm(q - q_near))
            if d < dist:
                best, dist = q, d
    return best


def states(v, model, config, q, cache: dict) -> bool:
    """Whether the configuration ``config`` states the joint values ``q``: ``q``'s own (the vendor's ``matches``), or
    one that differs from it only in fields that are boundaries of an axis's value (the vendor's ``relabel``) with
    each such axis within :data:`ON_BOUNDARY_DEG` of its boundary."""
    computed = v.configuration(model, q, cache)
    if v.matches(config, computed):
        return True
    r = v.relabel(config, computed)
    if r is None:
        return False
    a = np.degrees(np.asarray(q, dtype=float) * cache.get("signs", 1.0))
    return all(abs(a[j] - b) <= ON_BOUNDARY_DEG for _, j, b, _ in r[1])


def compensate_program(
    program: Program,
    nominal,
    identified,
    *,
    q0=None,
    branch_tol: float = np.radians(5.0),
    result=None,
    predict: bool = True,
    payload=None,
) -> ProgramCompensation:
    """Compensate every position of ``program`` for a controller that keeps ``nominal`` (a Robot) while the robot is
    ``identified``: each on its own configuration (the one it states; URScript poses: the solution nearest their
    ``get_inverse_kin`` ``qnear``, else nearest the previous position, the first nearest ``q0``, default the
    nominal's home), flange poses compensated (the program's tool and base frames exact, as the controller applies
    them). ``payload``: the payload on the flange for every position (kg, or (kg, (x, y, z)) its centre of mass in the
    model's flange frame, m; or (N, 4) one per compensated position): with an identified robot of compliant joints
    the commands are those that deflect onto the positions under it (:func:`denavit.compensation.compensate`)."""
    from ... import compensation as cp  # noqa: PLC0415
    from ...robot import Robot  # noqa: PLC0415

    v = program.vendor
    nominal = _robot(nominal)
    flange_robot = flange_of(nominal) if isinstance(nominal, Robot) else nominal
    model = flange_robot.model() if isinstance(flange_robot, Robot) else flange_robot.with_tool(np.eye(4))
    home = getattr(nominal, "home", None)
    q_prev = np.asarray(q0 if q0 is not None else (home if home is not None else np.zeros(model.nq)), dtype=float)
    F = v.flange_rotation(nominal)
    rows, positions, qs, left = [], [], [], []
    cache: dict = {"signs": v.signs(nominal)}
    for k, p in enumerate(program.points):
        if p.problem:
            left.append((p.where, p.problem))
            continue
        if p.kind == "joints":
            q = v.joint_values(nominal, p.values)
            T = _core.fk(model, q) @ _tool_in_flange(F, p.tool)
            Tf = T @ np.linalg.inv(_tool_in_flange(F, p.tool))
        else:
            Tf = flange_pose(p, v.to_pose(p.values), F)
            if p.config is None:
                q, found = cp.nearest_solutions(model, Tf[None], _near(v, nominal, p, q_prev))
                q = q[0] if found[0] else None
            else:
                q = configuration_solution(v, model, p, Tf, q_prev, cache)
            if q is None:
                raise DenavitError(
                    f"{p.where}: {p.name}: {v.describe(p.config) if p.config is not None else 'the pose'} is not"
                    f" reachable on the nominal {getattr(nominal, 'name', 'model')} (expected a pose its configuration"
                    " reaches within the joint limits)"
                )
        rows.append(k)
        positions.append(Tf)
        qs.append(q)
        q_prev = q
    T = np.array(positions).reshape(-1, 4, 4)
    Q = np.array(qs).reshape(-1, model.nq)
    if not rows:
        return ProgramCompensation(program, Rewrites(), None, [], Q, left, T)
    c = cp.compensate(
        flange_robot,
        identified,
        T,
        q_nominal=Q,
        branch_tol=branch_tol,
        result=result,
        predict=predict,
        payload=payload,
    )
    new, configs, relabels = {}, {}, []
    for i, k in enumerate(rows):
        p = program.points[k]
        if not c.ok[i]:
            why = ", ".join(
                x
                for x, f in (
                    ("unreachable", not c.reached[i]),
                    ("branch changed", c.branch_changed[i]),
                    ("path jump", c.path_jump[i]),
                )
                if f
            )
            left.append((p.where, why))
            continue
        qc = c.q_command[i]
        if p.kind == "joints":
            new[k] = v.joint_readings(nominal, qc, p)
            continue
        if p.config is not None and not _keeps(v, model, p.config, qc, cache):
            r = relabelled(v, model, p.config, Q[i], qc, cache, branch_tol)
            if r is None:
                left.append(
                    (
                        p.where,
                        f"the compensated command leaves {v.describe(p.config)} for"
                        f" {v.describe(v.configuration(model, qc, cache)).removeprefix('the configuration ')} (near a"
                        " configuration boundary, not only of an axis's value: a branch)",
                    )
                )
                continue
            configs[k] = r[0]
            relabels.append((p.where, r[1]))
        new[k] = v.pose_values(program_pose(p, c.commands[i], F), p)
    return ProgramCompensation(program, Rewrites(new, configs), c, rows, Q, left, T, relabels)


def relabelled(v, model, config, q_nominal: np.ndarray, q_command: np.ndarray, cache: dict, tol: float):
    """The configuration a position stated ``config`` is written with when its compensated command ``q_command``
    (rad) has another: ``(configuration, why)``, or None (the position is left as it was).

    The configuration data is part of the position: what the controller's inverse kinematics is held to. A command
    that is the same physical arm as the nominal solution ``q_nominal`` of ``config`` (every joint within ``tol``
    of it, as compensate's branch check) and whose configuration differs from ``config`` only in fields that are
    boundaries of an axis's value, each such axis having crossed its boundary between the two (ABB's cf1, cf4, cf6
    quadrants; KUKA's T bits, an axis's sign: the vendor's ``relabel``), is written with the configuration the
    controller records for it (what RobotStudio or the KUKA HMI writes when the arm is jogged there), and only when
    that configuration has no other solution of the command's pose: the controller, honouring it, runs the command.
    A shoulder, elbow or wrist-flip field (ABB's cfx, KUKA's S bits 0-2, FANUC's F/N U/D T/B) is a branch, never
    rewritten: axis 5 at 0 deg, where the flip changes, is the wrist singularity (axes 4 and 6 aligned, the other
    flip's solution half a turn of both away, the compensation ill-conditioned)."""
    qn, qc = np.asarray(q_nominal, dtype=float), np.asarray(q_command, dtype=float)
    if np.abs(qc - qn).max() > tol:
        return None
    r = v.relabel(config, v.configuration(model, qc, cache))
    if r is None:
        return None
    new, fields = r
    sg = cache.get("signs", 1.0)
    an, ac = np.degrees(qn * sg), np.degrees(qc * sg)
    if not all(
        min(an[j], ac[j]) - ON_BOUNDARY_DEG <= b <= max(an[j], ac[j]) + ON_BOUNDARY_DEG for _, j, b, _ in fields
    ):
        return None
    T = _core.fk(model, qc)
    others = [q for q in candidates(model, T) if v.matches(new, v.configuration(model, q, cache))]
    if not others or any(np.abs(q - qc).max() > 1e-6 for q in others):
        return None
    why = ", ".join(
        f"{name} (axis {j + 1} {an[j]:+.4f} -> {ac[j]:+.4f} deg, across its {what} at {b:g} deg)"
        for name, j, b, what in fields
    )
    written = v.describe(new).removeprefix("the configuration ")
    return new, f"configuration rewritten as the compensated command's, {written}: {why}; the same arm"


def _near(v, robot, point: Point, q_prev: np.ndarray) -> np.ndarray:
    """The joint values a pose without a configuration is solved nearest: the program's own hint (URScript's
    ``get_inverse_kin(x, qnear)``), else the previous position."""
    hint = point.extra.get("qnear")
    return q_prev if hint is None else v.joint_values(robot, hint)


def flange_of(robot):
    """``robot`` at its flange, the frame the vendors' flanges are given in: as it is when its tool is a pure rotation
    (a model's own flange frame, REP-199's tool0: the kr210's a half turn about its DH frame 6's z), else its tool
    taken off (a tool with an offset is not the flange; the program's tools are on the flange)."""
    t = robot.table
    if np.allclose(np.asarray(t.T_last_tool)[:3, 3], 0.0, rtol=0.0, atol=1e-12):
        return robot
    return replace(robot, table=_core.Table(t.convention, t.params, t.kinds, t.T_world_base, np.eye(4)))


def _keeps(v, model, config, q, cache: dict) -> bool:
    """Whether the joint values ``q`` or the same arm a whole turn of some revolute joints away (within the limits: the
    controller's solution of the same pose) have the configuration ``config``: a command at a turn boundary (a
    program's J4 at -180 deg, turn 0, compensated to -180.01) is the arm at 179.99 deg, turn 0, for the controller."""
    if v.matches(config, v.configuration(model, q, cache)):
        return True
    lo, hi = np.asarray(model.lower, dtype=float), np.asarray(model.upper, dtype=float)
    choices = []
    for j, kind in enumerate(model.kinds):
        shifts = [q[j] + 2 * np.pi * k for k in (-1, 1)] if kind == "revolute" else []
        choices.append([q[j]] + [x for x in shifts if lo[j] - 1e-9 <= x <= hi[j] + 1e-9])
    grids = np.meshgrid(*choices, indexing="ij")
    return any(v.matches(config, v.configuration(model, qq, cache)) for qq in np.stack([g.ravel() for g in grids], 1))


def _robot(r):
    """A built-in name or a robot file as its Robot (a Robot as given)."""
    if isinstance(r, (str, os.PathLike)):
        from ..robots import load  # noqa: PLC0415

        return load(r)
    if not hasattr(r, "table"):
        raise DenavitError(
            "nominal: expected a Robot, a built-in name or a robot file (the program's axis senses and frames need its"
            f" table), got {type(r).__name__}"
        )
    return r


def _tool_in_flange(F_rot: np.ndarray, tool: np.ndarray) -> np.ndarray:
    F = np.eye(4)
    F[:3, :3] = F_rot
    return F @ tool


def controller_joints(
    program: Program, robot, values: dict | None = None, *, configs: dict | None = None, q0=None
) -> np.ndarray:
    """The joint values (N, n) a nominal controller of ``robot`` runs each position of ``program`` at (its
    configuration honoured: the vendor's bits; URScript poses the solution nearest their ``qnear``, else nearest the
    previous position), with ``values`` ({point index: values}) and ``configs`` ({point index: configuration}) in
    place of the program's: what a simulated controller does (tests). A position no solution of which has its
    configuration is NaN."""
    from ... import compensation as cp  # noqa: PLC0415

    v = program.vendor
    robot = _robot(robot)
    model = flange_of(robot).model()
    F = v.flange_rotation(robot)
    home = getattr(robot, "home", None)
    q_prev = np.asarray(q0 if q0 is not None else (home if home is not None else np.zeros(model.nq)), dtype=float)
    out, cache = [], {"signs": v.signs(robot)}
    for k, p in enumerate(program.points):
        vals = p.values if values is None or k not in values else np.asarray(values[k])
        if p.problem:
            out.append(np.full(model.nq, np.nan))
            continue
        if p.kind == "joints":
            q = v.joint_values(robot, vals)
        else:
            Tf = flange_pose(p, v.to_pose(vals), F)
            if p.config is None:
                qq, found = cp.nearest_solutions(model, Tf[None], _near(v, robot, p, q_prev))
                q = qq[0] if found[0] else np.full(model.nq, np.nan)
            else:
                if configs and k in configs:
                    p = replace(p, config=configs[k])
                q = configuration_solution(v, model, p, Tf, q_prev, cache)
                q = np.full(model.nq, np.nan) if q is None else q
        out.append(q)
        if np.all(np.isfinite(q)):
            q_prev = q
    return np.array(out)


def tool_poses(program: Program, robot_model, Q: np.ndarray, flange_rot: np.ndarray) -> np.ndarray:
    """(N, 4, 4) the program's tool poses in its robot base frame reached at ``Q`` by ``robot_model`` (its flange)."""
    out = []
    for p, q in zip(program.points, Q, strict=True):
        out.append(
            _core.fk(robot_model, q) @ _tool_in_flange(flange_rot, p.tool)
            if np.all(np.isfinite(q))
            else np.full((4, 4), np.nan)
        )
    return np.array(out)
