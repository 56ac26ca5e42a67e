"""Reports: the static figures of an identification or a model, and one self-contained HTML file.

* :func:`write_figures` / :func:`write_model_figures` -- PNG (and/or SVG) files of :mod:`denavit.plotting`
  (matplotlib).
* :func:`write_report` -- an identification: an interactive 3-D view (measured points, fitted circles, centres,
  axes, the bounding box, the frames of the identified convention, of ED-H (or modified DH) and of the nominal
  model, origin paths), residual and parameter-error charts, and the tables (identified values, one-sigma,
  nominal, differences; axes; consecutive-axis relations; bounding box; notes).
* :func:`write_model_report` -- a robot: its frames beside those of another convention or another robot file
  (Guo et al. Figs. 6-7), the path of every frame origin while each joint moves (Guo et al. Fig. 3), and the tables.
* :func:`write_calibration_report` -- a whole-model calibration; :func:`write_compensation_report` -- a
  compensated program.

Every page is read in a minute: a summary first (what was measured, the model, the fit, the accuracy before
and after where known), then the 3-D view (its camera and aspect set from what it draws,
:func:`denavit.plotting.scene_view`), then the tables with a unit in every header.

The HTML file works offline and weighs under 1 MB: plotly.js is inlined once per page, as the gzip'ed partial
bundle :data:`PLOTLY_BUNDLE` (the trace types the reports draw), inflated by the browser's own
``DecompressionStream`` and run by the page's one loader, which then draws every figure from its JSON. There
is no other script, style sheet, font or image to fetch. Legend entries are grouped: a click on a joint
or a convention shows or hides all of its traces (double-click isolates it). Every number in a table is a
``<td>`` with a class naming its column and a ``data-value`` attribute holding the full-precision value in the
table's display unit, so that the report can be read by programs as well as people.

Files are written whole or not at all (:func:`denavit.io.output.write_text`). plotly and matplotlib are the
optional ``plot`` extra; a missing one raises :class:`~denavit.errors.DenavitError` naming
``pip install 'denavit[plot]'``.

Units: lengths in ``length`` (default mm, as in Hayat et al.), angles in ``angle`` (default deg), SI inside.
"""

from __future__ import annotations

import base64
import functools
import html
import json
import math
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from . import _core
from ._core import __version__
from .errors import DenavitError
from .io.output import atomic_path, write_text
from .io.units import angle_scale, cell_scale, column_scale, joint_scale, joint_unit, length_scale
from .plotting import (
    AXIS_COLOURS,
    INSTALL_HINT,
    UNDETERMINED_ANGLE,
    UNDETERMINED_LENGTH,
    UNDETERMINED_RATIO,
    box_edges,
    chain_path,
    circle_points,
    clean_ticks,
    frame_labels,
    frames_along,
    joint_colour,
    joint_names,
    line_span,
    motion_range,
    other_convention,
    parameter_errors,
    scene_size,
    scene_view,
    sweep_range,
    symmetric_limit,
    triad_lengths,
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


def _save_figure(fig, path: Path, dpi: int, force: bool = False) -> Path:
    """Save a matplotlib figure whole or not at all (``force``: :func:`denavit.io.output.atomic_path`)."""
    with atomic_path(path, force=force) as tmp:
        fig.savefig(tmp, dpi=dpi, format=path.suffix[1:])
    return path


def _write_all(figs: dict, folder, formats: Sequence[str], dpi: int, force: bool = False) -> list[Path]:
    folder = Path(folder)
    bad = [f for f in formats if f not in ("png", "svg", "pdf")]
    if bad:
        raise DenavitError(f"figure formats: expected png, svg or pdf, got {', '.join(bad)}")
    folder.mkdir(parents=True, exist_ok=True)
    out = []
    for stem, fig in figs.items():
        for fmt in formats:
            out.append(_save_figure(fig, folder / f"{stem}.{fmt}", dpi, force))
    return out


def write_figures(result: Identification, folder, *, formats: Sequence[str] = FIGURE_FORMATS, length: str = "mm", dpi: int = 110, force: bool = False) -> list[Path]:
    """Write the static figures of an identification into ``folder`` (created if needed).

    Files ``circles``, ``residuals``, ``bounding_box``, ``parameters``, ``frames`` (identified convention beside
    ED-H, or modified DH for an ED-H result) and ``origin_paths`` (joint 2 over its swept range), each in every
    one of ``formats`` ("png", "svg", "pdf"). Returns the paths written. ``force``: replace read-only files,
    write through ones with several hard links (:mod:`denavit.io.output`).
    """
    from .plotting import figures_for  # noqa: PLC0415

    return _write_all(figures_for(result, length=length), folder, formats, dpi, force)


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


def write_model_figures(robot: Robot, folder, *, compare=None, q=None, joint: int = 2, formats: Sequence[str] = FIGURE_FORMATS, length: str = "mm", dpi: int = 110,
                        force: bool = False) -> list[Path]:
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
    return _write_all(figs, folder, formats, dpi, force)


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


def _frame_traces(go, label: str, F: np.ndarray, ls: float, size: float, *, group: str, visible=True, dash: str = "solid", names=None, table=None, q=None,
                  textposition: str = "top right") -> list:
    """One legend group: the robot along its chain (:func:`denavit.plotting.chain_path` when ``table`` and
    ``q`` are given), the frame origins labelled once per group of coincident frames ("4,5,6",
    :func:`~denavit.plotting.frame_labels`), and the x, y, z axes of every frame (coincident frames shorter,
    :func:`~denavit.plotting.triad_lengths`, so that frame 6 does not hide frames 4 and 5)."""
    o = F[:, :3, 3]
    path = chain_path(table, q) / ls if table is not None else o / ls
    tr = [go.Scatter3d(x=path[:, 0], y=path[:, 1], z=path[:, 2], mode="lines", line={"color": "#555555", "width": 5, "dash": dash}, name=label, legendgroup=group,
                       showlegend=True, visible=visible, hoverinfo="skip")]
    labels = frame_labels(o, 0.4 * size)
    at = np.array([o[i] for i, _ in labels]) / ls
    hover = []
    for i, text in labels:
        frames = [int(k) for k in text.split(",")]
        who = ", ".join(f"frame {k}" + (f" ({names[k - 1]})" if names and k > 0 else "") for k in frames)
        p = o[i] / ls
        hover.append(f"{label}<br>{who}<br>origin {p[0]:.2f}, {p[1]:.2f}, {p[2]:.2f}")
    tr.append(go.Scatter3d(x=at[:, 0], y=at[:, 1], z=at[:, 2], mode="markers+text", text=[t for _, t in labels], textposition=textposition, textfont={"size": 11},
                           hovertext=hover, hoverinfo="text", marker={"size": 3, "color": "#555555"}, name=f"{label} origins", legendgroup=group, showlegend=False,
                           visible=visible))
    sizes = triad_lengths(o, size)
    for k in range(3):
        segs = [np.array([T[:3, 3], T[:3, 3] + sz * T[:3, k]]) for T, sz in zip(F, sizes, strict=True)]
        tr.append(_line3d(go, segs, ls, line={"color": AXIS_COLOURS[k], "width": 4, "dash": dash}, name=f"{label} {'xyz'[k]}", legendgroup=group, showlegend=False,
                          hoverinfo="skip", visible=visible))
    return tr


def _frame_points(F: np.ndarray, size: float) -> np.ndarray:
    """Origins and triad tips of frames ``F`` (what :func:`_frame_traces` draws), metres."""
    return np.vstack([F[:, :3, 3]] + [F[:, :3, 3] + size * F[:, :3, k] for k in range(3)])


def _path_traces(go, label: str, table: _core.Table, q0, joint: int, limits, ls: float, *, group: str, visible, colour: str, name: str, dash: str = "solid") -> list:
    """The path of every frame origin while ``joint`` moves (Guo et al. Fig. 3): thin, half transparent, so
    that the paths do not hide the robot they belong to."""
    values = np.linspace(limits[0], limits[1], 61)
    P = frames_along(table, q0, joint, values)[:, :, :3, 3]  # (m, n+1, 3)
    segs = [P[:, i] for i in range(P.shape[1]) if np.max(np.linalg.norm(P[:, i] - P[0, i], axis=1)) > 1e-9]
    if not segs:
        return []
    return [_line3d(go, segs, ls, line={"color": colour, "width": 2, "dash": dash}, opacity=0.55, name=name, legendgroup=group, showlegend=True, visible=visible,
                    hovertext=f"{label}: {name}", hoverinfo="text")]


def _scene_layout(length: str, points) -> dict:
    """The 3-D view's layout: axis ranges, aspect ratio and camera from the drawn points (display units,
    :func:`denavit.plotting.scene_view`), the legend on the right; the height comes from the page (CSS)."""
    v = scene_view(points)
    # no filled walls: plotly's gl3d draws a wall over the part of a text label that its glyphs' depth puts behind
    # it (a wrist frame's "4,5,6" near the back wall showed as "4,5,"); the grid alone keeps the box readable
    ax = {"showbackground": False, "gridcolor": "#c8ccd0", "exponentformat": "none", "nticks": 6}
    axes = {f"{c}axis": {"title": {"text": f"{c} [{length}]"}, "range": v["ranges"][k].tolist(), **ax} for k, c in enumerate("xyz")}
    return {
        "scene": {"aspectmode": "manual", "aspectratio": dict(zip("xyz", v["aspectratio"].tolist(), strict=True)), **axes,
                  "camera": {"eye": dict(zip("xyz", v["eye"].tolist(), strict=True)), "center": {"x": 0, "y": 0, "z": 0}, "up": {"x": 0, "y": 0, "z": 1}}},
        "margin": {"l": 0, "r": 0, "t": 10, "b": 0},
        "legend": {"groupclick": "togglegroup", "itemsizing": "constant", "font": {"size": 11}, "y": 0.94, "yanchor": "top"},
        "paper_bgcolor": "white",
        "uirevision": "view",
    }


_CONFIG = {"displaylogo": False, "responsive": True, "toImageButtonOptions": {"format": "png", "scale": 2}}
#: The partial plotly.js bundle the reports load (scatter, scatter3d, cone, ...: what they draw), gzip-compressed.
#: plotly.js-gl3d-dist-min 4.1.1 from npm, MIT licence (denavit/data/plotly-gl3d.LICENSE); its version matches
#: the plotly.js of plotly 6 and later, whose figure JSON it reads.
PLOTLY_BUNDLE = "plotly-gl3d.min.js.gz"
#: Its version (the plotly.js of plotly.py 7; figures written by plotly.py 6 and later draw with it).
PLOTLY_JS_VERSION = "4.1.1"


@functools.cache
def _bundle_base64() -> str:
    from importlib.resources import files  # noqa: PLC0415

    return base64.b64encode(files("denavit.data").joinpath(PLOTLY_BUNDLE).read_bytes()).decode("ascii")


def _figure_html(fig, div_id: str, cls: str = "plot") -> str:
    """A plotly figure as an empty <div> and its JSON (drawn by the page's one loader, :func:`_page`); the
    plotly.py template is dropped (plotly.js's defaults look the same and the page is 10 kB lighter)."""
    fig.update_layout(template="none")
    spec = fig.to_json(validate=False, pretty=False).replace("</", "<\\/")
    return f'<div id="{div_id}" class="{cls}"></div>\n<script type="application/json" class="figure" data-for="{div_id}">{spec}</script>'


# The one loader of a page: inflates the gzip'ed plotly.js bundle with the browser's DecompressionStream (no
# network, no inflater of our own), runs it once, then draws every figure from its JSON; each drawn figure's
# <div> gets data-rendered="true" (the browser tests wait for it). A failure is logged and shown on the page.
_LOADER = """(async () => {
  const bin = atob(document.getElementById('plotly-bundle').textContent.trim());
  const bytes = new Uint8Array(bin.length);
  for (let i = 0; i < bin.length; i++) bytes[i] = bin.charCodeAt(i);
  const code = await new Response(new Blob([bytes]).stream().pipeThrough(new DecompressionStream('gzip'))).text();
  const s = document.createElement('script');
  s.textContent = code;
  document.head.appendChild(s);
  for (const el of document.querySelectorAll('script.figure')) {
    const spec = JSON.parse(el.textContent), div = document.getElementById(el.dataset.for);
    await Plotly.newPlot(div, spec.data, spec.layout, %s);
    div.dataset.rendered = 'true';
  }
  document.body.dataset.rendered = 'true';
})().catch(e => {
  console.error('denavit report: the figures could not be drawn: ' + e);
  document.body.insertAdjacentHTML('afterbegin', '<p class="error">The figures could not be drawn (' + e + '); the tables below are complete.</p>');
});"""


_CSS = """
body { font-family: system-ui, -apple-system, "Segoe UI", Roboto, sans-serif; margin: 0 auto; max-width: 1400px; padding: 0 16px 40px; color: #222; }
h1 { font-size: 1.5em; margin: 16px 0 4px; } h2 { font-size: 1.2em; margin-top: 28px; border-bottom: 1px solid #ddd; } h3 { font-size: 1.05em; }
p.meta, p.hint { color: #555; margin: 4px 0; font-size: 0.92em; } p.error { color: #b00; font-weight: bold; }
div.plot3d { width: 100%; height: min(72vh, 820px); min-height: 420px; border: 1px solid #ddd; }
div.plot { width: 100%; }
table { border-collapse: collapse; margin: 8px 0 16px; font-size: 0.88em; }
caption { text-align: left; color: #555; padding: 4px 0; caption-side: top; }
th, td { border: 1px solid #d8d8d8; padding: 3px 8px; } th { background: #f2f4f6; }
td.num { text-align: right; font-variant-numeric: tabular-nums; font-family: ui-monospace, Menlo, Consolas, monospace; }
tbody tr:nth-child(even) { background: #fafbfc; }
.scroll { overflow-x: auto; }
dl.summary { display: grid; grid-template-columns: max-content auto; gap: 2px 16px; font-size: 0.95em; background: #f7f9fb; border: 1px solid #e1e5ea; padding: 10px 14px; }
dl.summary dt { color: #555; } dl.summary dd { margin: 0; }
ul.notes li { color: #8a5a00; }
footer { margin-top: 32px; color: #888; font-size: 0.85em; }
"""


def _page(title: str, meta: str, summary: str, body: str) -> str:
    """The whole page: the title, the summary (what an engineer reads first), the body, and once at the end
    the compressed plotly.js bundle with its loader (:data:`_LOADER`)."""
    loader = _LOADER % json.dumps(_CONFIG)
    return (f'<!DOCTYPE html>\n<html lang="en">\n<head>\n<meta charset="utf-8">\n<meta name="viewport" content="width=device-width, initial-scale=1">\n'
            f"<title>{html.escape(title)}</title>\n<style>{_CSS}</style>\n</head>\n<body>\n<header><h1>{html.escape(title)}</h1><p class=\"meta\">{meta}</p>"
            f"{summary}</header>\n{body}\n<footer>Written by denavit {html.escape(__version__)}. Self-contained: the page fetches nothing (plotly.js {PLOTLY_BUNDLE} "
            "is inlined, compressed).</footer>\n"
            f'<script type="application/octet-stream" id="plotly-bundle">{_bundle_base64()}</script>\n<script>{loader}</script>\n</body>\n</html>\n')


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
    traces, drawn = [], [pts, result.tool_point[None]]
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
            circle = circle_points(f.point, f.direction, f.radius)
            drawn.append(circle)
            traces.append(_line3d(go, [circle], ls, line={"color": col, "width": 3}, name=f"{nm} circle", legendgroup=grp, showlegend=False, hoverinfo="name"))
            c = f.point / ls
            traces.append(go.Scatter3d(x=[c[0]], y=[c[1]], z=[c[2]], mode="markers", marker={"size": 5, "color": col, "symbol": "circle-open", "line": {"width": 2}},
                                       name=f"{nm} centre", legendgroup=grp, showlegend=False,
                                       hovertext=f"{nm} centre {c[0]:.3f}, {c[1]:.3f}, {c[2]:.3f}<br>r = {f.radius / ls:.3f} {length}", hoverinfo="text"))
        else:
            traces.append(_line3d(go, [line_span(f.point, f.direction, s.points)], ls, line={"color": col, "width": 3}, name=f"{nm} line", legendgroup=grp, showlegend=False))
        tip = f.point + arrow * f.direction
        drawn.append(np.array([f.point - 0.3 * arrow * f.direction, tip]))
        traces.append(_line3d(go, [np.array([f.point - 0.3 * arrow * f.direction, tip])], ls, line={"color": col, "width": 6}, name=f"{nm} axis", legendgroup=grp,
                              showlegend=False, hoverinfo="name"))
        t, d = tip / ls, f.direction
        traces.append(go.Cone(x=[t[0]], y=[t[1]], z=[t[2]], u=[d[0]], v=[d[1]], w=[d[2]], anchor="tip", sizemode="absolute", sizeref=0.12 * arrow / ls,
                              colorscale=[[0, col], [1, col]], showscale=False, name=f"{nm} axis", legendgroup=grp, showlegend=False, hoverinfo="name"))
    tp = result.tool_point / ls
    traces.append(go.Scatter3d(x=[tp[0]], y=[tp[1]], z=[tp[2]], mode="markers", marker={"size": 6, "color": "black", "symbol": "diamond"}, name="tool point at home",
                               legendgroup="tool", showlegend=True))
    b = result.box
    edges = box_edges(b.center, b.axes, b.lengths)
    drawn += edges
    traces.append(_line3d(go, edges, ls, line={"color": "#444444", "width": 2}, name="bounding box (Hayat Table IV)", legendgroup="box", showlegend=True, visible="legendonly"))
    # frames of the identified convention, of the other one, and of the nominal model, at home
    conv = result.table.convention
    other = other_convention(conv)
    model = result.model()
    other_table = _core.extract(_core.axes(model, np.zeros(model.nq)), other).table
    home = result.sweeps.home
    tables = [("identified " + conv, result.table, True, "solid"), ("identified " + other, other_table, "legendonly", "dash")]
    if result.nominal is not None:
        tables.append((f"nominal {result.nominal.name} ({result.nominal.convention})", result.nominal.table, "legendonly", "dot"))
    Fs = [(label, t, t.frames(home), vis, dash, where) for (label, t, vis, dash), where in zip(tables, ("top right", "bottom left", "top left"), strict=False)]
    tri = 0.06 * scene_size(np.vstack([F[:, :3, 3] for _, _, F, _, _, _ in Fs] + [pts]))
    for label, t, F, vis, dash, where in Fs:
        traces += _frame_traces(go, label, F, ls, tri, group=f"frames-{label}", visible=vis, dash=dash, names=names, table=t, q=home, textposition=where)
        drawn.append(_frame_points(F, tri))
    n = result.axes.nq
    jp = 2 if n >= 2 else 1
    lim = sweep_range(result, jp)
    for (label, table), colour, dash in (((f"identified {conv}", result.table), "#6a3d9a", "solid"), ((f"identified {other}", other_table), "#b15928", "dash")):
        traces += _path_traces(go, label, table, home, jp, lim, ls, group=f"paths-{label}", visible="legendonly", colour=colour, dash=dash,
                               name=f"{label}: frame-origin paths, {names[jp - 1]} swept")
    fig = go.Figure(traces)
    fig.update_layout(**_scene_layout(length, np.vstack(drawn) / ls))
    return fig


def _residual_chart(go, result: Identification, ls: float, length: str):
    """Every point's residual as a marker (each is the distance of one measurement, not a curve), one colour
    per joint, each joint's points side by side; outliers as black crosses."""
    names = joint_names(result)
    fig = go.Figure()
    start = 0
    for s, f in zip(result.sweeps.sweeps, result.fits, strict=True):
        r = np.asarray(f.residuals) / ls
        x = start + np.arange(len(r))
        fig.add_trace(go.Scatter(x=x, y=r, mode="markers", name=f"{names[s.joint - 1]} (rms {f.rms / ls:.3g} {length})", marker={"color": joint_colour(s.joint - 1), "size": 6},
                                 hovertemplate=f"{names[s.joint - 1]} point %{{customdata}}: %{{y:.4f}} {length}<extra></extra>", customdata=np.arange(len(r))))
        if np.any(f.outliers):
            fig.add_trace(go.Scatter(x=x[f.outliers], y=r[f.outliers], mode="markers", marker={"color": "black", "symbol": "x", "size": 9}, showlegend=False,
                                     name=f"{names[s.joint - 1]} outliers"))
        start += len(r) + 3
    fig.update_layout(height=340, margin={"l": 70, "r": 10, "t": 40, "b": 40}, xaxis={"title": {"text": "measured point (joint by joint)"}, "showticklabels": False},
                      yaxis={"title": {"text": f"residual [{length}]"}, "exponentformat": "power", "zeroline": True},
                      title={"text": "Residual of every measured point", "font": {"size": 14}})
    return fig


def _parameter_chart(go, make_subplots, result: Identification, length: str, angle: str) -> tuple:
    """Identified - nominal (or identified) per column, only the parameters the data determine (the others
    named in the returned caption), with one-sigma bars; powers of ten written as such, never SI prefixes."""
    rows = parameter_errors(result, length, angle)
    names = joint_names(result)
    nominal = any(r.nominal is not None for r in rows)
    fig = make_subplots(rows=1, cols=len(rows), subplot_titles=[f"{r.column} [{r.unit}]" for r in rows], horizontal_spacing=0.06)
    left = []
    for k, r in enumerate(rows):
        y = clean_ticks(r.identified - r.nominal if r.nominal is not None else r.identified)
        m = r.shown
        fig.add_trace(go.Scatter(x=[names[i] for i in np.flatnonzero(m)], y=y[m], error_y={"type": "data", "array": r.sigma[m], "visible": True}, mode="markers",
                                 marker={"color": "#1f77b4", "size": 7}, name=r.column, showlegend=False,
                                 hovertemplate="%{x}: %{y:.4g} ± %{error_y.array:.2g} " + r.unit + "<extra></extra>"), row=1, col=k + 1)
        yax = {"exponentformat": "power", "zeroline": True, "zerolinecolor": "#999"}
        if r.nominal is not None:
            lim = symmetric_limit(y[m], r.sigma[m], 1e-6)
            yax["range"] = [-lim, lim]
        fig.update_yaxes(**yax, row=1, col=k + 1)
        fig.update_xaxes(categoryorder="array", categoryarray=names, range=[-0.5, len(names) - 0.5], tickangle=-30 if max(map(len, names)) > 3 else 0, row=1, col=k + 1)
        left += [f"{names[i]} {r.column} ({w})" for i, w in enumerate(r.why) if w]
    fig.update_layout(height=360, margin={"l": 50, "r": 10, "t": 70, "b": 60},
                      title={"text": ("Identified − nominal" if nominal else "Identified values") + ", error bars one sigma", "font": {"size": 14}})
    caption = ("Not drawn (in the table above): " + ", ".join(left) + ". Held: fixed by the convention or the fit (sigma 0); undetermined: one sigma beyond "
               f"{UNDETERMINED_LENGTH:.0%} of the measured extent for lengths, {UNDETERMINED_ANGLE} rad for angles, {UNDETERMINED_RATIO} for unitless screw components "
               "(the data fix a combination of such parameters, not each).") if left else ""
    return fig, caption


def _step_histogram(go, values, bins, name: str, colour: str):
    """A histogram drawn as a filled step line (the reports' partial plotly.js has no histogram trace)."""
    h, e = np.histogram(values, bins=bins)
    x = np.repeat(e, 2)[1:-1]
    y = np.repeat(h, 2)
    return go.Scatter(x=np.r_[e[0], x, e[-1]], y=np.r_[0, y, 0], mode="lines", line={"color": colour, "width": 1.5}, fill="tozeroy", opacity=0.6, name=name)


def _accuracy_section(go, result: Identification, length: str) -> tuple[str, dict | None]:
    """Accuracy before and after: the nominal model's error and the identified model's predicted error over the
    workspace (denavit.compensation.identification_accuracy), a table and a histogram. Also returns the
    summary numbers (display units) or None."""
    from .compensation import identification_accuracy  # noqa: PLC0415

    acc = identification_accuracy(result)
    if acc is None:
        return "", None
    ls = length_scale(length)
    s = acc.summary()
    rows = [f'<tr>{_td("model", label)}' + "".join(_td(k, s[key][k] / ls) for k in ("rms", "median", "p95", "max")) + "</tr>"
            for label, key in (("nominal (what the robot misses)", "nominal"), ("identified (predicted 1σ)", "identified"))]
    table = _table("accuracy", ["model", f"rms [{length}]", f"median [{length}]", f"95 % [{length}]", f"max [{length}]"], rows,
                   f"Tool position error over {s['configurations']} quasi-random configurations within the joint limits: the nominal model against the "
                   "identified one, and the identified model's error predicted from the axes' covariance (denavit.compensation).", "accuracy")
    nom, ide = np.asarray(acc.nominal) / ls, np.asarray(acc.identified) / ls
    both = np.concatenate([nom, ide])
    pos = both[both > 0]
    lo, hi = (float(pos.min()), float(pos.max())) if pos.size else (1e-6, 1.0)
    bins = np.geomspace(lo * 0.9, hi * 1.1, 41)
    fig = go.Figure([_step_histogram(go, np.maximum(v, lo), bins, name, colour)
                     for v, name, colour in ((nom, "nominal", "#c0392b"), (ide, "identified (predicted 1σ)", "#2471a3"))])
    fig.update_layout(height=320, margin={"l": 60, "r": 10, "t": 40, "b": 50},
                      xaxis={"type": "log", "title": {"text": f"tool position error [{length}]"}, "exponentformat": "power"}, yaxis={"title": {"text": "configurations"}},
                      title={"text": "Accuracy before and after identification", "font": {"size": 14}})
    return (f'<section id="accuracy-section"><h2>Accuracy</h2>{table}{_figure_html(fig, "accuracy-chart")}</section>',
            {"nominal": s["nominal"]["rms"] / ls, "identified": s["identified"]["rms"] / ls})


def report_html(result: Identification, *, length: str = "mm", angle: str = "deg", title: str | None = None) -> str:
    """The HTML text of :func:`write_report`."""
    from .identify import to_json  # noqa: PLC0415

    go, make_subplots = _plotly()
    ls = length_scale(length)
    doc = to_json(result)  # SI: scaled to length / angle below
    as_ = angle_scale(angle)
    names = joint_names(result)
    t, nt = result.table, result.nominal_table
    view = _figure_html(_identification_view(go, result, ls, length), VIEW_ID, "plot3d")
    resid = _figure_html(_residual_chart(go, result, ls, length), "residuals-chart")
    pfig, pcaption = _parameter_chart(go, make_subplots, result, length, angle)
    pchart = _figure_html(pfig, "parameters-chart") + (f'<p class="hint" id="parameters-not-drawn">{html.escape(pcaption)}</p>' if pcaption else "")

    # parameters: one row per joint and parameter, as printed by `denavit identify`
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
            rows.append(f'<tr data-joint="{html.escape(names[i])}" data-param="{c}">{_td("joint", names[i])}{_td("param", c)}{_td("unit", unit)}'
                        f'{_td("nominal", nom)}{_td("identified", value)}{_td("sigma", prow[c + "_sigma"] / sc)}{_td("difference", diff)}</tr>')
    params = _table("parameters", ["joint", "parameter", "unit", "nominal", "identified", "sigma (1σ)", "identified − nominal"], rows,
                    f"Identified {t.convention.upper()} parameters (docs/conventions.md); sigma propagated from the fits' covariance; nominal: "
                    + (f"{result.nominal.name}" if result.nominal else "none given") + ".", "parameters")
    arows = []
    for j in doc["joints"]:
        c, a = j["circle"], j["axis"]
        arows.append(f'<tr data-joint="{html.escape(j["joint"])}">{_td("joint", j["joint"])}'
                     + "".join(_td(f"point-{x}", v / ls) for x, v in zip("xyz", a["point_m"], strict=True)) + "".join(_td(f"direction-{x}", v, 6) for x, v in zip("xyz", a["direction"], strict=True))
                     + f'{_td("radius", None if c["radius_m"] is None else c["radius_m"] / ls)}{_td("arc", None if j["arc_rad"] is None else j["arc_rad"] / as_, 1)}'
                     f'{_td("rms", j["residuals"]["rms_m"] / ls)}{_td("max-residual", j["residuals"]["max_m"] / ls)}'
                     f'{_td("sigma-across", a["sigma_point_perp_m"] / ls)}{_td("sigma-direction", a["sigma_direction_rad"] / as_, 5)}{_td("n-points", j["residuals"]["n_points"], 0)}'
                     f'{_td("outliers", len(j["residuals"]["outliers"]), 0)}</tr>')
    axes_t = _table("axes", ["joint", f"point x [{length}]", f"point y [{length}]", f"point z [{length}]", "dir x [1]", "dir y [1]", "dir z [1]", f"radius [{length}]",
                             f"arc [{angle}]", f"rms [{length}]", f"max |residual| [{length}]", f"sigma across [{length}]", f"sigma direction [{angle}]", "points", "outliers"], arows,
                    f"Joint axes in the measurement frame: circle centre ({length}) and unit normal (Hayat et al. eq. 1-9), fit quality, one-sigma uncertainty.", "axes")
    b = doc["bounding_box"]
    brows = [f'<tr>{_td("l1", b["lengths_m"][0] / ls)}{_td("l2", b["lengths_m"][1] / ls)}{_td("l3", b["lengths_m"][2] / ls)}{_td("volume", b["volume_m3"])}'
             f'{_td("center", ", ".join(f"{v / ls:.3f}" for v in b["centre_m"]))}</tr>']
    box_t = _table("bounding-box", [f"l1 [{length}]", f"l2 [{length}]", f"l3 [{length}]", "volume [m³]", f"centre [{length}]"], brows,
                   "Minimum-volume oriented bounding box of all measured points (Hayat et al. Table IV).", "bounding-box")
    orows = [f"<tr>{''.join(_td(f'col-{k + 1}', v) for k, v in enumerate(row))}</tr>" for row in b["orientation"]]
    orient_t = _table("bounding-box-orientation", ["l1 axis [1]", "l2 axis [1]", "l3 axis [1]"], orows, "Orientation of the box: its axes as columns, in the measurement frame.",
                      "bounding-box")
    notes = "".join(f"<li>{html.escape(n)}</li>" for n in doc["notes"]) or "<li>none</li>"
    acc_html, acc = _accuracy_section(go, result, length)
    npts = sum(len(s.points) for s in result.sweeps.sweeps)
    summary = _summary([
        ("measured", f"{npts} points in {len(result.sweeps.sweeps)} single-joint sweeps from {doc['source']}"),
        ("model", f"{t.convention.upper()} table of {len(names)} joints, {result.method} fit; nominal: " + (result.nominal.name if result.nominal else "none")),
        *[("fit chosen", n[len("auto: "):]) for n in doc["notes"] if n.startswith("auto: ")],
        ("fit", f"residual rms {doc['rms_m'] / ls:.4g} {length}; worst axis sigma across {max(j['axis']['sigma_point_perp_m'] for j in doc['joints']) / ls:.3g} {length}"),
        *([("accuracy", f"tool position error rms {acc['nominal']:.3g} {length} with the nominal model -> {acc['identified']:.3g} {length} predicted with the "
            "identified one (1σ)")] if acc else []),
        ("tool error the table carries", f"{doc['max_tool_position_error_m'] / ls:.3g} {length}"),
        ("home", ", ".join(f"{v:.4g}" for v in np.asarray(doc["home"]) / joint_scale(result.sweeps.kinds, length, angle)) + f" ({angle} / {length}); tool point at home "
         + ", ".join(f"{v / ls:.3f}" for v in doc["tool_point_home_m"])
         + f" {length}"),
    ])
    title = title or f"denavit identification: {result.sweeps.source or 'sweeps'}"
    meta = html.escape(f"{len(names)} joints, method {result.method}, {t.convention.upper()} parameters; lengths in {length}, angles in {angle}, measurement frame.")
    body = "\n".join([
        _view_section(view, "Measured points, fitted full circles, centres and axis arrows per joint (Hayat et al. Fig. 7); frames of the identified convention "
                      "along the chain (others, the bounding box and origin paths: switch them on in the legend)."),
        f'<section id="results"><h2>Identified parameters</h2><div class="scroll">{params}</div>{pchart}</section>',
        f'<section id="fits"><h2>Joint axes and fits</h2><div class="scroll">{axes_t}</div>{resid}{_pairs_table(result.extraction.pairs, ls, length, angle)}</section>',
        f'<section id="box"><h2>Measuring volume</h2>{box_t}{orient_t}</section>',
        acc_html,
        f'<section id="notes-section"><h2>Notes</h2><ul class="notes" id="notes">{notes}</ul></section>',
    ])
    return _page(title, meta, summary, body)


def write_report(result: Identification, path, *, length: str = "mm", angle: str = "deg", title: str | None = None, force: bool = False) -> None:
    """Write the self-contained HTML report of an identification (see the module docs) to ``path``."""
    write_text(path, report_html(result, length=length, angle=angle, title=title), force=force)


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
    traces, drawn = [], []
    for i, T in enumerate(J):  # the joint axes: the geometric truth every convention is built on
        col, nm = joint_colour(i), robot.names[i]
        p, z = T[:3, 3], T[:3, 2]
        seg = np.array([p - 0.12 * size * z, p + 0.12 * size * z])
        drawn.append(seg)
        traces.append(_line3d(go, [seg], ls, line={"color": col, "width": 8}, name=f"axis {nm}", legendgroup=f"joint-{i + 1}", showlegend=True, hoverinfo="name"))
    tri = 0.07 * size
    for (label, t), F, dash, where in zip(tables, Fs, ("solid", "dash"), ("top right", "bottom left"), strict=True):
        traces += _frame_traces(go, label, F, ls, tri, group=f"frames-{label}", dash=dash, names=robot.names, table=t, q=qv, textposition=where)
        drawn += [_frame_points(F, tri), chain_path(t, qv)]
    for k in range(1, n + 1):
        lim = motion_range(robot.lower, robot.upper, qv, k, robot.table.kinds[k - 1])
        shown = False  # one legend entry per moving joint, for the paths of both conventions
        for (label, t), colour, dash in zip(tables, ("#6a3d9a", "#b15928"), ("solid", "dash"), strict=True):
            for tr in _path_traces(go, label, t, qv, k, lim, ls, group=f"paths-{k}", visible="legendonly", colour=colour, dash=dash,
                                   name=f"origin paths, {robot.names[k - 1]} moving"):
                tr.showlegend, shown = not shown, True
                traces.append(tr)
    fig = go.Figure(traces)
    fig.update_layout(**_scene_layout(length, np.vstack(drawn) / ls))
    view = _figure_html(fig, VIEW_ID, "plot3d")
    parts = []
    for idx, (label, t) in enumerate(tables):
        tid = "table-main" if idx == 0 else "table-compare"
        parts.append(f"<h3>{html.escape(label)}</h3>" + _param_table(tid, t, robot.names, length, angle, f"{t.convention} columns as in docs/conventions.md; {length}, {angle}."))
    frows = []
    for (label, _), F in zip(tables, Fs, strict=True):
        for i, T in enumerate(F):
            frows.append(f'<tr data-convention="{html.escape(label)}" data-frame="{i}">{_td("convention", label)}{_td("frame", str(i))}'
                         + "".join(_td(f"origin-{x}", v / ls) for x, v in zip("xyz", T[:3, 3], strict=True)) + "".join(_td(f"z-{x}", v) for x, v in zip("xyz", T[:3, 2], strict=True)) + "</tr>")
    frames_t = _table("frames", ["convention", "frame", f"origin x [{length}]", f"origin y [{length}]", f"origin z [{length}]", "z x [1]", "z y [1]", "z z [1]"], frows,
                      "Frame origins and z axes (unit vectors) in world at the configuration drawn (Table.frames).", "frames")
    rng = np.random.default_rng(0)
    lo = np.maximum(np.asarray(robot.lower, dtype=float), -math.pi)
    hi = np.minimum(np.asarray(robot.upper, dtype=float), math.pi)
    qs = lo + (hi - lo) * rng.random((64, n))
    ma, mb = tables[0][1].to_model(), tables[1][1].to_model()
    dmax = max(float(np.linalg.norm(_core.fk(ma, qq)[:3, 3] - _core.fk(mb, qq)[:3, 3])) for qq in np.vstack([qv, qs]))
    extra = _pairs_table(ex.pairs, ls, length, angle) if ex is not None else ""
    shown_q = qv / joint_scale(list(robot.table.kinds), length, angle)
    units = sorted({joint_unit(k, length, angle) for k in robot.table.kinds}, key=lambda u: u != angle)
    summary = _summary([("robot", f"{robot.name}: {robot.description}"), ("source", robot.source or "-"), ("conventions", " | ".join(lbl for lbl, _ in tables)),
                        ("configuration drawn", ", ".join(f"{v:.4g}" for v in shown_q) + f" ({' / '.join(units)})"),
                        ("FK agreement", f"max tool-position difference {dmax / ls:.3g} {length} over q and 64 random configurations within the limits")])
    title = title or f"denavit model: {robot.name}"
    meta = html.escape(f"{n} joints; {robot.convention} beside {tables[1][0]}; lengths in {length}, angles in {angle}.")
    body = "\n".join([
        _view_section(view, "Joint axes (coloured), the frames of both conventions along the chain (x red, y green, z blue; the second dashed; Guo et al. Figs. 6-7); "
                      "the path of every frame origin while a joint moves over its limits (Guo et al. Fig. 3) is in the legend."),
        f'<section id="tables"><h2>Parameters</h2>{"".join(parts)}{extra}</section>',
        f'<section id="frames-section"><h2>Frames</h2>{frames_t}</section>',
    ])
    return _page(title, meta, summary, body)


def write_model_report(robot: Robot, path, *, compare=None, q=None, length: str = "mm", angle: str = "deg", title: str | None = None, force: bool = False) -> None:
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
    force : bool
        Replace a read-only file, write through one with several hard links (:mod:`denavit.io.output`).
    """
    write_text(path, model_report_html(robot, compare=compare, q=q, length=length, angle=angle, title=title), force=force)


# ------------------------------------------------------------------------------------------------ calibration


def _robot_traces(go, label: str, table: _core.Table, q, ls: float, size: float, *, group: str, visible=True, dash: str = "solid", names=None,
                  textposition: str = "top right") -> tuple[list, np.ndarray]:
    """A robot's frames along its chain at ``q`` (:func:`_frame_traces`) and the points drawn (metres)."""
    F = table.frames(q)
    tr = _frame_traces(go, label, F, ls, size, group=group, visible=visible, dash=dash, names=names, table=table, q=q, textposition=textposition)
    return tr, np.vstack([_frame_points(F, size), chain_path(table, q)])


def _param_scale(unit: str, length: str, angle: str) -> tuple[float, str]:
    """SI per display unit and the unit's name of a calibration parameter ("length" | "angle" | "ratio")."""
    if unit in ("rad/(N m)", "m/N"):  # a joint compliance (calibration/compliance.py)
        return 1e-6, "urad/(N m)" if unit == "rad/(N m)" else "um/N"
    return (length_scale(length), length) if unit == "length" else (angle_scale(angle), angle) if unit == "angle" else (1.0, "1")


def calibration_report_html(res, *, length: str = "mm", angle: str = "deg", title: str | None = None) -> str:
    """The HTML text of :func:`write_calibration_report`."""
    go, _ = _plotly()
    ls = length_scale(length)
    meas, pz = res.measurements, res.parametrization
    nominal = pz.robot
    calibrated = res.robot()
    q0 = np.asarray(meas.q[0], dtype=float)
    pts = np.asarray(meas.points, dtype=float)
    test = np.zeros(len(pts), dtype=bool)
    if res.validation is not None:
        test[np.asarray(res.validation.test_indices, dtype=int)] = True
    size = scene_size(np.vstack([pts, calibrated.table.frames(q0)[:, :3, 3]]))
    traces, drawn = [], [pts]
    for mask, name, colour in ((~test, "measured (fitted)", "#1f77b4"), (test, "measured (held out)", "#ff7f0e")):
        if mask.any():
            p = pts[mask] / ls
            traces.append(go.Scatter3d(x=p[:, 0], y=p[:, 1], z=p[:, 2], mode="markers", marker={"size": 3, "color": colour}, name=name, legendgroup=name,
                                       hovertext=[meas.where[i] for i in np.flatnonzero(mask)], hoverinfo="text"))
    predicted = _core.fk_batch(res.model(), np.asarray(meas.q, dtype=float))[:, :3, 3]
    p = predicted / ls
    traces.append(go.Scatter3d(x=p[:, 0], y=p[:, 1], z=p[:, 2], mode="markers", marker={"size": 2.5, "color": "#2ca02c", "symbol": "diamond"},
                               name="predicted by the calibrated model", legendgroup="predicted", visible="legendonly"))
    tri = 0.07 * size
    tr, d = _robot_traces(go, f"calibrated {nominal.name} ({res.convention})", calibrated.table, q0, ls, tri, group="frames-calibrated", names=calibrated.names)
    traces += tr
    drawn.append(d)
    tr, _ = _robot_traces(go, f"nominal {nominal.name} ({nominal.convention})", nominal.table, q0, ls, tri, group="frames-nominal", visible="legendonly", dash="dash",
                          names=nominal.names, textposition="bottom left")
    traces += tr
    fig = go.Figure(traces)
    fig.update_layout(**_scene_layout(length, np.vstack(drawn) / ls))
    view = _figure_html(fig, VIEW_ID, "plot3d")

    rows = []
    for k, name in enumerate(res.names):
        sc, unit = _param_scale(pz.units[k], length, angle)
        nom, val, sig = res.nominal[k] / sc, res.values[k] / sc, res.sigma[k] / sc
        rows.append(f'<tr data-param="{html.escape(name)}">{_td("param", name)}{_td("unit", unit)}{_td("nominal", float(nom))}{_td("calibrated", float(val))}'
                    f'{_td("sigma", float(sig))}{_td("change", float(val - nom))}{_td("status", res.status[k])}</tr>')
    params = _table("parameters", ["parameter", "unit", "nominal", "calibrated", "sigma (1σ)", "calibrated − nominal", "status"], rows,
                    f"{res.convention.upper()} calibration parameters (docs/conventions.md, 'Calibration parametrisations'); sigma from the fit's covariance; "
                    "status: free, or why the parameter is held.", "parameters")
    r = np.linalg.norm(np.asarray(res.residuals, dtype=float).reshape(len(res.residuals), -1)[:, :3], axis=1) / ls
    rfig = go.Figure([go.Scatter(x=np.arange(len(r)), y=r, mode="markers", marker={"size": 6, "color": "#1f77b4"}, name="fitted poses",
                                 hovertemplate="pose %{x}: %{y:.4f} " + length + "<extra></extra>")])
    rfig.update_layout(height=320, margin={"l": 70, "r": 10, "t": 40, "b": 40}, xaxis={"title": {"text": "fitted pose"}},
                       yaxis={"title": {"text": f"tool position misfit [{length}]"}, "exponentformat": "power", "rangemode": "tozero"},
                       title={"text": "Misfit of every fitted pose (calibrated model)", "font": {"size": 14}})
    v = res.validation
    vtable = ""
    if v is not None:
        vrows = [f'<tr>{_td("model", label)}{_td("rms", a / ls)}{_td("max", b / ls)}</tr>'
                 for label, a, b in (("before: nominal geometry, base and tool fitted", v.before_rms, v.before_max), ("after: calibrated", v.after_rms, v.after_max))]
        vtable = _table("validation", ["model", f"rms [{length}]", f"max [{length}]"], vrows,
                        f"Tool position error on {v.n_test} held-out poses (not used by the fit) of {v.n_train + v.n_test}.", "validation")
    notes = "".join(f"<li>{html.escape(n)}</li>" for n in res.notes) or "<li>none</li>"
    free = sum(st == "free" for st in res.status)
    summary = _summary([
        ("measured", f"{meas.n} {'poses' if meas.kind == 'pose' else 'tool points'} from {meas.source}"),
        ("model", f"{res.convention.upper()} calibration of {nominal.name}: {free} of {len(res.names)} parameters free, loss {res.loss}"
         + ("" if res.converged else ", NOT converged")),
        ("fit", f"misfit rms {res.rms / ls:.4g} {length} (noise estimate {res.noise / ls:.3g} {length} per coordinate)"),
        *([("accuracy", f"held-out tool position error rms {v.before_rms / ls:.4g} -> {v.after_rms / ls:.4g} {length}, max {v.before_max / ls:.4g} -> "
            f"{v.after_max / ls:.4g} {length}")] if v is not None else []),
        *([("model chosen", res.model_choice.line(ls, length))] if getattr(res, "model_choice", None) is not None else []),
        ("identifiability", res.identifiability.summary()),
    ])
    title = title or f"denavit calibration: {meas.source}"
    meta = html.escape(f"{len(calibrated.names)} joints, {res.convention.upper()} parameters; lengths in {length}, angles in {angle}, measurement frame.")
    body = "\n".join([
        _view_section(view, "Measured tool points (held-out ones in orange) and the calibrated robot's frames along its chain at the first pose; the nominal "
                      "robot and the calibrated model's predictions are in the legend."),
        f'<section id="results"><h2>Calibrated parameters</h2><div class="scroll">{params}</div></section>',
        f'<section id="fits"><h2>Fit and validation</h2>{vtable}{_figure_html(rfig, "residuals-chart")}</section>',
        f'<section id="notes-section"><h2>Notes</h2><ul class="notes" id="notes">{notes}</ul></section>',
    ])
    return _page(title, meta, summary, body)


def write_calibration_report(res, path, *, length: str = "mm", angle: str = "deg", title: str | None = None, force: bool = False) -> Path:
    """Write the self-contained HTML report of a :class:`denavit.calibration.Calibration` to ``path``: a summary
    (what was measured, the model, the misfit, the held-out accuracy before and after), the measured points with
    the calibrated robot in 3-D, the parameter table with units and sigmas, the misfit of every pose. Returns
    the path."""
    write_text(path, calibration_report_html(res, length=length, angle=angle, title=title), force=force)
    return Path(path)


# ------------------------------------------------------------------------------------------------ compensation


#: Rows of the compensation report's target table (all of them are in the program written by ``compensate``).
TARGET_ROWS = 500


def compensation_report_html(comp, nominal: Robot, identified: Robot, *, source: str = "", where=None, length: str = "mm", angle: str = "deg",
                             title: str | None = None) -> str:
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
            traces.append(go.Scatter3d(x=p[:, 0], y=p[:, 1], z=p[:, 2], mode="markers", marker={"size": 3.5, "color": colour}, name=name, legendgroup=name,
                                       hovertext=[f"{where[i]}: error without compensation {comp.before[i] / ls:.4f} {length}" for i in np.flatnonzero(mask)], hoverinfo="text"))
    if ok.any():
        traces.append(_line3d(go, [np.array([a, b]) for a, b in zip(tgt[ok], cmd[ok], strict=True)], ls, line={"color": "#ff7f0e", "width": 3},
                              name="target -> command sent", legendgroup="commands"))
    q0 = np.asarray(comp.q_nominal[0], dtype=float)
    size = scene_size(np.vstack([tgt, nominal.table.frames(q0)[:, :3, 3]]))
    tri = 0.07 * size
    tr, d = _robot_traces(go, f"nominal {nominal.name} at target 1", nominal.table, q0, ls, tri, group="frames-nominal", names=nominal.names)
    traces += tr
    drawn.append(d)
    q1 = np.asarray(comp.q[0], dtype=float)
    if np.all(np.isfinite(q1)):
        tr, d = _robot_traces(go, f"identified {identified.name} at target 1", identified.table, q1, ls, tri, group="frames-identified", visible="legendonly",
                              dash="dash", names=identified.names, textposition="bottom left")
        traces += tr
    fig = go.Figure(traces)
    fig.update_layout(**_scene_layout(length, np.vstack(drawn) / ls))
    view = _figure_html(fig, VIEW_ID, "plot3d")

    idx = np.arange(n)
    efig = go.Figure([go.Scatter(x=idx[ok] + 1, y=np.asarray(comp.before)[ok] / ls, mode="markers", marker={"size": 6, "color": "#c0392b"}, name="without compensation")])
    if comp.predicted_after is not None:
        efig.add_trace(go.Scatter(x=idx[ok] + 1, y=np.asarray(comp.predicted_after)[ok] / ls, mode="markers", marker={"size": 6, "color": "#2471a3"},
                                  name="with compensation (predicted 1σ)"))
    efig.update_layout(height=320, margin={"l": 70, "r": 10, "t": 40, "b": 40}, xaxis={"title": {"text": "target"}},
                       yaxis={"title": {"text": f"tool position error [{length}]"}, "exponentformat": "power", "rangemode": "tozero"},
                       title={"text": "Position error of every target the robot can be sent", "font": {"size": 14}})
    rows = []
    for i in range(min(n, TARGET_ROWS)):
        flags = ", ".join(x for x, f in (("unreachable", not comp.reached[i]), ("branch changed", comp.branch_changed[i]), ("path jump", comp.path_jump[i])) if f)
        rows.append(f'<tr data-target="{i + 1}">{_td("target", where[i])}{_td("before", float(comp.before[i]) / ls)}{_td("shift", float(np.linalg.norm(cmd[i] - tgt[i])) / ls)}'
                    f'{_td("residual", float(comp.residual[i]) / ls)}{_td("flags", flags or "ok")}</tr>')
    targets_t = _table("targets", ["target", f"error without compensation [{length}]", f"command shift [{length}]", f"solve residual [{length}]", "flags"], rows,
                       f"Per target (first {TARGET_ROWS} of {n})" if n > TARGET_ROWS else "Per target.", "targets")
    before = np.asarray(comp.before)[ok] / ls
    summary = _summary([
        ("program", f"{n} targets" + (f" from {source}" if source else "") + f"; {int((~ok).sum())} flagged (unreachable, branch changed or path jump)"),
        ("models", f"controller's nominal {nominal.name} -> identified {identified.name}"),
        *([("accuracy", f"tool position error without compensation rms {np.sqrt(np.mean(before ** 2)):.4g} {length}, max {before.max():.4g} {length}; "
            f"with it: solve residual max {np.asarray(comp.residual)[ok].max() / ls:.3g} {length}"
            + (f", predicted rms {np.sqrt(np.mean((np.asarray(comp.predicted_after)[ok] / ls) ** 2)):.3g} {length} (1σ)" if comp.predicted_after is not None else ""))]
          if ok.any() else [("accuracy", "no target can be sent")]),
    ])
    title = title or "denavit compensation" + (f": {source}" if source else "")
    meta = html.escape(f"{n} targets; lengths in {length}, angles in {angle}, robot base frame.")
    body = "\n".join([
        _view_section(view, "The program's targets (flagged ones red), the shift from each target to the command sent (orange), the nominal robot at the "
                      "first target; the identified robot is in the legend."),
        f'<section id="errors"><h2>Errors</h2>{_figure_html(efig, "errors-chart")}</section>',
        f'<section id="targets-section"><h2>Targets</h2><div class="scroll">{targets_t}</div></section>',
    ])
    return _page(title, meta, summary, body)


def write_compensation_report(comp, nominal: Robot, identified: Robot, path, *, source: str = "", where=None, length: str = "mm", angle: str = "deg",
                              title: str | None = None, force: bool = False) -> Path:
    """Write the self-contained HTML report of a :class:`denavit.compensation.Compensation` (of ``nominal`` ->
    ``identified`` robots) to ``path``: a summary (targets, flagged ones, the error without compensation and
    after it), the targets and the commands in 3-D with the robot, the error of every target, the table of
    targets (``where``: a label per target, e.g. "file:line"). Returns the path."""
    write_text(path, compensation_report_html(comp, nominal, identified, source=source, where=where, length=length, angle=angle, title=title), force=force)
    return Path(path)


__all__ = [
    "DECIMALS",
    "FIGURE_FORMATS",
    "PLOTLY_BUNDLE",
    "PLOTLY_JS_VERSION",
    "TARGET_ROWS",
    "VIEW_ID",
    "calibration_report_html",
    "compensation_report_html",
    "fmt_value",
    "model_report_html",
    "report_html",
    "write_calibration_report",
    "write_compensation_report",
    "write_figures",
    "write_model_figures",
    "write_model_report",
    "write_report",
]
