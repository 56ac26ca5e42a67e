"""``models``, ``show`` and ``export``: the built-in robots and a robot file's table, as read."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer

from .common import commands
from .console import console, fail, print_rows, print_table, say, status, table_rows, wrote
from .options import AngleOpt, BaseLinkOpt, ChainOnlyOpt, JsonOpt, LengthOpt, ModelArg, TipLinkOpt
from .outputs import SI_UNITS, emit_json, json_target, require_plot_extra
from .values import load_robot, parse_joint_values

if TYPE_CHECKING:
    from ..robot import Robot


@commands.command()
def models(json_out: JsonOpt = None) -> None:
    """List the built-in robots (names and descriptions: no units)."""
    from ..io.robots import builtin_names, load  # noqa: PLC0415

    json_out = json_target(json_out)
    rows = []
    for name in builtin_names():
        r = load(name)
        rows.append(
            {
                "name": name,
                "convention": r.convention,
                "joints": len(r.names),
                "description": r.description,
                "source": r.source,
            }
        )
    if json_out:
        emit_json(rows, json_out)
        if json_out == "-":
            return
    print_rows(
        "Built-in robots",
        ["name", "convention", "joints", "description"],
        [[r["name"], r["convention"], str(r["joints"]), r["description"]] for r in rows],
        left=(1, 3),
        prose=(3,),
    )


def robot_json(robot: Robot) -> dict:
    """A robot as JSON, SI: its table's rows keyed by column (m, rad; POE w and a prismatic v unitless), kinds, limits,
    home, its model checksum."""
    from ..fleet.checksum import model_checksum  # noqa: PLC0415

    si = ["rad" if k == "revolute" else "m" for k in robot.table.kinds]
    return {
        "model": robot.name,
        "convention": robot.convention,
        "description": robot.description,
        "source": robot.source,
        "units": SI_UNITS,
        "joints": [
            {"joint": n, "kind": k, **row, "lower": float(lo), "upper": float(hi)}
            for n, k, row, lo, hi in zip(
                robot.names, robot.table.kinds, table_rows(robot.table, "m", "rad"), robot.lower, robot.upper
            )
        ],
        "joint_units": si,
        "home": None if robot.home is None else [float(v) for v in robot.home],
        "compliance": _compliance_rows(robot),
        "model_checksum": model_checksum(robot),
    }


def _compliance_rows(robot: Robot) -> list | None:
    """The joints' compliances (a robot file's [compliance], issue 37) as rows naming their unit (SI), or None."""
    if robot.compliance is None:
        return None
    cov = robot.compliance_covariance
    return [
        {
            "joint": n,
            "unit": "rad/(N m)" if k == "revolute" else "m/N",
            "value": float(v),
            "sigma": None if cov is None else float(max(cov[i, i], 0.0) ** 0.5),
        }
        for i, (n, k, v) in enumerate(zip(robot.names, robot.table.kinds, robot.compliance, strict=True))
    ]


@commands.command()
def show(
    model: ModelArg,
    length: LengthOpt = "mm",
    angle: AngleOpt = "deg",
    report: Annotated[
        Path | None,
        typer.Option(
            "--report", help="Write a self-contained HTML report: 3-D frames of two conventions, origin paths, tables."
        ),
    ] = None,
    plot: Annotated[
        Path | None, typer.Option("--plot", help="Write the static figures (PNG) into this folder.")
    ] = None,
    compare: Annotated[
        str | None,
        typer.Option(
            "--compare",
            help="Drawn beside the robot in --report/--plot: a convention (dh|mdh|edh|poe) or another robot "
            "(built-in name or file). Default edh (mdh for an ED-H robot).",
        ),
    ] = None,
    q: Annotated[
        str | None,
        typer.Option(
            "--q",
            help="Configuration drawn in --report/--plot, one value per joint in --angle units (prismatic: --length); "
            "default the file's home, else zeros.",
        ),
    ] = None,
    json_out: JsonOpt = None,
    base_link: BaseLinkOpt = None,
    tip_link: TipLinkOpt = None,
) -> None:
    """Print a robot file's table as read (with units); optionally draw its frames beside another convention's."""
    from ..fleet.checksum import model_checksum  # noqa: PLC0415

    require_plot_extra(report=report, plot=plot)  # before any work: the plot extra's modules
    json_out = json_target(json_out)
    for given, flag in ((compare, "--compare"), (q, "--q")):
        if given is not None and not (report or plot):
            fail(f"{flag} {given}: it sets what --report or --plot draws; give one of them too")
    robot = load_robot(model, base_link, tip_link)
    qv = parse_joint_values(q, "--q", robot, length, angle) if q is not None else None
    if json_out:
        emit_json(robot_json(robot), json_out)
    if json_out != "-":
        say("bold", f"{robot.name} ({robot.convention})", f" — {robot.description}")
        if robot.source:
            console.print(f"  source: {robot.source}", soft_wrap=True)
        print_table(robot.table, robot.names, length, angle, f"{robot.name} in {robot.convention}")
        console.print(f"Model checksum {model_checksum(robot)} (of the geometry, the same in any convention)")
        if robot.compliance is not None:
            console.print(
                "Joint compliances (urad/(N m), um/N for a prismatic joint): "
                + ", ".join(f"{n} {v * 1e6:.4g}" for n, v in zip(robot.names, robot.compliance, strict=True))
            )
    if report or plot:
        from .. import report as rep  # noqa: PLC0415

        if plot:
            with status(f"drawing the figures into {plot} ..."):
                files = rep.write_model_figures(robot, plot, compare=compare, q=qv, length=length)
            for f in files:
                wrote(f)
        if report:
            with status(f"writing the report {report} ..."):
                rep.write_model_report(robot, report, compare=compare, q=qv, length=length, angle=angle)
            wrote(report)


@commands.command(name="export")
def export_cmd(
    model: ModelArg,
    length: LengthOpt = "mm",
    angle: AngleOpt = "deg",
    json_out: JsonOpt = None,
    base_link: BaseLinkOpt = None,
    tip_link: TipLinkOpt = None,
    chain_only: ChainOnlyOpt = False,
    ur_kinematics: Annotated[
        Path | None,
        typer.Option(
            "--ur-kinematics",
            help="Write Universal Robots' kinematics-parameters YAML (what ur_description's kinematics_params_file "
            "reads) instead of a robot file ('-': standard output).",
        ),
    ] = None,
    ur_nominal: Annotated[
        str,
        typer.Option(
            "--ur-nominal",
            help="With --ur-kinematics: the nominal UR arm (a standard DH robot file or built-in) whose link frames "
            "the file follows.",
        ),
    ] = "ur5",
) -> None:
    """Print a robot file (TOML) in --length / --angle units (or, with --json, the robot as JSON in SI), or write a UR
    kinematics-parameters file."""
    from ..fleet.checksum import model_checksum  # noqa: PLC0415

    json_out = json_target(json_out)
    robot = load_robot(model, base_link, tip_link, chain_only=chain_only)
    if ur_kinematics is not None:
        from ..compensation import flange_model  # noqa: PLC0415
        from ..io.ur_calibration import save  # noqa: PLC0415

        nominal = load_robot(ur_nominal, what="--ur-nominal")
        # the flange compensate uses (a calibration's measured point as its tool: its canonical flange, whichever file)
        flange = flange_model(nominal, robot)
        save(ur_kinematics, flange, nominal.table)
        wrote(ur_kinematics, f" (model checksum {model_checksum(flange)})")
        return
    if json_out:
        emit_json(robot_json(robot), json_out)
        return
    from ..io.robotfile import dumps  # noqa: PLC0415

    print(dumps(robot, length, angle), end="")
    say("dim", f"model checksum {model_checksum(robot)}", err=True)
