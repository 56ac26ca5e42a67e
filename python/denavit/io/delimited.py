"""Delimited text (CSV with ``,`` or ``;``) as every denavit reader splits it, on the standard :mod:`csv` module:
``#`` comment lines and blank lines skipped, one separator per file, numbers strictly finite decimals, header
names unique. Errors name the file, the line and the column.

This module also holds the one number rule of every reader: :func:`number` for a text cell (CSV, URDF
attributes), :func:`as_number` for a value a TOML, JSON or YAML parser has already typed (no booleans, no
strings that look like numbers).

Whole tables of plain numbers (a sweep file's millions of rows) are read at C speed first, column-wise
(:func:`plain_head` and :func:`plain_columns`: Apache Arrow's CSV reader on every core for big ones, numpy's C reader
for the rest); whatever they do not take is read row by row with :func:`number`, whose errors name the line and
column.
"""

from __future__ import annotations

import csv
import io
import math
import os
import re
import stat
import warnings
from typing import NamedTuple

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
            f"{where}: a coordinate of {value_m:.3g} m is beyond {MAX_LENGTH:.0e} m: not a measured point (a wrong"
            " unit?)"
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
            f"{where}: expected a number in the float range, got an integer of about"
            f" {int(value.bit_length() * math.log10(2)) + 1} digits"
        ) from None
    if math.isnan(v) or (finite and math.isinf(v)):
        raise DenavitError(f"{where}: expected a finite number, got {'NaN' if math.isnan(v) else v}")
    return v


#: The bytes a table may hold for :func:`numeric_table` besides its separator: digits, sign, point, exponent,
#: blanks and line ends. No letters (``inf``, ``nan``), underscores, quotes or ``#`` comments.
PLAIN = b"0123456789+-.eE \t\r\n"


def numeric_table(data: bytes, delim: str, ncols: int) -> np.ndarray | None:
    """The (m, ``ncols``) numbers of ``data`` (lines of ``ncols`` cells separated by ``delim``, ``\\n`` or
    ``\\r\\n`` line ends), parsed at C speed by :func:`numpy.loadtxt` (:func:`plain_columns` reads more than
    :data:`ARROW_BYTES` with Arrow's reader by the same rule); None when it is not such a table of finite plain
    decimals, for the caller to read row by row with :func:`number` (whose errors name the line and the column).

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
        or data[:1] in (b"\n", b"\r")  # a blank line before the first row
        or data.find(b"\n\n", 0, end) >= 0
        or (b"\r" in data and (data.count(b"\r") != data.count(b"\r\n") or data.find(b"\n\r\n", 0, end) >= 0))
    ):
        return None  # a blank line (not a row: the line numbers would slip) or a lone carriage return
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


#: Data rows of more bytes than this are read by :func:`plain_columns` from a memory map, in pieces, by Arrow's CSV
#: reader on threads of the call; fewer by numpy's reader whole. Arrow reads each piece serially
#: (``use_threads=False``), never on its own thread pool: a command that exited right after reading with Arrow's
#: thread pool running had once been aborted at exit ("terminate called without an active exception").
ARROW_BYTES = 8_000_000


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


class Head(NamedTuple):
    """The lines of a delimited file up to its header (``#`` comments, blank lines, the header), decoded, and where
    its data rows start: ``offset`` (bytes) and ``line`` (the line number of the first)."""

    lines: list[str]
    offset: int
    line: int


#: The most bytes :func:`plain_head` reads before the header (comment lines); beyond, the whole-file reader reads.
HEAD_BYTES = 1 << 20


def plain_head(path: str | os.PathLike, what: str) -> Head | None:
    """The :class:`Head` of the delimited file ``path``, read without reading the rest: the C-speed readers' first
    step (:func:`plain_columns`). None when the file is not plainly readable so (missing, not a regular file, beyond
    the size limit, a head longer than :data:`HEAD_BYTES`, not UTF-8, no header line): then the caller reads the
    whole file, as text, and says what is wrong."""
    from .. import limits  # noqa: PLC0415

    try:
        with open(path, "rb") as f:
            st = os.fstat(f.fileno())
            if not stat.S_ISREG(st.st_mode) or st.st_size > limits.size("file_bytes"):
                return None
            data = f.read(min(HEAD_BYTES, limits.size("line_bytes")))
    except OSError:
        return None
    pos = 0
    while True:  # the comment lines and the header: up to the first line that is neither blank nor a comment
        nl = data.find(b"\n", pos)
        if nl < 0:
            return None
        try:
            line = decode(data[pos : nl + 1] if pos else data[: nl + 1], str(path))
        except DenavitError:
            return None
        pos = nl + 1
        parts = line.splitlines()
        if any(x.strip() and not x.lstrip().startswith("#") for x in parts):
            if len(parts) != 1:
                return None
            break
    head = decode(data[:pos], str(path)).splitlines()
    return Head(head, pos, len(head) + 1)


def plain_columns(
    path: str | os.PathLike, head: Head, delim: str, ncols: int, groups: list[list[int]]
) -> list[np.ndarray] | None:
    """The data rows of ``path`` after its ``head`` (:func:`plain_head`) when they form a table of ``ncols`` finite
    plain numbers (:func:`numeric_table`'s rule): for each group of column indices of ``groups``, an (m, len(group))
    C-contiguous array of its columns (the other columns are split, not converted), row ``k`` being line
    ``head.line + k``. None when they do not: then the caller reads the file row by row, naming the line and column
    of what is wrong.

    Up to :data:`ARROW_BYTES` of rows are read whole by :func:`numeric_table`; more are read from a memory map in
    pieces, each parsed by Arrow's CSV reader on a thread of this call (one per core) straight into the arrays,
    without holding the file's text (its pages are given back as the pieces are read)."""
    from .. import limits  # noqa: PLC0415

    try:
        size = os.stat(path).st_size - head.offset
        if size <= ARROW_BYTES:
            with open(path, "rb") as f:
                f.seek(head.offset)
                data = f.read()
            ends = np.flatnonzero(np.frombuffer(data, np.uint8) == 10)
            if len(data) and np.diff(ends, prepend=-1, append=len(data)).max() - 1 > limits.size("line_bytes"):
                return None  # a line beyond the limit: the whole-file reader says so
            table = numeric_table(data, delim, ncols)
            return None if table is None else [np.ascontiguousarray(table[:, g]) for g in groups]
        return _mapped_columns(path, head.offset, delim, ncols, groups)
    except OSError:
        return None


#: The bytes of a piece of :func:`plain_columns`' memory-mapped reading (cut at a line end).
PIECE_BYTES = 16 << 20


def _mapped_columns(path, offset: int, delim: str, ncols: int, groups: list[list[int]]) -> list[np.ndarray] | None:
    """:func:`plain_columns` of more than :data:`ARROW_BYTES`: the data cut into pieces at line ends; per piece, on
    a thread pool of this call, its line ends counted (each row's place), then its rows parsed by Arrow into the
    arrays. None at the first piece Arrow declines, a piece of rows other than its lines (a lone ``\\r``) or a
    value that is not finite."""
    import mmap  # noqa: PLC0415
    from concurrent.futures import ThreadPoolExecutor  # noqa: PLC0415

    from .. import limits  # noqa: PLC0415

    longest = limits.size("line_bytes")
    with open(path, "rb") as f:
        mm = mmap.mmap(f.fileno(), 0, access=mmap.ACCESS_READ)
    try:
        end = len(mm)
        while end > offset and mm[end - 1] in b" \t\r\n":  # trailing blank lines end the file; they are not rows
            end -= 1
        cuts = [offset]
        while cuts[-1] < end:
            nl = mm.find(b"\n", min(cuts[-1] + PIECE_BYTES, end), end)
            if nl - cuts[-1] > PIECE_BYTES + longest:
                return None  # a line beyond the line limit: the whole-file reader says so
            cuts.append(end if nl < 0 else nl + 1)
        pieces = list(zip(cuts[:-1], cuts[1:]))
        if not pieces:
            return None
        threads = max(1, min(8, len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()))
        with ThreadPoolExecutor(threads) as pool:
            rows = list(pool.map(lambda ab: _line_ends(mm, *ab), pieces))
            rows[-1] += 1  # the last row has no line end (trailing blanks stripped)
            starts = np.r_[0, np.cumsum(rows)]
            out = [np.empty((int(starts[-1]), len(g))) for g in groups]
            names = [f"c{i}" for i in range(ncols)]
            block = max(4096, min(1 << 20, longest + 2))
            done = pool.map(
                lambda k: _parse_piece(mm, pieces[k], int(starts[k]), rows[k], delim, names, groups, out, block),
                range(len(pieces)),
            )
            if not all(list(done)):
                return None
        return out
    finally:
        try:
            mm.close()
        except BufferError:  # a view still held by Arrow: unmapped when it goes
            pass


def _line_ends(mm, a: int, b: int) -> int:
    """The line ends (``\\n``) in bytes ``a:b`` of the map (numpy: without the GIL); its pages given back after."""
    n = int(np.count_nonzero(np.frombuffer(mm, np.uint8, b - a, a) == 10))
    _give_back(mm, a, b)
    return n


def _give_back(mm, a: int, b: int) -> None:
    """Drop the pages wholly inside bytes ``a:b`` of the map from this process's memory (they stay in the page
    cache): a mapped file read once would otherwise count in full in the process's resident memory."""
    import mmap  # noqa: PLC0415

    page = mmap.PAGESIZE
    lo, hi = -(-a // page) * page, b // page * page
    if hi > lo and hasattr(mm, "madvise"):
        mm.madvise(mmap.MADV_DONTNEED, lo, hi - lo)


def _parse_piece(mm, piece, row: int, rows: int, delim, names, groups, out, block: int) -> bool:
    """Rows ``row:row + rows`` of ``out`` (one array per group of columns) from bytes ``piece`` of the map, by
    Arrow's CSV reader on this thread; False when Arrow declines, the rows are not the piece's lines or a value is
    not finite."""
    import pyarrow as pa  # noqa: PLC0415 (loaded with the first big table)

    a, b = piece
    view = memoryview(mm)[a:b]
    buf = pa.py_buffer(view)
    t = _arrow_read(buf, delim, names, sorted({i for g in groups for i in g}), block)
    del buf
    view.release()
    if t is None or t.num_rows != rows:
        return False
    ok = True
    for arr, g in zip(out, groups):
        for j, i in enumerate(g):
            at = row
            for chunk in t.column(names[i]).chunks:
                v = chunk.to_numpy(zero_copy_only=False)
                arr[at : at + len(v), j] = v
                at += len(v)
        ok = ok and bool(np.isfinite(arr[row : row + rows]).all())
    del t
    _give_back(mm, a, b)
    return ok


def _arrow_read(source, delim: str, names: list[str], include: list[int], block: int):
    """The Arrow table of CSV ``source`` (no header, columns ``names``), the columns ``include`` typed float64 (no
    inference: ``-0`` stays -0.0), no quoting, no null or boolean spellings, serially on the calling thread; None
    when Arrow declines (a row of another length, a cell that is not a number)."""
    import pyarrow as pa  # noqa: PLC0415 (loaded with the first big table)
    from pyarrow import csv as pacsv  # noqa: PLC0415

    keep = [names[i] for i in include]
    try:
        return pacsv.read_csv(
            source,
            read_options=pacsv.ReadOptions(column_names=names, use_threads=False, block_size=block),
            parse_options=pacsv.ParseOptions(
                delimiter=delim, quote_char=False, double_quote=False, escape_char=False, ignore_empty_lines=False
            ),
            convert_options=pacsv.ConvertOptions(
                column_types=dict.fromkeys(keep, pa.float64()),
                include_columns=keep,
                null_values=[],
                true_values=[],
                false_values=[],
                strings_can_be_null=False,
                quoted_strings_can_be_null=False,
            ),
        )
    except (pa.ArrowInvalid, pa.ArrowNotImplementedError):
        return None
