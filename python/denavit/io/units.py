"""Units at the edges (files, CSV, CLI). Inside everything is SI: metres, radians, kilograms.

This module is the only place that knows unit names and scales:

- :func:`length_scale`, :func:`angle_scale`, :func:`mass_scale`, :func:`inertia_scale`: SI per unit;
- :func:`joint_scale`: the per-joint-kind rule (a revolute joint's value is an angle, a prismatic joint's a
  length), used for every joint value (readings, home, limits, ranges, rates) in every reader and writer;
- :func:`parse_declaration` / :func:`declared_units`: the one parser of a file's ``# units:`` line;
- :func:`column_scale`: the unit of a parameter table's column (angles, lengths, unitless POE directions).
"""

from __future__ import annotations

import math
import re
from collections.abc import Iterable, Sequence
from typing import TYPE_CHECKING

from ..errors import DenavitError

if TYPE_CHECKING:
    from pathlib import Path

    import numpy as np

    from .. import _core

LENGTH = {"m": 1.0, "mm": 1e-3, "cm": 1e-2, "um": 1e-6, "in": 0.0254}
ANGLE = {"rad": 1.0, "deg": math.pi / 180.0}
MASS = {"kg": 1.0, "g": 1e-3}
#: The keys a ``# units:`` declaration may set.
DECLARATION_KEYS = ("length", "angle", "mass", "inertia", "time")
TIME = {"s": 1.0, "ms": 1e-3, "us": 1e-6, "ns": 1e-9}


def _pre(where: str) -> str:
    return f"{where}: " if where else ""


def _lookup(units: dict[str, float], what: str, unit: str, where: str) -> float:
    try:
        return units[str(unit).strip().lower()]
    except KeyError:
        raise DenavitError(f"{_pre(where)}unknown {what} unit {unit!r}: expected one of {', '.join(units)}") from None


def length_scale(unit: str, where: str = "") -> float:
    """Metres per `unit` ("m", "mm", "cm", "um", "in")."""
    return _lookup(LENGTH, "length", unit, where)


def angle_scale(unit: str, where: str = "") -> float:
    """Radians per `unit` ("rad", "deg")."""
    return _lookup(ANGLE, "angle", unit, where)


def mass_scale(unit: str, where: str = "") -> float:
    """Kilograms per `unit` ("kg", "g")."""
    return _lookup(MASS, "mass", unit, where)


def time_scale(unit: str, where: str = "") -> float:
    """Seconds per `unit` ("s", "ms", "us", "ns")."""
    return _lookup(TIME, "time", unit, where)


def inertia_scale(unit: str, where: str = "") -> float:
    """kg m^2 per `unit`, a mass unit times a squared length unit: "kg m^2", "g mm^2", "kg*cm^2", ..."""
    m = re.fullmatch(r"\s*([a-zA-Z]+)\s*[* ]\s*([a-zA-Z]+)\s*(\^2|\*\*2|2)\s*", str(unit))
    if not m:
        raise DenavitError(
            f'{_pre(where)}unknown inertia unit {unit!r}: expected a mass unit times a squared length unit, e.g. "kg'
            ' m^2" or "g mm^2"'
        )
    return mass_scale(m.group(1), where) * length_scale(m.group(2), where) ** 2


def joint_scale(kinds: Sequence[str], length: str, angle: str, where: str = "") -> np.ndarray:
    """(n,) SI per file unit of each joint's value: ``angle`` for a revolute joint, ``length`` for a prismatic one.

    The one rule for joint values (readings, home, limits, ranges, rates, q on the command line): multiply a
    value in the file's units by this to get SI, divide an SI value by it to write it out.
    """
    import numpy as np  # noqa: PLC0415 (numpy is the package's own; kept lazy so `denavit --help` stays fast)

    ls, as_ = length_scale(length, where), angle_scale(angle, where)
    out = []
    for i, k in enumerate(kinds):
        if k == "revolute":
            out.append(as_)
        elif k == "prismatic":
            out.append(ls)
        else:
            raise DenavitError(
                f"{_pre(where)}joint {i + 1}: unknown joint kind {k!r}: expected 'revolute' or 'prismatic'"
            )
    return np.asarray(out, dtype=float)


def joint_unit(kind: str, length: str, angle: str) -> str:
    """The unit name of a joint value of ``kind`` ("revolute": ``angle``, "prismatic": ``length``)."""
    return angle if kind == "revolute" else length


#: A ``# units:`` declaration: a comment line whose first word is ``units`` and a colon, with or without a
#: space after the ``#`` (``# units: length=mm angle=deg``, ``#units:length=m,angle=rad``).
DECLARATION_RE = re.compile(r"^\s*#\s*units\s*:(.*)$", re.IGNORECASE)


def parse_declaration(lines: Iterable[str], where: str = "") -> dict[str, str]:
    """The units a file declares in its ``# units:`` comment lines, as ``{"length": "mm", "angle": "deg"}``.

    Each part is ``key=value`` (separated by spaces, commas or semicolons); keys are
    :data:`DECLARATION_KEYS` and values are checked against the known units. A key declared twice with
    different values (in one line or in two) is an error naming both lines: a file has one set of units.
    Returns an empty dict when the file declares nothing.
    """
    out: dict[str, str] = {}
    at: dict[str, int] = {}
    checks = {
        "length": length_scale,
        "angle": angle_scale,
        "mass": mass_scale,
        "inertia": inertia_scale,
        "time": time_scale,
    }
    for ln, line in enumerate(lines, 1):
        m = DECLARATION_RE.match(line)
        if not m:
            continue
        here = f"{where}:{ln}" if where else f"line {ln}"
        body = m.group(1).strip()
        # "inertia=kg m^2" holds a space: split on key= boundaries, not on every blank
        parts = re.split(r"[\s,;]+(?=[A-Za-z_]+\s*=)", body)
        if not body:
            raise DenavitError(f"{here}: empty units declaration: expected e.g. '# units: length=mm angle=deg'")
        for part in parts:
            part = part.strip().strip(",;").strip()
            if "=" not in part:
                raise DenavitError(
                    f"{here}: units declaration part {part[:40]!r} is not key=value: expected e.g. '# units: length=mm"
                    " angle=deg'"
                )
            key, value = (s.strip() for s in part.split("=", 1))
            key = key.lower()
            if key not in checks:
                raise DenavitError(
                    f"{here}: unknown key {key[:40]!r} in the units declaration: expected {', '.join(DECLARATION_KEYS)}"
                )
            checks[key](value, here)
            value = value.lower() if key != "inertia" else value
            if key in out and out[key] != value:
                raise DenavitError(
                    f"{here}: {key}={value} contradicts {key}={out[key]} declared at line {at[key]}: a file has one set"
                    " of units"
                )
            out[key], at[key] = value, ln
    return out


def declared_units(path: str | Path, text: str | None = None) -> dict[str, str]:
    """The units that the file at ``path`` declares (:func:`parse_declaration`); ``text`` if already read."""
    from .text import read_text  # noqa: PLC0415

    return parse_declaration((read_text(path) if text is None else text).splitlines(), str(path))


def input_units(
    declared: dict[str, str],
    length: str | None,
    angle: str | None,
    where: str,
    need: Sequence[str] = ("length", "angle"),
) -> dict[str, str]:
    """The units to read a file with: what it declares wins; ``length`` / ``angle`` (the command line's) fill in
    what it does not declare; anything in ``need`` still missing is an error naming the file."""
    units = dict(declared)
    given = {"length": length, "angle": angle}
    for k, v in given.items():
        if k not in units and v:
            units[k] = v
    missing = [k for k in need if k not in units]
    if missing:
        raise DenavitError(
            f"{where}: units not declared ({', '.join(missing)}): add a line '# units: length=mm angle=deg' or pass"
            " --length/--angle"
        )
    return units


def column_scale(table: _core.Table, k: int, length: str = "mm", angle: str = "deg") -> tuple[float, str]:
    """(SI per display unit, unit name) of table column ``k``: angles in ``angle``, POE directions unitless.

    A POE row's ``w`` is unitless; its ``v`` is a length for a revolute joint (v = -w x p) and a unit direction
    for a prismatic one: see :func:`cell_scale` for the per-row rule.
    """
    if table.angle_columns[k]:
        return angle_scale(angle), angle
    if table.convention == "poe" and not table.columns[k].startswith("v"):
        return 1.0, "1"
    return length_scale(length), length


def cell_scale(table: _core.Table, row: int, k: int, length: str = "mm", angle: str = "deg") -> tuple[float, str]:
    """(SI per display unit, unit name) of the parameter in ``row``, column ``k``: as :func:`column_scale`, but a
    prismatic POE row's ``v`` (a unit direction) is unitless."""
    if table.convention == "poe" and table.kinds[row] == "prismatic":
        return 1.0, "1"
    return column_scale(table, k, length, angle)
