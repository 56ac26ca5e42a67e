"""``calibrate``: the whole model from measured points or poses at known joint readings."""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path
from typing import Annotated

import typer

from ..errors import DenavitError
from ..io.units import angle_scale, length_scale
from .common import commands
from .console import console, fail, num, print_rows, say, spread, status, wrote
from .options import (
    CONVENTION,
    BaseLinkOpt,
    ColumnsOpt,
    ConventionOpt,
    CouplingOpt,
    JsonOpt,
    NominalAliasOpt,
    TargetOpt,
    TipLinkOpt,
    TrackerNoiseOpt,
    TrackerPositionOpt,
    VerboseOpt,
)
from .outputs import check_outputs, emit_json, json_target, require_plot_extra, save_urdf_of
from .values import calib_unit, check_noises, convention_name, load_robot, model_first, parse_point

ModelArg = Annotated[
    str,
    typer.Argument(
        metavar="MODEL",
        help="The nominal model (built-in name, robot file or URDF), then DATA. (`DATA --nominal MODEL`: deprecated.)",
    ),
]

DataArg = Annotated[
    Path | None,
    typer.Argument(
        metavar="DATA",
        help=(
            "Measurements: CSV 'q1..qn,x,y,z[,rx,ry,rz]' (several targets per pose: 'q1..qn,x,y,z,x2,y2,z2,...'), "
            "a long-form sweep CSV (with 'joint'), JSON, or a recording."
        ),
    ),
]


FixOpt = Annotated[
    str | None,
    typer.Option(
        "--fix",
        help="Parameters to hold at their nominal values: names or patterns, comma-separated (e.g. 'base_*,tool_z').",
    ),
]

SaveOpt = Annotated[
    Path | None,
    typer.Option(
        "--save",
        help=(
            "Write the calibrated robot file (.toml, ED-H, with its \\[covariance]: compensate predicts the error"
            " after) to this path."
        ),
    ),
]

UrdfOpt = Annotated[
    Path | None,
    typer.Option(
        "--urdf", help="Write the calibrated robot as URDF, with a URDF nominal's meshes, inertials and limits."
    ),
]

ReportOpt = Annotated[
    Path | None, typer.Option("--report", help="Write a self-contained HTML report (summary, 3-D view, tables).")
]

LossOpt = Annotated[str, typer.Option("--loss", help="linear | soft_l1 | huber | cauchy | arctan (robust loss)")]

StartOpt = Annotated[str, typer.Option("--start", help="nominal | circles (circle-point identification of sweep data)")]

HoldoutOpt = Annotated[float, typer.Option("--holdout", help="Fraction of the poses held out to validate the fit.")]

ScaleOpt = Annotated[bool, typer.Option("--scale", help="Also estimate a scale per joint.")]

ToolOpt = Annotated[
    str | None,
    typer.Option("--tool", help="Tool point in the flange frame, --length units (default: the nominal model's tool)."),
]

NoiseOpt = Annotated[
    float | None,
    typer.Option(
        "--noise", help="Known point noise (1 sigma per coordinate), --length units (default: from the residuals)."
    ),
]


LengthOpt = Annotated[
    str,
    typer.Option(
        "--length",
        help=(
            "Length unit of what is typed and printed, and of the data where they declare none: mm | m | cm | um | in."
            " JSON stays SI."
        ),
    ),
]

AngleOpt = Annotated[
    str,
    typer.Option(
        "--angle",
        help=(
            "Angle unit of what is typed and printed, and of the data where they declare none: deg | rad. JSON"
            " stays SI."
        ),
    ),
]

SeedOpt = Annotated[int, typer.Option("--seed", help="Seed of the held-out split.")]

ModelOpt = Annotated[
    str,
    typer.Option(
        "--model",
        help=(
            "What is free: auto (chosen by leave-one-pose-out prediction error), base-tool, offsets, full (every"
            " identifiable parameter, least squares), full-prior (with the priors), full-prior-no-beta or"
            " full-prior-no-last (docs/cli.md)"
        ),
    ),
]

PriorOpt = Annotated[
    str | None,
    typer.Option(
        "--prior",
        help=(
            'Prior widths (1 sigma) about the nominal, by kind or parameter name: e.g. "length=1mm, angle=0.1deg,'
            ' offset=0.1deg, scale=100ppm, a_5=2mm" (these are the defaults; bare numbers in --length / --angle), or'
            " none."
        ),
    ),
]


DataFormatOpt = Annotated[
    str,
    typer.Option(
        "--format",
        help=(
            "measurements (q1..qn,x,y,z CSV, sweep CSV, JSON) | tracker | rtde | rsi | bag | columns | auto (from the"
            " content)."
        ),
    ),
]


PayloadOpt = Annotated[
    str | None,
    typer.Option(
        "--payload",
        help=(
            "The payload on the flange for every pose where the data give none (a pose file's payload_mass, payload_x,"
            " payload_y, payload_z columns): its mass with a unit (kg, g) and optionally its centre of mass in the"
            ' flange frame, e.g. "5 kg @ 0,0,80 mm" (--length units without one). With a payload the joints\''
            " compliance under gravity is a candidate of --model auto (it needs the nominal's link masses)."
        ),
    ),
]


@commands.command()
def calibrate(
    first: ModelArg,
    data: DataArg = None,
    nominal: NominalAliasOpt = None,
    convention: ConventionOpt = CONVENTION,
    fix: FixOpt = None,
    json_path: JsonOpt = None,
    save: SaveOpt = None,
    urdf: UrdfOpt = None,
    report: ReportOpt = None,
    loss: LossOpt = "linear",
    start: StartOpt = "nominal",
    holdout: HoldoutOpt = 0.2,
    scale: ScaleOpt = False,
    tool: ToolOpt = None,
    noise: NoiseOpt = None,
    tracker_noise: TrackerNoiseOpt = None,
    tracker_position: TrackerPositionOpt = None,
    length: LengthOpt = "mm",
    angle: AngleOpt = "deg",
    verbose: VerboseOpt = False,
    seed: SeedOpt = 0,
    model: ModelOpt = "auto",
    prior: PriorOpt = None,
    coupling: CouplingOpt = None,
    data_format: DataFormatOpt = "auto",
    columns: ColumnsOpt = None,
    target: TargetOpt = None,
    base_link: BaseLinkOpt = None,
    tip_link: TipLinkOpt = None,
    payload: PayloadOpt = None,
) -> None:
    """Calibrate the whole model from measured points or poses at known joint readings (one least-squares fit)."""
    require_plot_extra(report=report)  # before any work: the plot extra's modules
    import numpy as np  # noqa: PLC0415

    from .. import calibration as cal  # noqa: PLC0415
    from ..api import read_measurements  # noqa: PLC0415

    check_outputs(**{"--save": save, "--json": json_path})
    json_path = json_target(json_path)
    nominal, data = model_first(first, data, nominal, "calibrate")
    data = Path(data)
    robot = load_robot(nominal, base_link, tip_link, "MODEL")
    convention = convention_name(convention)
    # the reader applies the one units rule (denavit.io.units.input_units): what the file declares wins; several
    # targets per pose: every one (a TargetMeasurements), or the one asked
    meas = read_measurements(
        data,
        robot,
        format=data_format,
        length=length,
        angle=angle,
        columns=columns,
        target=None if target is None else target - 1,
        inform=lambda kind, text: say("dim", f"{kind}:", f" {text}"),
    )
    from ..io.robotfile import parse_coupling  # noqa: PLC0415

    C = parse_coupling(coupling, list(robot.table.kinds), "--coupling") if coupling else robot.coupling
    if C is not None:  # the readings -> the joint values the model turns by
        meas = replace(meas, q=np.asarray(meas.q) @ C.T)
    ls = length_scale(length)
    tp = None if tool is None else parse_point(tool, "--tool", ls, ())
    if noise is not None and not (math.isfinite(noise) and noise > 0):
        fail(f"--noise: expected the known one-sigma point noise, a finite value > 0 in {length}, got {noise}")
    sigma = None if noise is None else noise * ls
    check_noises(robot.model(), tp, length, angle, ("--noise", sigma, "length"))
    from .identify import parse_tracker_noise  # noqa: PLC0415 (one parser of the option for both commands)

    tn = parse_tracker_noise(tracker_noise, tracker_position, length, angle)
    if tn is not None and sigma is not None:
        fail(
            "--noise and --tracker-noise: give one (the tracker's model declares each point's noise shape; its scale is"
            " estimated from the residuals)"
        )
    fixes = [f.strip() for f in (fix or "").split(",") if f.strip()]
    from ..calibration.priors import parse_prior  # noqa: PLC0415
    from ..calibration.selection import MODELS  # noqa: PLC0415

    if model not in MODELS:
        fail(f"--model: expected one of {', '.join(MODELS)}, got {model!r}")
    prior_spec = None if prior is None else parse_prior(prior, length_scale(length), angle_scale(angle)) or False
    from ..io.payload import parse_payload  # noqa: PLC0415

    pl = None if payload is None else parse_payload(payload, length)
    with status(
        f"calibrating {robot.name} ({convention}) from {meas.n} {'poses' if meas.kind == 'pose' else 'points'}..."
    ) as st:
        res = cal.calibrate(
            meas,
            robot,
            progress=st.update,
            convention=convention,
            fix=fixes,
            loss=loss,
            start=start,
            holdout=holdout,
            scale=scale,
            tool=tp,
            noise=sigma,
            tracker_noise=tn,
            seed=seed,
            model=model,
            prior=prior_spec,
            payload=pl,
        )
    if json_path:
        from ..io.results import to_json  # noqa: PLC0415

        emit_json(to_json(res), json_path)
    if json_path != "-":
        print_calibration(res, length, angle, verbose)
    _refuse_jumps(res, robot, length, angle)
    if save:
        from ..fleet.checksum import saved_checksum  # noqa: PLC0415
        from ..io.results import save as save_result  # noqa: PLC0415
        from ..io.results import saved_robot  # noqa: PLC0415

        save_result(res, save, length=length, angle=angle)  # with [training]: validate flags poses outside them
        written = saved_robot(res, length=length, angle=angle) if str(save) == "-" else None  # (read back if a file)
        wrote(save, f" (model checksum {saved_checksum(save, written)})")
    if urdf:  # the calibrated geometry, with a URDF nominal's meshes, inertials and limits
        save_urdf_of(res.model(), urdf, res.robot())
    if report:
        from ..report import write_calibration_report  # noqa: PLC0415

        with status("writing the report ..."):
            write_calibration_report(res, report, length=length, angle=angle)
        wrote(report)


#: calibrate notes a length parameter that moves from the nominal's by more than this fraction of the robot's size,
#: and refuses one that moves by more than the size.
FLAG_SIZE = 0.1


def _refuse_jumps(res, robot, length: str, angle: str) -> None:
    """A calibration whose kinematic length parameters move from the nominal's by more than the robot's size is not a
    calibration of this robot (readings coupled but not declared, the wrong unit, another robot): refused; by more
    than ``FLAG_SIZE`` of it, a note. The registration (``base_*``, ``tool_*``: where the tracker and the target
    stand) is not judged: a tracker 10 m away is normal."""
    import numpy as np  # noqa: PLC0415

    from .. import _core  # noqa: PLC0415
    from ..calibration.registration import is_registration  # noqa: PLC0415

    m = robot.model()
    q0 = np.zeros(m.nq) if robot.home is None else robot.home
    base = np.asarray(m.T_world_base)[:3, 3]
    size = max(
        [float(np.linalg.norm(np.asarray(p) - base)) for p in _core.axes(m, q0).points]
        + [float(np.linalg.norm(_core.fk(m, q0)[:3, 3] - base)), 1e-3]
    )
    pz = res.parametrization
    # the kinematic parameters only: base and tool are where the tracker and the target stand (registered in closed
    # form, denavit.calibration.registration), which may be anywhere
    moves = [
        (name, abs(v - n))
        for name, v, n, u in zip(res.names, res.values, res.nominal, pz.units, strict=True)
        if u == "length" and not is_registration(name) and abs(v - n) > FLAG_SIZE * size
    ]
    jumps = [(name, d) for name, d in moves if d > size]
    ls = length_scale(length)
    if moves and not jumps:
        say(
            "yellow",
            "note:",
            f" {', '.join(f'{name} moves {d / ls:.4g} {length}' for name, d in moves[:4])} from the nominal, more than"
            f" {FLAG_SIZE:g} of the robot's size ({size / ls:.4g} {length}): a calibration moves parameters by"
            " millimetres; check for coupled readings (--coupling), the units and the nominal",
        )
    if jumps:
        worst = ", ".join(f"{name} by {d / ls:.4g} {length}" for name, d in sorted(jumps, key=lambda x: -x[1])[:4])
        raise DenavitError(
            f"{res.measurements.source}: the calibration moves {len(jumps)} parameter(s) from the nominal"
            f" {robot.name}'s by more than the robot's size ({size / ls:.4g} {length}): {worst}; expected a calibration"
            ' of this robot (readings coupled, as a Fanuc\'s J3? declare --coupling "q3=r3+r2" or [couplings]; points'
            " in another unit? the wrong nominal?)"
        )


def print_calibration(res, length: str, angle: str, verbose: bool = False) -> None:
    pz = res.parametrization
    meas = res.measurements
    say(
        "bold",
        f"Calibration of {pz.robot.name}",
        f" ({res.convention}, {meas.n} {'poses' if meas.kind == 'pose' else 'points'}; "
        f"{res.elapsed * 1e3:.1f} ms, {res.evaluations} evaluations{'' if res.converged else ', NOT converged'})",
    )
    console.print(f"  data: {meas.source}", soft_wrap=True)
    rows = []
    for k, name in enumerate(res.names):
        u, s = calib_unit(pz.units[k], length, angle)
        nom, val, sig = res.nominal[k] / s, res.values[k] / s, res.sigma[k] / s
        rows.append([name, u, num(nom, u), num(val, u), spread(sig), num(val - nom, u), res.status[k]])
    print_rows(
        None,
        ["parameter", "unit", "nominal", "calibrated", "sigma", "change", "status"],
        rows,
        left=(1, 6),
        caption=(
            "sigma: one standard deviation (covariance of the fit; with priors the posterior's, prior included);"
            " change: calibrated - nominal"
        ),
    )
    ana = res.identifiability
    console.print(f"Identifiability: {ana.summary()}")
    structural = [u for u in ana.unidentifiable if u.structural]
    if structural and not verbose:
        console.print(
            f"Redundant in the {res.convention} parametrisation (held at their start values; reasons with --verbose):"
            f" {', '.join(u.name for u in structural)}"
        )
    for u in ana.unidentifiable:
        if verbose or not u.structural:
            say("yellow", "not identifiable:" if not u.structural else "redundant:", f" {u.name}: {u.reason}")
    ls = length_scale(length)
    console.print(
        f"Residuals: rms {spread(res.rms / ls)} {length} (noise estimate {spread(res.noise / ls)} {length} per"
        " coordinate)"
        + (f", rotation rms {spread(res.rms_rotation / angle_scale(angle))} {angle}" if meas.kind == "pose" else "")
    )
    if getattr(res, "model_choice", None) is not None:
        console.print(f"Model: {res.model_choice.line(ls, length)}", soft_wrap=True)
    v = res.validation
    if v is not None:
        console.print(
            f"Held-out validation ({v.n_test} of {v.n_train + v.n_test} poses): tool-position error rms"
            f" {spread(v.before_rms / ls)} -> {spread(v.after_rms / ls)} {length}, max {spread(v.before_max / ls)} ->"
            f" {spread(v.after_max / ls)} {length} (before: nominal geometry with base and tool fitted)"
        )
    for note in res.notes:
        say("yellow", "note:", f" {note}")
