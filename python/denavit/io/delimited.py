"""Delimited text (CSV with ``,`` or ``;``) as every denavit reader splits it, on the standard :mod:`csv` module:
``#`` comment lines and blank lines skipped, one separator per file, numbers strictly finite decimals, header
names unique. Errors name the file, the line and the column.
"""

from __future__ import annotations

import csv
import math
import re

from ..errors import DenavitError


def number(text: str, where: str, column: str) -> float:
    """A finite decimal number of cell ``text`` (errors name the place and the column)."""
    try:
        v = float(text)
    except ValueError:
        hint = " (a decimal comma? write numbers with a decimal point)" if re.fullmatch(r"[-+]?\d+,\d+", text) else ""
        raise DenavitError(f"{where}: column {column!r} must be a number, got {text[:40]!r}{hint}") from None
    if not math.isfinite(v):
        raise DenavitError(f"{where}: column {column!r} must be finite, got {text[:40]!r}")
    return v


def is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def rows(lines: list[str], where: str = "") -> tuple[list[tuple[int, list[str]]], str]:
    """(line number, cells) of every line that is neither blank nor a ``#`` comment, and the separator (``;``
    when the first such line holds more semicolons than commas, else ``,``); a trailing separator is dropped.
    A line the csv module cannot split (e.g. a cell over its field limit) is an error naming ``where`` and the line."""
    data = [(ln, line) for ln, line in enumerate(lines, 1) if line.strip() and not line.lstrip().startswith("#")]
    if not data:
        return [], ","
    first = data[0][1]
    delim = ";" if first.count(";") > first.count(",") else ","
    out = []
    for ln, line in data:
        cells = split(line, delim, f"{where}:{ln}" if where else f"line {ln}")
        if len(cells) > 1 and cells[-1] == "":
            cells.pop()
        out.append((ln, cells))
    return out, delim


def split(line: str, delim: str, where: str) -> list[str]:
    """The cells of one line (stripped), on the csv module; what it cannot split is a one-line error at ``where``."""
    try:
        return [c.strip() for c in next(csv.reader([line], delimiter=delim))]
    except csv.Error as e:
        raise DenavitError(f"{where}: cannot split the line into cells ({e}; the line has {len(line)} characters)") from None


def header(cells: list[str], where: str) -> list[str]:
    """Lower-cased column names; a name given twice is an error."""
    cols = [c.lower() for c in cells]
    dup = sorted({c for c in cols if cols.count(c) > 1})
    if dup:
        raise DenavitError(f"{where}: column(s) {', '.join(dup)} named twice in the header {','.join(cells)!r}")
    return cols
