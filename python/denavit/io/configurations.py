"""Configuration files: a CSV of joint configurations, header ``q1,...,qn``, one row per configuration
(the candidates of ``denavit plan --candidates``).

Units by the one rule (:func:`denavit.io.units.input_units`): the file's ``# units:`` line wins, the caller's
``length`` / ``angle`` fill what it does not declare; revolute values take the angle unit, prismatic ones the
length unit (:func:`~denavit.io.units.joint_scale`).
"""

from __future__ import annotations

import os
from collections.abc import Sequence

import numpy as np

from ..errors import DenavitError
from . import delimited as dl
from .text import read_text
from .units import input_units, joint_scale, parse_declaration


def read_configurations(
    path: str | os.PathLike, kinds: Sequence[str], *, length: str | None = None, angle: str | None = None
) -> np.ndarray:
    """(m, n) configurations (SI) of a CSV whose header names ``q1..qn`` (``n = len(kinds)``): plain numbers read
    column-wise at C speed (:func:`~denavit.io.delimited.plain_columns`), anything else row by row (errors name the
    line and the column)."""
    where = str(path)
    head, got = dl.plain_head(path, "configurations file"), None
    if head is not None:
        try:
            units, data, delim, cols, idx = _layout(head.lines, kinds, length, angle, where)
        except DenavitError:  # said by the whole-file reader, in its order
            pass
        else:
            got = dl.plain_columns(path, head, delim, len(cols), [idx])
    if got is not None:
        out = got[0]
    else:
        lines = read_text(path, "configurations file", lines=True).splitlines()
        units, data, delim, cols, idx = _layout(lines, kinds, length, angle, where)
        need = [f"q{i + 1}" for i in range(len(kinds))]
        out = []
        for ln, cells in data[1:]:
            if len(cells) != len(cols):
                raise DenavitError(f"{where}:{ln}: expected {len(cols)} values, got {len(cells)}")
            out.append([dl.number(cells[i], f"{where}:{ln}", c) for i, c in zip(idx, need)])
    if not len(out):
        raise DenavitError(f"{where}: no configurations")
    return np.asarray(out, dtype=float) * joint_scale(kinds, units.get("length", "m"), units.get("angle", "rad"), where)


def _layout(lines: list[str], kinds: Sequence[str], length, angle, where: str):
    """(units, rows, separator, column names, the indices of q1..qn) of a configurations file's ``lines`` (the
    whole file's or those up to its header); a wrong header is a one-line error."""
    need_units = [u for u, k in (("angle", "revolute"), ("length", "prismatic")) if k in kinds]
    units = input_units(parse_declaration(lines, where), length, angle, where, need=need_units)
    data, delim = dl.rows(lines, where)
    n = len(kinds)
    need = [f"q{i + 1}" for i in range(n)]
    if not data:
        raise DenavitError(f"{where}: no header and no configurations: expected a header {','.join(need)}")
    hline, names = data[0]
    cols = dl.header(names, f"{where}:{hline}")
    missing = [c for c in need if c not in cols]
    unknown = [c for c in cols if c not in need]
    if missing or unknown:
        what = f"missing {', '.join(missing)}" if missing else f"unknown column(s) {', '.join(unknown)}"
        raise DenavitError(f"{where}:{hline}: header must name q1..q{n} ({n} joints); {what}, got {','.join(names)!r}")
    return units, data, delim, cols, [cols.index(c) for c in need]
