"""The report of a whole-model calibration (:func:`write_calibration_report`)."""

from __future__ import annotations

import html
from pathlib import Path

import numpy as np

from .. import _core
from ..io.output import write_text
from ..io.units import length_scale
from ..plotting import (
    scene_size,
)
from .html import (
    VIEW_ID,
    _figure_html,
    _page,
    _param_scale,
    _plotly,
    _robot_traces,
    _scene_layout,
    _summary,
    _table,
    _td,
    _view_section,
)


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
            traces.append(
                go.Scatter3d(
                    x=p[:, 0],
                    y=p[:, 1],
                    z=p[:, 2],
                    mode="markers",
                    marker={"size": 3, "color": colour},
                    name=name,
                    legendgroup=name,
                    hovertext=[meas.where[i] for i in np.flatnonzero(mask)],
                    hoverinfo="text",
                )
            )
    predicted = _core.fk_batch(res.model(), np.asarray(meas.q, dtype=float))[:, :3, 3]
    p = predicted / ls
    traces.append(
        go.Scatter3d(
            x=p[:, 0],
            y=p[:, 1],
            z=p[:, 2],
            mode="markers",
            marker={"size": 2.5, "color": "#2ca02c", "symbol": "diamond"},
            name="predicted by the calibrated model",
            legendgroup="predicted",
            visible="legendonly",
        )
    )
    tri = 0.07 * size
    tr, d = _robot_traces(
        go,
        f"calibrated {nominal.name} ({res.convention})",
        calibrated.table,
        q0,
        ls,
        tri,
        group="frames-calibrated",
        names=calibrated.names,
    )
    traces += tr
    drawn.append(d)
    tr, _ = _robot_traces(
        go,
        f"nominal {nominal.name} ({nominal.convention})",
        nominal.table,
        q0,
        ls,
        tri,
        group="frames-nominal",
        visible="legendonly",
        dash="dash",
        names=nominal.names,
        textposition="bottom left",
    )
    traces += tr
    fig = go.Figure(traces)
    fig.update_layout(**_scene_layout(length, np.vstack(drawn) / ls))
    view = _figure_html(fig, VIEW_ID, "plot3d")

    rows = []
    for k, name in enumerate(res.names):
        sc, unit = _param_scale(pz.units[k], length, angle)
        nom, val, sig = res.nominal[k] / sc, res.values[k] / sc, res.sigma[k] / sc
        rows.append(
            f'<tr data-param="{html.escape(name)}">{_td("param", name)}{_td("unit", unit)}{_td("nominal", float(nom))}{_td("calibrated", float(val))}'
            f"{_td('sigma', float(sig))}{_td('change', float(val - nom))}{_td('status', res.status[k])}</tr>"
        )
    params = _table(
        "parameters",
        ["parameter", "unit", "nominal", "calibrated", "sigma (1σ)", "calibrated − nominal", "status"],
        rows,
        f"{res.convention.upper()} calibration parameters (docs/conventions.md, 'Calibration parametrisations'); sigma from the fit's covariance; "
        "status: free, or why the parameter is held.",
        "parameters",
    )
    r = np.linalg.norm(np.asarray(res.residuals, dtype=float).reshape(len(res.residuals), -1)[:, :3], axis=1) / ls
    rfig = go.Figure(
        [
            go.Scatter(
                x=np.arange(len(r)),
                y=r,
                mode="markers",
                marker={"size": 6, "color": "#1f77b4"},
                name="fitted poses",
                hovertemplate="pose %{x}: %{y:.4f} " + length + "<extra></extra>",
            )
        ]
    )
    rfig.update_layout(
        height=320,
        margin={"l": 70, "r": 10, "t": 40, "b": 40},
        xaxis={"title": {"text": "fitted pose"}},
        yaxis={"title": {"text": f"tool position misfit [{length}]"}, "exponentformat": "power", "rangemode": "tozero"},
        title={"text": "Misfit of every fitted pose (calibrated model)", "font": {"size": 14}},
    )
    v = res.validation
    vtable = ""
    if v is not None:
        vrows = [
            f"<tr>{_td('model', label)}{_td('rms', a / ls)}{_td('max', b / ls)}</tr>"
            for label, a, b in (
                ("before: nominal geometry, base and tool fitted", v.before_rms, v.before_max),
                ("after: calibrated", v.after_rms, v.after_max),
            )
        ]
        vtable = _table(
            "validation",
            ["model", f"rms [{length}]", f"max [{length}]"],
            vrows,
            f"Tool position error on {v.n_test} held-out poses (not used by the fit) of {v.n_train + v.n_test}.",
            "validation",
        )
    notes = "".join(f"<li>{html.escape(n)}</li>" for n in res.notes) or "<li>none</li>"
    free = sum(st == "free" for st in res.status)
    summary = _summary(
        [
            ("measured", f"{meas.n} {'poses' if meas.kind == 'pose' else 'tool points'} from {meas.source}"),
            (
                "model",
                f"{res.convention.upper()} calibration of {nominal.name}: {free} of {len(res.names)} parameters free, loss {res.loss}"
                + ("" if res.converged else ", NOT converged"),
            ),
            (
                "fit",
                f"misfit rms {res.rms / ls:.4g} {length} (noise estimate {res.noise / ls:.3g} {length} per coordinate)",
            ),
            *(
                [
                    (
                        "accuracy",
                        f"held-out tool position error rms {v.before_rms / ls:.4g} -> {v.after_rms / ls:.4g} {length}, max {v.before_max / ls:.4g} -> "
                        f"{v.after_max / ls:.4g} {length}",
                    )
                ]
                if v is not None
                else []
            ),
            *(
                [("model chosen", res.model_choice.line(ls, length))]
                if getattr(res, "model_choice", None) is not None
                else []
            ),
            ("identifiability", res.identifiability.summary()),
        ]
    )
    title = title or f"denavit calibration: {meas.source}"
    meta = html.escape(
        f"{len(calibrated.names)} joints, {res.convention.upper()} parameters; lengths in {length}, angles in {angle}, measurement frame."
    )
    body = "\n".join(
        [
            _view_section(
                view,
                "Measured tool points (held-out ones in orange) and the calibrated robot's frames along its chain at the first pose; the nominal "
                "robot and the calibrated model's predictions are in the legend.",
            ),
            f'<section id="results"><h2>Calibrated parameters</h2><div class="scroll">{params}</div></section>',
            f'<section id="fits"><h2>Fit and validation</h2>{vtable}{_figure_html(rfig, "residuals-chart")}</section>',
            f'<section id="notes-section"><h2>Notes</h2><ul class="notes" id="notes">{notes}</ul></section>',
        ]
    )
    return _page(title, meta, summary, body)


def write_calibration_report(
    res, path, *, length: str = "mm", angle: str = "deg", title: str | None = None, force: bool = False
) -> Path:
    """Write the self-contained HTML report of a :class:`denavit.calibration.Calibration` to ``path``: a summary
    (what was measured, the model, the misfit, the held-out accuracy before and after), the measured points with
    the calibrated robot in 3-D, the parameter table with units and sigmas, the misfit of every pose. Returns
    the path."""
    write_text(path, calibration_report_html(res, length=length, angle=angle, title=title), force=force)
    return Path(path)
