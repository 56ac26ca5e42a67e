"""Units at the edges (files, CSV, CLI). Inside everything is SI: metres and radians."""

from __future__ import annotations

import math

from typing import TYPE_CHECKING

from .errors import DenavitError

if TYPE_CHECKING:
    from . import _core

LENGTH = {"m": 1.0, "mm": 1e-3, "cm": 1e-2, "um": 1e-6, "in": 0.0254}
ANGLE = {"rad": 1.0, "deg": math.pi / 180.0}


def length_scale(unit: str, where: str = "") -> float:
    """Metres per `unit` ("m", "mm", "cm", "um", "in")."""
    try:
        return LENGTH[str(unit).strip().lower()]
    except KeyError:
        raise DenavitError(f"{where + ': ' if where else ''}unknown length unit {unit!r}: expected one of {', '.join(LENGTH)}") from None


def angle_scale(unit: str, where: str = "") -> float:
    """Radians per `unit` ("rad", "deg")."""
    try:
        return ANGLE[str(unit).strip().lower()]
    except KeyError:
        raise DenavitError(f"{where + ': ' if where else ''}unknown angle unit {unit!r}: expected one of {', '.join(ANGLE)}") from None


def column_scale(table: _core.Table, k: int, length: str = "mm", angle: str = "deg") -> tuple[float, str]:
    """(SI per display unit, unit name) of table column ``k``: angles in ``angle``, POE directions unitless."""
    if table.angle_columns[k]:
        return angle_scale(angle), angle
    if table.convention == "poe" and not table.columns[k].startswith("v"):
        return 1.0, "1"
    return length_scale(length), length
