"""Reports: the static figures of an identification or a model, and one self-contained HTML file.

* :func:`write_figures` / :func:`write_model_figures` -- PNG (and/or SVG) files of :mod:`denavit.plotting`
  (matplotlib).
* :func:`write_report` -- an identification: an interactive 3-D view (measured points, fitted circles, centres,
  axes, the bounding box, the frames of the identified convention, of ED-H (or modified DH) and of the nominal
  model, origin paths), residual and parameter-error charts, and the tables (identified values, one-sigma,
  nominal, differences; axes; consecutive-axis relations; bounding box; notes).
* :func:`write_model_report` -- a robot: its frames beside those of another convention or another robot file
  (Guo et al. Figs. 6-7), the path of every frame origin while each joint moves (Guo et al. Fig. 3), and the tables.

The HTML file works offline: the plotly.js bundle is inlined (``include_plotlyjs=True``, no CDN, no MathJax),
there is no other script, style sheet, font or image to fetch. Legend entries are grouped: a click on a joint
or a convention shows or hides all of its traces (double-click isolates it). Every number in a table is a
``<td>`` with a class naming its column and a ``data-value`` attribute holding the full-precision value in the
table's display unit, so that the report can be read by programs as well as people.

Files are written whole or not at all (:func:`denavit.io.output.write_text`). plotly and matplotlib are the
optional ``plot`` extra; a missing one raises :class:`~denavit.errors.DenavitError` naming
``pip install 'denavit[plot]'``.

Units: lengths in ``length`` (default mm, as in Hayat et al.), angles in ``angle`` (default deg), SI inside.
"""

from __future__ import annotations

import html
import math
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from . import _core
from ._core import __version__
from .errors import DenavitError
from .io.output import atomic_path, write_text
from .io.units import angle_scale, cell_scale, column_scale, length_scale
from .plotting import (
    AXIS_COLOURS,
    INSTALL_HINT,
    box_edges,
    circle_points,
    frames_along,
    joint_colour,
    joint_names,
    line_span,
    motion_range,
    other_convention,
    parameter_errors,
    scene_size,
    sweep_range,
)
from .robot import Robot, load

if TYPE_CHECKING:  # pragma: no cover
    from .identify import Identification

#: Formats written by :func:`write_figures` unless told otherwise.
FIGURE_FORMATS = ("png",)
#: Decimals of every number in the HTML tables (the full value is in each cell's ``data-value``).
DECIMALS = 4
#: The id of the interactive 3-D view's element.
VIEW_ID = "view3d"


# ------------------------------------------------------------------------------------------------ figures


def _save_figure(fig, path: Path, dpi: int) -> Path:
    """Save a matplotlib figure whole or not at all."""
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=dpi, format=path.suffix[1:])
    return path


def _write_all(figs: dict, folder, formats: Sequence[str], dpi: int) -> list[Path]:
    folder = Path(folder)
    bad = [f for f in formats if f not in ("png", "svg", "pdf")]
    if bad:
        raise DenavitError(f"figure formats: expected png, svg or pdf, got {', '.join(bad)}")
    folder.mkdir(parents=True, exist_ok=True)
    out = []
    for stem, fig in figs.items():
        for fmt in formats:
            out.append(_save_figure(fig, folder / f"{stem}.{fmt}", dpi))
    return out


def write_figures(result: Identification, folder, *, formats: Sequence[str] = FIGURE_FORMATS, length: str = "mm", dpi: int = 110) -> list[Path]:
    """Write the static figures of an identification into ``folder`` (created if needed).

    Files ``circles``, ``residuals``, ``bounding_box``, ``parameters``, ``frames`` (identified convention beside
    ED-H, or modified DH for an ED-H result) and ``origin_paths`` (joint 2 over its swept range), each in every
    one of ``formats`` ("png", "svg", "pdf"). Returns the paths written.
    """
    from .plotting import figures_for  # noqa: PLC0415

    return _write_all(figures_for(result, length=length), folder, formats, dpi)


def _convention(name: str) -> str | None:
    """The core's name of the convention ``name`` (any alias: "craig", "MDH", ...), or None if it names none."""
    try:
        return _core.convention_info(name)["name"]
    except DenavitError:
        return None


def _compare_tables(robot: Robot, compare) -> tuple[list[tuple[str, _core.Table]], _core.Extraction | None]:
    """The robot's table and the one drawn beside it: a convention name (the robot extracted into it), a robot
    (or the name / file of one, with the same number of joints), or None (ED-H, modified DH beside ED-H)."""
    first = (f"{robot.name} ({robot.convention})", robot.table)
    conv = other_convention(robot.convention) if compare is None else _convention(compare) if isinstance(compare, str) else None
    if conv is not None:
        m = robot.model()
        nominal = robot.table if robot.convention == conv else None
        ex = _core.extract(_core.axes(m, np.zeros(m.nq)), conv, nominal=nominal)
        return [first, (f"{robot.name} in {conv}", ex.table)], ex
    other = compare if isinstance(compare, Robot) else load(compare)
    if len(other.names) != len(robot.names):
        raise DenavitError(f"compare: {other.name} has {len(other.names)} joints, {robot.name} has {len(robot.names)}")
    label = f"{other.name} ({other.convention})"
    if label == first[0]:
        label += " [2]"
    return [first, (label, other.table)], None


def write_model_figures(robot: Robot, folder, *, compare=None, q=None, joint: int = 2, formats: Sequence[str] = FIGURE_FORMATS, length: str = "mm", dpi: int = 110) -> list[Path]:
    """Write ``frames`` (the robot beside ``compare``, see :func:`write_model_report`) and ``origin_paths``
    (joint ``joint`` over its limits) into ``folder``. ``q`` : (n,) rad / m, default the robot's home or zeros."""
    from .plotting import plot_frames, plot_origin_paths  # noqa: PLC0415

    tables, _ = _compare_tables(robot, compare)
    n = len(robot.names)
    qv = _model_q(robot, q)
    joint = min(max(joint, 1), n)
    lim = motion_range(robot.lower, robot.upper, qv, joint, robot.table.kinds[joint - 1])
    figs = {"frames": plot_frames(tables, qv, length=length, title=f"{robot.name}: frames of each convention (x red, y green, z blue)"),
            "origin_paths": plot_origin_paths(tables, joint, qv, limits=lim, length=length)}
    return _write_all(figs, folder, formats, dpi)


# ------------------------------------------------------------------------------------------------ HTML helpers


def _plotly():
    try:
        import plotly.graph_objects as go  # noqa: PLC0415
        from plotly.subplots import make_subplots  # noqa: PLC0415
    except ImportError as e:
        raise DenavitError(f"the HTML report needs plotly, which is not installed ({e}): {INSTALL_HINT}") from None
    return go, make_subplots


def fmt_value(v, decimals: int = DECIMALS) -> str:
    """A table number as shown in the report: fixed ``decimals``, no negative zero, '-' for None/NaN."""
    if v is None or not np.isfinite(v):
        return "-"
    s = f"{v:.{decimals}f}"
    return s[1:] if s.startswith("-") and float(s) == 0 else s


def _td(cls: str, v, decimals: int = DECIMALS) -> str:
    if v is None or (isinstance(v, float) and not np.isfinite(v)):
        return f'<td class="{cls}">-</td>'
    if isinstance(v, str):
        return f'<td class="{cls}">{html.escape(v)}</td>'
    return f'<td class="{cls} num" data-value="{float(v)!r}">{fmt_value(float(v), decimals)}</td>'


def _table(tid: str, header: Sequence[str], rows: Sequence[str], caption: str = "", cls: str = "") -> str:
    cap = f"<caption>{html.escape(caption)}</caption>" if caption else ""
    head = "".join(f"<th>{html.escape(h)}</th>" for h in header)
    return f'<table id="{tid}" class="{cls}">{cap}<thead><tr>{head}</tr></thead><tbody>\n' + "\n".join(rows) + "\n</tbody></table>"


def _segments(segs) -> tuple[list, list, list]:
    """x, y, z lists of several polylines separated by None (one plotly trace draws them all)."""
    xs, ys, zs = [], [], []
    for s in segs:
        s = np.asarray(s, dtype=float)
        xs += s[:, 0].tolist() + [None]
        ys += s[:, 1].tolist() + [None]
        zs += s[:, 2].tolist() + [None]
    return xs, ys, zs


def _line3d(go, segs, ls: float, **kw):
    x, y, z = _segments([np.asarray(s) / ls for s in segs])
    return go.Scatter3d(x=x, y=y, z=z, mode="lines", **kw)


def _frame_traces(go, label: str, F: np.ndarray, ls: float, size: float, *, group: str, visible=True, dash: str = "solid", names=None) -> list:
    """Skeleton through the frame origins (labelled 0..n) and the x, y, z axes of every frame, one legend group."""
    o = F[:, :3, 3] / ls
    hover = [f"{label}<br>frame {i}" + (f" ({names[i - 1]})" if names and i > 0 else "") + f"<br>origin {p[0]:.2f}, {p[1]:.2f}, {p[2]:.2f}" for i, p in enumerate(o)]
    tr = [go.Scatter3d(x=o[:, 0], y=o[:, 1], z=o[:, 2], mode="lines+markers+text", text=[str(i) for i in range(len(o))], textposition="top right",
                       hovertext=hover, hoverinfo="text", line={"color": "#555555", "width": 5, "dash": dash}, marker={"size": 3, "color": "#555555"},
                       name=label, legendgroup=group, showlegend=True, visible=visible)]
    for k in range(3):
        segs = [np.array([T[:3, 3], T[:3, 3] + size * T[:3, k]]) for T in F]
        tr.append(_line3d(go, segs, ls, line={"color": AXIS_COLOURS[k], "width": 4, "dash": dash}, name=f"{label} {'xyz'[k]}", legendgroup=group, showlegend=False,
                          hoverinfo="skip", visible=visible))
    return tr


def _path_traces(go, label: str, table: _core.Table, q0, joint: int, limits, ls: float, *, group: str, visible, colour: str, name: str, dash: str = "solid") -> list:
    values = np.linspace(limits[0], limits[1], 61)
    P = frames_along(table, q0, joint, values)[:, :, :3, 3]  # (m, n+1, 3)
    segs = [P[:, i] for i in range(P.shape[1]) if np.max(np.linalg.norm(P[:, i] - P[0, i], axis=1)) > 1e-9]
    if not segs:
        return []
    return [_line3d(go, segs, ls, line={"color": colour, "width": 3, "dash": dash}, name=name, legendgroup=group, showlegend=True, visible=visible,
                    hovertext=label, hoverinfo="name")]


def _scene_layout(length: str, height: int = 680) -> dict:
    ax = {"showbackground": True, "backgroundcolor": "#f4f6f8", "gridcolor": "#d0d4d8"}
    return {
        "scene": {"aspectmode": "data", "xaxis": {"title": {"text": f"x [{length}]"}, **ax}, "yaxis": {"title": {"text": f"y [{length}]"}, **ax},
                  "zaxis": {"title": {"text": f"z [{length}]"}, **ax}},
        "height": height,
        "margin": {"l": 0, "r": 0, "t": 30, "b": 0},
        "legend": {"groupclick": "togglegroup", "title": {"text": "click: show/hide, double-click: only this"}, "itemsizing": "constant"},
        "paper_bgcolor": "white",
    }


_CONFIG = {"displaylogo": False, "responsive": True, "toImageButtonOptions": {"format": "png", "scale": 2}}
_RENDERED = "document.getElementById('{plot_id}').dataset.rendered = 'true';"


def _figure_html(fig, div_id: str, *, first: bool) -> str:
    """A plotly figure as a <div>; the first one carries the whole plotly.js bundle inline (offline, no CDN)."""
    return fig.to_html(full_html=False, include_plotlyjs=bool(first), include_mathjax=False, div_id=div_id, config=_CONFIG, post_script=_RENDERED)


_CSS = """
body { font-family: system-ui, -apple-system, "Segoe UI", Roboto, sans-serif; margin: 0 auto; max-width: 1280px; padding: 0 16px 40px; color: #222; }
h1 { font-size: 1.5em; margin: 16px 0 4px; } h2 { font-size: 1.2em; margin-top: 28px; border-bottom: 1px solid #ddd; }
p.meta, p.hint { color: #555; margin: 4px 0; font-size: 0.92em; }
#view3d { width: 100%; height: 680px; border: 1px solid #ddd; }
table { border-collapse: collapse; margin: 8px 0 16px; font-size: 0.88em; }
caption { text-align: left; color: #555; padding: 4px 0; caption-side: top; }
th, td { border: 1px solid #d8d8d8; padding: 3px 8px; } th { background: #f2f4f6; }
td.num { text-align: right; font-variant-numeric: tabular-nums; font-family: ui-monospace, Menlo, Consolas, monospace; }
tbody tr:nth-child(even) { background: #fafbfc; }
dl.summary { display: grid; grid-template-columns: max-content auto; gap: 2px 16px; font-size: 0.92em; }
dl.summary dt { color: #555; } dl.summary dd { margin: 0; }
ul.notes li { color: #8a5a00; }
footer { margin-top: 32px; color: #888; font-size: 0.85em; }
"""


def _page(title: str, meta: str, body: str) -> str:
    return (f'<!DOCTYPE html>\n<html lang="en">\n<head>\n<meta charset="utf-8">\n<meta name="viewport" content="width=device-width, initial-scale=1">\n'
            f"<title>{html.escape(title)}</title>\n<style>{_CSS}</style>\n</head>\n<body>\n<header><h1>{html.escape(title)}</h1><p class=\"meta\">{meta}</p></header>\n"
            f"{body}\n<footer>Written by denavit {html.escape(__version__)}. Self-contained: the page fetches nothing (plotly.js is inlined).</footer>\n</body>\n</html>\n")


def _summary(items: Sequence[tuple[str, str]]) -> str:
    return '<dl class="summary" id="summary">' + "".join(f"<dt>{html.escape(k)}</dt><dd>{html.escape(v)}</dd>" for k, v in items) + "</dl>"


def _view_section(view_html: str, what: str) -> str:
    return (f'<section id="view"><h2>3-D view</h2><p class="hint">{html.escape(what)} Drag to rotate, scroll to zoom, right-drag to pan; '
            f"click a legend entry to show or hide that joint or convention, double-click to show it alone.</p>\n{view_html}\n</section>")


def _pairs_table(pairs, ls: float, length: str, angle: str) -> str:
    a = angle_scale(angle)
    rows = [f'<tr data-pair="{p.joint}">{_td("pair", f"{p.joint}-{p.joint + 1}")}{_td("relation", p.relation)}{_td("angle", p.angle / a)}{_td("distance", p.distance / ls)}'
            f'{_td("hayati-beta", p.hayati_beta / a)}</tr>' for p in pairs]
    return _table("pairs", ["axes", "relation", f"angle [{angle}]", f"distance [{length}]", f"Hayati beta [{angle}]"], rows,
                  "Consecutive joint axes (docs/conventions.md: parallel / intersecting / skew, the common normal's length).", "pairs")


def _param_table(tid: str, table: _core.Table, names: Sequence[str], length: str, angle: str, caption: str) -> str:
    sc = [column_scale(table, k, length, angle) for k in range(len(table.columns))]
    rows = []
    for i, (nm, kind, row) in enumerate(zip(names, table.kinds, table.params, strict=True)):
        cells = "".join(_td(c, v / cell_scale(table, i, k, length, angle)[0]) for k, (c, v) in enumerate(zip(table.columns, row, strict=True)))
        rows.append(f'<tr data-joint="{html.escape(nm)}">{_td("joint", nm)}{_td("kind", kind)}{cells}</tr>')
    header = ["joint", "kind"] + [f"{c} [{u}]" for c, (_, u) in zip(table.columns, sc, strict=True)]
    return _table(tid, header, rows, caption, f"parameters {table.convention}")


# ------------------------------------------------------------------------------------------------ identification


def _identification_view(go, result: Identification, ls: float, length: str):
    names = joint_names(result)
    pts = result.sweeps.all_points
    size = scene_size(pts)
    arrow = 0.25 * size
    traces = []
    for s, f in zip(result.sweeps.sweeps, result.fits, strict=True):
        j = s.joint
        col, nm, grp = joint_colour(j - 1), names[j - 1], f"joint-{j}"
        p = s.points / ls
        hover = [f"{nm} point {k}<br>residual {r / ls:.4f} {length}" for k, r in enumerate(f.residuals)]
        traces.append(go.Scatter3d(x=p[:, 0], y=p[:, 1], z=p[:, 2], mode="markers", marker={"size": 3.5, "color": col}, name=f"{nm} (points, circle, axis)",
                                   legendgroup=grp, showlegend=True, hovertext=hover, hoverinfo="text"))
        if np.any(f.outliers):
            o = p[f.outliers]
            traces.append(go.Scatter3d(x=o[:, 0], y=o[:, 1], z=o[:, 2], mode="markers", marker={"size": 6, "color": "black", "symbol": "x"},
                                       name=f"{nm} outliers", legendgroup=grp, showlegend=False))
        if result.sweeps.kinds[j - 1] == "revolute" and np.isfinite(f.radius):
            traces.append(_line3d(go, [circle_points(f.point, f.direction, f.radius)], ls, line={"color": col, "width": 3}, name=f"{nm} circle", legendgroup=grp,
                                  showlegend=False, hoverinfo="name"))
            c = f.point / ls
            traces.append(go.Scatter3d(x=[c[0]], y=[c[1]], z=[c[2]], mode="markers", marker={"size": 5, "color": col, "symbol": "circle-open", "line": {"width": 2}},
                                       name=f"{nm} centre", legendgroup=grp, showlegend=False,
                                       hovertext=f"{nm} centre {c[0]:.3f}, {c[1]:.3f}, {c[2]:.3f}<br>r = {f.radius / ls:.3f} {length}", hoverinfo="text"))
        else:
            traces.append(_line3d(go, [line_span(f.point, f.direction, s.points)], ls, line={"color": col, "width": 3}, name=f"{nm} line", legendgroup=grp, showlegend=False))
        tip = f.point + arrow * f.direction
        traces.append(_line3d(go, [np.array([f.point - 0.3 * arrow * f.direction, tip])], ls, line={"color": col, "width": 6}, name=f"{nm} axis", legendgroup=grp,
                              showlegend=False, hoverinfo="name"))
        t, d = tip / ls, f.direction
        traces.append(go.Cone(x=[t[0]], y=[t[1]], z=[t[2]], u=[d[0]], v=[d[1]], w=[d[2]], anchor="tip", sizemode="absolute", sizeref=0.12 * arrow / ls,
                              colorscale=[[0, col], [1, col]], showscale=False, name=f"{nm} axis", legendgroup=grp, showlegend=False, hoverinfo="name"))
    tp = result.tool_point / ls
    traces.append(go.Scatter3d(x=[tp[0]], y=[tp[1]], z=[tp[2]], mode="markers", marker={"size": 6, "color": "black", "symbol": "diamond"}, name="tool point at home",
                               legendgroup="tool", showlegend=True))
    b = result.box
    traces.append(_line3d(go, box_edges(b.center, b.axes, b.lengths), ls, line={"color": "#444444", "width": 2}, name="bounding box (Hayat Table IV)",
                          legendgroup="box", showlegend=True, visible="legendonly"))
    # frames of the identified convention, of the other one, and of the nominal model, at home
    conv = result.table.convention
    other = other_convention(conv)
    model = result.model()
    other_table = _core.extract(_core.axes(model, np.zeros(model.nq)), other).table
    home = result.sweeps.home
    Fs = [("identified " + conv, result.table.frames(home), True, "solid"), ("identified " + other, other_table.frames(home), "legendonly", "dash")]
    if result.nominal is not None:
        Fs.append((f"nominal {result.nominal.name} ({result.nominal.convention})", result.nominal.table.frames(home), "legendonly", "dot"))
    tri = 0.06 * scene_size(np.vstack([F[:, :3, 3] for _, F, _, _ in Fs] + [pts]))
    for label, F, vis, dash in Fs:
        traces += _frame_traces(go, label, F, ls, tri, group=f"frames-{label}", visible=vis, dash=dash, names=names)
    n = result.axes.nq
    jp = 2 if n >= 2 else 1
    lim = sweep_range(result, jp)
    for (label, table), colour, dash in (((f"identified {conv}", result.table), "#6a3d9a", "solid"), ((f"identified {other}", other_table), "#b15928", "dash")):
        traces += _path_traces(go, label, table, home, jp, lim, ls, group=f"paths-{label}", visible="legendonly", colour=colour, dash=dash,
                               name=f"{label}: frame-origin paths, {names[jp - 1]} swept")
    fig = go.Figure(traces)
    fig.update_layout(**_scene_layout(length))
    return fig


def _residual_chart(go, result: Identification, ls: float, length: str):
    names = joint_names(result)
    fig = go.Figure()
    for s, f in zip(result.sweeps.sweeps, result.fits, strict=True):
        r = np.asarray(f.residuals) / ls
        fig.add_trace(go.Scatter(x=np.arange(len(r)), y=r, mode="lines+markers", name=f"{names[s.joint - 1]} (rms {f.rms / ls:.3g})", marker={"color": joint_colour(s.joint - 1), "size": 5},
                                 line={"width": 1}))
    fig.update_layout(height=340, margin={"l": 60, "r": 10, "t": 30, "b": 40}, xaxis={"title": {"text": "point"}}, yaxis={"title": {"text": f"residual [{length}]"}},
                      title={"text": "Residuals per joint", "font": {"size": 14}})
    return fig


def _parameter_chart(go, make_subplots, result: Identification, length: str, angle: str):
    rows = parameter_errors(result, length, angle)
    names = joint_names(result)
    nominal = result.nominal_table is not None
    fig = make_subplots(rows=1, cols=len(rows), subplot_titles=[f"{c} [{u}]" for c, u, *_ in rows])
    for k, (c, unit, ident, sig, nom) in enumerate(rows):
        y = ident - nom if nom is not None else ident
        fig.add_trace(go.Scatter(x=names, y=y, error_y={"type": "data", "array": sig, "visible": True}, mode="markers", marker={"color": "#1f77b4", "size": 7},
                                 name=c, showlegend=False, hovertemplate="%{x}: %{y:.4g} ± %{error_y.array:.2g} " + unit + "<extra></extra>"), row=1, col=k + 1)
    fig.update_layout(height=330, margin={"l": 50, "r": 10, "t": 60, "b": 40},
                      title={"text": ("Identified − nominal" if nominal else "Identified values") + ", error bars one sigma", "font": {"size": 14}})
    return fig


def _accuracy_section(go, result: Identification, length: str) -> str:
    """Accuracy before and after: the nominal model's error and the identified model's predicted error over the
    workspace (denavit.compensation.identification_accuracy), a table and a histogram."""
    from .compensation import identification_accuracy  # noqa: PLC0415

    acc = identification_accuracy(result)
    if acc is None:
        return ""
    ls = length_scale(length)
    s = acc.summary()
    rows = [f'<tr>{_td("model", label)}' + "".join(_td(k, s[key][k] / ls) for k in ("rms", "median", "p95", "max")) + "</tr>"
            for label, key in (("nominal (what the robot misses)", "nominal"), ("identified (predicted 1σ)", "identified"))]
    table = _table("accuracy", ["model", f"rms [{length}]", f"median [{length}]", f"95 % [{length}]", f"max [{length}]"], rows,
                   f"Tool position error over {s['configurations']} quasi-random configurations within the joint limits: the nominal model against the "
                   "identified one, and the identified model's error predicted from the axes' covariance (denavit.compensation).", "accuracy")
    fig = go.Figure()
    for v, name, colour in ((acc.nominal, "nominal", "#c0392b"), (acc.identified, "identified (predicted 1σ)", "#2471a3")):
        fig.add_trace(go.Histogram(x=np.log10(np.maximum(np.asarray(v) / ls, 1e-12)), name=name, marker={"color": colour}, opacity=0.7, nbinsx=40))
    fig.update_layout(barmode="overlay", height=320, margin={"l": 60, "r": 10, "t": 30, "b": 40},
                      xaxis={"title": {"text": f"log10 tool position error [{length}]"}}, yaxis={"title": {"text": "configurations"}},
                      title={"text": "Accuracy before and after identification", "font": {"size": 14}})
    return f'<section id="accuracy-section"><h2>Accuracy</h2>{table}{_figure_html(fig, "accuracy-chart", first=False)}</section>'


def report_html(result: Identification, *, length: str = "mm", angle: str = "deg", title: str | None = None) -> str:
    """The HTML text of :func:`write_report`."""
    from .identify import to_json  # noqa: PLC0415

    go, make_subplots = _plotly()
    ls = length_scale(length)
    doc = to_json(result, length, angle)
    names = joint_names(result)
    t, nt = result.table, result.nominal_table
    view = _figure_html(_identification_view(go, result, ls, length), VIEW_ID, first=True)
    resid = _figure_html(_residual_chart(go, result, ls, length), "residuals-chart", first=False)
    pchart = _figure_html(_parameter_chart(go, make_subplots, result, length, angle), "parameters-chart", first=False)

    # parameters: one row per joint and parameter, as printed by `denavit identify`
    rows = []
    for i, prow in enumerate(doc["parameters"]):
        for k, c in enumerate(t.columns):
            sc, unit = cell_scale(t, i, k, length, angle)
            nom = float(nt.params[i, k] / sc) if nt is not None else None
            diff = None if nom is None else prow[c] - nom
            if diff is not None and t.angle_columns[k]:
                half = math.pi / sc
                diff = (diff + half) % (2 * half) - half
            rows.append(f'<tr data-joint="{html.escape(names[i])}" data-param="{c}">{_td("joint", names[i])}{_td("param", c)}{_td("unit", unit)}'
                        f'{_td("nominal", nom)}{_td("identified", prow[c])}{_td("sigma", prow[c + "_sigma"])}{_td("difference", diff)}</tr>')
    params = _table("parameters", ["joint", "parameter", "unit", "nominal", "identified", "sigma (1σ)", "identified − nominal"], rows,
                    f"Identified {t.convention.upper()} parameters (docs/conventions.md); sigma propagated from the fits' covariance; nominal: "
                    + (f"{result.nominal.name}" if result.nominal else "none given") + ".", "parameters")
    arows = []
    for j in doc["joints"]:
        c, a = j["circle"], j["axis"]
        arows.append(f'<tr data-joint="{html.escape(j["joint"])}">{_td("joint", j["joint"])}'
                     + "".join(_td(f"point-{x}", v) for x, v in zip("xyz", a["point"], strict=True)) + "".join(_td(f"direction-{x}", v, 6) for x, v in zip("xyz", a["direction"], strict=True))
                     + f'{_td("radius", c["radius"])}{_td("arc", j["arc_deg"], 1)}{_td("rms", j["residuals"]["rms"])}{_td("max-residual", j["residuals"]["max"])}'
                     f'{_td("sigma-across", a["sigma_point_perp"])}{_td("sigma-direction", a["sigma_direction_deg"], 5)}{_td("n-points", j["residuals"]["n_points"], 0)}'
                     f'{_td("outliers", len(j["residuals"]["outliers"]), 0)}</tr>')
    axes_t = _table("axes", ["joint", "point x", "point y", "point z", "dir x", "dir y", "dir z", f"radius [{length}]", "arc [deg]", f"rms [{length}]",
                             f"max |residual| [{length}]", f"sigma across [{length}]", "sigma direction [deg]", "points", "outliers"], arows,
                    f"Joint axes in the measurement frame ({length}): circle centre and normal (Hayat et al. eq. 1-9), fit quality, one-sigma uncertainty.", "axes")
    b = doc["bounding_box"]
    brows = [f'<tr>{_td("l1", b["lengths"][0])}{_td("l2", b["lengths"][1])}{_td("l3", b["lengths"][2])}{_td("volume", b["volume_m3"])}'
             f'{_td("center", ", ".join(f"{v:.3f}" for v in b["center"]))}</tr>']
    box_t = _table("bounding-box", [f"l1 [{length}]", f"l2 [{length}]", f"l3 [{length}]", "volume [m³]", f"centre [{length}]"], brows,
                   "Minimum-volume oriented bounding box of all measured points (Hayat et al. Table IV).", "bounding-box")
    orows = [f"<tr>{''.join(_td(f'col-{k + 1}', v) for k, v in enumerate(row))}</tr>" for row in b["orientation"]]
    orient_t = _table("bounding-box-orientation", ["l1 axis", "l2 axis", "l3 axis"], orows, "Orientation of the box: its axes as columns, in the measurement frame.", "bounding-box")
    notes = "".join(f"<li>{html.escape(n)}</li>" for n in doc["notes"]) or "<li>none</li>"
    summary = _summary([("data", doc["source"]), ("method", doc["method"]), ("convention", t.convention), ("nominal", result.nominal.name if result.nominal else "none"),
                        ("residual rms", f"{doc['rms']:.4f} {length}"), ("tool point at home", ", ".join(f"{v:.3f}" for v in doc["tool_point_home"]) + f" {length}"),
                        ("tool error the table carries", f"{doc['max_tool_position_error']:.3g} {length}"),
                        ("home", ", ".join(f"{v:.4g}" for v in doc["home"]) + f" ({angle} / {length})")])
    title = title or f"denavit identification: {result.sweeps.source or 'sweeps'}"
    meta = html.escape(f"{len(names)} joints, method {result.method}, {t.convention.upper()} parameters; lengths in {length}, angles in {angle}, measurement frame.")
    body = "\n".join([
        _view_section(view, "Measured points, fitted full circles, centres and axis arrows per joint (Hayat et al. Fig. 7); frames of the identified convention "
                      "(others, the bounding box and origin paths: switch them on in the legend)."),
        f'<section id="results"><h2>Identified parameters</h2>{summary}{params}{pchart}</section>',
        f'<section id="fits"><h2>Joint axes and fits</h2>{axes_t}{resid}{_pairs_table(result.extraction.pairs, ls, length, angle)}</section>',
        f'<section id="box"><h2>Measuring volume</h2>{box_t}{orient_t}</section>',
        _accuracy_section(go, result, length),
        f'<section id="notes-section"><h2>Notes</h2><ul class="notes" id="notes">{notes}</ul></section>',
    ])
    return _page(title, meta, body)


def write_report(result: Identification, path, *, length: str = "mm", angle: str = "deg", title: str | None = None) -> None:
    """Write the self-contained HTML report of an identification (see the module docs) to ``path``."""
    write_text(path, report_html(result, length=length, angle=angle, title=title))


# ------------------------------------------------------------------------------------------------ model


def _model_q(robot: Robot, q) -> np.ndarray:
    n = len(robot.names)
    qv = (robot.home if robot.home is not None else np.zeros(n)) if q is None else np.asarray(q, dtype=float)
    if qv.shape != (n,):
        raise DenavitError(f"q: expected {n} joint values for {robot.name}, got shape {qv.shape}")
    return qv


def model_report_html(robot: Robot, *, compare=None, q=None, length: str = "mm", angle: str = "deg", title: str | None = None) -> str:
    """The HTML text of :func:`write_model_report`."""
    go, _ = _plotly()
    ls = length_scale(length)
    tables, ex = _compare_tables(robot, compare)
    qv = _model_q(robot, q)
    m = robot.model()
    n = m.nq
    J = _core.joint_frames(m, qv)
    Fs = [t.frames(qv) for _, t in tables]
    allo = np.vstack([F[:, :3, 3] for F in Fs] + [J[:, :3, 3]])
    size = scene_size(allo)
    traces = []
    for i, T in enumerate(J):  # the joint axes: the geometric truth every convention is built on
        col, nm = joint_colour(i), robot.names[i]
        p, z = T[:3, 3], T[:3, 2]
        traces.append(_line3d(go, [np.array([p - 0.12 * size * z, p + 0.12 * size * z])], ls, line={"color": col, "width": 8}, name=f"axis {nm}",
                              legendgroup=f"joint-{i + 1}", showlegend=True, hoverinfo="name"))
    tri = 0.07 * size
    for (label, _), F, dash in zip(tables, Fs, ("solid", "dash"), strict=True):
        traces += _frame_traces(go, label, F, ls, tri, group=f"frames-{label}", dash=dash, names=robot.names)
    for k in range(1, n + 1):
        lim = motion_range(robot.lower, robot.upper, qv, k, robot.table.kinds[k - 1])
        for (label, t), colour, dash in zip(tables, ("#6a3d9a", "#b15928"), ("solid", "dash"), strict=True):
            traces += _path_traces(go, label, t, qv, k, lim, ls, group=f"paths-{label}-{k}", visible=True if k == 2 or n == 1 else "legendonly", colour=colour, dash=dash,
                                   name=f"{label}: origin paths, {robot.names[k - 1]} moving")
    fig = go.Figure(traces)
    fig.update_layout(**_scene_layout(length))
    view = _figure_html(fig, VIEW_ID, first=True)
    parts = []
    for idx, (label, t) in enumerate(tables):
        tid = "table-main" if idx == 0 else "table-compare"
        parts.append(f"<h3>{html.escape(label)}</h3>" + _param_table(tid, t, robot.names, length, angle, f"{t.convention} columns as in docs/conventions.md; {length}, {angle}."))
    frows = []
    for (label, _), F in zip(tables, Fs, strict=True):
        for i, T in enumerate(F):
            frows.append(f'<tr data-convention="{html.escape(label)}" data-frame="{i}">{_td("convention", label)}{_td("frame", str(i))}'
                         + "".join(_td(f"origin-{x}", v / ls) for x, v in zip("xyz", T[:3, 3], strict=True)) + "".join(_td(f"z-{x}", v) for x, v in zip("xyz", T[:3, 2], strict=True)) + "</tr>")
    frames_t = _table("frames", ["convention", "frame", f"origin x [{length}]", f"origin y [{length}]", f"origin z [{length}]", "z x", "z y", "z z"], frows,
                      "Frame origins and z axes in world at the configuration drawn (Table.frames).", "frames")
    rng = np.random.default_rng(0)
    lo = np.maximum(np.asarray(robot.lower, dtype=float), -math.pi)
    hi = np.minimum(np.asarray(robot.upper, dtype=float), math.pi)
    qs = lo + (hi - lo) * rng.random((64, n))
    ma, mb = tables[0][1].to_model(), tables[1][1].to_model()
    dmax = max(float(np.linalg.norm(_core.fk(ma, qq)[:3, 3] - _core.fk(mb, qq)[:3, 3])) for qq in np.vstack([qv, qs]))
    extra = _pairs_table(ex.pairs, ls, length, angle) if ex is not None else ""
    summary = _summary([("robot", f"{robot.name}: {robot.description}"), ("source", robot.source or "-"), ("conventions", " | ".join(lbl for lbl, _ in tables)),
                        ("configuration drawn", ", ".join(f"{v:.4g}" for v in qv) + " (rad / m)"),
                        ("FK agreement", f"max tool-position difference {dmax / ls:.3g} {length} over q and 64 random configurations within the limits")])
    title = title or f"denavit model: {robot.name}"
    meta = html.escape(f"{n} joints; {robot.convention} beside {tables[1][0]}; lengths in {length}, angles in {angle}.")
    body = "\n".join([
        _view_section(view, "Joint axes (coloured), the frames of both conventions (x red, y green, z blue; the second dashed; Guo et al. Figs. 6-7), "
                      "and the path of every frame origin while a joint moves over its limits (Guo et al. Fig. 3; joint 2 shown, the others in the legend)."),
        f'<section id="tables"><h2>Parameters</h2>{summary}{"".join(parts)}{extra}</section>',
        f'<section id="frames-section"><h2>Frames</h2>{frames_t}</section>',
    ])
    return _page(title, meta, body)


def write_model_report(robot: Robot, path, *, compare=None, q=None, length: str = "mm", angle: str = "deg", title: str | None = None) -> None:
    """Write the self-contained HTML report of a robot model to ``path``.

    Parameters
    ----------
    robot : Robot
        E.g. ``denavit.load_robot("tiansui_mdh")``.
    compare : str or Robot, optional
        What to draw beside it: a convention ("dh", "mdh", "edh", "poe": the robot extracted into it), another
        robot (or its built-in name / file, e.g. "tiansui_edh" for Guo et al. Table II), default ED-H (modified
        DH for an ED-H robot).
    q : array-like, shape (n,), optional
        Configuration drawn (rad / m), default the robot's home, else zeros.
    """
    write_text(path, model_report_html(robot, compare=compare, q=q, length=length, angle=angle, title=title))


__all__ = [
    "DECIMALS",
    "FIGURE_FORMATS",
    "VIEW_ID",
    "fmt_value",
    "model_report_html",
    "report_html",
    "write_figures",
    "write_model_figures",
    "write_model_report",
    "write_report",
]
