"""``ik``: inverse kinematics."""

from __future__ import annotations

from typing import Annotated

import typer
from rich.text import Text

from ..errors import DenavitError
from ..io.units import angle_scale, joint_unit, length_scale
from .common import commands
from .console import console, fail, num, print_rows, spread
from .options import AngleOpt, BaseLinkOpt, JsonOpt, LengthOpt, ModelArg, TipLinkOpt
from .outputs import SI_UNITS, emit_json, json_target, pose_rows
from .values import deprecated, joint_values_out, load_robot, parse_joint_values, parse_numbers, parse_pose, positive


@commands.command()
def ik(
    model: ModelArg,
    goal: Annotated[
        str | None,
        typer.Option(
            "--goal",
            help=(
                "The tool pose to reach (T_world_tool), as fk prints it: x, y, z, rx, ry, rz (--length units, then the "
                "rotation vector in --angle units); 'rpy: x, y, z, roll, pitch, yaw' names roll, pitch, yaw instead"
                " (R = "
                "Rz(yaw) Ry(pitch) Rx(roll)); or the rows of the 4x4 pose, 16 (or 12) numbers, the translation in"
                " --length "
                "units."
            ),
        ),
    ] = None,
    pose: Annotated[
        str | None,
        typer.Option(
            "--pose",
            help="Deprecated: --goal; six numbers here are x, y, z, roll, pitch, yaw (R = Rz(yaw) Ry(pitch) Rx(roll)).",
        ),
    ] = None,
    q0: Annotated[
        str | None,
        typer.Option(
            "--q0",
            help="Start configuration, one value per joint, in --angle units (prismatic: --length); default zeros.",
        ),
    ] = None,
    length: LengthOpt = "mm",
    angle: AngleOpt = "deg",
    method: Annotated[str, typer.Option("--method", help="lm (Levenberg-Marquardt) | newton (Newton-Raphson)")] = "lm",
    tol_position: Annotated[
        float | None,
        typer.Option(
            "--tol-position",
            help="Largest accepted position error, in --length units (default 1e-10 m, whatever the unit).",
        ),
    ] = None,
    tol_rotation: Annotated[
        float | None,
        typer.Option(
            "--tol-rotation",
            help="Largest accepted rotation error, in --angle units (default 1e-10 rad, whatever the unit).",
        ),
    ] = None,
    restarts: Annotated[
        int, typer.Option("--restarts", help="Further attempts from seeded random configurations.")
    ] = 50,
    seed: Annotated[int, typer.Option("--seed", help="Seed of the random restarts.")] = 0,
    no_limits: Annotated[bool, typer.Option("--no-limits", help="Ignore the joint limits.")] = False,
    json_out: JsonOpt = None,
    base_link: BaseLinkOpt = None,
    tip_link: TipLinkOpt = None,
) -> None:
    """Inverse kinematics: joint values that put the tool at --pose, judged from the measured final error against the
    tolerances.

    Exit code 1 when the target is not met (the residual is printed).
    """
    from .. import _core  # noqa: PLC0415

    json_out = json_target(json_out)
    robot = load_robot(model, base_link, tip_link)
    m = robot.model()
    ls, as_ = length_scale(length), angle_scale(angle)
    if (goal is None) == (pose is None):
        fail("give the tool pose to reach: --goal x,y,z,rx,ry,rz (as fk prints it)")
    T = parse_pose(goal, angle, ls, "--goal", six="rotvec") if goal is not None else parse_pose(pose, angle, ls)
    if pose is not None and len(parse_numbers(pose, "--pose")) == 6 and not pose.strip().lower().startswith("rpy"):
        deprecated(
            "--pose x,y,z,roll,pitch,yaw", "--goal 'rpy: x,y,z,roll,pitch,yaw' (or --goal x,y,z,rx,ry,rz)", last=True
        )
    start = parse_joint_values(q0, "--q0", robot, length, angle)
    tp = positive(tol_position, "--tol-position", ls, 1e-10, length)
    tr = positive(tol_rotation, "--tol-rotation", as_, 1e-10, angle)
    try:
        r = _core.ik(
            m,
            T,
            start,
            method=method,
            tol_position=tp,
            tol_rotation=tr,
            restarts=restarts,
            seed=seed,
            respect_limits=not no_limits,
        )
    except DenavitError as e:  # the core names the goal T_goal (the error's `what`): say which option gave it
        if e.what == "T_goal":
            fail(f"{'--goal' if goal is not None else '--pose'}: {e}")
        raise
    if json_out:
        emit_json(
            {
                "model": robot.name,
                "units": SI_UNITS,
                "success": r.success,
                "q": list(map(float, r.q)),
                "joint_units": ["rad" if k == "revolute" else "m" for k in robot.table.kinds],
                "iterations": r.iterations,
                "restarts": r.restarts,
                "position_error_m": r.position_error,
                "rotation_error_rad": r.rotation_error,
                "T_world_tool": pose_rows(_core.fk(m, r.q), 1.0),
            },
            json_out,
        )
    if json_out != "-":
        verdict = ("solved", "bold green") if r.success else ("not solved", "bold red")
        console.print(
            Text.assemble(
                (robot.name, "bold"),
                " — ",
                verdict,
                f": position error {spread(r.position_error / ls)} {length}, rotation error"
                f" {spread(r.rotation_error / as_)} {angle} ({r.iterations} iterations, {r.restarts} restarts)",
            )
        )
        q_out = joint_values_out(r.q, robot, length, angle)
        print_rows(
            "q",
            ["joint", "q", "unit"],
            [
                [n, num(v, joint_unit(k, length, angle)), joint_unit(k, length, angle)]
                for n, v, k in zip(robot.names, q_out, robot.table.kinds)
            ],
            left=(2,),
        )
    if not r.success:
        raise typer.Exit(1)
