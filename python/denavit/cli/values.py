"""Values from the command line, SI out: numbers, one value per joint, sweep ranges, points and poses, counts and
noises, and the robot a MODEL names.

Units are declared at this edge and applied by :mod:`denavit.io.units` only: a joint value (``--q``,
``--home``, ``--ranges``, rates) is in the angle unit for a revolute joint and in the length unit for a
prismatic one (:func:`~denavit.io.units.joint_scale`); table cells follow
:func:`~denavit.io.units.cell_scale` (a POE ``w``, and a prismatic joint's ``v``, are unitless).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from ..errors import DenavitError
from ..io.units import LENGTH, angle_scale, joint_scale, joint_unit, length_scale
from .console import fail, say

if TYPE_CHECKING:
    from collections.abc import Sequence

    import numpy as np

    from .. import _core
    from ..robot import Robot


def load_robot(
    model: str, base_link: str | None = None, tip_link: str | None = None, what: str = "MODEL", chain_only: bool = False
) -> Robot:
    """The robot of a MODEL argument (built-in name, robot file or URDF; ``base_link``/``tip_link`` pick a URDF's
    chain), with what the reader chose on the user's behalf said in one line each."""
    from ..io.robots import load  # noqa: PLC0415

    if (base_link is not None or tip_link is not None) and not str(model).lower().endswith(".urdf"):
        fail(f"--base-link/--tip-link apply to a URDF {what}, got {model!r}")
    if chain_only and not str(model).lower().endswith(".urdf"):
        chain_only = False  # a robot file or built-in is a chain already
    robot = load(model, base_link=base_link, tip_link=tip_link, chain_only=chain_only)
    for note in robot.notes:
        say("dim", "note:", f" {note}", err=True)
    return robot


def convention_name(name: str) -> str:
    """The canonical name of a convention (the core's one parser: dh, sdh, mdh, craig, modified-dh, edh, poe)."""
    from .. import _core  # noqa: PLC0415

    return _core.convention_info(name)["name"]


def parse_numbers(text: str | None, what: str) -> list[float]:
    """Numbers separated by commas and/or spaces ("90,-90,90" or "90 -90 90")."""
    from ..io.delimited import NUMBER  # noqa: PLC0415 (the one number rule of every reader)

    if not text:
        return []
    tokens = text.replace(",", " ").split()
    bad = next((t for t in tokens if not NUMBER.fullmatch(t)), None)
    if bad is not None:
        fail(
            f"{what}: expected numbers (ASCII decimal, e.g. -90 or 1.5e-3) separated by commas or spaces, got"
            f" {bad[:40]!r}"
        )
    values = [float(t) for t in tokens]
    if not all(math.isfinite(v) for v in values):
        fail(f"{what}: expected finite numbers, got {text[:80]!r}")
    return values


def parse_joint_values(
    text: str | None, what: str, robot: Robot, length: str, angle: str, default=None, limits: bool = True
) -> np.ndarray:
    """One value per joint from the command line (``--q``, ``--qd``, ``--home``, ...), SI out: revolute values
    in ``angle``, prismatic ones in ``length`` (rates per s, per s^2). Without ``text``: ``default`` (SI),
    else zeros; an empty ``text`` (``--q ""``) is an error, not zeros. With ``limits``, values beyond the robot's
    joint limits are warned about (:func:`warn_limits`)."""
    import numpy as np  # noqa: PLC0415

    n = len(robot.names)
    if text is None:
        return np.zeros(n) if default is None else np.asarray(default, dtype=float)
    values = parse_numbers(text, what)
    if len(values) != n:
        fail(f"{what}: expected {n} joint values for {robot.name}, got {len(values) or 'none'}")
    q = np.array(values) * joint_scale(robot.table.kinds, length, angle, what)
    if limits:
        check_joint_values(q, robot.table.kinds, what, length, angle)
        warn_limits(q, robot, what, length, angle)
    return q


def check_joint_values(q, kinds, what: str, length: str, angle: str) -> None:
    """Joint values (SI, (..., n)) within the plausible (:mod:`denavit.limits`: revolute within the turns allowed,
    prismatic within 1 km), else the one-line error in the units typed."""
    import numpy as np  # noqa: PLC0415

    from .. import limits  # noqa: PLC0415

    q2 = np.asarray(q, dtype=float).reshape(-1, len(kinds))
    for j, kind in enumerate(kinds):
        if kind == "revolute":
            limits.check_angles(q2[:, j], f"{what}: joint {j + 1}", angle, angle_scale(angle), joint=True)
        else:
            limits.check_lengths(q2[:, j], f"{what}: joint {j + 1}", length, length_scale(length))


def warn_limits(q, robot: Robot, what: str, length: str, angle: str) -> None:
    """A warning on stderr for each joint value (SI) beyond the robot's limits, in the units typed; in degrees
    the hint that radians were meant is rarely right, in radians that degrees were meant almost always is."""
    import numpy as np  # noqa: PLC0415

    lo, hi = np.asarray(robot.lower, dtype=float), np.asarray(robot.upper, dtype=float)
    sc = joint_scale(robot.table.kinds, length, angle)
    bad = [j for j in range(len(q)) if not lo[j] - 1e-12 <= q[j] <= hi[j] + 1e-12]
    for j in bad:
        u = joint_unit(robot.table.kinds[j], length, angle)
        say(
            "bold yellow",
            "warning:",
            f" {what}: joint {robot.names[j]} = {q[j] / sc[j]:.6g} {u} is beyond its limits [{lo[j] / sc[j]:.6g},"
            f" {hi[j] / sc[j]:.6g}] {u}",
            err=True,
        )
    if bad and angle == "rad" and all(k == "revolute" for k in robot.table.kinds):
        say("bold yellow", "warning:", f" {what} is read in rad (--angle rad): were degrees meant?", err=True)


def joint_values_out(values, robot: Robot, length: str, angle: str) -> list[float]:
    """SI joint values in the display units (revolute: ``angle``, prismatic: ``length``)."""
    return (values / joint_scale(robot.table.kinds, length, angle)).tolist()


def parse_ranges(text: str | None, robot: Robot, length: str, angle: str, default: str) -> np.ndarray:
    """--ranges: 'paper90' / 'paper30' (Hayat Table II, a 6-joint revolute arm) or start,end pairs per joint
    (revolute: ``angle``, prismatic: ``length``); SI out, shape (n, 2), by :func:`denavit.api.protocol_ranges`."""
    import numpy as np  # noqa: PLC0415

    from ..api import protocol_ranges  # noqa: PLC0415

    n = len(robot.names)
    key = text or default
    if key.lower() in ("paper90", "paper30"):
        try:
            return protocol_ranges(robot, key)
        except DenavitError as e:
            fail(f"--ranges: {e}; give start,end pairs for this one")
    vals = parse_numbers(text, "--ranges")
    if len(vals) != 2 * n:
        fail(f"--ranges: expected {2 * n} values (start,end per joint), got {len(vals)}")
    r = np.array(vals).reshape(n, 2) * joint_scale(robot.table.kinds, length, angle, "--ranges")[:, None]
    check_joint_values(r.T, robot.table.kinds, "--ranges", length, angle)
    return protocol_ranges(robot, r)


def parse_pose(text: str, angle: str, ls: float, what: str = "--pose", six: str = "rpy") -> np.ndarray:
    """A pose from the command line, SI out: 16 (or 12) numbers, the rows of the 4x4 matrix; or 6 numbers, the
    position x,y,z and the orientation: a rotation vector rx,ry,rz (the pose format ``fk`` prints and the targets
    files hold) when ``six`` is "rotvec", roll,pitch,yaw with R = Rz(yaw) Ry(pitch) Rx(roll) (URDF's rpy) when it is
    "rpy"; a text starting ``rpy:`` or ``rotvec:`` names its convention whatever ``six`` says. Positions scaled by
    ``ls`` (metres per unit), angles in ``angle``."""
    import numpy as np  # noqa: PLC0415

    from .. import limits  # noqa: PLC0415
    from ..geometry import pose, rotvec_matrix, xyz_rpy_pose  # noqa: PLC0415
    from ..io.units import angle_scale  # noqa: PLC0415

    head, sep, rest = text.partition(":")
    if sep and head.strip().lower() in ("rpy", "rotvec"):
        six, text = head.strip().lower(), rest
    v = parse_numbers(text, what)
    unit = _length_unit(ls)
    if len(v) in (12, 16):
        T = np.eye(4)
        T[: len(v) // 4] = np.reshape(v, (len(v) // 4, 4))
        T[:3, 3] *= ls
        limits.check_lengths(T[:3, 3], f"{what}: position", unit, ls)
        return T
    names = "roll, pitch, yaw" if six == "rpy" else "rotation vector"
    if len(v) == 6:
        limits.check_lengths(np.array(v[:3]) * ls, f"{what}: position", unit, ls)
        a = np.array(v[3:]) * angle_scale(angle)
        limits.check_angles(a, f"{what}: {names}", angle, angle_scale(angle))
        xyz = np.array(v[:3]) * ls
        return xyz_rpy_pose(xyz, a) if six == "rpy" else pose(rotvec_matrix(a), xyz)
    fail(
        f"{what}: expected 16 or 12 numbers (rows of the 4x4 pose) or 6 (x,y,z,{names.replace(', ', ',')}), got"
        f" {len(v)}"
    )
    raise AssertionError


def pose_text(T: np.ndarray, length: str, angle: str) -> str:
    """The pose format: x,y,z (``length``) and the rotation vector rx,ry,rz (``angle``), ten significant digits, as
    ``ik --goal`` reads it."""
    from ..geometry import matrix_rotvec  # noqa: PLC0415

    v = [*(T[:3, 3] / length_scale(length)), *(matrix_rotvec(T[:3, :3]) / angle_scale(angle))]
    return ",".join(f"{x:.10g}" if abs(x) >= 1e-12 else "0" for x in v)


def parse_point(text: str | None, what: str, ls: float, default_si: Sequence[float]) -> np.ndarray:
    """A point x,y,z typed in the length unit (``ls`` metres per unit), SI out; ``default_si`` (metres, a
    physical default that keeps its size whatever the unit) without ``text``."""
    import numpy as np  # noqa: PLC0415

    from .. import limits  # noqa: PLC0415

    if text is None:
        return np.asarray(default_si, dtype=float)
    p = np.array(parse_numbers(text, what)) * ls
    if p.shape != (3,):
        fail(f"{what}: expected 3 values (x, y, z), got {p.size}")
    limits.check_lengths(p, what, _length_unit(ls), ls)
    return p


def _length_unit(ls: float) -> str:
    """The name of the length unit of ``ls`` metres (for a message)."""
    return next((u for u in ("mm", "m", "cm", "um", "in") if u in LENGTH and LENGTH[u] == ls), f"x {ls:g} m")


def count(value: int, what: str, limit: str, least: int = 1, counted: str | None = None) -> int:
    """A count typed (``--points``, ``--random``): an integer >= ``least`` within the size limit ``limit``
    (:mod:`denavit.limits`), checked before anything is allocated."""
    from .. import limits  # noqa: PLC0415

    return limits.check_count(value, what, limit, least, counted)


def positive(value: float | None, what: str, scale: float, default_si: float | None, unit: str) -> float | None:
    """A non-negative quantity typed in ``unit`` (``scale`` SI per unit), SI out; ``default_si`` without a value."""
    if value is None:
        return default_si
    if not (math.isfinite(value) and value >= 0):
        fail(f"{what}: expected a finite value >= 0 in {unit}, got {value}")
    return value * scale


def check_noises(model: _core.Model, tool, length: str, angle: str, *noises: tuple[str, float | None, str]) -> None:
    """Noises (SI, one sigma) as physically plausible (:mod:`denavit.limits`): ``(option, value, kind)`` with kind
    "length" (below the robot's size, with the tool point ``tool``), "angle" (below half a turn) or "joint" (a
    joint reading: by the joints' kinds); errors in the units typed."""
    from .. import limits  # noqa: PLC0415

    ls, as_ = length_scale(length), angle_scale(angle)
    for what, value, kind in noises:
        if value is None:
            continue
        if kind == "angle" or (kind == "joint" and "revolute" in model.kinds):
            limits.check_angle_noise(value, what + (" (revolute joints)" if kind == "joint" else ""), angle, as_)
        if kind == "length" or (kind == "joint" and "prismatic" in model.kinds):
            limits.check_noise(
                value, what + (" (prismatic joints)" if kind == "joint" else ""), model, tool, length, ls
            )


def calib_unit(unit: str, length: str, angle: str) -> tuple[str, float]:
    """Display unit and scale (SI per display unit) of a calibration parameter ("length" | "angle" | "ratio")."""
    from ..io.units import angle_scale, length_scale  # noqa: PLC0415

    if unit == "length":
        return length, length_scale(length)
    if unit == "angle":
        return angle, angle_scale(angle)
    if unit in ("rad/(N m)", "m/N"):  # a joint compliance (calibration/compliance.py)
        return ("urad/(N m)" if unit == "rad/(N m)" else "um/N"), 1e-6
    return "1", 1.0


#: The deprecated spellings of the command being run: those said, and those to say when it is done
#: (:func:`deprecated`; :class:`~.common.Command` starts and ends each run with :func:`say_deprecated`).
_deprecations: dict = {"seen": set(), "last": []}


def deprecated(old: str, new: str, last: bool = False) -> None:
    """One ``warning:`` line on stderr, once per command run, that the spelling ``old`` is deprecated for ``new``
    (docs/cli.md, "One grammar"); the old spelling keeps working. With ``last`` the line comes after the command's
    work, when it is done (:func:`say_deprecated`): an error stays the one line of a failed run."""
    if old in _deprecations["seen"]:
        return
    _deprecations["seen"].add(old)
    if last:
        _deprecations["last"].append((old, new))
    else:
        say("bold yellow", "warning:", f" {old} is deprecated: use {new}", err=True)


def say_deprecated(done: bool = True) -> None:
    """The deprecated spellings a finished command used (``done``), one ``warning:`` line each (:func:`deprecated`
    ``last``); then a clean slate for the next run."""
    pending = _deprecations["last"] if done else []
    _deprecations["seen"], _deprecations["last"] = set(), []
    for old, new in pending:
        say("bold yellow", "warning:", f" {old} is deprecated: use {new}", err=True)


def model_first(first, second, nominal: str | None, command: str, data: str = "DATA", required: bool = True):
    """(MODEL, DATA) of ``COMMAND MODEL DATA``, the nominal model first as in every command (docs/cli.md, "One
    grammar"), or of the deprecated ``COMMAND DATA --nominal MODEL`` (a warning when done). Without ``required`` a
    single argument is DATA alone (``identify DATA``: no nominal)."""
    if nominal is not None:
        if second is not None:
            fail(f"--nominal {nominal}: MODEL is the first argument ({first}): give it once")
        deprecated("--nominal MODEL", f"MODEL as the first argument: denavit {command} MODEL {data}", last=True)
        return nominal, first
    if second is None:
        if required and first is not None:
            fail(f"give MODEL {data}: the nominal model first, then {data} (denavit {command} MODEL {data}), got one")
        return None, first
    return first, second
