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
from collections.abc import Iterable, Iterator, Sequence
from contextlib import contextmanager
from contextvars import ContextVar
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

#: The accepted form, as the errors show it.
DECLARATION_FORM = "'# units: length=mm angle=deg'"

_KEY_WORD = r"(?:lengths?|angles?|mass(?:es)?|inertias?|times?)"
#: A unit name as a comment may spell it: the accepted names and their spelled-out forms.
_UNIT_WORD = (
    r"(?:mm|cm|um|µm|μm|m|in|rad|deg|kg|g|s|ms|us|ns|si|(?:milli|centi|micro)?met(?:er|re)s?|microns?|inch(?:es)?"
    r"|radians?|degrees?|(?:kilo)?grams?|(?:milli|micro|nano)?seconds?)"
)
_END = r"(?![A-Za-z0-9°µμ])"
#: A comment that looks like a units declaration but is not one (:func:`parse_declaration` refuses it): after the
#: ``#`` (or ``##``), a quantity's name (``length``, ``angles``, ... or ``units``/``unit``, optionally with ``unit``
#: after it: ``length unit``, ``angle_units``), then, directly or after ``:``, ``=``, ``in``, ``is``, ``are``, ``[`` or
#: ``(``, a unit name (``# length: mm``, ``# angles = rad``, ``#units length=mm``, ``# lengths in mm``,
#: ``# Length [mm]``, ``# units mm``); or ``unit`` / ``units`` and ``:`` / ``=`` (``# unit: m``, ``## units: ...``).
#: Prose that names a quantity without giving its unit right after (``# angle of the tool 30 deg``) is a comment.
NEAR_DECLARATION_RE = re.compile(
    rf"^\s*#+\s*(?:(?:units?[\s:=]+)?{_KEY_WORD}|units?){_END}(?:[\s_-]*units?{_END})?"
    rf"\s*(?:[:=]|\b(?:in|is|are)\b|[\[(])?\s*{_UNIT_WORD}{_END}"
    rf"|^\s*#+\s*units?\s*[:=]",
    re.IGNORECASE,
)
_PAIR_RE = re.compile(
    rf"\b({_KEY_WORD}){_END}(?:[\s_-]*units?{_END})?\s*(?:[:=]|\b(?:in|is|are)\b|[\[(])?\s*([A-Za-zµμ]+)", re.IGNORECASE
)


def _kind(unit: str) -> str | None:
    """The declaration key whose units hold ``unit`` (the unit tables' names are disjoint), or None."""
    u = unit.lower()
    return next((k for k, t in (("length", LENGTH), ("angle", ANGLE), ("mass", MASS), ("time", TIME)) if u in t), None)


def _suggestion(texts: Iterable[str], declared: dict[str, str]) -> str:
    """The accepted line for what ``texts`` (comment lines, or a declaration's body) say, where each says it
    unambiguously (a key and one of its units, or bare units of distinct kinds: ``mm, rad``); else the example."""
    out = dict(declared)
    for text in texts:
        pairs = [(next(d for d in DECLARATION_KEYS if k.lower().startswith(d)), v) for k, v in _PAIR_RE.findall(text)]
        if not pairs:  # bare units: '# units: mm, rad', '# units mm deg'
            words = re.findall(r"[A-Za-zµμ]+", re.sub(r"^\s*#+\s*units?\b", "", text, flags=re.IGNORECASE))
            pairs = [(_kind(w), w) for w in words]
        if not pairs:
            return DECLARATION_FORM
        for k, v in pairs:
            v = v.lower()
            if k is None or _kind(v) != k or out.get(k, v) != v:
                return DECLARATION_FORM
            out[k] = v
    return "'# units: " + " ".join(f"{k}={v}" for k, v in out.items()) + "'"


def parse_declaration(lines: Iterable[str], where: str = "") -> dict[str, str]:
    """The units a file declares in its ``# units:`` comment lines, as ``{"length": "mm", "angle": "deg"}``.

    Each part is ``key=value`` (separated by spaces, commas or semicolons); keys are
    :data:`DECLARATION_KEYS` and values are checked against the known units. A key declared twice with
    different values (in one line or in two) is an error naming both lines: a file has one set of units.
    A comment that looks like a declaration but is not one (:data:`NEAR_DECLARATION_RE`: ``# length: mm``,
    ``# unit: m``, ``#units length=mm``) is an error naming its line and the accepted form, never a comment
    ignored (the reader would have read the file in the caller's units). Returns an empty dict when the file
    declares nothing.
    """
    out: dict[str, str] = {}
    at: dict[str, int] = {}
    near: list[tuple[int, str]] = []
    checks = {
        "length": length_scale,
        "angle": angle_scale,
        "mass": mass_scale,
        "inertia": inertia_scale,
        "time": time_scale,
    }
    for ln, line in enumerate(lines, 1):
        if not line.lstrip().startswith("#"):
            continue
        m = DECLARATION_RE.match(line)
        if not m:
            if NEAR_DECLARATION_RE.match(line):
                near.append((ln, line))
            continue
        here = f"{where}:{ln}" if where else f"line {ln}"
        body = m.group(1).strip()
        # "inertia=kg m^2" holds a space: split on key= boundaries, not on every blank
        parts = re.split(r"[\s,;]+(?=[A-Za-z_]+\s*=)", body)
        if not body:
            raise DenavitError(f"{here}: empty units declaration: expected e.g. {DECLARATION_FORM}")
        for part in parts:
            part = part.strip().strip(",;").strip()
            if "=" not in part:
                raise DenavitError(
                    f"{here}: units declaration part {part[:40]!r} is not key=value: expected {_suggestion([body], {})}"
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
    if near:
        ln, line = near[0]
        here = f"{where}:{ln}" if where else f"line {ln}"
        raise DenavitError(
            f"{here}: {line.strip()[:60]!r} looks like a units declaration but is not in its form: expected"
            f" {_suggestion([t for _, t in near], out)} (one line of key=value), or reword the comment"
        )
    return out


def declared_units(path: str | Path, text: str | None = None) -> dict[str, str]:
    """The units that the file at ``path`` declares (:func:`parse_declaration`); ``text`` if already read."""
    from .text import read_text  # noqa: PLC0415

    return parse_declaration((read_text(path) if text is None else text).splitlines(), str(path))


#: The command line's typed units (:func:`typed_units`); None outside a command.
_typed: ContextVar[dict[str, str] | None] = ContextVar("denavit_typed_units", default=None)


@contextmanager
def typed_units(typed: dict[str, str]) -> Iterator[None]:
    """Inside the block, the command line's ``--length`` / ``--angle`` the user typed (``{"length": "m"}``): what
    :func:`input_units` compares a file's declaration with (a default, unlike a typed unit, is said nowhere)."""
    token = _typed.set(dict(typed))
    try:
        yield
    finally:
        _typed.reset(token)


def _check_declared(declared: dict, where: str) -> None:
    """A declaration read from anywhere (a ``# units:`` line, a JSON ``"units"`` object): its keys are
    :data:`DECLARATION_KEYS` and its values their units; a misspelt key (``"lengths"``) is an error, never ignored."""
    checks = {"length": length_scale, "angle": angle_scale, "mass": mass_scale, "inertia": inertia_scale}
    for key, value in declared.items():
        if key not in DECLARATION_KEYS:
            raise DenavitError(
                f"{where}: unknown key {str(key)[:40]!r} in the units declaration: expected"
                f" {', '.join(DECLARATION_KEYS)}"
            )
        checks.get(key, time_scale)(value, f"{where}: units")


def input_units(
    declared: dict[str, str],
    length: str | None,
    angle: str | None,
    where: str,
    need: Sequence[str] = ("length", "angle"),
) -> dict[str, str]:
    """The units to read a file with: what it declares wins; ``length`` / ``angle`` (the command line's) fill in
    what it does not declare; anything in ``need`` still missing is an error naming the file.

    On the command line (:func:`typed_units`), a declared unit that differs from the ``--length`` / ``--angle`` the
    user typed is a :class:`~denavit.errors.DenavitWarning` naming both (the option still sets what is printed and
    written); a default, and in Python an argument (a fallback by this rule), disagrees silently."""
    import warnings  # noqa: PLC0415

    from ..errors import DenavitWarning  # noqa: PLC0415

    _check_declared(declared, where)
    units = dict(declared)
    typed = _typed.get() or {}
    for k, v in {"length": length, "angle": angle}.items():
        if k not in units and v:
            units[k] = v
        elif k in units and v and k in typed and typed[k].strip().lower() != units[k].lower():
            warnings.warn(
                f"{where}: declares {k}={units[k]}: read in {units[k]}, not in --{k} {typed[k]} (which sets what is"
                " printed and written)",
                DenavitWarning,
                stacklevel=2,
            )
    missing = [k for k in need if k not in units]
    if missing:
        raise DenavitError(
            f"{where}: units not declared ({', '.join(missing)}): add a line {DECLARATION_FORM} or pass"
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
