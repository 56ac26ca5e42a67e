"""The report of a whole-model calibration (:func:`write_calibration_report`)."""

from __future__ import annotations

import html
from pathlib import Path

import numpy as np

from .. import _core
from ..io.output import write_text
from ..io.units import length_scale
from .html import (
    SceneRobot,
    _figure_html,
    _marker_groups,
    _notes_html,
    _page,
    _param_scale,
    _plotly,
    _robot_scene,
    _summary,
    _table,
    _td,
    _view_section,
)


def _calibration_view(go, res, ls: float, length: str) -> str:
    """The 3-D view: the measured tool points (held-out ones in orange), the calibrated model's predictions and the
    nominal robot in the legend, the calibrated robot's frames along its chain at the first pose."""
    meas, nominal = res.measurements, res.parametrization.robot
    calibrated = res.robot()
    q0 = np.asarray(meas.q[0], dtype=float)
    pts = np.asarray(meas.points, dtype=float)
    test = np.zeros(len(pts), dtype=bool)
    if res.validation is not None:
        test[np.asarray(res.validation.test_indices, dtype=int)] = True
    groups = ((~test, "measured (fitted)", "#1f77b4"), (test, "measured (held out)", "#ff7f0e"))
    traces = _marker_groups(go, pts, groups, ls, size=3, hover=lambda i: meas.where[i])
    p = _core.fk_batch(res.model(), np.asarray(meas.q, dtype=float))[:, :3, 3] / ls
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
    shown = SceneRobot(
        f"calibrated {nominal.name} ({res.convention})", "frames-calibrated", calibrated.table, q0, calibrated.names
    )
    other = SceneRobot(
        f"nominal {nominal.name} ({nominal.convention})", "frames-nominal", nominal.table, q0, nominal.names
    )
    return _robot_scene(go, traces, pts, ls, length, shown, other)


def _parameters_table(res, length: str, angle: str) -> str:
    """Every calibration parameter in its unit: nominal, calibrated, sigma, change and status."""
    pz = res.parametrization
    rows = []
    for k, name in enumerate(res.names):
        sc, unit = _param_scale(pz.units[k], length, angle)
        nom, val, sig = res.nominal[k] / sc, res.values[k] / sc, res.sigma[k] / sc
        rows.append(
            f'<tr data-param="{html.escape(name)}">{_td("param", name)}{_td("unit", unit)}{_td("nominal", float(nom))}'
            f"{_td('calibrated', float(val))}{_td('sigma', float(sig))}{_td('change', float(val - nom))}"
            f"{_td('status', res.status[k])}</tr>"
        )
    return _table(
        "parameters",
        ["parameter", "unit", "nominal", "calibrated", "sigma (1σ)", "calibrated − nominal", "status"],
        rows,
        f"{res.convention.upper()} calibration parameters (docs/conventions.md, 'Calibration parametrisations'); "
        "sigma from the fit's covariance; status: free, or why the parameter is held.",
        "parameters",
    )


def _misfit_chart(go, res, ls: float, length: str):
    """The tool position misfit of every fitted pose under the calibrated model."""
    r = np.linalg.norm(np.asarray(res.residuals, dtype=float).reshape(len(res.residuals), -1)[:, :3], axis=1) / ls
    fig = go.Figure(
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
    fig.update_layout(
        height=320,
        margin={"l": 70, "r": 10, "t": 40, "b": 40},
        xaxis={"title": {"text": "fitted pose"}, "zeroline": False},  # x = 0 is pose 0: the zero line had hidden it
        yaxis={"title": {"text": f"tool position misfit [{length}]"}, "exponentformat": "power", "rangemode": "tozero"},
        title={"text": "Misfit of every fitted pose (calibrated model)", "font": {"size": 14}},
    )
    return fig


def _validation_table(v, ls: float, length: str) -> str:
    """The held-out poses' tool position error before and after ("" without a validation)."""
    if v is None:
        return ""
    rows = [
        f"<tr>{_td('model', label)}{_td('rms', a / ls)}{_td('max', b / ls)}</tr>"
        for label, a, b in (
            ("before: nominal geometry, base and tool fitted", v.before_rms, v.before_max),
            ("after: calibrated", v.after_rms, v.after_max),
        )
    ]
    return _table(
        "validation",
        ["model", f"rms [{length}]", f"max [{length}]"],
        rows,
        f"Tool position error on {v.n_test} held-out poses (not used by the fit) of {v.n_train + v.n_test}.",
        "validation",
    )


def _calibration_summary(res, ls: float, length: str) -> str:
    """What was measured, the model, the misfit, the held-out accuracy, the model chosen, the identifiability."""
    meas, v = res.measurements, res.validation
    free = sum(st == "free" for st in res.status)
    model = (
        f"{res.convention.upper()} calibration of {res.parametrization.robot.name}: {free} of {len(res.names)} "
        f"parameters free, loss {res.loss}" + ("" if res.converged else ", NOT converged")
    )
    accuracy = (
        f"held-out tool position error rms {v.before_rms / ls:.4g} -> {v.after_rms / ls:.4g} {length}, max "
        f"{v.before_max / ls:.4g} -> {v.after_max / ls:.4g} {length}"
        if v is not None
        else None
    )
    choice = getattr(res, "model_choice", None)
    return _summary(
        [
            ("measured", f"{meas.n} {'poses' if meas.kind == 'pose' else 'tool points'} from {meas.source}"),
            ("model", model),
            (
                "fit",
                f"misfit rms {res.rms / ls:.4g} {length} (noise estimate {res.noise / ls:.3g} {length} per coordinate)",
            ),
            *([("accuracy", accuracy)] if accuracy else []),
            *([("model chosen", choice.line(ls, length))] if choice is not None else []),
            ("identifiability", res.identifiability.summary()),
        ]
    )


def calibration_report_html(res, *, length: str = "mm", angle: str = "deg", title: str | None = None) -> str:
    """The HTML text of :func:`write_calibration_report`."""
    go, _ = _plotly()
    ls = length_scale(length)
    meas = res.measurements
    view = _calibration_view(go, res, ls, length)
    params = _parameters_table(res, length, angle)
    vtable = _validation_table(res.validation, ls, length)
    misfit = _figure_html(_misfit_chart(go, res, ls, length), "residuals-chart")
    title = title or f"denavit calibration: {meas.source}"
    meta = html.escape(
        f"{len(res.robot().names)} joints, {res.convention.upper()} parameters; lengths in {length}, angles in "
        f"{angle}, measurement frame."
    )
    body = "\n".join(
        [
            _view_section(
                view,
                "Measured tool points (held-out ones in orange) and the calibrated robot's frames along its chain at "
                "the first pose; the nominal robot and the calibrated model's predictions are in the legend.",
            ),
            f'<section id="results"><h2>Calibrated parameters</h2><div class="scroll">{params}</div></section>',
            f'<section id="fits"><h2>Fit and validation</h2>{vtable}{misfit}</section>',
            f'<section id="notes-section"><h2>Notes</h2>{_notes_html(res.notes)}</section>',
        ]
    )
    return _page(title, meta, _calibration_summary(res, ls, length), body)


def write_calibration_report(
    res, path, *, length: str = "mm", angle: str = "deg", title: str | None = None, force: bool = False
) -> Path:
    """Write the self-contained HTML report of a :class:`denavit.calibration.Calibration` to ``path``: a summary
    (what was measured, the model, the misfit, the held-out accuracy before and after), the measured points with
    the calibrated robot in 3-D, the parameter table with units and sigmas, the misfit of every pose. Returns
    the path."""
    write_text(path, calibration_report_html(res, length=length, angle=angle, title=title), force=force)
    return Path(path)
