"""The report of a compensated program (:func:`write_compensation_report`)."""

from __future__ import annotations

import html
from pathlib import Path

import numpy as np

from ..io.output import write_text
from ..io.units import length_scale
from ..plotting import (
    scene_size,
)
from ..robot import Robot
from .html import (
    VIEW_ID,
    _figure_html,
    _line3d,
    _page,
    _plotly,
    _robot_traces,
    _scene_layout,
    _summary,
    _table,
    _td,
    _view_section,
)

#: Rows of the compensation report's target table (all of them are in the program written by ``compensate``).
TARGET_ROWS = 500


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
    where = list(where) if where is not None else [f"target {i + 1}" for i in range(n)]
    ok = np.asarray(comp.ok, dtype=bool)
    tgt = np.asarray(comp.targets)[:, :3, 3]
    cmd = np.asarray(comp.commands)[:, :3, 3]
    traces, drawn = [], [tgt, cmd]
    for mask, name, colour in ((ok, "targets", "#1f77b4"), (~ok, "flagged targets", "#d62728")):
        if mask.any():
            p = tgt[mask] / ls
            traces.append(
                go.Scatter3d(
                    x=p[:, 0],
                    y=p[:, 1],
                    z=p[:, 2],
                    mode="markers",
                    marker={"size": 3.5, "color": colour},
                    name=name,
                    legendgroup=name,
                    hovertext=[
                        f"{where[i]}: error without compensation {comp.before[i] / ls:.4f} {length}"
                        for i in np.flatnonzero(mask)
                    ],
                    hoverinfo="text",
                )
            )
    if ok.any():
        traces.append(
            _line3d(
                go,
                [np.array([a, b]) for a, b in zip(tgt[ok], cmd[ok], strict=True)],
                ls,
                line={"color": "#ff7f0e", "width": 3},
                name="target -> command sent",
                legendgroup="commands",
            )
        )
    q0 = np.asarray(comp.q_nominal[0], dtype=float)
    size = scene_size(np.vstack([tgt, nominal.table.frames(q0)[:, :3, 3]]))
    tri = 0.07 * size
    tr, d = _robot_traces(
        go,
        f"nominal {nominal.name} at target 1",
        nominal.table,
        q0,
        ls,
        tri,
        group="frames-nominal",
        names=nominal.names,
    )
    traces += tr
    drawn.append(d)
    q1 = np.asarray(comp.q[0], dtype=float)
    if np.all(np.isfinite(q1)):
        tr, d = _robot_traces(
            go,
            f"identified {identified.name} at target 1",
            identified.table,
            q1,
            ls,
            tri,
            group="frames-identified",
            visible="legendonly",
            dash="dash",
            names=identified.names,
            textposition="bottom left",
        )
        traces += tr
    fig = go.Figure(traces)
    fig.update_layout(**_scene_layout(length, np.vstack(drawn) / ls))
    view = _figure_html(fig, VIEW_ID, "plot3d")

    idx = np.arange(n)
    efig = go.Figure(
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
        efig.add_trace(
            go.Scatter(
                x=idx[ok] + 1,
                y=np.asarray(comp.predicted_after)[ok] / ls,
                mode="markers",
                marker={"size": 6, "color": "#2471a3"},
                name="with compensation (predicted 1σ)",
            )
        )
    efig.update_layout(
        height=320,
        margin={"l": 70, "r": 10, "t": 40, "b": 40},
        # targets are numbered 1, 2, ...: whole-number ticks (a few targets had got ticks at 1, 1.5, 2; issue 40)
        xaxis={"title": {"text": "target"}, "tickformat": "d", **({"dtick": 1} if n <= 20 else {})},
        yaxis={"title": {"text": f"tool position error [{length}]"}, "exponentformat": "power", "rangemode": "tozero"},
        title={"text": "Position error of every target the robot can be sent", "font": {"size": 14}},
    )
    rows = []
    for i in range(min(n, TARGET_ROWS)):
        flags = ", ".join(
            x
            for x, f in (
                ("unreachable", not comp.reached[i]),
                ("branch changed", comp.branch_changed[i]),
                ("path jump", comp.path_jump[i]),
            )
            if f
        )
        rows.append(
            f'<tr data-target="{i + 1}">{_td("target", where[i])}{_td("before", float(comp.before[i]) / ls)}{_td("shift", float(np.linalg.norm(cmd[i] - tgt[i])) / ls)}'
            f"{_td('residual', float(comp.residual[i]) / ls)}{_td('flags', flags or 'ok')}</tr>"
        )
    targets_t = _table(
        "targets",
        [
            "target",
            f"error without compensation [{length}]",
            f"command shift [{length}]",
            f"solve residual [{length}]",
            "flags",
        ],
        rows,
        f"Per target (first {TARGET_ROWS} of {n})" if n > TARGET_ROWS else "Per target.",
        "targets",
    )
    before = np.asarray(comp.before)[ok] / ls
    summary = _summary(
        [
            (
                "program",
                f"{n} targets"
                + (f" from {source}" if source else "")
                + f"; {int((~ok).sum())} flagged (unreachable, branch changed or path jump)",
            ),
            ("models", f"controller's nominal {nominal.name} -> identified {identified.name}"),
            *(
                [
                    (
                        "accuracy",
                        f"tool position error without compensation rms {np.sqrt(np.mean(before**2)):.4g} {length}, max {before.max():.4g} {length}; "
                        f"with it: solve residual max {np.asarray(comp.residual)[ok].max() / ls:.3g} {length}"
                        + (
                            f", predicted rms {np.sqrt(np.mean((np.asarray(comp.predicted_after)[ok] / ls) ** 2)):.3g} {length} (1σ)"
                            if comp.predicted_after is not None
                            else ""
                        ),
                    )
                ]
                if ok.any()
                else [("accuracy", "no target can be sent")]
            ),
        ]
    )
    title = title or "denavit compensation" + (f": {source}" if source else "")
    meta = html.escape(f"{n} targets; lengths in {length}, angles in {angle}, robot base frame.")
    body = "\n".join(
        [
            _view_section(
                view,
                "The program's targets (flagged ones red), the shift from each target to the command sent (orange), the nominal robot at the "
                "first target; the identified robot is in the legend.",
            ),
            f'<section id="errors"><h2>Errors</h2>{_figure_html(efig, "errors-chart")}</section>',
            f'<section id="targets-section"><h2>Targets</h2><div class="scroll">{targets_t}</div></section>',
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
    ``identified`` robots) to ``path``: a summary (targets, flagged ones, the error without compensation and
    after it), the targets and the commands in 3-D with the robot, the error of every target, the table of
    targets (``where``: a label per target, e.g. "file:line"). Returns the path."""
    write_text(
        path,
        compensation_report_html(
            comp, nominal, identified, source=source, where=where, length=length, angle=angle, title=title
        ),
        force=force,
    )
    return Path(path)
