"""Printing: the consoles (standard output, and stderr for notes, warnings and errors), one-line messages
(:func:`say`, :func:`fail`, :func:`wrote`), what a slow step is doing (:func:`status`), and numbers and tables in
the digits of their unit."""

from __future__ import annotations

import math
from contextlib import contextmanager
from typing import TYPE_CHECKING

import typer
from rich.console import Console
from rich.table import Table as RichTable
from rich.text import Text

from ..io.units import ANGLE, LENGTH, angle_scale, cell_scale, column_scale, length_scale

if TYPE_CHECKING:
    from collections.abc import Iterator, Sequence

    from .. import _core


# markup off: units in headers ("a [mm]"), file paths and messages are printed as written; style only through say()
console = Console(markup=False)


err_console = Console(stderr=True, markup=False)


def say(style: str, head: str, rest: str = "", err: bool = False) -> None:
    """Print `head` in a rich `style` followed by plain `rest`."""
    (err_console if err else console).print(
        Text.assemble((head, style), rest), soft_wrap=True
    )  # one line, whatever the width


def fail(msg: str) -> None:
    """A one-line error on stderr and exit code 2."""
    say("bold red", "error:", f" {msg}", err=True)
    raise typer.Exit(2)


def wrote(path, detail: str = "") -> None:
    """Say where an output went (on stderr when it went to standard output, so the output stays clean)."""
    say("", f"wrote {path}{detail}", err=str(path) == "-")


#: A step that lasts longer than this (s) says what it is doing.
PATIENCE = 1.0


@contextmanager
def status(message: str) -> Iterator:
    """Say what a step that takes more than :data:`PATIENCE` is doing, on stderr. Its ``update(text)`` (the
    ``progress`` callback of :func:`denavit.identify` and :func:`denavit.calibrate`) shows the stage and, given
    the fraction of the work done (a :class:`denavit.progress.Stage`'s, or ``fraction``), a bar with the
    percentage and the time left on a terminal (a spinner until then); elsewhere one line, with the percentage, once
    the step has lasted that long (a quick step, or an error found at once, prints nothing but its result)."""
    if err_console.is_terminal:
        from rich.progress import (  # noqa: PLC0415
            BarColumn,
            Progress,
            SpinnerColumn,
            TaskProgressColumn,
            TextColumn,
            TimeRemainingColumn,
        )

        columns = (SpinnerColumn(), TextColumn("{task.description}"), BarColumn(), TaskProgressColumn())
        with Progress(*columns, TimeRemainingColumn(), console=err_console, transient=True) as bar:
            yield _Bar(bar, bar.add_task(message, total=None), message)
        return
    line = _Line(message)
    line.timer.start()
    try:
        yield line
    finally:
        line.timer.cancel()


class _Bar:
    """:func:`status` on a terminal: a rich progress bar, indeterminate until a fraction comes."""

    def __init__(self, bar, task, message: str) -> None:
        self.bar, self.task, self.message = bar, task, message

    def update(self, text: str = "", fraction: float | None = None) -> None:
        fraction = getattr(text, "fraction", fraction)  # a denavit.progress.Stage carries it
        described = f"{self.message} {text}" if text else self.message
        if fraction is None:
            self.bar.update(self.task, description=described)
        else:
            self.bar.update(self.task, description=described, total=1.0, completed=min(max(fraction, 0.0), 1.0))


class _Line:
    """:func:`status` elsewhere: one line once the step has lasted :data:`PATIENCE`."""

    def __init__(self, message: str) -> None:
        import threading  # noqa: PLC0415

        self.message = self.text = message
        self.timer = threading.Timer(PATIENCE, lambda: err_console.print(self.text, soft_wrap=True))
        self.timer.daemon = True

    def update(self, text: str = "", fraction: float | None = None) -> None:
        fraction = getattr(text, "fraction", fraction)  # a denavit.progress.Stage carries it
        done = "" if fraction is None else f" ({100 * min(max(fraction, 0.0), 1.0):.0f} %)"
        self.text = (f"{self.message} {text}" if text else self.message) + done


def fmt(v: float, nd: int = 6) -> str:
    """A table cell: ``nd`` decimals, "nan" for NaN (never 0.000000), -0 shown as 0; from 1e15 on in exponent
    form (beyond a double's 16 digits the decimals are noise, and 1e300 had printed 300 digits)."""
    if v != v:
        return "nan"
    if abs(v) >= 1e15:
        return f"{v:.{max(nd, 6)}e}"
    return f"{v:.{nd}f}" if abs(v) >= 0.5 * 10.0**-nd else f"{0.0:.{nd}f}"


#: The resolution printed: 1 um for lengths, 0.001 deg for angles, 1e-6 for unitless numbers.
RESOLUTION = {"length": 1e-6, "angle": math.radians(1e-3), "1": 1e-6}


def decimals(unit: str) -> int:
    """Decimals that show :data:`RESOLUTION` in ``unit`` (3 in mm, 6 in m, 3 in deg, 5 in rad, 6 unitless)."""
    u = str(unit).strip().lower()
    if u in LENGTH:
        r = RESOLUTION["length"] / length_scale(u)
    elif u in ANGLE:
        r = RESOLUTION["angle"] / angle_scale(u)
    else:
        r = RESOLUTION["1"]
    return max(0, math.ceil(-math.log10(r) - 1e-9))


def num(v: float, unit: str) -> str:
    """A value in ``unit`` with the digits of its resolution (:func:`decimals`)."""
    return fmt(v, decimals(unit))


def spread(v: float) -> str:
    """A sigma, rms or other small positive spread: 3 significant figures (never ``0.000`` in metres); "-"
    where it is not finite (not identifiable)."""
    if not math.isfinite(v):
        return "-"
    return f"{v:.3g}"


def print_rows(
    title: str | None,
    headers: Sequence[str],
    rows: Sequence[Sequence[str]],
    *,
    caption: str | None = None,
    labels: int = 1,
    left: Sequence[int] = (),
    group: bool = False,
    prose: Sequence[int] = (),
) -> None:
    """A table that never cuts a number or a name: a rich table when every column fits the console at its
    widest cell (headers may wrap between words), else a long layout, each row's ``labels`` first cells as a
    heading and one ``header  value`` line per other cell. ``left``: columns justified left (labels are);
    ``group``: a rich table shows the first cell only where it changes, with a line between groups; ``prose``:
    columns of text that may wrap between words (descriptions)."""
    headers = list(headers)
    rows = [list(r) for r in rows]

    def longest_word(text: str) -> int:
        return max((len(w) for w in text.split()), default=0)

    ks = range(len(headers))
    least = [
        max([longest_word(r[k]) if k in prose else len(r[k]) for r in rows] + [longest_word(headers[k]), 1]) for k in ks
    ]
    width = [
        max([len(r[k]) for r in rows] + [len(headers[k]), 1]) for k in ks
    ]  # headers (and prose) on one line if the console allows
    for k in sorted(ks, key=lambda k: least[k] - width[k]):  # else wrap the widest-for-its-content first
        excess = sum(width) + 3 * len(headers) + 1 - console.width
        if excess <= 0:
            break
        width[k] = max(least[k], width[k] - excess)
    if sum(width) + 3 * len(headers) + 1 <= console.width:
        import textwrap  # noqa: PLC0415

        # the widths are decided here (rich would shrink columns by cutting them): headers wrapped between
        # words to their column's width, cells never wrapped but prose
        t = RichTable(title=title)  # the caption printed below it at the console's width, not the table's

        for k, h in enumerate(headers):
            t.add_column(
                textwrap.fill(h, width[k], break_long_words=False),
                justify="left" if k < labels or k in left else "right",
                width=width[k] if k in prose else None,
                no_wrap=k not in prose,
                overflow="fold",
            )
        for i, r in enumerate(rows):
            last = i + 1 == len(rows) or rows[i + 1][0] != r[0]
            first = i == 0 or rows[i - 1][0] != r[0]
            t.add_row(
                *([r[0] if first else "", *r[1:]] if group else r), end_section=group and last and i + 1 < len(rows)
            )
        console.print(t)
        if caption:
            console.print(caption, style="table.caption", soft_wrap=False)
        return
    if title:
        say("bold", title)
    hw = max((len(h) for h in headers[labels:]), default=0)
    for r in rows:
        say("bold", " ".join(c for c in r[:labels] if c))
        for h, c in zip(headers[labels:], r[labels:]):
            console.print(f"  {h:<{hw}}  {c}", soft_wrap=True)
    if caption:
        console.print(caption)


def table_rows(table: _core.Table, length: str, angle: str) -> list[dict]:
    """The table's rows in display units (:func:`denavit.io.units.cell_scale`), keyed by column name."""
    return [
        {c: float(v / cell_scale(table, i, k, length, angle)[0]) for k, (c, v) in enumerate(zip(table.columns, row))}
        for i, row in enumerate(table.params)
    ]


def print_table(table: _core.Table, names: list[str], length: str, angle: str, title: str) -> None:
    """A parameter table with each column's unit in its header and the digits of that unit."""
    prismatic_poe = table.convention == "poe" and "prismatic" in table.kinds
    units = [column_scale(table, k, length, angle)[1] for k in range(len(table.columns))]
    rows = [
        [n, *(num(v, cell_scale(table, i, k, length, angle)[1]) for k, v in enumerate(row.values()))]
        for i, (n, row) in enumerate(zip(names, table_rows(table, length, angle)))
    ]
    print_rows(
        title,
        ["joint", *(f"{c} [{u}]" for c, u in zip(table.columns, units))],
        rows,
        caption="v of a prismatic joint: its unit direction [1]" if prismatic_poe else None,
    )
