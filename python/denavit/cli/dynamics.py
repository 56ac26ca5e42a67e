"""``dynamics``: inverse dynamics (recursive Newton-Euler)."""

from __future__ import annotations

from typing import Annotated

import typer

from .common import commands
from .console import fail, fmt, print_rows, say
from .options import AngleOpt, BaseLinkOpt, ChainOnlyOpt, JsonOpt, LengthOpt, ModelArg, TipLinkOpt
from .outputs import SI_UNITS, emit_json, json_target
from .values import load_robot, parse_joint_values, parse_numbers


@commands.command()
def dynamics(
    model: ModelArg,
    q: Annotated[
        str | None,
        typer.Option("--q", help="Joint values, one per joint, in --angle units (prismatic: --length); default zeros."),
    ] = None,
    qd: Annotated[
        str | None,
        typer.Option("--qd", help="Joint velocities in --angle (prismatic: --length) units per second; default zeros."),
    ] = None,
    qdd: Annotated[
        str | None,
        typer.Option(
            "--qdd",
            help="Joint accelerations in --angle (prismatic: --length) units per second squared; default zeros.",
        ),
    ] = None,
    length: LengthOpt = "mm",
    angle: AngleOpt = "deg",
    gravity: Annotated[
        str, typer.Option("--gravity", help="Gravity in world, m/s^2 (SI whatever --length).")
    ] = "0,0,-9.81",
    f_ext: Annotated[
        str | None,
        typer.Option(
            "--f-ext",
            help=(
                'Wrench on the tool by the environment, "fx,fy,fz,nx,ny,nz" in N and N m (SI), tool-frame axes, moment'
                " about the tool origin."
            ),
        ),
    ] = None,
    json_out: JsonOpt = None,
    base_link: BaseLinkOpt = None,
    tip_link: TipLinkOpt = None,
    chain_only: ChainOnlyOpt = False,
) -> None:
    """Inverse dynamics (recursive Newton-Euler): the joint torques (N m) / forces (N) for q, qd, qdd.

    Uses the link inertias of the robot file (\\[joints.inertia]); without them every link is massless and a
    warning says so. Also prints the gravity part of the torques.
    """
    from .. import _core  # noqa: PLC0415

    json_out = json_target(json_out)
    robot = load_robot(model, base_link, tip_link, chain_only=chain_only)
    m = robot.model()
    qv = parse_joint_values(q, "--q", robot, length, angle)
    qdv, qddv = (
        parse_joint_values(t, what, robot, length, angle, limits=False) for t, what in ((qd, "--qd"), (qdd, "--qdd"))
    )
    _check_rates(qdv, robot, length, angle)
    g = parse_numbers(gravity, "--gravity")
    if len(g) != 3:
        fail(f"--gravity: expected 3 values (m/s^2, world), got {len(g)}")
    f = parse_numbers(f_ext, "--f-ext") if f_ext else None
    if f is not None and len(f) != 6:
        fail(f"--f-ext: expected 6 values fx,fy,fz,nx,ny,nz (N, N m, tool frame), got {len(f)}")
    tau = _core.rnea(m, qv, qdv, qddv, gravity=g, f_ext=f)
    tau_g = _core.gravity_torques(m, qv, gravity=g)
    units = ["N m" if k == "revolute" else "N" for k in robot.table.kinds]
    warning = (
        None
        if robot.inertials is not None
        else f"{robot.name} carries no inertial parameters ([joints.inertia]): every link is massless"
    )
    if warning:
        say("bold yellow", "warning:", f" {warning}", err=True)
    if json_out:
        doc = {
            "model": robot.name,
            "units": {**SI_UNITS, "time": "s", "torque": "N m", "force": "N"},
            "q": qv.tolist(),
            "qd": qdv.tolist(),
            "qdd": qddv.tolist(),
            "joint_units": ["rad" if k == "revolute" else "m" for k in robot.table.kinds],
            "gravity_m_s2": g,
            "f_ext": f,
            "tau": tau.tolist(),
            "tau_gravity": tau_g.tolist(),
            "tau_units": units,
        }
        if warning:
            doc["warning"] = warning
        emit_json(doc, json_out)
        if json_out == "-":
            return
    say("bold", robot.name, f" ({robot.description}) — inverse dynamics, gravity {g} m/s^2 in world")
    print_rows(
        "Joint efforts",
        ["joint", "tau", "of which gravity", "unit"],
        [[n, fmt(v), fmt(vg), u] for n, v, vg, u in zip(robot.names, tau, tau_g, units)],
        left=(3,),
    )


def _check_rates(qd, robot, length: str, angle: str) -> None:
    """Joint rates whose squares are finite (the core's bound, sqrt of the largest double per SI unit), or a
    one-line error in the units typed (the core's own names rad/s)."""
    import math  # noqa: PLC0415

    import numpy as np  # noqa: PLC0415

    from ..io.units import joint_scale, joint_unit  # noqa: PLC0415

    sc = joint_scale(robot.table.kinds, length, angle)
    bound = math.sqrt(float(np.finfo(float).max))
    for j, v in enumerate(qd):
        if abs(v) > bound:
            u = joint_unit(robot.table.kinds[j], length, angle)
            fail(
                f"--qd: joint {robot.names[j]} = {v / sc[j]:.6g} {u}/s: expected |qd| <= {bound / sc[j]:.5g} {u}/s"
                " (rates whose squares are finite)"
            )
