"""``fk``: forward kinematics."""

from __future__ import annotations

from typing import Annotated

import typer
from rich.table import Table as RichTable

from .. import _core
from ..io.output import json_text
from ..io.units import length_scale
from ..robot import load
from .common import JsonOpt, ModelArg, app, console, fmt, joint_values_out, parse_joint_values, pose_rows, say


@app.command()
def fk(
    model: ModelArg,
    q: Annotated[str | None, typer.Option("--q", help="Joint values, one per joint, e.g. \"90,-90,90,0,90,0\" (default zeros).")] = None,
    deg: Annotated[bool, typer.Option("--deg", help="Revolute joint values in degrees (default radians).")] = False,
    unit: Annotated[str, typer.Option("--unit", help="Length unit of the output and of prismatic values: m, mm, ...")] = "m",
    json_out: JsonOpt = False,
) -> None:
    """Forward kinematics: the tool pose and every joint frame (T_world_joint)."""
    robot = load(model)
    m = robot.model()
    angle = "deg" if deg else "rad"
    qv = parse_joint_values(q, "--q", robot, unit, angle)
    ls = length_scale(unit)
    T = _core.fk(m, qv)
    frames = _core.joint_frames(m, qv)
    if json_out:
        print(json_text({"model": robot.name, "units": {"length": unit, "angle": angle}, "q": joint_values_out(qv, robot, unit, angle),
                          "T_world_tool": pose_rows(T, ls), "T_world_joint": {n: pose_rows(F, ls) for n, F in zip(robot.names, frames)}}), end="")
        return
    say("bold", robot.name, f" ({robot.description}) — lengths in {unit}")
    t = RichTable(title="T_world_tool")
    for c in ("", "x", "y", "z", "p"):
        t.add_column(c, justify="right")
    for i, row in enumerate(pose_rows(T, ls)[:3]):
        t.add_row("xyz"[i], *(fmt(v) for v in row))
    console.print(t)
    ft = RichTable(title="Joint frames (origin, z axis) in world")
    for c in ("joint", "x", "y", "z", "z_x", "z_y", "z_z"):
        ft.add_column(c, justify="right")
    for n, F in zip(robot.names, frames):
        ft.add_row(n, *(fmt(v / ls) for v in F[:3, 3]), *(fmt(v) for v in F[:3, 2]))
    console.print(ft)
