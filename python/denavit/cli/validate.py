"""``validate``: score a saved model on another measurement session (:mod:`denavit.calibration.validate`)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from ..io.units import angle_scale, length_scale
from .common import commands
from .console import console, print_rows, say, spread, status, wrote
from .options import AngleOpt, BaseLinkOpt, ColumnsOpt, JsonOpt, LengthOpt, TargetOpt, TipLinkOpt
from .outputs import check_outputs, emit_json, json_target, require_plot_extra
from .values import load_robot, parse_point, positive

#: Sessions of at most this many poses print every pose; larger ones the worst and the flagged ones up to it.
ROWS = 30


@commands.command()
def validate(
    model: Annotated[
        str,
        typer.Argument(
            help=(
                "The model to score: a robot file (e.g. from calibrate --save, with its \\[covariance] and"
                " \\[training]), a URDF or a built-in name."
            )
        ),
    ],
    data: Annotated[
        Path,
        typer.Argument(
            help=(
                "Another measurement session, in any format calibrate reads (CSV 'q1..qn,x,y,z[,rx,ry,rz]' or with"
                " further targets 'x2,y2,z2,...', sweep CSV, JSON, a recording)."
            )
        ),
    ],
    refit_registration: Annotated[
        bool,
        typer.Option(
            "--refit-registration",
            help=(
                "Re-fit base and tool (the kinematics frozen): data from another placement of the tracker. Default: the"
                " model's registration is kept (the data are in the frame it was calibrated in)."
            ),
        ),
    ] = False,
    tool: Annotated[
        str | None,
        typer.Option("--tool", help="Tool point in the flange frame, --length units (default: the model's tool)."),
    ] = None,
    max_sigma: Annotated[
        float | None,
        typer.Option(
            "--max-sigma",
            help=(
                "Flag poses whose predicted error (1 sigma, from the model's covariance) exceeds this, --length units"
                " (default: 3 x the median)."
            ),
        ),
    ] = None,
    json_path: JsonOpt = None,
    report: Annotated[
        Path | None,
        typer.Option(
            "--report",
            help="Write a self-contained HTML report (summary, per-pose errors with their predicted sigma, ISO 9283).",
        ),
    ] = None,
    plot: Annotated[Path | None, typer.Option("--plot", help="Write the static figure (PNG) into this folder.")] = None,
    length: LengthOpt = "mm",
    angle: AngleOpt = "deg",
    data_format: Annotated[
        str,
        typer.Option(
            "--format",
            help=(
                "measurements (q1..qn,x,y,z CSV, sweep CSV, JSON) | tracker | rtde | rsi | bag | columns | auto (from"
                " the content)."
            ),
        ),
    ] = "auto",
    columns: ColumnsOpt = None,
    target: TargetOpt = None,
    base_link: BaseLinkOpt = None,
    tip_link: TipLinkOpt = None,
    payload: Annotated[
        str | None,
        typer.Option(
            "--payload",
            help=(
                "The payload on the flange for every pose where the data give none (a pose file's payload_mass,"
                " payload_x,payload_y,payload_z columns): its mass with a unit (kg, g) and optionally its centre of"
                ' mass in the flange frame, e.g. "5 kg @ 0,0,80 mm" (--length units without one). A model with'
                " compliant joints (a robot file's \\[compliance]) is predicted with its joints deflected under it."
            ),
        ),
    ] = None,
) -> None:
    """Score a saved model on another measurement session: per-pose tool-position errors, RMS, max and percentiles,
    extrapolation flags (outside the training joint ranges, large predicted sigma), ISO 9283 pose accuracy and
    repeatability of repeated poses."""
    require_plot_extra(report=report, plot=plot)  # before any work: the plot extra's modules
    import numpy as np  # noqa: PLC0415

    from ..api import _measurements  # noqa: PLC0415
    from ..calibration import validate as va  # noqa: PLC0415

    check_outputs(**{"--json": json_path})
    json_path = json_target(json_path)
    robot = load_robot(model, base_link, tip_link, "MODEL")
    ls, as_ = length_scale(length), angle_scale(angle)
    tp = None if tool is None else parse_point(tool, "--tool", ls, ())
    ms = positive(max_sigma, "--max-sigma", ls, None, length)
    fmt = "auto" if data_format == "auto" else data_format
    meas = _measurements(
        str(data),
        robot,
        points=None,
        poses=None,
        format=fmt,
        length=length,
        angle=angle,
        columns=columns,
        target=None if target is None else target - 1,
    )
    if (
        robot.coupling is not None
    ):  # the readings -> the joint values the model turns by (the robot file's [couplings]), as calibrate
        from dataclasses import replace  # noqa: PLC0415

        meas = replace(meas, q=np.asarray(meas.q) @ np.asarray(robot.coupling).T)
        robot = replace(robot, coupling=None)
    with status(f"validating {robot.name} on {meas.n} poses ..."):
        res = va.validate(
            robot,
            meas,
            registration="refit" if refit_registration else "frozen",
            tool=tp,
            max_sigma=ms,
            payload=_payload(payload, length),
        )
    if json_path:
        from ..io.results import to_json  # noqa: PLC0415

        emit_json(to_json(res), json_path)
    if json_path != "-":
        print_validation(res, length, angle, ls, as_)
    if report or plot:
        from ..report import write_validation_figures, write_validation_report  # noqa: PLC0415

        if report:
            with status("writing the report ..."):
                write_validation_report(res, report, length=length)
            wrote(report)
        if plot:
            with status(f"drawing the figure into {plot} ..."):
                files = write_validation_figures(res, plot, length=length)
            for f in files:
                wrote(f)


def print_validation(res, length: str, angle: str, ls: float, as_: float) -> None:
    """The summary, the per-pose table (all poses of a small session, else the worst and the flagged) and ISO 9283."""
    import numpy as np  # noqa: PLC0415

    say(
        "bold",
        f"Validation of {res.model_name}",
        f" on {res.n} {'poses' if res.measure == 'pose' else 'points'} (registration {res.registration})",
    )
    console.print(f"  data: {res.source}", soft_wrap=True)
    pc = res.percentiles
    console.print(
        f"Tool-position error: rms {spread(res.rms / ls)} {length}, max {spread(res.max / ls)} {length}; percentiles "
        + ", ".join(f"p{p} {spread(v / ls)}" for p, v in pc.items())
        + f" {length}"
        + ("" if res.rms_rotation is None else f"; rotation rms {spread(res.rms_rotation / as_)} {angle}")
    )
    order = np.argsort(-res.errors)
    flagged = [i for i in range(res.n) if res.flags[i]]
    show = list(range(res.n)) if res.n <= ROWS else sorted(set(order[: ROWS // 2].tolist()) | set(flagged[: ROWS // 2]))
    rows = []
    for i in show:
        rows.append(
            [
                res.where[i],
                spread(res.errors[i] / ls),
                "-" if res.sigma is None else spread(res.sigma[i] / ls),
                ", ".join(res.flags[i]).replace("_", " ")
                + (f" ({', '.join(res.joint_names[j] for j in res.outside[i])})" if res.outside[i] else "")
                or "-",
            ]
        )
    caption = (
        None
        if res.n <= ROWS
        else f"the {ROWS // 2} largest errors and up to {ROWS // 2} flagged poses of {res.n} (every pose in --json)"
    )
    print_rows(
        None, ["pose", f"error [{length}]", f"predicted sigma [{length}]", "flags"], rows, left=(3,), caption=caption
    )
    if flagged:
        n_range = len(res.flagged("outside_training_range"))
        n_sigma = len(res.flagged("large_predicted_sigma"))
        rms_in = float(np.sqrt(np.mean(np.delete(res.errors, flagged) ** 2))) if len(flagged) < res.n else float("nan")
        rms_out = float(np.sqrt(np.mean(res.errors[flagged] ** 2)))
        console.print(
            f"Extrapolation: {len(flagged)} of {res.n} poses flagged ({n_range} outside the training joint ranges,"
            f" {n_sigma} with a large predicted sigma): rms {spread(rms_out / ls)} {length} there,"
            f" {spread(rms_in / ls)} {length} elsewhere"
        )
    if res.groups:
        grows = [
            [
                ", ".join(res.where[i] for i in g.indices[:2]) + (" ..." if g.n > 2 else ""),
                str(g.n),
                spread(g.ap / ls),
                spread(g.rp / ls),
            ]
            for g in res.groups
        ]
        print_rows(
            "ISO 9283 (repeated poses)",
            ["pose", "visits", f"AP [{length}]", f"RP [{length}]"],
            grows[:ROWS],
            caption=(
                "AP: distance from the barycentre of the attained positions to the commanded (the model's); RP = l_bar"
                " + 3 S_l (clause 7.2)"
            ),
        )
    for note in res.notes:
        say("yellow", "note:", f" {note}")


def _payload(text, length: str):
    """``--payload`` as (mass kg, centre of mass m), or None (denavit.io.payload)."""
    from ..io.payload import parse_payload  # noqa: PLC0415

    return None if text is None else parse_payload(text, length)
