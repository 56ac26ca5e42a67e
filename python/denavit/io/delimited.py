"""Delimited text (CSV with ``,`` or ``;``) as every denavit reader splits it, on the standard :mod:`csv` module:
``#`` comment lines and blank lines skipped, one separator per file, numbers strictly finite decimals, header
names unique. Errors name the file, the line and the column.

This module also holds the one number rule of every reader: :func:`number` for a text cell (CSV, URDF
attributes), :func:`as_number` for a value a TOML, JSON or YAML parser has already typed (no booleans, no
strings that look like numbers).

Whole tables of plain numbers (a sweep file's millions of rows) take :func:`numeric_table`, Apache Arrow's CSV
reader for big ones and numpy's C reader for the rest, first; whatever they do not take is read row by
row with :func:`number`, whose errors name the line and column.
"""

from __future__ import annotations

import csv
import io
import math
import re
import warnings

import numpy as np

from ..errors import DenavitError
from .text import decode

#: A number as every text reader accepts it: ASCII decimal digits, an optional sign, point and exponent
#: (``12``, ``-0.5``, ``.5``, ``1e-3``, ``2.E+4``). Python's ``float()`` also takes ``1_000``, full-width and
#: Arabic-Indic digits, ``infinity``, ``nan`` and surrounding blanks: none of those is a measurement.
NUMBER = re.compile(r"[-+]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][-+]?[0-9]+)?")
NON_FINITE = re.compile(r"[-+]?(?:inf|infinity|nan)", re.IGNORECASE)  # float() reads these


def number(text: str, where: str, column: str) -> float:
    """The finite number of cell ``text`` (:data:`NUMBER`); anything else is a one-line error naming the place
    (``file:line``) and the column."""
    if NUMBER.fullmatch(text):
        v = float(text)
        if math.isfinite(v):
            return v
        raise DenavitError(f"{where}: column {column!r} must be finite, got {text[:40]!r} (beyond the float range)")
    if NON_FINITE.fullmatch(text.strip()):
        raise DenavitError(f"{where}: column {column!r} must be finite, got {text[:40]!r}")
    raise DenavitError(f"{where}: column {column!r} must be a number, got {text[:40]!r}{_hint(text)}")


#: The farthest a measured point may lie from the origin of its frame, in metres: over a thousand times the
#: Earth's radius (survey coordinates in a national grid are ~1e7 m), far below where squares overflow.
MAX_LENGTH = 1e9


def length(text: str, where: str, column: str, scale: float) -> float:
    """The coordinate of cell ``text`` in metres (``scale`` metres per file unit): :func:`number`, and within
    :data:`MAX_LENGTH` (a 1e308 mm coordinate had overflowed the calibration's residuals to a traceback)."""
    return far(number(text, where, column) * scale, f"{where}: column {column!r}")


def far(value_m: float, where: str) -> float:
    """``value_m`` (metres) if within :data:`MAX_LENGTH`, else a one-line error naming ``where``."""
    if abs(value_m) > MAX_LENGTH:
        raise DenavitError(
            f"{where}: a coordinate of {value_m:.3g} m is beyond {MAX_LENGTH:.0e} m: not a measured point (a wrong unit?)"
        )
    return value_m


def _hint(text: str) -> str:
    if re.fullmatch(r"[-+]?\d+,\d+", text, re.ASCII):
        return " (a decimal comma? write numbers with a decimal point)"
    if "_" in text:
        return " (no digit separators: write 1000, not 1_000)"
    if any(c.isdigit() and not c.isascii() for c in text):
        return " (ASCII digits 0-9 only)"
    if text != text.strip():
        return " (blanks around the number)"
    return ""


def is_number(text: str) -> bool:
    """Whether ``text`` is a number as :func:`number` reads it (finite or not)."""
    return NUMBER.fullmatch(text) is not None


def as_number(value, where: str, *, finite: bool = True) -> float:
    """A number already parsed by a TOML, JSON or YAML reader, as a float: an integer or a float, not a boolean
    nor a string that looks like a number, within the float range; finite unless ``finite`` is False (then
    only NaN is refused). Errors name ``where`` (e.g. ``file: home[2]``)."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        if isinstance(value, str):
            shown = f"{value[:40]!r}{'...' if len(value) > 40 else ''} (a string)"
        else:
            shown = (
                str(value).lower()
                if isinstance(value, bool)
                else {type(None): "nothing (null)", list: "a list", dict: "a table"}.get(
                    type(value), type(value).__name__
                )
            )
        raise DenavitError(f"{where}: expected a number, got {shown}")
    try:
        v = float(value)
    except OverflowError:
        raise DenavitError(
            f"{where}: expected a number in the float range, got an integer of about {int(value.bit_length() * math.log10(2)) + 1} digits"
        ) from None
    if math.isnan(v) or (finite and math.isinf(v)):
        raise DenavitError(f"{where}: expected a finite number, got {'NaN' if math.isnan(v) else v}")
    return v


#: The bytes a table may hold for :func:`numeric_table` besides its separator: digits, sign, point, exponent,
#: blanks and line ends. No letters (``inf``, ``nan``), underscores, quotes or ``#`` comments.
PLAIN = b"0123456789+-.eE \t\r\n"


def numeric_table(data: bytes, delim: str, ncols: int) -> np.ndarray | None:
    """The (m, ``ncols``) numbers of ``data`` (lines of ``ncols`` cells separated by ``delim``, ``\\n`` or
    ``\\r\\n`` line ends), parsed at C speed: beyond :data:`ARROW_BYTES` by :func:`pyarrow.csv.read_csv` (a
    quarter of numpy's reader's CPU on a 184 MB sweep file, benchmarks/bench_io.py), else or where Arrow declines
    (blanks around a cell) by :func:`numpy.loadtxt`; None when it is not such a table of finite plain decimals, for the caller to
    read row by row with :func:`number` (whose errors name the line and the column).

    It takes only cells ``[+-]digits[.digits][e[+-]digits]`` with blanks around them (:data:`PLAIN`: the
    grammar left to the parsers once letters are excluded), every one of which :func:`number` takes with the
    same value (all round correctly: Arrow's fast_float, numpy's ``PyOS_string_to_double``, Python's ``float``);
    and only when every line is a row (no blank lines before the last row, no comments), so that row ``k`` is
    line ``k + 1`` of ``data``. Anything else
    (a word, ``nan``, a number beyond float range, a missing or extra cell, a trailing separator, a quoted cell,
    a lone ``\\r``) gives None.
    """
    sep = delim.encode()
    if len(sep) != 1 or sep in PLAIN or data.translate(None, PLAIN + sep):
        return None
    end = len(data)
    while end and data[end - 1] in b" \t\r\n":  # trailing blank lines end the file; they are not rows
        end -= 1
    if (
        not end
        or data.find(b"\n\n", 0, end) >= 0
        or (b"\r" in data and (data.count(b"\r") != data.count(b"\r\n") or data.find(b"\n\r\n", 0, end) >= 0))
    ):
        return None  # a blank line (not a row: the line numbers would slip) or a lone carriage return
    table = _arrow_table(data[:end], delim, ncols) if end > ARROW_BYTES else None
    if table is None:
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("error")
                table = np.loadtxt(
                    io.BytesIO(data), delimiter=delim, dtype=float, comments=None, ndmin=2, encoding="latin1"
                )
        except (ValueError, UserWarning):
            return None
    if table.shape[1] != ncols or not np.isfinite(table).all():
        return None
    return table


#: Tables of more bytes than this go to Arrow's reader, smaller ones to numpy's. Arrow reads serially
#: (``use_threads=False``): a command that exited right after reading with Arrow's thread pool running had once
#: been aborted at exit ("terminate called without an active exception"); serially it costs the same CPU.
ARROW_BYTES = 8_000_000


def _arrow_table(data: bytes, delim: str, ncols: int) -> np.ndarray | None:
    """``data`` (no blank lines, no comments, cells of :data:`PLAIN`) as an (m, ``ncols``) float table by Arrow's
    CSV reader, every column typed float64 (no inference: ``-0`` stays -0.0), no quoting, no null or boolean
    spellings; None when Arrow declines (a row of another length, a cell with blanks around it)."""
    import pyarrow as pa  # noqa: PLC0415 (loaded with the first big table)
    from pyarrow import csv as pacsv  # noqa: PLC0415

    names = [f"c{i}" for i in range(ncols)]
    try:
        t = pacsv.read_csv(
            io.BytesIO(data),
            read_options=pacsv.ReadOptions(column_names=names, use_threads=False),
            parse_options=pacsv.ParseOptions(
                delimiter=delim, quote_char=False, double_quote=False, escape_char=False, ignore_empty_lines=False
            ),
            convert_options=pacsv.ConvertOptions(
                column_types=dict.fromkeys(names, pa.float64()),
                null_values=[],
                true_values=[],
                false_values=[],
                strings_can_be_null=False,
                quoted_strings_can_be_null=False,
            ),
        )
    except (pa.ArrowInvalid, pa.ArrowNotImplementedError):
        return None
    out = np.empty((t.num_rows, ncols))
    for i in range(ncols):
        out[:, i] = t.column(i).to_numpy()
    return out


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
    from ..limits import check_size  # noqa: PLC0415

    try:
        cells = [c.strip() for c in next(csv.reader([line], delimiter=delim))]
    except csv.Error as e:
        raise DenavitError(
            f"{where}: cannot split the line into cells ({e}; the line has {len(line)} characters)"
        ) from None
    if len(cells) > 64:
        check_size(len(cells) - (cells[-1] == ""), "columns", where, "columns")
    return cells


def header(cells: list[str], where: str) -> list[str]:
    """Lower-cased column names; a name given twice is an error."""
    cols = [c.lower() for c in cells]
    dup = sorted({c for c in cols if cols.count(c) > 1})
    if dup:
        raise DenavitError(f"{where}: column(s) {', '.join(dup)} named twice in the header {','.join(cells)!r}")
    return cols


def fast_table(data: bytes, where: str):
    """A delimited file's bytes read by :func:`numeric_table`, without splitting its rows in Python: (the
    lines up to the header, decoded, the table (m, columns of the header), the line number of its first row), or
    None when the data rows are not a plain numeric table (then the caller's row-by-row reader reads it, and
    names the line and column of what is wrong). The sweep and measurement CSV readers' fast path."""
    pos = 0
    while True:  # the comment lines and the header: up to the first line that is neither blank nor a comment
        nl = data.find(b"\n", pos)
        if nl < 0:
            return None
        try:
            line = decode(data[pos : nl + 1], where) if pos else decode(data[: nl + 1], where)
        except DenavitError:
            return None
        pos = nl + 1
        parts = line.splitlines()
        if any(x.strip() and not x.lstrip().startswith("#") for x in parts):
            if len(parts) != 1:
                return None
            break
    head = decode(data[:pos], where).splitlines()
    found, delim = rows(head, where)
    table = numeric_table(data[pos:], delim, len(found[0][1]))
    return None if table is None else (head, table, len(head) + 1)
