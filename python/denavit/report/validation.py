"""The report and figure of ``denavit validate`` (:class:`denavit.calibration.validate.ModelValidation`), built
with the HTML helpers of :mod:`denavit.report.html` and matplotlib as :mod:`denavit.plotting` draws.

The HTML report: a summary (model, session, registration, RMS / max / percentiles, flagged poses, ISO 9283), the
error of every pose beside its predicted sigma (flagged poses marked), the distribution of the errors, the ISO
9283 table and the per-pose table. ``--plot DIR``: ``validation.png``, the per-pose errors and their histogram.
"""

from __future__ import annotations

import html
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from ..io.output import write_text
from ..io.units import length_scale
from .html import FIGURE_FORMATS, _figure_html, _page, _plotly, _summary, _table, _td, _write_all

#: Rows of the report's per-pose table (every pose is in the JSON document).
POSE_ROWS = 500

_FLAG_COLOURS = {"": "#1f77b4", "outside_training_range": "#d62728", "large_predicted_sigma": "#ff7f0e"}


def _flag_of(flags) -> str:
    return "outside_training_range" if "outside_training_range" in flags else "large_predicted_sigma" if flags else ""


def validation_report_html(v, *, length: str = "mm", title: str | None = None) -> str:
    """The HTML text of :func:`write_validation_report`."""
    go, _ = _plotly()
    ls = length_scale(length)
    idx = np.arange(v.n)
    kinds = np.array([_flag_of(f) for f in v.flags])
    traces = []
    for kind, label in (
        ("", "poses"),
        ("outside_training_range", "outside the training joint ranges"),
        ("large_predicted_sigma", "large predicted sigma"),
    ):
        m = kinds == kind
        if m.any():
            traces.append(
                go.Scatter(
                    x=idx[m] + 1,
                    y=v.errors[m] / ls,
                    mode="markers",
                    marker={"size": 6, "color": _FLAG_COLOURS[kind]},
                    name=f"error: {label}",
                    hovertext=[v.where[i] for i in idx[m]],
                    hovertemplate="%{hovertext}: %{y:.4f} " + length + "<extra></extra>",
                )
            )
    if v.sigma is not None:
        traces.append(
            go.Scatter(
                x=idx + 1,
                y=v.sigma / ls,
                mode="markers",
                marker={"size": 5, "color": "#7f7f7f", "symbol": "line-ew-open"},
                name="predicted sigma (1σ, 3-D)",
            )
        )
    efig = go.Figure(traces)
    efig.add_hline(
        y=v.rms / ls, line={"color": "#2ca02c", "dash": "dash"}, annotation_text=f"rms {v.rms / ls:.4g} {length}"
    )
    efig.update_layout(
        height=360,
        margin={"l": 70, "r": 10, "t": 40, "b": 40},
        xaxis={"title": {"text": "pose"}},
        yaxis={"title": {"text": f"tool position error [{length}]"}, "rangemode": "tozero"},
        title={"text": f"Error of every pose (registration {v.registration})", "font": {"size": 14}},
    )
    hfig = go.Figure(
        [go.Histogram(x=v.errors / ls, nbinsx=min(60, max(10, v.n // 5)), marker={"color": "#1f77b4"}, name="poses")]
    )
    hfig.update_layout(
        height=300,
        margin={"l": 70, "r": 10, "t": 40, "b": 40},
        xaxis={"title": {"text": f"tool position error [{length}]"}},
        yaxis={"title": {"text": "poses"}},
        title={"text": "Distribution of the errors", "font": {"size": 14}},
    )
    iso = ""
    if v.groups:
        grows = [
            f"<tr>{_td('pose', ', '.join(v.where[i] for i in g.indices[:3]) + (' ...' if g.n > 3 else ''))}"
            f"{_td('visits', str(g.n))}"
            f"{_td('ap', g.ap / ls)}{_td('rp', g.rp / ls)}</tr>"
            for g in v.groups
        ]
        iso = _table(
            "iso9283",
            ["pose", "visits", f"AP [{length}]", f"RP [{length}]"],
            grows,
            "ISO 9283 clause 7.2: AP, the distance from the barycentre of the attained positions to the commanded one"
            " (the model's prediction); RP = l_bar + 3 S_l, l_j the distances of the attained positions to their"
            " barycentre.",
            "iso9283",
        )
    rows = []
    for i in range(min(v.n, POSE_ROWS)):
        flags = ", ".join(f.replace("_", " ") for f in v.flags[i]) + (
            f" ({', '.join(v.joint_names[j] for j in v.outside[i])})" if v.outside[i] else ""
        )
        rows.append(
            f'<tr data-pose="{i + 1}">{_td("where", v.where[i])}{_td("error", float(v.errors[i]) / ls)}'
            f"{_td('sigma', None if v.sigma is None else float(v.sigma[i]) / ls)}{_td('flags', flags or '-')}</tr>"
        )
    poses = _table(
        "poses",
        ["pose", f"error [{length}]", f"predicted sigma [{length}]", "flags"],
        rows,
        f"Per pose (first {POSE_ROWS} of {v.n})" if v.n > POSE_ROWS else "Per pose.",
        "poses",
    )
    pc = ", ".join(f"p{p} {e / ls:.4g}" for p, e in v.percentiles.items())
    summary = _summary(
        [
            ("model", v.model_name),
            ("session", f"{v.n} {'poses' if v.measure == 'pose' else 'tool points'} from {v.source}"),
            (
                "registration",
                (
                    "kept as the model has it (frozen)"
                    if v.registration == "frozen"
                    else "base and tool re-fitted, the kinematics frozen (refit)"
                ),
            ),
            (
                "accuracy",
                f"tool position error rms {v.rms / ls:.4g} {length}, max {v.max / ls:.4g} {length}; {pc} {length}",
            ),
            ("extrapolation", f"{v.n_flagged} of {v.n} poses flagged"),
            *(
                [
                    (
                        "ISO 9283",
                        (
                            f"{len(v.groups)} repeated poses: AP max {max(g.ap for g in v.groups) / ls:.4g} {length},"
                            f" RP max {max(g.rp for g in v.groups) / ls:.4g} {length}"
                        ),
                    )
                ]
                if v.groups
                else []
            ),
        ]
    )
    notes = "".join(f"<li>{html.escape(n)}</li>" for n in v.notes) or "<li>none</li>"
    title = title or f"denavit validation: {v.model_name} on {v.source}"
    meta = html.escape(f"{len(v.joint_names)} joints; lengths in {length}; measurement frame of the session.")
    body = "\n".join(
        [
            (
                "<section"
                f' id="errors"><h2>Errors</h2>{_figure_html(efig, "errors-chart")}'
                f"{_figure_html(hfig, 'histogram-chart')}</section>"
            ),
            *([f'<section id="iso"><h2>ISO 9283</h2><div class="scroll">{iso}</div></section>'] if iso else []),
            f'<section id="poses-section"><h2>Poses</h2><div class="scroll">{poses}</div></section>',
            f'<section id="notes-section"><h2>Notes</h2><ul class="notes" id="notes">{notes}</ul></section>',
        ]
    )
    return _page(title, meta, summary, body)


def write_validation_report(v, path, *, length: str = "mm", title: str | None = None) -> Path:
    """Write the self-contained HTML report of a validation to ``path``; returns the path."""
    write_text(path, validation_report_html(v, length=length, title=title))
    return Path(path)


def plot_validation(v, *, length: str = "mm"):
    """The per-pose errors (flagged poses coloured, the predicted sigma where known) and their histogram."""
    from ..plotting import _figure  # noqa: PLC0415

    ls = length_scale(length)
    fig = _figure(figsize=(10.0, 4.2), layout="constrained")
    ax, hx = fig.add_subplot(1, 2, 1), fig.add_subplot(1, 2, 2)
    ax.set_gid("errors")
    hx.set_gid("histogram")
    idx = np.arange(v.n) + 1
    kinds = np.array([_flag_of(f) for f in v.flags])
    for kind, label in (
        ("", "pose"),
        ("outside_training_range", "outside training range"),
        ("large_predicted_sigma", "large predicted sigma"),
    ):
        m = kinds == kind
        if m.any():
            ax.plot(idx[m], v.errors[m] / ls, "o", ms=3.5, ls="none", color=_FLAG_COLOURS[kind], label=label)
    if v.sigma is not None:
        ax.plot(idx, v.sigma / ls, "_", ms=6, ls="none", color="0.45", label="predicted sigma")
    ax.axhline(v.rms / ls, color="#2ca02c", ls="--", lw=1, label=f"rms {v.rms / ls:.3g} {length}")
    ax.set_xlabel("pose")
    ax.set_ylabel(f"tool position error [{length}]")
    ax.set_ylim(bottom=0)
    ax.legend(fontsize=7)
    hx.hist(v.errors / ls, bins=min(60, max(10, v.n // 5)), color="#1f77b4")
    hx.set_xlabel(f"tool position error [{length}]")
    hx.set_ylabel("poses")
    fig.suptitle(
        f"{v.model_name} on {v.n} poses (registration {v.registration}): max {v.max / ls:.3g} {length}", fontsize=10
    )
    return fig


def write_validation_figures(
    v, folder, *, formats: Sequence[str] = FIGURE_FORMATS, length: str = "mm", dpi: int = 110
) -> list[Path]:
    """Write ``validation`` (:func:`plot_validation`) into ``folder`` in each of ``formats``; returns the paths."""
    return _write_all({"validation": plot_validation(v, length=length)}, folder, formats, dpi)


__all__ = [
    "POSE_ROWS",
    "plot_validation",
    "validation_report_html",
    "write_validation_figures",
    "write_validation_report",
]
