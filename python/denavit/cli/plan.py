"""``plan``: predicted sigmas (Cramer-Rao bound) and measuring volume of a protocol, before measuring."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from ..io.units import angle_scale, length_scale
from .common import commands
from .console import console, fail, num, print_rows, say, spread, status
from .options import (
    CONVENTION,
    AngleOpt,
    BaseLinkOpt,
    ConventionOpt,
    JsonOpt,
    LengthOpt,
    ModelArg,
    SchedulerOpt,
    TipLinkOpt,
    VerboseOpt,
    WorkersOpt,
)
from .outputs import SI_UNITS, emit_json, json_target
from .values import (
    calib_unit,
    check_noises,
    convention_name,
    count,
    load_robot,
    parse_joint_values,
    parse_point,
    parse_ranges,
    positive,
)

#: Physical defaults (SI): a tool point 50, 30, 100 mm from the flange, a tracker's 0.02 mm noise.
TOOL_M = (0.05, 0.03, 0.1)
NOISE_M = 2e-5


RangesOpt = Annotated[
    str | None,
    typer.Option(
        "--ranges",
        help="Sweeps: per-joint start,end pairs in --angle units (prismatic: --length), or 'paper30' / 'paper90' "
        "(Hayat Table II).",
    ),
]

HomeOpt = Annotated[
    str | None,
    typer.Option(
        "--home",
        help="Home configuration of the sweeps in --angle units, prismatic joints in --length (default: the model "
        "file's home, else zeros).",
    ),
]

PointsOpt = Annotated[int, typer.Option("--points", help="Points per sweep.")]

ToolOpt = Annotated[
    str | None,
    typer.Option(
        "--tool", help="Tool point in the flange frame, in --length units (default 50,30,100 mm whatever the unit)."
    ),
]

NoiseOpt = Annotated[
    float | None,
    typer.Option(
        "--noise",
        help="Point noise (1 sigma per coordinate), in --length units (default 0.02 mm whatever the unit).",
    ),
]


FixOpt = Annotated[
    str | None, typer.Option("--fix", help="Parameters held fixed (names or patterns, comma-separated).")
]

RandomOpt = Annotated[
    int | None,
    typer.Option("--random", help="Plan N configurations spread over the joint limits instead of sweeps."),
]

CandidatesOpt = Annotated[
    Path | None,
    typer.Option(
        "--candidates",
        help="CSV of candidate configurations (header q1..qn, --angle / --length units unless a '# units:' line "
        "declares them).",
    ),
]

SelectOpt = Annotated[
    int | None,
    typer.Option("--select", help="Pick this many most informative poses from the candidates (D-optimal)."),
]

PayloadOpt = Annotated[
    str | None,
    typer.Option(
        "--payload",
        help="Also predict the joints' compliances' sigmas for the planned poses measured twice, without payload "
        "and with this one: its mass with a unit and optionally its centre of mass in the flange frame, e.g. "
        '"5 kg @ 0,0,80 mm" (needs the model\'s link masses).',
    ),
]

MonteCarloOpt = Annotated[
    int | None,
    typer.Option(
        "--monte-carlo",
        help="Also calibrate the plan N times on simulated data (the model with fresh noise) and compare each "
        "parameter's spread with its predicted sigma; the runs are Dask tasks (--scheduler, --workers).",
    ),
]

SeedOpt = Annotated[int, typer.Option("--seed", help="With --monte-carlo: run k's noise is drawn from seed + k.")]

CheckPosesOpt = Annotated[
    int | None,
    typer.Option(
        "--check-poses",
        help="Instead: choose the drift check's N poses (denavit check) for the highest power against a change of "
        "any joint's offset; MODEL with its [covariance] (calibrate --save).",
    ),
]

OutputOpt = Annotated[
    Path | None, typer.Option("-o", "--output", help="With --check-poses: write the poses' CSV here (default: print).")
]


@commands.command()
def plan(
    model: ModelArg,
    ranges: RangesOpt = None,
    home: HomeOpt = None,
    points: PointsOpt = 30,
    tool: ToolOpt = None,
    noise: NoiseOpt = None,
    convention: ConventionOpt = CONVENTION,
    fix: FixOpt = None,
    random: RandomOpt = None,
    candidates: CandidatesOpt = None,
    select: SelectOpt = None,
    length: LengthOpt = "mm",
    angle: AngleOpt = "deg",
    json_out: JsonOpt = None,
    base_link: BaseLinkOpt = None,
    tip_link: TipLinkOpt = None,
    payload: PayloadOpt = None,
    monte_carlo: MonteCarloOpt = None,
    seed: SeedOpt = 0,
    scheduler: SchedulerOpt = None,
    workers: WorkersOpt = None,
    check_poses: CheckPosesOpt = None,
    output: OutputOpt = None,
    verbose: VerboseOpt = False,
) -> None:
    """Predict every parameter's sigma (Cramer-Rao bound) and the measuring volume of a protocol, before measuring."""

    from .. import calibration as cal  # noqa: PLC0415
    from ..io.configurations import read_configurations  # noqa: PLC0415

    json_out = json_target(json_out)
    if random is not None and random >= 1:
        count(random, "--random", "poses", counted="configurations")
    if candidates is None and random is None:
        count(points, "--points", "points", least=3, counted="points per sweep")
    robot = load_robot(model, base_link, tip_link)
    n = len(robot.names)
    ls = length_scale(length)
    convention = convention_name(convention)
    tp = parse_point(tool, "--tool", ls, TOOL_M)
    sigma = positive(noise, "--noise", ls, NOISE_M, length)
    check_noises(robot.model(), tp, length, angle, ("--noise", sigma, "length"))
    if check_poses is not None:
        from ..fleet.check import FALSE_ALARM  # noqa: PLC0415
        from .check import write_design  # noqa: PLC0415

        count(check_poses, "--check-poses", "poses", counted="poses")
        write_design(robot, check_poses, sigma, FALSE_ALARM, output, length, angle)
        return
    if output is not None:
        fail(f"-o {output}: it writes the poses of --check-poses; give --check-poses N too")
    if monte_carlo is not None and monte_carlo < 2:
        fail(f"--monte-carlo: expected 2 runs or more (a spread needs two), got {monte_carlo}")
    protocol, q = None, None
    if candidates is not None or random is not None:
        if candidates is not None:
            q = read_configurations(candidates, robot.table.kinds, length=length, angle=angle)
        else:
            if random < 1:
                fail(f"--random: expected a positive count, got {random}")
            q = cal.configurations(robot, random)
    else:
        h = parse_joint_values(home, "--home", robot, length, angle, default=robot.home)
        r = parse_ranges(ranges, robot, length, angle, "paper30")
        count(n * points, "--points", "poses", counted=f"poses ({n} sweeps x {points:,} points)")
        protocol = cal.Protocol(h, r, points, tp)
    fixes = [f.strip() for f in (fix or "").split(",") if f.strip()]
    with status("planning..."):
        p = cal.plan(robot, protocol, q=q, noise=sigma, convention=convention, fix=fixes, tool=tp, select=select)
    cp = None
    if payload is not None:  # the two-payload protocol's compliances (calibration/compliance.py)
        from ..calibration.compliance import plan_compliance  # noqa: PLC0415
        from ..io.payload import parse_payload  # noqa: PLC0415

        mass, com = parse_payload(payload, length)
        cp = plan_compliance(robot, p.q, (0.0, mass), com=com, noise=sigma, tool=tp, convention=convention)
    mc = None if monte_carlo is None else _monte_carlo(robot, p, monte_carlo, tp, fixes, seed, scheduler, workers)
    if json_out:
        emit_json({**_plan_json(p, robot, sigma, cp), "monte_carlo": _study_json(mc)}, json_out)
        if json_out == "-":
            return
    what = (
        f"{len(p.q)} poses" + (f" ({select} selected of the candidates)" if select else "")
        if protocol is None
        else f"sweeps of {points} points"
    )
    _print_plan(p, robot, cp, what, sigma, length, angle, verbose)
    if mc is not None:
        _print_study(mc, p, length, angle)


def _monte_carlo(robot, p, runs: int, tool, fix, seed: int, scheduler, workers):
    """The plan's Monte Carlo study (:func:`denavit.fleet.montecarlo.study`) on a Dask cluster (a local one by default
    when Dask is installed) or in this process, with a progress bar of its tasks on stderr."""
    from rich.progress import Progress  # noqa: PLC0415

    from ..fleet.montecarlo import study  # noqa: PLC0415
    from ..fleet.runner import connect, disconnect  # noqa: PLC0415
    from .console import err_console  # noqa: PLC0415

    with status("starting the Dask cluster..."):
        client = connect(scheduler, workers, required=False)
    try:
        with Progress(console=err_console, transient=True) as bar:
            task = bar.add_task(f"Monte Carlo, {runs} runs", total=None)
            return study(
                robot,
                p,
                runs,
                tool=tool,
                fix=fix,
                seed=seed,
                client=client,
                progress=lambda d, t: bar.update(task, completed=d, total=t),
            )
    finally:
        disconnect(client)


def _study_json(mc) -> dict | None:
    """The --json document's ``monte_carlo`` (SI), or None without --monte-carlo."""
    if mc is None:
        return None

    def f(v):
        return float(v) if v == v else None

    return {
        "runs": mc.runs,
        "seed": mc.seed,
        "failed": mc.failed,
        "parameters": [
            {"name": n, "planned_sigma": f(pl), "spread": f(sp), "ratio": f(r), "bias": f(b)}
            for n, pl, sp, r, b in zip(mc.names, mc.planned, mc.spread, mc.ratio, mc.bias, strict=True)
        ],
    }


def _print_study(mc, p, length: str, angle: str) -> None:
    """The Monte Carlo table: every estimated parameter's planned sigma beside the spread of its estimates."""
    import numpy as np  # noqa: PLC0415

    units = p.parametrization.units
    rows = []
    for k, nm in enumerate(mc.names):
        if not np.isfinite(mc.planned[k]):
            continue
        u, s = calib_unit(units[k], length, angle)
        rows.append(
            [nm, u, spread(mc.planned[k] / s), spread(mc.spread[k] / s), f"{mc.ratio[k]:.3g}", spread(mc.bias[k] / s)]
        )
    print_rows(
        f"Monte Carlo: {mc.runs} calibrations of simulated data (seed {mc.seed}), {mc.runs - mc.failed} converged",
        ["parameter", "unit", "planned sigma", "spread", "spread / planned", "bias"],
        rows,
        left=(1,),
        caption="spread: standard deviation of the estimates; bias: their mean error (1 / sqrt(runs) of a sigma is "
        "chance); the model itself is the truth",
    )
    r = mc.ratio[np.isfinite(mc.ratio)]
    if len(r):
        console.print(
            f"spread / planned sigma: median {np.median(r):.3g}, {r.min():.3g} to {r.max():.3g} over {len(r)} "
            f"parameters (the spread of {mc.runs - mc.failed} runs is uncertain by "
            f"{100 / np.sqrt(2 * max(mc.runs - mc.failed - 1, 1)):.2g} %)"
        )


def _plan_json(p, robot, sigma: float, cp) -> dict:
    """The --json document of a plan (SI)."""
    import numpy as np  # noqa: PLC0415

    pz, n = p.parametrization, len(robot.names)
    return {
        "model": robot.name,
        "convention": pz.convention,
        "units": SI_UNITS,
        "noise_m": sigma,
        "n_poses": len(p.q),
        "parameters": [
            {
                "name": nm,
                "unit": calib_unit(pz.units[k], "m", "rad")[0],
                "sigma": None if not np.isfinite(p.sigma[k]) else float(p.sigma[k]),
            }
            for k, nm in enumerate(p.names)
        ],
        "axis_sigma": [
            {
                "joint": nm,
                "position_m": a[0],
                "direction_rad": a[1],
                **({"per_circle_position_m": c[0], "per_circle_direction_rad": c[1]} if c is not None else {}),
            }
            for nm, a, c in zip(
                robot.names,
                p.axis_sigma.tolist(),
                p.per_circle_sigma.tolist() if p.per_circle_sigma is not None else [None] * n,
            )
        ],
        "bounding_box": {"lengths_m": p.box.lengths.tolist(), "volume_m3": p.box.volume},
        "identifiability": {
            "rank": p.identifiability.rank,
            "condition_number": p.identifiability.condition_number,
            "observability": p.identifiability.observability,
            "unidentifiable": [
                {"name": u.name, "structural": u.structural, "reason": u.reason}
                for u in p.identifiability.unidentifiable
            ],
        },
        "selected": None if p.selected is None else p.selected.tolist(),
        "compliance": None
        if cp is None
        else [
            {
                "name": nm,
                "unit": "rad/(N m)" if k == "revolute" else "m/N",
                "sigma": None if not np.isfinite(s_) else float(s_),
            }
            for nm, k, s_ in zip(cp.names, robot.table.kinds, cp.sigma, strict=True)
        ],
    }


def _print_plan(p, robot, cp, what: str, sigma: float, length: str, angle: str, verbose: bool) -> None:
    """A plan's tables: every parameter's sigma, the joint axes', the measuring volume, what the protocol cannot
    identify (the redundant parameters by name, with their reasons under --verbose), the compliances."""
    pz = p.parametrization
    ls, as_ = length_scale(length), angle_scale(angle)
    say(
        "bold",
        f"Plan for {robot.name}",
        f" ({pz.convention}): {what}, noise {spread(sigma / ls)} {length} per coordinate",
    )
    rows = []
    for k, nm in enumerate(p.names):
        u, s = calib_unit(pz.units[k], length, angle)
        rows.append([nm, u, spread(p.sigma[k] / s)])
    print_rows(
        None,
        ["parameter", "unit", "sigma"],
        rows,
        left=(1,),
        caption="Cramer-Rao bound (one sigma) of every parameter; '-': not identifiable (see below)",
    )
    heads = ["joint", f"position [{length}]", f"direction [{angle}]"] + (
        [f"per-circle position [{length}]", "ratio"] if p.per_circle_sigma is not None else []
    )
    arows = []
    for j, nm in enumerate(robot.names):
        row = [nm, spread(p.axis_sigma[j, 0] / ls), spread(p.axis_sigma[j, 1] / as_)]
        if p.per_circle_sigma is not None:
            row += [spread(p.per_circle_sigma[j, 0] / ls), f"{p.per_circle_sigma[j, 0] / p.axis_sigma[j, 0]:.2f}"]
        arows.append(row)
    print_rows("Joint axes at home: predicted sigma across the axis and of its direction", heads, arows)
    b = p.box
    console.print(
        f"Measuring volume (minimum oriented bounding box): {' x '.join(num(v / ls, length) for v in b.lengths)} "
        f"{length}, {b.volume:.4g} m^3"
    )
    console.print(f"Identifiability: {p.identifiability.summary()}")
    red = [u for u in p.identifiability.unidentifiable if u.structural]
    if red and verbose:
        console.print(f"Redundant in the {pz.convention} parametrisation (held at nominal):")
        for u in red:
            console.print(f"  redundant: {u.name}: {u.reason}")
    elif red:
        console.print(
            f"Redundant in the {pz.convention} parametrisation (held at nominal; reasons with --verbose): "
            + ", ".join(u.name for u in red)
        )
    for u in p.identifiability.unidentifiable:
        if not u.structural:
            say("yellow", "not identifiable from this protocol:", f" {u.name}: {u.reason}")
    if p.selected is not None:
        console.print(f"Selected candidates (0-based, in the order chosen): {', '.join(map(str, p.selected.tolist()))}")
    for note in p.notes:
        say("yellow", "note:", f" {note}")
    if cp is not None:
        crow = [
            [nm, "urad/(N m)" if k == "revolute" else "um/N", spread(s_ / 1e-6), f"{t:.4g}"]
            for nm, k, s_, t in zip(cp.names, robot.table.kinds, cp.sigma, cp.torque_max, strict=True)
        ]
        print_rows(
            f"Joint compliances, the poses measured at 0 and {cp.payloads[-1]:g} kg ({cp.n_poses} measurements)",
            ["compliance", "unit", "sigma", "largest torque [N m / N]"],
            crow,
            left=(1,),
            caption="Cramer-Rao bound (one sigma) with the geometry fitted alongside; '-': no parameter (the joint "
            "holds no gravity torque)",
        )
        for note in cp.notes:
            say("yellow", "note:", f" {note}")
