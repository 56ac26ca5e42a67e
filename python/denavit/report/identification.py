"""The report and figures of an identification (:func:`write_report`, :func:`write_figures`)."""

from __future__ import annotations

import html
import math
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from .. import _core
from ..io.output import write_text
from ..io.units import angle_scale, cell_scale, joint_scale, length_scale
from ..plotting import (
    UNDETERMINED_ANGLE,
    UNDETERMINED_LENGTH,
    UNDETERMINED_RATIO,
    box_edges,
    circle_points,
    clean_ticks,
    joint_colour,
    joint_names,
    line_span,
    other_convention,
    parameter_errors,
    scene_size,
    sweep_range,
    symmetric_limit,
)

if TYPE_CHECKING:  # pragma: no cover
    from ..identification import Identification
from .html import (
    FIGURE_FORMATS,
    VIEW_ID,
    _figure_html,
    _frame_points,
    _frame_traces,
    _line3d,
    _notes_html,
    _page,
    _pairs_table,
    _path_traces,
    _plotly,
    _scene_layout,
    _summary,
    _table,
    _td,
    _view_section,
    _write_all,
)


def write_figures(
    result: Identification,
    folder,
    *,
    formats: Sequence[str] = FIGURE_FORMATS,
    length: str = "mm",
    dpi: int = 110,
    force: bool = False,
) -> list[Path]:
    """Write the static figures of an identification into ``folder`` (created if needed).

    Files ``circles``, ``residuals``, ``bounding_box``, ``parameters``, ``frames`` (identified convention beside
    ED-H, or modified DH for an ED-H result) and ``origin_paths`` (joint 2 over its swept range), each in every
    one of ``formats`` ("png", "svg", "pdf"). Returns the paths written. ``force``: replace read-only files,
    write through ones with several hard links (:mod:`denavit.io.output`).
    """
    from ..plotting import figures_for  # noqa: PLC0415

    return _write_all(figures_for(result, length=length), folder, formats, dpi, force)


# ------------------------------------------------------------------------------------------------ identification


def _sweep_traces(go, s, f, name: str, colour: str, ls: float, length: str, arrow: float, kind: str):
    """One joint's sweep in the 3-D view (one legend group): its measured points and outliers, the fitted full
    circle and its centre (a revolute joint) or line (a prismatic one), and the axis arrow. Returns the traces
    and the points drawn (metres) beyond the measured ones."""
    grp = f"joint-{s.joint}"
    p = s.points / ls
    hover = [f"{name} point {k}<br>residual {r / ls:.4f} {length}" for k, r in enumerate(f.residuals)]
    traces = [
        go.Scatter3d(
            x=p[:, 0],
            y=p[:, 1],
            z=p[:, 2],
            mode="markers",
            marker={"size": 3.5, "color": colour},
            name=f"{name} (points, circle, axis)",
            legendgroup=grp,
            showlegend=True,
            hovertext=hover,
            hoverinfo="text",
        )
    ]
    drawn = []
    if np.any(f.outliers):
        o = p[f.outliers]
        traces.append(
            go.Scatter3d(
                x=o[:, 0],
                y=o[:, 1],
                z=o[:, 2],
                mode="markers",
                marker={"size": 6, "color": "black", "symbol": "x"},
                name=f"{name} outliers",
                legendgroup=grp,
                showlegend=False,
            )
        )
    if kind == "revolute" and np.isfinite(f.radius):
        circle = circle_points(f.point, f.direction, f.radius)
        drawn.append(circle)
        line = {"color": colour, "width": 3}
        traces.append(
            _line3d(
                go, [circle], ls, line=line, name=f"{name} circle", legendgroup=grp, showlegend=False, hoverinfo="name"
            )
        )
        c = f.point / ls
        traces.append(
            go.Scatter3d(
                x=[c[0]],
                y=[c[1]],
                z=[c[2]],
                mode="markers",
                marker={"size": 5, "color": colour, "symbol": "circle-open", "line": {"width": 2}},
                name=f"{name} centre",
                legendgroup=grp,
                showlegend=False,
                hovertext=f"{name} centre {c[0]:.3f}, {c[1]:.3f}, {c[2]:.3f}<br>r = {f.radius / ls:.3f} {length}",
                hoverinfo="text",
            )
        )
    else:
        span = line_span(f.point, f.direction, s.points)
        line = {"color": colour, "width": 3}
        traces.append(_line3d(go, [span], ls, line=line, name=f"{name} line", legendgroup=grp, showlegend=False))
    tip = f.point + arrow * f.direction
    shaft = np.array([f.point - 0.3 * arrow * f.direction, tip])
    drawn.append(shaft)
    line = {"color": colour, "width": 6}
    traces.append(
        _line3d(go, [shaft], ls, line=line, name=f"{name} axis", legendgroup=grp, showlegend=False, hoverinfo="name")
    )
    t, d = tip / ls, f.direction
    traces.append(
        go.Cone(
            x=[t[0]],
            y=[t[1]],
            z=[t[2]],
            u=[d[0]],
            v=[d[1]],
            w=[d[2]],
            anchor="tip",
            sizemode="absolute",
            sizeref=0.12 * arrow / ls,
            colorscale=[[0, colour], [1, colour]],
            showscale=False,
            name=f"{name} axis",
            legendgroup=grp,
            showlegend=False,
            hoverinfo="name",
        )
    )
    return traces, drawn


def _convention_traces(go, result: Identification, names: list[str], ls: float):
    """The frames at home of the identified convention (shown), of the other one and of the nominal model (in the
    legend), and the frame-origin paths while joint 2 (1 of a one-joint arm) moves over its swept range (in the
    legend). Returns the traces and the points drawn (metres)."""
    conv = result.table.convention
    other = other_convention(conv)
    model = result.model()
    other_table = _core.extract(_core.axes(model, np.zeros(model.nq)), other).table
    home = result.sweeps.home
    tables = [
        ("identified " + conv, result.table, True, "solid"),
        ("identified " + other, other_table, "legendonly", "dash"),
    ]
    if result.nominal is not None:
        nominal = result.nominal
        tables.append((f"nominal {nominal.name} ({nominal.convention})", nominal.table, "legendonly", "dot"))
    Fs = [
        (label, t, t.frames(home), vis, dash, where)
        for (label, t, vis, dash), where in zip(tables, ("top right", "bottom left", "top left"), strict=False)
    ]
    pts = result.sweeps.all_points
    tri = 0.06 * scene_size(np.vstack([F[:, :3, 3] for _, _, F, _, _, _ in Fs] + [pts]))
    traces, drawn = [], []
    for label, t, F, vis, dash, where in Fs:
        traces += _frame_traces(
            go,
            label,
            F,
            ls,
            tri,
            group=f"frames-{label}",
            visible=vis,
            dash=dash,
            names=names,
            table=t,
            q=home,
            textposition=where,
        )
        drawn.append(_frame_points(F, tri))
    jp = 2 if result.axes.nq >= 2 else 1
    lim = sweep_range(result, jp)
    for (label, table), colour, dash in (
        ((f"identified {conv}", result.table), "#6a3d9a", "solid"),
        ((f"identified {other}", other_table), "#b15928", "dash"),
    ):
        traces += _path_traces(
            go,
            label,
            table,
            home,
            jp,
            lim,
            ls,
            group=f"paths-{label}",
            visible="legendonly",
            colour=colour,
            dash=dash,
            name=f"{label}: frame-origin paths, {names[jp - 1]} swept",
        )
    return traces, drawn


def _identification_view(go, result: Identification, ls: float, length: str):
    """The 3-D view: every joint's sweep (:func:`_sweep_traces`), the tool point at home, the bounding box (in the
    legend) and the frames of the conventions (:func:`_convention_traces`); camera and ranges from what is drawn."""
    names = joint_names(result)
    pts = result.sweeps.all_points
    arrow = 0.25 * scene_size(pts)
    traces, drawn = [], [pts, result.tool_point[None]]
    for s, f in zip(result.sweeps.sweeps, result.fits, strict=True):
        j = s.joint
        kind = result.sweeps.kinds[j - 1]
        tr, d = _sweep_traces(go, s, f, names[j - 1], joint_colour(j - 1), ls, length, arrow, kind)
        traces += tr
        drawn += d
    tp = result.tool_point / ls
    traces.append(
        go.Scatter3d(
            x=[tp[0]],
            y=[tp[1]],
            z=[tp[2]],
            mode="markers",
            marker={"size": 6, "color": "black", "symbol": "diamond"},
            name="tool point at home",
            legendgroup="tool",
            showlegend=True,
        )
    )
    b = result.box
    edges = box_edges(b.center, b.axes, b.lengths)
    drawn += edges
    traces.append(
        _line3d(
            go,
            edges,
            ls,
            line={"color": "#444444", "width": 2},
            name="bounding box (Hayat Table IV)",
            legendgroup="box",
            showlegend=True,
            visible="legendonly",
        )
    )
    tr, d = _convention_traces(go, result, names, ls)
    traces += tr
    drawn += d
    fig = go.Figure(traces)
    fig.update_layout(**_scene_layout(length, np.vstack(drawn) / ls))
    return fig


def _residual_chart(go, result: Identification, ls: float, length: str):
    """Every point's residual as a marker (each is the distance of one measurement, not a curve), one colour
    per joint, each joint's points side by side in sweep order; outliers as black crosses. The x axis is labelled
    per joint, under the middle of its points: its name and how many points it has (it had no tick labels)."""
    names = joint_names(result)
    fig = go.Figure()
    start = 0
    ticks, labels = [], []
    for s, f in zip(result.sweeps.sweeps, result.fits, strict=True):
        r = np.asarray(f.residuals) / ls
        x = start + np.arange(len(r))
        fig.add_trace(
            go.Scatter(
                x=x,
                y=r,
                mode="markers",
                name=f"{names[s.joint - 1]} (rms {f.rms / ls:.3g} {length})",
                marker={"color": joint_colour(s.joint - 1), "size": 6},
                hovertemplate=f"{names[s.joint - 1]} point %{{customdata}}: %{{y:.4f}} {length}<extra></extra>",
                customdata=np.arange(len(r)),
            )
        )
        if np.any(f.outliers):
            fig.add_trace(
                go.Scatter(
                    x=x[f.outliers],
                    y=r[f.outliers],
                    mode="markers",
                    marker={"color": "black", "symbol": "x", "size": 9},
                    showlegend=False,
                    name=f"{names[s.joint - 1]} outliers",
                )
            )
        ticks.append(start + (len(r) - 1) / 2)
        labels.append(f"{names[s.joint - 1]}: {len(r)} points")
        start += len(r) + 3
    fig.update_layout(
        height=340,
        margin={"l": 70, "r": 10, "t": 40, "b": 50},
        xaxis={
            "title": {"text": "measured point, joint by joint in sweep order"},
            "tickmode": "array",
            "tickvals": ticks,
            "ticktext": labels,
            "showgrid": False,
            "zeroline": False,  # x = 0 is the first point, not a zero: the line hid it
        },
        yaxis={"title": {"text": f"residual [{length}]"}, "exponentformat": "power", "zeroline": True},
        title={"text": "Residual of every measured point", "font": {"size": 14}},
    )
    return fig


def _parameter_chart(go, make_subplots, result: Identification, length: str, angle: str) -> tuple:
    """Identified - nominal (or identified) per column, only the parameters the data determine (the others
    named in the returned caption), with one-sigma bars; powers of ten written as such, never SI prefixes."""
    rows = parameter_errors(result, length, angle)
    names = joint_names(result)
    nominal = any(r.nominal is not None for r in rows)
    fig = make_subplots(
        rows=1, cols=len(rows), subplot_titles=[f"{r.column} [{r.unit}]" for r in rows], horizontal_spacing=0.06
    )
    left = []
    for k, r in enumerate(rows):
        y = clean_ticks(r.identified - r.nominal if r.nominal is not None else r.identified)
        m = r.shown
        fig.add_trace(
            go.Scatter(
                x=[names[i] for i in np.flatnonzero(m)],
                y=y[m],
                error_y={"type": "data", "array": r.sigma[m], "visible": True},
                mode="markers",
                marker={"color": "#1f77b4", "size": 7},
                name=r.column,
                showlegend=False,
                hovertemplate="%{x}: %{y:.4g} ± %{error_y.array:.2g} " + r.unit + "<extra></extra>",
            ),
            row=1,
            col=k + 1,
        )
        yax = {"exponentformat": "power", "zeroline": True, "zerolinecolor": "#999"}
        if r.nominal is not None:
            lim = symmetric_limit(y[m], r.sigma[m], 1e-6)
            yax["range"] = [-lim, lim]
        fig.update_yaxes(**yax, row=1, col=k + 1)
        fig.update_xaxes(
            categoryorder="array",
            categoryarray=names,
            range=[-0.5, len(names) - 0.5],
            tickangle=-30 if max(map(len, names)) > 3 else 0,
            row=1,
            col=k + 1,
        )
        left += [f"{names[i]} {r.column} ({w})" for i, w in enumerate(r.why) if w]
    fig.update_layout(
        height=360,
        margin={"l": 50, "r": 10, "t": 70, "b": 60},
        title={
            "text": ("Identified − nominal" if nominal else "Identified values") + ", error bars one sigma",
            "font": {"size": 14},
        },
    )
    caption = (
        (
            "Not drawn (in the table above): "
            + ", ".join(left)
            + ". Held: fixed by the convention or the fit (sigma 0); undetermined: one sigma beyond "
            f"{UNDETERMINED_LENGTH:.0%} of the measured extent for lengths, {UNDETERMINED_ANGLE} rad for angles, "
            f"{UNDETERMINED_RATIO} for unitless screw components "
            "(the data fix a combination of such parameters, not each)."
        )
        if left
        else ""
    )
    return fig, caption


def _step_histogram(go, values, bins, name: str, colour: str):
    """A histogram drawn as a filled step line (the reports' partial plotly.js has no histogram trace)."""
    h, e = np.histogram(values, bins=bins)
    x = np.repeat(e, 2)[1:-1]
    y = np.repeat(h, 2)
    return go.Scatter(
        x=np.r_[e[0], x, e[-1]],
        y=np.r_[0, y, 0],
        mode="lines",
        line={"color": colour, "width": 1.5},
        fill="tozeroy",
        opacity=0.6,
        name=name,
    )


def _accuracy_section(go, result: Identification, length: str) -> tuple[str, dict | None]:
    """Accuracy before and after: the nominal model's error and the identified model's predicted error over the
    workspace (denavit.accuracy.identification_accuracy), a table and a histogram. Also returns the
    summary numbers (display units) or None."""
    from ..accuracy import identification_accuracy  # noqa: PLC0415

    acc = identification_accuracy(result)
    if acc is None:
        return "", None
    ls = length_scale(length)
    s = acc.summary()
    rows = [
        f"<tr>{_td('model', label)}"
        + "".join(_td(k, s[key][k] / ls) for k in ("rms", "median", "p95", "max"))
        + "</tr>"
        for label, key in (("nominal (what the robot misses)", "nominal"), ("identified (predicted 1σ)", "identified"))
    ]
    table = _table(
        "accuracy",
        ["model", f"rms [{length}]", f"median [{length}]", f"95 % [{length}]", f"max [{length}]"],
        rows,
        f"Tool position error over {s['configurations']} quasi-random configurations within the joint limits: "
        "the nominal model against the "
        "identified one, and the identified model's error predicted from the axes' covariance (denavit.compensation).",
        "accuracy",
    )
    nom, ide = np.asarray(acc.nominal) / ls, np.asarray(acc.identified) / ls
    both = np.concatenate([nom, ide])
    pos = both[both > 0]
    lo, hi = (float(pos.min()), float(pos.max())) if pos.size else (1e-6, 1.0)
    bins = np.geomspace(lo * 0.9, hi * 1.1, 41)
    fig = go.Figure(
        [
            _step_histogram(go, np.maximum(v, lo), bins, name, colour)
            for v, name, colour in ((nom, "nominal", "#c0392b"), (ide, "identified (predicted 1σ)", "#2471a3"))
        ]
    )
    fig.update_layout(
        height=320,
        margin={"l": 60, "r": 10, "t": 40, "b": 50},
        xaxis={"type": "log", "title": {"text": f"tool position error [{length}]"}, "exponentformat": "power"},
        yaxis={"title": {"text": "configurations"}},
        title={"text": "Accuracy before and after identification", "font": {"size": 14}},
    )
    return (
        f'<section id="accuracy-section"><h2>Accuracy</h2>{table}{_figure_html(fig, "accuracy-chart")}</section>',
        {"nominal": s["nominal"]["rms"] / ls, "identified": s["identified"]["rms"] / ls},
    )


def _parameters_table(result: Identification, doc: dict, names: list[str], length: str, angle: str) -> str:
    """One row per joint and parameter, as printed by `denavit identify`: nominal, identified, sigma, difference
    (angles wrapped to half a turn), each in its cell's unit."""
    t, nt = result.table, result.nominal_table
    rows = []
    for i, prow in enumerate(doc["parameters"]):
        for k, c in enumerate(t.columns):
            sc, unit = cell_scale(t, i, k, length, angle)
            nom = float(nt.params[i, k] / sc) if nt is not None else None
            value = prow[c] / sc
            diff = None if nom is None else value - nom
            if diff is not None and t.angle_columns[k]:
                half = math.pi / sc
                diff = (diff + half) % (2 * half) - half
            rows.append(
                f'<tr data-joint="{html.escape(names[i])}" data-param="{c}">{_td("joint", names[i])}{_td("param", c)}'
                f"{_td('unit', unit)}{_td('nominal', nom)}{_td('identified', value)}"
                f"{_td('sigma', prow[c + '_sigma'] / sc)}{_td('difference', diff)}</tr>"
            )
    return _table(
        "parameters",
        ["joint", "parameter", "unit", "nominal", "identified", "sigma (1σ)", "identified − nominal"],
        rows,
        f"Identified {t.convention.upper()} parameters (docs/conventions.md); sigma propagated from the fits' "
        "covariance; nominal: " + (f"{result.nominal.name}" if result.nominal else "none given") + ".",
        "parameters",
    )


def _axes_table(doc: dict, ls: float, length: str, angle: str) -> str:
    """The joint axes in the measurement frame: circle centre and unit normal, fit quality, one-sigma uncertainty."""
    as_ = angle_scale(angle)
    rows = []
    for j in doc["joints"]:
        c, a, r = j["circle"], j["axis"], j["residuals"]
        rows.append(
            f'<tr data-joint="{html.escape(j["joint"])}">{_td("joint", j["joint"])}'
            + "".join(_td(f"point-{x}", v / ls) for x, v in zip("xyz", a["point_m"], strict=True))
            + "".join(_td(f"direction-{x}", v, 6) for x, v in zip("xyz", a["direction"], strict=True))
            + _td("radius", None if c["radius_m"] is None else c["radius_m"] / ls)
            + _td("arc", None if j["arc_rad"] is None else j["arc_rad"] / as_, 1)
            + f"{_td('rms', r['rms_m'] / ls)}{_td('max-residual', r['max_m'] / ls)}"
            + _td("sigma-across", a["sigma_point_perp_m"] / ls)
            + f"{_td('sigma-direction', a['sigma_direction_rad'] / as_, 5)}{_td('n-points', r['n_points'], 0)}"
            f"{_td('outliers', len(r['outliers']), 0)}</tr>"
        )
    return _table(
        "axes",
        [
            "joint",
            f"point x [{length}]",
            f"point y [{length}]",
            f"point z [{length}]",
            "dir x [1]",
            "dir y [1]",
            "dir z [1]",
            f"radius [{length}]",
            f"arc [{angle}]",
            f"rms [{length}]",
            f"max |residual| [{length}]",
            f"sigma across [{length}]",
            f"sigma direction [{angle}]",
            "points",
            "outliers",
        ],
        rows,
        f"Joint axes in the measurement frame: circle centre ({length}) and unit normal (Hayat et al. eq. 1-9), "
        "fit quality, one-sigma uncertainty.",
        "axes",
    )


def _box_tables(doc: dict, ls: float, length: str) -> str:
    """The measuring volume: the bounding box's sides, volume and centre, then its orientation."""
    b = doc["bounding_box"]
    side = "".join(_td(f"l{k + 1}", v / ls) for k, v in enumerate(b["lengths_m"]))
    centre = ", ".join(f"{v / ls:.3f}" for v in b["centre_m"])
    box = _table(
        "bounding-box",
        [f"l1 [{length}]", f"l2 [{length}]", f"l3 [{length}]", "volume [m³]", f"centre [{length}]"],
        [f"<tr>{side}{_td('volume', b['volume_m3'])}{_td('center', centre)}</tr>"],
        "Minimum-volume oriented bounding box of all measured points (Hayat et al. Table IV).",
        "bounding-box",
    )
    orows = [f"<tr>{''.join(_td(f'col-{k + 1}', v) for k, v in enumerate(row))}</tr>" for row in b["orientation"]]
    orient = _table(
        "bounding-box-orientation",
        ["l1 axis [1]", "l2 axis [1]", "l3 axis [1]"],
        orows,
        "Orientation of the box: its axes as columns, in the measurement frame.",
        "bounding-box",
    )
    return box + orient


def _identification_summary(
    result: Identification, doc: dict, acc: dict | None, names: list[str], length: str, angle: str
) -> str:
    """What an engineer reads first: what was measured, the model, auto's choices, the fit, the accuracy before
    and after (when a nominal is known), the tool error the table carries, the home configuration."""
    ls = length_scale(length)
    t = result.table
    npts = sum(len(s.points) for s in result.sweeps.sweeps)
    worst = max(j["axis"]["sigma_point_perp_m"] for j in doc["joints"]) / ls
    home = np.asarray(doc["home"]) / joint_scale(result.sweeps.kinds, length, angle)
    # auto's choices, each under its own name (the fit, then the reading scales: "fit chosen" had shown twice)
    auto = [n[len("auto: ") :] for n in doc["notes"] if n.startswith("auto: ")]
    chosen = [
        ("reading scales" if "scale error" in n and k else "fit chosen" if not k else "also chosen", n)
        for k, n in enumerate(auto)
    ]
    accuracy = (
        f"tool position error rms {acc['nominal']:.3g} {length} with the nominal model -> {acc['identified']:.3g} "
        f"{length} predicted with the identified one (1σ)"
        if acc
        else None
    )
    return _summary(
        [
            ("measured", f"{npts} points in {len(result.sweeps.sweeps)} single-joint sweeps from {doc['source']}"),
            (
                "model",
                f"{t.convention.upper()} table of {len(names)} joints, {result.method} fit; nominal: "
                + (result.nominal.name if result.nominal else "none"),
            ),
            *chosen,
            ("fit", f"residual rms {doc['rms_m'] / ls:.4g} {length}; worst axis sigma across {worst:.3g} {length}"),
            *([("accuracy", accuracy)] if accuracy else []),
            ("tool error the table carries", f"{doc['max_tool_position_error_m'] / ls:.3g} {length}"),
            (
                "home",
                ", ".join(f"{v:.4g}" for v in home)
                + f" ({angle} / {length}); tool point at home "
                + ", ".join(f"{v / ls:.3f}" for v in doc["tool_point_home_m"])
                + f" {length}",
            ),
        ]
    )


def report_html(result: Identification, *, length: str = "mm", angle: str = "deg", title: str | None = None) -> str:
    """The HTML text of :func:`write_report`: the summary, the 3-D view, the identified parameters and their chart,
    the joint axes with the residuals and the consecutive-axis relations, the measuring volume, the accuracy
    (with a nominal model) and the notes."""
    from ..io.results import to_json  # noqa: PLC0415

    go, make_subplots = _plotly()
    ls = length_scale(length)
    doc = to_json(result)  # SI: scaled to length / angle below
    names = joint_names(result)
    t = result.table
    view = _figure_html(_identification_view(go, result, ls, length), VIEW_ID, "plot3d")
    resid = _figure_html(_residual_chart(go, result, ls, length), "residuals-chart")
    pfig, pcaption = _parameter_chart(go, make_subplots, result, length, angle)
    pchart = _figure_html(pfig, "parameters-chart") + (
        f'<p class="hint" id="parameters-not-drawn">{html.escape(pcaption)}</p>' if pcaption else ""
    )
    params = _parameters_table(result, doc, names, length, angle)
    axes_t = _axes_table(doc, ls, length, angle)
    pairs = _pairs_table(result.extraction.pairs, ls, length, angle)
    acc_html, acc = _accuracy_section(go, result, length)
    summary = _identification_summary(result, doc, acc, names, length, angle)
    title = title or f"denavit identification: {result.sweeps.source or 'sweeps'}"
    meta = html.escape(
        f"{len(names)} joints, method {result.method}, {t.convention.upper()} parameters; lengths in {length}, "
        f"angles in {angle}, measurement frame."
    )
    body = "\n".join(
        [
            _view_section(
                view,
                "Measured points, fitted full circles, centres and axis arrows per joint (Hayat et al. Fig. 7); frames "
                "of the identified convention along the chain (others, the bounding box and origin paths: switch "
                "them on in the legend).",
            ),
            f'<section id="results"><h2>Identified parameters</h2><div class="scroll">{params}</div>{pchart}</section>',
            (
                f'<section id="fits"><h2>Joint axes and fits</h2><div class="scroll">{axes_t}</div>{resid}{pairs}'
                "</section>"
            ),
            f'<section id="box"><h2>Measuring volume</h2>{_box_tables(doc, ls, length)}</section>',
            acc_html,
            f'<section id="notes-section"><h2>Notes</h2>{_notes_html(doc["notes"])}</section>',
        ]
    )
    return _page(title, meta, summary, body)


def write_report(
    result: Identification,
    path,
    *,
    length: str = "mm",
    angle: str = "deg",
    title: str | None = None,
    force: bool = False,
) -> None:
    """Write the self-contained HTML report of an identification (see the module docs) to ``path``."""
    write_text(path, report_html(result, length=length, angle=angle, title=title), force=force)
