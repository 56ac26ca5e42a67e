"""``ik``: inverse kinematics."""

from __future__ import annotations

from typing import Annotated

import typer
from rich.table import Table as RichTable
from rich.text import Text

from .. import _core
from ..io.output import json_text
from ..io.units import joint_unit, length_scale
from ..robot import load
from .common import JsonOpt, ModelArg, app, console, fmt, joint_values_out, parse_joint_values, parse_pose, pose_rows


@app.command()
def ik(
    model: ModelArg,
    pose: Annotated[str, typer.Option("--pose", help="Target T_world_tool: 16 (or 12) numbers, the rows of the 4x4 pose, or \"x,y,z,roll,pitch,yaw\" with R = Rz(yaw) Ry(pitch) Rx(roll).")],
    q0: Annotated[str | None, typer.Option("--q0", help="Start configuration, one value per joint (default zeros).")] = None,
    deg: Annotated[bool, typer.Option("--deg", help="Angles (revolute joints, roll/pitch/yaw) in degrees (default radians).")] = False,
    unit: Annotated[str, typer.Option("--unit", help="Length unit of --pose, prismatic values and the position error: m, mm, ...")] = "m",
    method: Annotated[str, typer.Option("--method", help="lm (Levenberg-Marquardt) | newton (Newton-Raphson)")] = "lm",
    tol_position: Annotated[float, typer.Option("--tol-position", help="Largest accepted position error, in --unit.")] = 1e-10,
    tol_rotation: Annotated[float, typer.Option("--tol-rotation", help="Largest accepted rotation error, rad.")] = 1e-10,
    restarts: Annotated[int, typer.Option("--restarts", help="Further attempts from seeded random configurations.")] = 50,
    seed: Annotated[int, typer.Option("--seed")] = 0,
    no_limits: Annotated[bool, typer.Option("--no-limits", help="Ignore the joint limits.")] = False,
    json_out: JsonOpt = False,
) -> None:
    """Inverse kinematics: joint values that put the tool at --pose. Success is judged from the measured final
    error against the tolerances; exit code 1 when the target is not met (the residual is printed)."""
    robot = load(model)
    m = robot.model()
    angle = "deg" if deg else "rad"
    ls = length_scale(unit)
    T = parse_pose(pose, angle, ls)
    start = parse_joint_values(q0, "--q0", robot, unit, angle)
    r = _core.ik(m, T, start, method=method, tol_position=tol_position * ls, tol_rotation=tol_rotation,
                 restarts=restarts, seed=seed, respect_limits=not no_limits)
    q_out = joint_values_out(r.q, robot, unit, angle)
    if json_out:
        print(json_text({"model": robot.name, "units": {"length": unit, "angle": angle}, "success": r.success,
                          "q": q_out, "iterations": r.iterations, "restarts": r.restarts,
                          "position_error": r.position_error / ls, "rotation_error_rad": r.rotation_error,
                          "T_world_tool": pose_rows(_core.fk(m, r.q), ls)}), end="")
    else:
        verdict = ("solved", "bold green") if r.success else ("not solved", "bold red")
        console.print(Text.assemble((robot.name, "bold"), " — ", verdict, f": position error {r.position_error / ls:.3e} {unit}, "
                                    f"rotation error {r.rotation_error:.3e} rad ({r.iterations} iterations, {r.restarts} restarts)"))
        t = RichTable(title="q")
        for c in ("joint", "q", "unit"):
            t.add_column(c, justify="right")
        for n, v, k in zip(robot.names, q_out, robot.table.kinds):
            t.add_row(n, fmt(v), joint_unit(k, unit, angle))
        console.print(t)
    if not r.success:
        raise typer.Exit(1)
