"""Limits by design (docs/cli.md, "Limits"): every size an input may ask for is checked against a documented limit
before anything is allocated, and every number read or typed against what is physically plausible for its
quantity, each with a one-line :class:`~denavit.errors.DenavitError` that names the limit and, where raising it
makes sense, how (an environment variable ``DENAVIT_MAX_...``).

Sizes (raisable): :data:`SIZES`, read through :func:`size`. Values (fixed): :data:`MAX_LENGTH_M` for a length of
a robot (a link, a tool, a joint's travel, a pose's position), :data:`MAX_TURNS` turns for a geometric angle (a
parameter, a pose's roll, pitch and yaw), :data:`MAX_JOINT_TURNS` for a joint value or limit, a noise below the
robot's size (:func:`robot_size`) and, for an angle, below half a turn.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass

import numpy as np

from .errors import DenavitError


@dataclass(frozen=True)
class Size:
    """A size limit: its default, the environment variable that raises it, what it counts."""

    default: int
    env: str
    what: str


#: The size limits (name: default, environment variable, what is counted); docs/cli.md's "Limits" table says why
#: each value.
SIZES = {
    "joints": Size(64, "DENAVIT_MAX_JOINTS", "joints in a serial chain"),
    "urdf_links": Size(4096, "DENAVIT_MAX_URDF_LINKS", "links (and as many joints) in a URDF"),
    "columns": Size(1000, "DENAVIT_MAX_COLUMNS", "columns in a delimited file"),
    "line_bytes": Size(4 << 20, "DENAVIT_MAX_LINE_BYTES", "bytes in a line of a delimited file"),
    "file_bytes": Size(1 << 30, "DENAVIT_MAX_FILE_BYTES", "bytes in a text file read"),
    "points": Size(1_000_000, "DENAVIT_MAX_POINTS", "points per sweep"),
    "poses": Size(100_000, "DENAVIT_MAX_POSES", "poses in a plan"),
}

#: The longest length of a robot, in metres: a link, an offset, a tool, a joint's travel, a pose's position. The
#: largest serial machines (gantries, cable robots, telescopes' hexapods) are tens of metres; 1 km is far beyond
#: any and far below where products and squares lose digits or overflow. (A measured point may lie farther, in a
#: tracker's or a survey's frame: :data:`denavit.io.delimited.MAX_LENGTH`.)
MAX_LENGTH_M = 1000.0

#: The largest geometric angle, in turns: a parameter of a table (alpha, theta, beta), a frame's roll, pitch and yaw,
#: a pose's; written plainly it is within one turn, 4 leave room for any unwrapped writing while refusing 1e300
#: (whose sine is noise).
MAX_TURNS = 4.0

#: The largest joint value, in turns: a revolute joint's value, range, limit or home. Multi-turn joints exist (a
#: wrist's ±720 degrees, an ABB axis in independent mode ±96 revolutions); at 100 turns a double still resolves
#: 1e-13 rad, while 1e300 rad means nothing.
MAX_JOINT_TURNS = 100.0

#: The largest angular noise (one sigma, rad): half a turn; beyond it a rotation noise wraps around and means nothing.
MAX_ANGLE_NOISE = math.pi


def size(name: str) -> int:
    """The limit ``name`` of :data:`SIZES`: its environment variable (a positive integer) if set, else the default."""
    s = SIZES[name]
    text = os.environ.get(s.env)
    if text is None or not text.strip():
        return s.default
    try:
        value = int(text.strip().replace("_", ""))
    except ValueError:
        value = 0
    if value < 1:
        raise DenavitError(
            f"{s.env}={text[:40]!r}: expected a positive integer (the limit of {s.what}), got {text[:40]!r}"
        )
    return value


def raise_hint(name: str) -> str:
    """How to raise the limit ``name`` (for a message)."""
    return f"set {SIZES[name].env} to raise it"


def check_size(count, name: str, where: str, what: str | None = None) -> int:
    """``count`` (an integer) if within the limit ``name`` (and >= 0), else the one-line error naming the limit
    and how to raise it. ``what`` names the count in the message (default: the limit's own ``what``)."""
    limit = size(name)
    if count > limit:
        shown = f"{count:,}" if isinstance(count, int) else str(count)
        raise DenavitError(
            f"{where}: {shown} {what or SIZES[name].what} is beyond the limit of {limit:,} ({raise_hint(name)};"
            ' docs/cli.md, "Limits")'
        )
    return count


def _worst(values) -> tuple[int, float]:
    v = np.abs(np.asarray(values, dtype=float).ravel())
    v = np.where(np.isnan(v), np.inf, v)
    k = int(np.argmax(v)) if v.size else 0
    return k, (float(v[k]) if v.size else 0.0)


def check_lengths(values, where: str, unit: str = "m", scale: float = 1.0) -> None:
    """Every value (metres) finite and within :data:`MAX_LENGTH_M`, else a one-line error showing the worst in
    ``unit`` (``scale`` metres per unit)."""
    k, worst = _worst(values)
    if not worst <= MAX_LENGTH_M:
        shown = np.asarray(values, dtype=float).ravel()[k] / scale
        raise DenavitError(
            f"{where}: expected a finite length within {MAX_LENGTH_M / scale:.6g} {unit} (1 km: no robot is larger),"
            f" got {shown:.6g} {unit}"
        )


def check_angles(values, where: str, unit: str = "rad", scale: float = 1.0, joint: bool = False) -> None:
    """Every value (rad) finite and within :data:`MAX_TURNS` turns (``joint``: a joint value, :data:`MAX_JOINT_TURNS`),
    else a one-line error showing the worst in ``unit`` (``scale`` rad per unit)."""
    turns = MAX_JOINT_TURNS if joint else MAX_TURNS
    limit = turns * 2 * math.pi
    k, worst = _worst(values)
    if not worst <= limit + 1e-9:
        shown = np.asarray(values, dtype=float).ravel()[k] / scale
        what = "joint value" if joint else "angle"
        raise DenavitError(
            f"{where}: expected a finite {what} within ±{limit / scale:.6g} {unit} ({turns:g} turns), got {shown:.6g}"
            f" {unit}"
        )


def check_joint_values(values, kinds, where: str) -> None:
    """Joint values (SI, (..., n)): revolute within :data:`MAX_JOINT_TURNS` turns, prismatic within
    :data:`MAX_LENGTH_M`."""
    v = np.asarray(values, dtype=float)
    if v.size == 0:
        return
    rev = np.array([k == "revolute" for k in kinds])
    v2 = v.reshape(-1, len(rev))
    if rev.any():
        check_angles(v2[:, rev], where, joint=True)
    if (~rev).any():
        check_lengths(v2[:, ~rev], where)


def robot_size(model, tool=None) -> float:
    """The size of a robot (m): the length of its chain at q = 0, the distances from each joint frame's origin to
    the next's and to the flange, plus its prismatic joints' travel and the tool point's distance from the flange
    (``tool``, (3,) or (k, 3) m); at least 1 mm. A noise (one sigma) is below it."""
    from . import _core  # noqa: PLC0415

    n = model.nq
    F = np.asarray(_core.joint_frames(model, np.zeros(n)))
    ends = np.vstack(
        [
            np.asarray(model.T_world_base)[None, :3, 3],
            F[:, :3, 3],
            np.asarray(_core.fk(model, np.zeros(n)))[None, :3, 3],
        ]
    )
    total = float(np.linalg.norm(np.diff(ends, axis=0), axis=1).sum())
    for k, lo, hi in zip(model.kinds, model.lower, model.upper):
        if k == "prismatic":
            total += min(max(abs(lo), abs(hi)), MAX_LENGTH_M)
    if tool is not None:
        t = np.asarray(tool, dtype=float)
        t = t[:3, 3] if t.shape == (4, 4) else t  # a tool frame T_flange_tool
        total += (
            float(np.linalg.norm(np.atleast_2d(t).reshape(-1, t.shape[-1] if t.ndim else 1), axis=1).max())
            if t.size
            else 0.0
        )
    return max(total, 1e-3) if math.isfinite(total) else MAX_LENGTH_M


def check_noise(value, where: str, model, tool=None, unit: str = "m", scale: float = 1.0) -> None:
    """A length noise (one sigma, m): finite, >= 0, and below the robot's size (:func:`robot_size`)."""
    v = float(value)
    if not (math.isfinite(v) and v >= 0):
        raise DenavitError(f"{where}: expected a finite noise >= 0 {unit}, got {v / scale:.6g} {unit}")
    s = robot_size(model, tool)
    if v >= s:
        raise DenavitError(
            f"{where}: a noise of {v / scale:.6g} {unit} (one sigma) is not below the robot's size, {s / scale:.6g}"
            f" {unit} (its chain's length, travel and tool point): expected a measuring noise, a small fraction of it"
            " (a wrong unit?)"
        )


def check_angle_noise(value, where: str, unit: str = "rad", scale: float = 1.0) -> None:
    """An angular noise (one sigma, rad): finite, >= 0, below :data:`MAX_ANGLE_NOISE`."""
    v = float(value)
    if not (math.isfinite(v) and 0 <= v < MAX_ANGLE_NOISE):
        raise DenavitError(
            f"{where}: expected a finite angular noise >= 0 and below half a turn ({MAX_ANGLE_NOISE / scale:.6g}"
            f" {unit}; beyond it a rotation wraps around), got {v / scale:.6g} {unit}"
        )


def check_count(value, where: str, name: str, least: int = 1, what: str | None = None) -> int:
    """A count typed or given (``--points``, ``--random``): an integer >= ``least`` within the size limit ``name``."""
    import operator  # noqa: PLC0415

    try:
        n = None if isinstance(value, bool) else operator.index(value)
    except TypeError:
        n = None
    if n is None or n < least:
        raise DenavitError(f"{where}: expected an integer >= {least}, got {value!r}")
    return check_size(n, name, where, what)


def floats(value, where: str) -> np.ndarray:
    """``value`` as a float array (a copy); numpy dates and durations (``datetime64``, ``timedelta64``), which
    numpy would turn into days or seconds since 1970 without a word, are refused: joint values, points and
    poses are numbers in SI units."""
    a = value if isinstance(value, np.ndarray) else np.asarray(value)
    kind = a.dtype.kind
    if kind == "O" and a.size:
        kind = next(
            (np.asarray(v).dtype.kind for v in a.ravel() if isinstance(v, (np.datetime64, np.timedelta64))), kind
        )
    if kind in "mM":
        raise DenavitError(
            f"{where}: expected numbers (rad / m), got numpy"
            f" {'dates (datetime64)' if kind == 'M' else 'durations (timedelta64)'}"
        )
    return np.array(a, dtype=float)
