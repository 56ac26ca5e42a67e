"""A robot's report and figures: its frames beside another convention's or robot's, the frame origins' paths
(:func:`write_model_report`, :func:`write_model_figures`)."""

from __future__ import annotations

import html
import math
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from .. import _core
from ..errors import DenavitError
from ..io.output import write_text
from ..io.robots import load
from ..io.units import joint_scale, joint_unit, length_scale
from ..plotting import (
    chain_path,
    joint_colour,
    motion_range,
    other_convention,
    scene_size,
)
from ..robot import Robot
from .html import (
    FIGURE_FORMATS,
    VIEW_ID,
    _figure_html,
    _frame_points,
    _frame_traces,
    _line3d,
    _page,
    _pairs_table,
    _param_table,
    _path_traces,
    _plotly,
    _scene_layout,
    _summary,
    _table,
    _td,
    _view_section,
    _write_all,
)


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
    conv = (
        other_convention(robot.convention)
        if compare is None
        else _convention(compare)
        if isinstance(compare, str)
        else None
    )
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


def write_model_figures(
    robot: Robot,
    folder,
    *,
    compare=None,
    q=None,
    joint: int = 2,
    formats: Sequence[str] = FIGURE_FORMATS,
    length: str = "mm",
    dpi: int = 110,
    force: bool = False,
) -> list[Path]:
    """Write ``frames`` (the robot beside ``compare``, see :func:`write_model_report`) and ``origin_paths``
    (joint ``joint`` over its limits) into ``folder``. ``q`` : (n,) rad / m, default the robot's home or zeros."""
    from ..plotting import plot_frames, plot_origin_paths  # noqa: PLC0415

    tables, _ = _compare_tables(robot, compare)
    n = len(robot.names)
    qv = _model_q(robot, q)
    joint = min(max(joint, 1), n)
    lim = motion_range(robot.lower, robot.upper, qv, joint, robot.table.kinds[joint - 1])
    figs = {
        "frames": plot_frames(
            tables, qv, length=length, title=f"{robot.name}: frames of each convention (x red, y green, z blue)"
        ),
        "origin_paths": plot_origin_paths(tables, joint, qv, limits=lim, length=length),
    }
    return _write_all(figs, folder, formats, dpi, force)


# ------------------------------------------------------------------------------------------------ model


def _model_q(robot: Robot, q) -> np.ndarray:
    n = len(robot.names)
    qv = (robot.home if robot.home is not None else np.zeros(n)) if q is None else np.asarray(q, dtype=float)
    if qv.shape != (n,):
        raise DenavitError(f"q: expected {n} joint values for {robot.name}, got shape {qv.shape}")
    return qv


def model_report_html(
    robot: Robot, *, compare=None, q=None, length: str = "mm", angle: str = "deg", title: str | None = None
) -> str:
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
        traces.append(
            _line3d(
                go,
                [seg],
                ls,
                line={"color": col, "width": 8},
                name=f"axis {nm}",
                legendgroup=f"joint-{i + 1}",
                showlegend=True,
                hoverinfo="name",
            )
        )
    tri = 0.07 * size
    for (label, t), F, dash, where in zip(tables, Fs, ("solid", "dash"), ("top right", "bottom left"), strict=True):
        traces += _frame_traces(
            go,
            label,
            F,
            ls,
            tri,
            group=f"frames-{label}",
            dash=dash,
            names=robot.names,
            table=t,
            q=qv,
            textposition=where,
        )
        drawn += [_frame_points(F, tri), chain_path(t, qv)]
    for k in range(1, n + 1):
        lim = motion_range(robot.lower, robot.upper, qv, k, robot.table.kinds[k - 1])
        shown = False  # one legend entry per moving joint, for the paths of both conventions
        for (label, t), colour, dash in zip(tables, ("#6a3d9a", "#b15928"), ("solid", "dash"), strict=True):
            for tr in _path_traces(
                go,
                label,
                t,
                qv,
                k,
                lim,
                ls,
                group=f"paths-{k}",
                visible="legendonly",
                colour=colour,
                dash=dash,
                name=f"origin paths, {robot.names[k - 1]} moving",
            ):
                tr.showlegend, shown = not shown, True
                traces.append(tr)
    fig = go.Figure(traces)
    fig.update_layout(**_scene_layout(length, np.vstack(drawn) / ls))
    view = _figure_html(fig, VIEW_ID, "plot3d")
    parts = []
    for idx, (label, t) in enumerate(tables):
        tid = "table-main" if idx == 0 else "table-compare"
        parts.append(
            f"<h3>{html.escape(label)}</h3>"
            + _param_table(
                tid,
                t,
                robot.names,
                length,
                angle,
                f"{t.convention} columns as in docs/conventions.md; {length}, {angle}.",
            )
        )
    frows = []
    for (label, _), F in zip(tables, Fs, strict=True):
        for i, T in enumerate(F):
            frows.append(
                f'<tr data-convention="{html.escape(label)}"'
                f' data-frame="{i}">{_td("convention", label)}{_td("frame", str(i))}'
                + "".join(_td(f"origin-{x}", v / ls) for x, v in zip("xyz", T[:3, 3], strict=True))
                + "".join(_td(f"z-{x}", v) for x, v in zip("xyz", T[:3, 2], strict=True))
                + "</tr>"
            )
    frames_t = _table(
        "frames",
        [
            "convention",
            "frame",
            f"origin x [{length}]",
            f"origin y [{length}]",
            f"origin z [{length}]",
            "z x [1]",
            "z y [1]",
            "z z [1]",
        ],
        frows,
        "Frame origins and z axes (unit vectors) in world at the configuration drawn (Table.frames).",
        "frames",
    )
    rng = np.random.default_rng(0)
    lo = np.maximum(np.asarray(robot.lower, dtype=float), -math.pi)
    hi = np.minimum(np.asarray(robot.upper, dtype=float), math.pi)
    qs = lo + (hi - lo) * rng.random((64, n))
    ma, mb = tables[0][1].to_model(), tables[1][1].to_model()
    dmax = max(float(np.linalg.norm(_core.fk(ma, qq)[:3, 3] - _core.fk(mb, qq)[:3, 3])) for qq in np.vstack([qv, qs]))
    extra = _pairs_table(ex.pairs, ls, length, angle) if ex is not None else ""
    shown_q = qv / joint_scale(list(robot.table.kinds), length, angle)
    units = sorted({joint_unit(k, length, angle) for k in robot.table.kinds}, key=lambda u: u != angle)
    summary = _summary(
        [
            ("robot", f"{robot.name}: {robot.description}"),
            ("source", robot.source or "-"),
            ("conventions", " | ".join(lbl for lbl, _ in tables)),
            ("configuration drawn", ", ".join(f"{v:.4g}" for v in shown_q) + f" ({' / '.join(units)})"),
            (
                "FK agreement",
                (
                    f"max tool-position difference {dmax / ls:.3g} {length} over q and 64 random configurations within"
                    " the limits"
                ),
            ),
        ]
    )
    title = title or f"denavit model: {robot.name}"
    meta = html.escape(f"{n} joints; {robot.convention} beside {tables[1][0]}; lengths in {length}, angles in {angle}.")
    body = "\n".join(
        [
            _view_section(
                view,
                "Joint axes (coloured), the frames of both conventions along the chain (x red, y green, z blue; the"
                " second dashed; Guo et al. Figs. 6-7); the path of every frame origin while a joint moves over its"
                " limits (Guo et al. Fig. 3) is in the legend.",
            ),
            f'<section id="tables"><h2>Parameters</h2>{"".join(parts)}{extra}</section>',
            f'<section id="frames-section"><h2>Frames</h2>{frames_t}</section>',
        ]
    )
    return _page(title, meta, summary, body)


def write_model_report(
    robot: Robot,
    path,
    *,
    compare=None,
    q=None,
    length: str = "mm",
    angle: str = "deg",
    title: str | None = None,
    force: bool = False,
) -> None:
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
    write_text(
        path, model_report_html(robot, compare=compare, q=q, length=length, angle=angle, title=title), force=force
    )
