"""``models``, ``show`` and ``export``: the built-in robots and a robot file's table, as read."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer
from rich.table import Table as RichTable

from ..io.output import json_text
from ..robot import builtin_names, load
from .common import BaseLinkOpt, ChainOnlyOpt, JsonOpt, ModelArg, TipLinkOpt, app, console, load_robot, parse_joint_values, print_table, wrote


@app.command()
def models(json_out: JsonOpt = False) -> None:
    """List the built-in robots."""
    rows = []
    for name in builtin_names():
        r = load(name)
        rows.append({"name": name, "convention": r.convention, "joints": len(r.names), "description": r.description, "source": r.source})
    if json_out:
        print(json_text(rows), end="")
        return
    t = RichTable(title="Built-in robots")
    for c in ("name", "convention", "joints", "description"):
        t.add_column(c)
    for r in rows:
        t.add_row(r["name"], r["convention"], str(r["joints"]), r["description"])
    console.print(t)


@app.command()
def show(
    model: ModelArg,
    length: str = "mm",
    angle: str = "deg",
    report: Annotated[Path | None, typer.Option("--report", help="Write a self-contained HTML report: 3-D frames of two conventions, origin paths, tables.")] = None,
    plot: Annotated[Path | None, typer.Option("--plot", help="Write the static figures (PNG) into this folder.")] = None,
    compare: Annotated[str | None, typer.Option("--compare", help="Drawn beside the robot in --report/--plot: a convention (dh|mdh|edh|poe) or another robot (built-in name or file). Default edh (mdh for an ED-H robot).")] = None,
    q: Annotated[str | None, typer.Option("--q", help="Configuration drawn in --report/--plot, one value per joint (default: the file's home, else zeros).")] = None,
    deg: Annotated[bool, typer.Option("--deg", help="--q revolute values in degrees (default radians); prismatic values in --length.")] = False,
    base_link: BaseLinkOpt = None,
    tip_link: TipLinkOpt = None,
) -> None:
    """Print a robot file's table as read (with units); optionally draw its frames beside another convention's."""
    robot = load_robot(model, base_link, tip_link)
    print_table(robot.table, robot.names, length, angle, f"{robot.name} ({robot.convention}) — {robot.source}")
    if report or plot:
        from .. import report as rep  # noqa: PLC0415

        qv = parse_joint_values(q, "--q", robot, length, "deg" if deg else "rad") if q else None
        if plot:
            for f in rep.write_model_figures(robot, plot, compare=compare, q=qv, length=length):
                wrote(f)
        if report:
            rep.write_model_report(robot, report, compare=compare, q=qv, length=length, angle=angle)
            wrote(report)


@app.command(name="export")
def export_cmd(
    model: ModelArg,
    length: str = "mm",
    angle: str = "deg",
    base_link: BaseLinkOpt = None,
    tip_link: TipLinkOpt = None,
    chain_only: ChainOnlyOpt = False,
    ur_kinematics: Annotated[Path | None, typer.Option("--ur-kinematics", help="Write Universal Robots' kinematics-parameters YAML (what ur_description's kinematics_params_file reads) instead of a robot file ('-': standard output).")] = None,
    ur_nominal: Annotated[str, typer.Option("--ur-nominal", help="With --ur-kinematics: the nominal UR arm (a standard DH robot file or built-in) whose link frames the file follows.")] = "ur5",
) -> None:
    """Print a robot file (TOML) in the given units, or write a UR kinematics-parameters file."""
    robot = load_robot(model, base_link, tip_link, chain_only=chain_only)
    if ur_kinematics is not None:
        from ..io.ur_calibration import save  # noqa: PLC0415

        save(ur_kinematics, robot.model(), load_robot(ur_nominal, what="--ur-nominal").table)
        wrote(ur_kinematics)
        return
    from ..io.robotfile import dumps  # noqa: PLC0415

    print(dumps(robot, length, angle), end="")
