"""The report of a compensated program (:func:`write_compensation_report`)."""

from __future__ import annotations

import html
import os
from pathlib import Path

import numpy as np

from ..io.output import write_text
from ..io.units import length_scale
from ..robot import Robot
from .html import (
    SceneRobot,
    _figure_html,
    _line3d,
    _marker_groups,
    _page,
    _plotly,
    _robot_scene,
    _summary,
    _table,
    _td,
    _view_section,
)

#: Rows of the compensation report's position table (all of them are in the program written by ``compensate``).
POSITION_ROWS = 500


def _compensation_view(go, comp, nominal: Robot, identified: Robot, where, ls: float, length: str) -> str:
    """The 3-D view: the program's positions (flagged ones red), the shift from each position to the command sent,
    the nominal robot at the first position; the identified robot (when it reaches the first position) in the legend."""
    ok = np.asarray(comp.ok, dtype=bool)
    tgt = np.asarray(comp.positions)[:, :3, 3]
    cmd = np.asarray(comp.commands)[:, :3, 3]
    groups = ((ok, "positions", "#1f77b4"), (~ok, "flagged positions", "#d62728"))

    def hover(i: int) -> str:
        return f"{where[i]}: error without compensation {comp.before[i] / ls:.4f} {length}"

    traces = _marker_groups(go, tgt, groups, ls, size=3.5, hover=hover)
    if ok.any():
        traces.append(
            _line3d(
                go,
                [np.array([a, b]) for a, b in zip(tgt[ok], cmd[ok], strict=True)],
                ls,
                line={"color": "#ff7f0e", "width": 3},
                name="position -> command sent",
                legendgroup="commands",
            )
        )
    q0 = np.asarray(comp.q_nominal[0], dtype=float)
    q1 = np.asarray(comp.q[0], dtype=float)
    shown = SceneRobot(f"nominal {nominal.name} at position 1", "frames-nominal", nominal.table, q0, nominal.names)
    other = (
        SceneRobot(
            f"identified {identified.name} at position 1", "frames-identified", identified.table, q1, identified.names
        )
        if np.all(np.isfinite(q1))
        else None
    )
    return _robot_scene(go, traces, tgt, ls, length, shown, other, also=[cmd])


def _error_chart(go, comp, ls: float, length: str):
    """The error at every position the robot can be sent, without compensation and predicted with it."""
    ok = np.asarray(comp.ok, dtype=bool)
    n = len(comp)
    idx = np.arange(n)
    fig = go.Figure(
        [
            go.Scatter(
                x=idx[ok] + 1,
                y=np.asarray(comp.before)[ok] / ls,
                mode="markers",
                marker={"size": 6, "color": "#c0392b"},
                name="without compensation",
            )
        ]
    )
    if comp.predicted_after is not None:
        fig.add_trace(
            go.Scatter(
                x=idx[ok] + 1,
                y=np.asarray(comp.predicted_after)[ok] / ls,
                mode="markers",
                marker={"size": 6, "color": "#2471a3"},
                name="with compensation (predicted 1σ)",
            )
        )
    fig.update_layout(
        height=320,
        margin={"l": 70, "r": 10, "t": 40, "b": 40},
        # positions are numbered 1, 2, ...: whole-number ticks (a few positions had got ticks at 1, 1.5, 2; issue 40)
        xaxis={"title": {"text": "position"}, "tickformat": "d", **({"dtick": 1} if n <= 20 else {})},
        yaxis={"title": {"text": f"tool position error [{length}]"}, "exponentformat": "power", "rangemode": "tozero"},
        title={"text": "Tool position error at every position the robot can be sent", "font": {"size": 14}},
    )
    return fig


def _positions_table(comp, where, ls: float, length: str) -> str:
    """The first :data:`POSITION_ROWS` positions: error without compensation, command shift, solve residual, flags.
    The folder every position's place shares ("/a/b/prog.dat:13") is said once in the caption, not on every row."""
    n = len(comp)
    common = os.path.commonprefix([str(w) for w in where])
    folder = common[: max(common.rfind("/"), common.rfind(os.sep)) + 1]
    where = [str(w)[len(folder) :] for w in where]
    tgt = np.asarray(comp.positions)[:, :3, 3]
    cmd = np.asarray(comp.commands)[:, :3, 3]
    rows = []
    for i in range(min(n, POSITION_ROWS)):
        flags = ", ".join(
            x
            for x, f in (
                ("unreachable", not comp.reached[i]),
                ("branch changed", comp.branch_changed[i]),
                ("path jump", comp.path_jump[i]),
            )
            if f
        )
        shift = float(np.linalg.norm(cmd[i] - tgt[i])) / ls
        rows.append(
            f'<tr data-position="{i + 1}">{_td("position", where[i])}{_td("before", float(comp.before[i]) / ls)}'
            f"{_td('shift', shift)}{_td('residual', float(comp.residual[i]) / ls)}{_td('flags', flags or 'ok')}</tr>"
        )
    return _table(
        "positions",
        [
            "position",
            f"error without compensation [{length}]",
            f"command shift [{length}]",
            f"solve residual [{length}]",
            "flags",
        ],
        rows,
        (f"Per position (first {POSITION_ROWS} of {n})" if n > POSITION_ROWS else "Per position")
        + (f"; files in {folder}." if folder else "."),
        "positions",
    )


def _compensation_summary(comp, nominal: Robot, identified: Robot, source: str, ls: float, length: str) -> str:
    """The program, the models, the error without compensation and what is left with it."""
    n = len(comp)
    ok = np.asarray(comp.ok, dtype=bool)
    before = np.asarray(comp.before)[ok] / ls
    if ok.any():
        predicted = (
            f", predicted rms {np.sqrt(np.mean((np.asarray(comp.predicted_after)[ok] / ls) ** 2)):.3g} {length} (1σ)"
            if comp.predicted_after is not None
            else ""
        )
        accuracy = (
            f"tool position error without compensation rms {np.sqrt(np.mean(before**2)):.4g} {length}, max "
            f"{before.max():.4g} {length}; with it: solve residual max "
            f"{np.asarray(comp.residual)[ok].max() / ls:.3g} {length}" + predicted
        )
    else:
        accuracy = "no position can be sent"
    return _summary(
        [
            (
                "program",
                f"{n} positions"
                + (f" from {source}" if source else "")
                + f"; {int((~ok).sum())} flagged (unreachable, branch changed or path jump)",
            ),
            ("models", f"controller's nominal {nominal.name} -> identified {identified.name}"),
            ("accuracy", accuracy),
        ]
    )


def compensation_report_html(
    comp,
    nominal: Robot,
    identified: Robot,
    *,
    source: str = "",
    where=None,
    length: str = "mm",
    angle: str = "deg",
    title: str | None = None,
) -> str:
    """The HTML text of :func:`write_compensation_report`."""
    go, _ = _plotly()
    ls = length_scale(length)
    n = len(comp)
    where = list(where) if where is not None else [f"position {i + 1}" for i in range(n)]
    view = _compensation_view(go, comp, nominal, identified, where, ls, length)
    errors = _figure_html(_error_chart(go, comp, ls, length), "errors-chart")
    positions_t = _positions_table(comp, where, ls, length)
    summary = _compensation_summary(comp, nominal, identified, source, ls, length)
    title = title or "denavit compensation" + (f": {source}" if source else "")
    meta = html.escape(f"{n} positions; lengths in {length}, angles in {angle}, robot base frame.")
    body = "\n".join(
        [
            _view_section(
                view,
                "The program's positions (flagged ones red), the shift from each position to the command sent "
                "(orange), the nominal robot at the first position; the identified robot is in the legend.",
            ),
            f'<section id="errors"><h2>Errors</h2>{errors}</section>',
            f'<section id="positions-section"><h2>Positions</h2><div class="scroll">{positions_t}</div></section>',
        ]
    )
    return _page(title, meta, summary, body)


def write_compensation_report(
    comp,
    nominal: Robot,
    identified: Robot,
    path,
    *,
    source: str = "",
    where=None,
    length: str = "mm",
    angle: str = "deg",
    title: str | None = None,
    force: bool = False,
) -> Path:
    """Write the self-contained HTML report of a :class:`denavit.compensation.Compensation` (of ``nominal`` ->
    ``identified`` robots) to ``path``: a summary (positions, flagged ones, the error without compensation and
    after it), the positions and the commands in 3-D with the robot, the error at every position, the table of
    positions (``where``: a label per position, e.g. "file:line"). Returns the path."""
    write_text(
        path,
        compensation_report_html(
            comp, nominal, identified, source=source, where=where, length=length, angle=angle, title=title
        ),
        force=force,
    )
    return Path(path)
