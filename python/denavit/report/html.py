"""The shared parts of every report: figures written whole, the HTML page (its one loader of the inlined plotly bundle,
style and tables), the 3-D scene helpers."""

from __future__ import annotations

import base64
import functools
import html
import json
from collections.abc import Sequence
from pathlib import Path
from typing import NamedTuple

import numpy as np

from .. import _core
from .._core import __version__
from ..errors import DenavitError
from ..io.output import atomic_path
from ..io.units import angle_scale, cell_scale, column_scale, length_scale
from ..plotting import (
    AXIS_COLOURS,
    chain_path,
    frame_labels,
    frames_along,
    install_hint,
    scene_size,
    scene_view,
    triad_lengths,
)

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


# ------------------------------------------------------------------------------------------------ HTML helpers


def _plotly():
    try:
        import plotly.graph_objects as go  # noqa: PLC0415
        from plotly.subplots import make_subplots  # noqa: PLC0415
    except ImportError as e:
        raise DenavitError(f"the HTML report needs plotly, which is not installed ({e}): {install_hint()}") from None
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
    return (
        f'<table id="{tid}" class="{cls}">{cap}<thead><tr>{head}</tr></thead><tbody>\n'
        + "\n".join(rows)
        + "\n</tbody></table>"
    )


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


def _frame_traces(
    go,
    label: str,
    F: np.ndarray,
    ls: float,
    size: float,
    *,
    group: str,
    visible=True,
    dash: str = "solid",
    names=None,
    table=None,
    q=None,
    textposition: str = "top right",
) -> list:
    """One legend group: the robot along its chain (:func:`denavit.plotting.chain_path` when ``table`` and
    ``q`` are given), the frame origins labelled once per group of coincident frames ("4,5,6",
    :func:`~denavit.plotting.frame_labels`), and the x, y, z axes of every frame (coincident frames shorter,
    :func:`~denavit.plotting.triad_lengths`, so that frame 6 does not hide frames 4 and 5)."""
    o = F[:, :3, 3]
    path = chain_path(table, q) / ls if table is not None else o / ls
    tr = [
        go.Scatter3d(
            x=path[:, 0],
            y=path[:, 1],
            z=path[:, 2],
            mode="lines",
            line={"color": "#555555", "width": 5, "dash": dash},
            name=label,
            legendgroup=group,
            showlegend=True,
            visible=visible,
            hoverinfo="skip",
        )
    ]
    labels = frame_labels(o, 0.4 * size)
    at = np.array([o[i] for i, _ in labels]) / ls
    hover = []
    for i, text in labels:
        frames = [int(k) for k in text.split(",")]
        who = ", ".join(f"frame {k}" + (f" ({names[k - 1]})" if names and k > 0 else "") for k in frames)
        p = o[i] / ls
        hover.append(f"{label}<br>{who}<br>origin {p[0]:.2f}, {p[1]:.2f}, {p[2]:.2f}")
    tr.append(
        go.Scatter3d(
            x=at[:, 0],
            y=at[:, 1],
            z=at[:, 2],
            mode="markers+text",
            text=[t for _, t in labels],
            textposition=textposition,
            textfont={"size": 11},
            hovertext=hover,
            hoverinfo="text",
            marker={"size": 3, "color": "#555555"},
            name=f"{label} origins",
            legendgroup=group,
            showlegend=False,
            visible=visible,
        )
    )
    sizes = triad_lengths(o, size)
    for k in range(3):
        segs = [np.array([T[:3, 3], T[:3, 3] + sz * T[:3, k]]) for T, sz in zip(F, sizes, strict=True)]
        tr.append(
            _line3d(
                go,
                segs,
                ls,
                line={"color": AXIS_COLOURS[k], "width": 4, "dash": dash},
                name=f"{label} {'xyz'[k]}",
                legendgroup=group,
                showlegend=False,
                hoverinfo="skip",
                visible=visible,
            )
        )
    return tr


def _frame_points(F: np.ndarray, size: float) -> np.ndarray:
    """Origins and triad tips of frames ``F`` (what :func:`_frame_traces` draws), metres."""
    return np.vstack([F[:, :3, 3]] + [F[:, :3, 3] + size * F[:, :3, k] for k in range(3)])


def _path_traces(
    go,
    label: str,
    table: _core.Table,
    q0,
    joint: int,
    limits,
    ls: float,
    *,
    group: str,
    visible,
    colour: str,
    name: str,
    dash: str = "solid",
) -> list:
    """The path of every frame origin while ``joint`` moves (Guo et al. Fig. 3): thin, half transparent, so
    that the paths do not hide the robot they belong to."""
    values = np.linspace(limits[0], limits[1], 61)
    P = frames_along(table, q0, joint, values)[:, :, :3, 3]  # (m, n+1, 3)
    segs = [P[:, i] for i in range(P.shape[1]) if np.max(np.linalg.norm(P[:, i] - P[0, i], axis=1)) > 1e-9]
    if not segs:
        return []
    return [
        _line3d(
            go,
            segs,
            ls,
            line={"color": colour, "width": 2, "dash": dash},
            opacity=0.55,
            name=name,
            legendgroup=group,
            showlegend=True,
            visible=visible,
            hovertext=f"{label}: {name}",
            hoverinfo="text",
        )
    ]


def _scene_layout(length: str, points) -> dict:
    """The 3-D view's layout: axis ranges, aspect ratio and camera from the drawn points (display units,
    :func:`denavit.plotting.scene_view`), the legend on the right; the height comes from the page (CSS)."""
    v = scene_view(points)
    # no filled walls: plotly's gl3d draws a wall over the part of a text label that its glyphs' depth puts behind
    # it (a wrist frame's "4,5,6" near the back wall showed as "4,5,"); the grid alone keeps the box readable
    ax = {"showbackground": False, "gridcolor": "#c8ccd0", "exponentformat": "none", "nticks": 6}
    axes = {
        f"{c}axis": {"title": {"text": f"{c} [{length}]"}, "range": v["ranges"][k].tolist(), **ax}
        for k, c in enumerate("xyz")
    }
    return {
        "scene": {
            "aspectmode": "manual",
            "aspectratio": dict(zip("xyz", v["aspectratio"].tolist(), strict=True)),
            **axes,
            "camera": {
                "eye": dict(zip("xyz", v["eye"].tolist(), strict=True)),
                "center": {"x": 0, "y": 0, "z": 0},
                "up": {"x": 0, "y": 0, "z": 1},
            },
        },
        "margin": {"l": 0, "r": 0, "t": 10, "b": 0},
        "legend": {
            "groupclick": "togglegroup",
            "itemsizing": "constant",
            "font": {"size": 11},
            "y": 0.94,
            "yanchor": "top",
        },
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
    return (
        f'<div id="{div_id}" class="{cls}"></div>\n'
        f'<script type="application/json" class="figure" data-for="{div_id}">{spec}</script>'
    )


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
});"""  # noqa: E501 (the page's script, its lines whole)


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
"""  # noqa: E501 (the style sheet, one rule per line)


def _page(title: str, meta: str, summary: str, body: str) -> str:
    """The whole page: the title, the summary (what an engineer reads first), the body, and once at the end
    the compressed plotly.js bundle with its loader (:data:`_LOADER`)."""
    loader = _LOADER % json.dumps(_CONFIG)
    return (
        '<!DOCTYPE html>\n<html lang="en">\n<head>\n<meta charset="utf-8">\n'
        '<meta name="viewport" content="width=device-width, initial-scale=1">\n'
        f"<title>{html.escape(title)}</title>\n<style>{_CSS}</style>\n</head>\n<body>\n"
        f'<header><h1>{html.escape(title)}</h1><p class="meta">{meta}</p>'
        f"{summary}</header>\n{body}\n<footer>Written by denavit {html.escape(__version__)}. "
        f"Self-contained: the page fetches nothing (plotly.js {PLOTLY_BUNDLE} "
        "is inlined, compressed).</footer>\n"
        f'<script type="application/octet-stream" id="plotly-bundle">{_bundle_base64()}</script>\n'
        f"<script>{loader}</script>\n</body>\n</html>\n"
    )


def _summary(items: Sequence[tuple[str, str]]) -> str:
    return (
        '<dl class="summary" id="summary">'
        + "".join(f"<dt>{html.escape(k)}</dt><dd>{html.escape(v)}</dd>" for k, v in items)
        + "</dl>"
    )


def _notes_html(notes: Sequence[str]) -> str:
    """The notes as warning-coloured bullets; no notes: a plain "none", not a warning-coloured bullet."""
    items = "".join(f"<li>{html.escape(n)}</li>" for n in notes)
    return f'<ul class="notes" id="notes">{items}</ul>' if items else '<p class="none" id="notes">none</p>'


def _view_section(view_html: str, what: str) -> str:
    return (
        f'<section id="view"><h2>3-D view</h2><p class="hint">{html.escape(what)} Drag to rotate, scroll to zoom, '
        "right-drag to pan; click a legend entry to show or hide that joint or convention, double-click to show it "
        f"alone.</p>\n{view_html}\n</section>"
    )


def _pairs_table(pairs, ls: float, length: str, angle: str) -> str:
    a = angle_scale(angle)
    rows = [
        f'<tr data-pair="{p.joint}">{_td("pair", f"{p.joint}-{p.joint + 1}")}{_td("relation", p.relation)}'
        f"{_td('angle', p.angle / a)}{_td('distance', p.distance / ls)}"
        f"{_td('hayati-beta', p.hayati_beta / a)}</tr>"
        for p in pairs
    ]
    return _table(
        "pairs",
        ["axes", "relation", f"angle [{angle}]", f"distance [{length}]", f"Hayati beta [{angle}]"],
        rows,
        "Consecutive joint axes (docs/conventions.md: parallel / intersecting / skew, the common normal's length).",
        "pairs",
    )


def _param_table(tid: str, table: _core.Table, names: Sequence[str], length: str, angle: str, caption: str) -> str:
    sc = [column_scale(table, k, length, angle) for k in range(len(table.columns))]
    rows = []
    for i, (nm, kind, row) in enumerate(zip(names, table.kinds, table.params, strict=True)):
        cells = "".join(
            _td(c, v / cell_scale(table, i, k, length, angle)[0])
            for k, (c, v) in enumerate(zip(table.columns, row, strict=True))
        )
        rows.append(f'<tr data-joint="{html.escape(nm)}">{_td("joint", nm)}{_td("kind", kind)}{cells}</tr>')
    header = ["joint", "kind"] + [f"{c} [{u}]" for c, (_, u) in zip(table.columns, sc, strict=True)]
    return _table(tid, header, rows, caption, f"parameters {table.convention}")


# ------------------------------------------------------------------------------------------------ calibration


def _robot_traces(
    go,
    label: str,
    table: _core.Table,
    q,
    ls: float,
    size: float,
    *,
    group: str,
    visible=True,
    dash: str = "solid",
    names=None,
    textposition: str = "top right",
) -> tuple[list, np.ndarray]:
    """A robot's frames along its chain at ``q`` (:func:`_frame_traces`) and the points drawn (metres)."""
    F = table.frames(q)
    tr = _frame_traces(
        go,
        label,
        F,
        ls,
        size,
        group=group,
        visible=visible,
        dash=dash,
        names=names,
        table=table,
        q=q,
        textposition=textposition,
    )
    return tr, np.vstack([_frame_points(F, size), chain_path(table, q)])


class SceneRobot(NamedTuple):
    """A robot drawn in a 3-D view by :func:`_robot_scene`: its legend ``label`` and ``group``, the ``table`` drawn
    at joint values ``q`` (SI), and the joint ``names`` of its hover texts."""

    label: str
    group: str
    table: _core.Table
    q: np.ndarray
    names: Sequence[str]


def _marker_groups(go, points, groups, ls: float, *, size: float, hover) -> list:
    """Markers of ``points`` ((m, 3), metres), one trace and legend group per ``(mask, name, colour)`` of
    ``groups`` that selects any point; ``hover(i)`` is the hover text of point ``i``."""
    traces = []
    for mask, name, colour in groups:
        if mask.any():
            p = points[mask] / ls
            traces.append(
                go.Scatter3d(
                    x=p[:, 0],
                    y=p[:, 1],
                    z=p[:, 2],
                    mode="markers",
                    marker={"size": size, "color": colour},
                    name=name,
                    legendgroup=name,
                    hovertext=[hover(i) for i in np.flatnonzero(mask)],
                    hoverinfo="text",
                )
            )
    return traces


def _robot_scene(
    go, traces: list, points, ls: float, length: str, shown: SceneRobot, other: SceneRobot | None, *, also=()
) -> str:
    """The 3-D view of the calibration and compensation reports, as HTML: ``traces`` (the points measured or
    aimed at), then the ``shown`` robot's frames along its chain and the ``other`` robot's in the legend (dashed,
    labels below left). Triads are 7 % of the extent of ``points`` and the shown robot (metres); the camera
    frames ``points``, the arrays of ``also`` (metres) and the shown robot (:func:`_scene_layout`)."""
    size = scene_size(np.vstack([points, shown.table.frames(shown.q)[:, :3, 3]]))
    tri = 0.07 * size
    tr, d = _robot_traces(go, shown.label, shown.table, shown.q, ls, tri, group=shown.group, names=shown.names)
    traces = [*traces, *tr]
    if other is not None:
        tr, _ = _robot_traces(
            go,
            other.label,
            other.table,
            other.q,
            ls,
            tri,
            group=other.group,
            visible="legendonly",
            dash="dash",
            names=other.names,
            textposition="bottom left",
        )
        traces += tr
    fig = go.Figure(traces)
    fig.update_layout(**_scene_layout(length, np.vstack([points, *also, d]) / ls))
    return _figure_html(fig, VIEW_ID, "plot3d")


def _param_scale(unit: str, length: str, angle: str) -> tuple[float, str]:
    """SI per display unit and the unit's name of a calibration parameter ("length" | "angle" | "ratio")."""
    if unit in ("rad/(N m)", "m/N"):  # a joint compliance (calibration/compliance.py)
        return 1e-6, "urad/(N m)" if unit == "rad/(N m)" else "um/N"
    return (
        (length_scale(length), length)
        if unit == "length"
        else (angle_scale(angle), angle)
        if unit == "angle"
        else (1.0, "1")
    )


# ------------------------------------------------------------------------------------------------ compensation
