"""``fk``: forward kinematics."""

from __future__ import annotations

from typing import Annotated

import typer

from ..io.units import length_scale
from .common import commands
from .console import num, print_rows, say
from .options import AngleOpt, BaseLinkOpt, JsonOpt, LengthOpt, ModelArg, TipLinkOpt
from .outputs import SI_UNITS, emit_json, json_target, pose_rows
from .values import load_robot, parse_joint_values, pose_text


@commands.command()
def fk(
    model: ModelArg,
    q: Annotated[
        str | None,
        typer.Option(
            "--q",
            help=(
                "Joint values, one per joint, in --angle units (default deg; prismatic: --length, default mm), e.g."
                ' "90,-90,90,0,90,0" (default zeros); beyond the limits: a warning.'
            ),
        ),
    ] = None,
    length: LengthOpt = "mm",
    angle: AngleOpt = "deg",
    json_out: JsonOpt = None,
    base_link: BaseLinkOpt = None,
    tip_link: TipLinkOpt = None,
) -> None:
    """Forward kinematics: the tool pose and every joint frame (T_world_joint)."""
    from .. import _core  # noqa: PLC0415
    from ..geometry import matrix_rotvec  # noqa: PLC0415

    json_out = json_target(json_out)
    robot = load_robot(model, base_link, tip_link)
    m = robot.model()
    qv = parse_joint_values(q, "--q", robot, length, angle)
    ls = length_scale(length)
    T = _core.fk(m, qv)
    frames = _core.joint_frames(m, qv)
    if json_out:
        emit_json(
            {
                "model": robot.name,
                "units": SI_UNITS,
                "q": qv.tolist(),
                "joint_units": ["rad" if k == "revolute" else "m" for k in robot.table.kinds],
                "T_world_tool": pose_rows(T, 1.0),
                "pose": {"xyz_m": T[:3, 3].tolist(), "rotvec_rad": matrix_rotvec(T[:3, :3]).tolist()},
                "T_world_joint": {n: pose_rows(F, 1.0) for n, F in zip(robot.names, frames)},
            },
            json_out,
        )
        if json_out == "-":
            return
    say("bold", robot.name, f" ({robot.description})")
    say(
        "bold",
        "pose",
        f" (x,y,z [{length}], rotation vector [{angle}]; ik --goal reads it): {pose_text(T, length, angle)}",
    )
    print_rows(
        "T_world_tool",
        ["", "x [1]", "y [1]", "z [1]", f"p [{length}]"],
        [
            ["xyz"[i], *(num(v, "1") for v in row[:3]), num(row[3], length)]
            for i, row in enumerate(pose_rows(T, ls)[:3])
        ],
    )
    print_rows(
        "Joint frames in world: origin and z axis",
        ["joint", f"x [{length}]", f"y [{length}]", f"z [{length}]", "z_x [1]", "z_y [1]", "z_z [1]"],
        [
            [n, *(num(v / ls, length) for v in F[:3, 3]), *(num(v, "1") for v in F[:3, 2])]
            for n, F in zip(robot.names, frames)
        ],
    )
