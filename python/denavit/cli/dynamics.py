"""``dynamics``: inverse dynamics (recursive Newton-Euler)."""

from __future__ import annotations

import math
from typing import Annotated

import typer
from rich.table import Table as RichTable

from .. import _core
from ..io.output import json_text
from .common import BaseLinkOpt, JsonOpt, ModelArg, TipLinkOpt, app, console, fail, fmt, joint_values_out, load_robot, parse_joint_values, parse_numbers, say


@app.command()
def dynamics(
    model: ModelArg,
    q: Annotated[str | None, typer.Option("--q", help="Joint values, one per joint (default zeros).")] = None,
    qd: Annotated[str | None, typer.Option("--qd", help="Joint velocities per second (default zeros).")] = None,
    qdd: Annotated[str | None, typer.Option("--qdd", help="Joint accelerations per second squared (default zeros).")] = None,
    deg: Annotated[bool, typer.Option("--deg", help="Revolute values (and their rates) in degrees (default radians).")] = False,
    unit: Annotated[str, typer.Option("--unit", help="Length unit of prismatic values and their rates: m, mm, ...")] = "m",
    gravity: Annotated[str, typer.Option("--gravity", help="Gravity in world, m/s^2.")] = "0,0,-9.81",
    f_ext: Annotated[str | None, typer.Option("--f-ext", help="Wrench on the tool by the environment, \"fx,fy,fz,nx,ny,nz\" in N and N m, tool-frame axes, moment about the tool origin.")] = None,
    json_out: JsonOpt = False,
    base_link: BaseLinkOpt = None,
    tip_link: TipLinkOpt = None,
) -> None:
    """Inverse dynamics (recursive Newton-Euler): the joint torques (N m) / forces (N) for q, qd, qdd.

    Uses the link inertias of the robot file (\\[joints.inertia]); without them every link is massless and a
    warning says so. Also prints the gravity part of the torques.
    """
    robot = load_robot(model, base_link, tip_link)
    m = robot.model()
    angle = "deg" if deg else "rad"
    qv, qdv, qddv = (parse_joint_values(t, what, robot, unit, angle) for t, what in ((q, "--q"), (qd, "--qd"), (qdd, "--qdd")))
    g = parse_numbers(gravity, "--gravity")
    if len(g) != 3:
        fail(f"--gravity: expected 3 values (m/s^2, world), got {len(g)}")
    f = parse_numbers(f_ext, "--f-ext") if f_ext else None
    if f is not None and len(f) != 6:
        fail(f"--f-ext: expected 6 values fx,fy,fz,nx,ny,nz (N, N m, tool frame), got {len(f)}")
    tau = _core.rnea(m, qv, qdv, qddv, gravity=g, f_ext=f)
    tau_g = _core.gravity_torques(m, qv, gravity=g)
    if not all(map(math.isfinite, [*tau.tolist(), *tau_g.tolist()])):  # e.g. qd = 1e160: squares overflow to NaN
        fail("the torques overflow (not finite) for these --q/--qd/--qdd: expected the joint values, rates and accelerations of a moving robot")
    units = ["N m" if k == "revolute" else "N" for k in robot.table.kinds]
    warning = None if robot.inertials is not None else f"{robot.name} carries no inertial parameters ([joints.inertia]): every link is massless"
    if json_out:
        doc = {
            "model": robot.name,
            "units": {"angle": angle, "length": unit, "time": "s", "torque": "N m", "force": "N"},
            "q": joint_values_out(qv, robot, unit, angle), "qd": joint_values_out(qdv, robot, unit, angle), "qdd": joint_values_out(qddv, robot, unit, angle),
            "gravity": g, "f_ext": f, "tau": tau.tolist(), "tau_gravity": tau_g.tolist(), "tau_units": units,
        }
        if warning:
            doc["warning"] = warning
        print(json_text(doc), end="")
        return
    if warning:
        say("bold yellow", "warning:", f" {warning}", err=True)
    say("bold", robot.name, f" ({robot.description}) — inverse dynamics, gravity {g} m/s^2 in world")
    t = RichTable(title="Joint efforts")
    for c in ("joint", "tau", "of which gravity", "unit"):
        t.add_column(c, justify="right")
    for name, v, vg, u in zip(robot.names, tau, tau_g, units):
        t.add_row(name, fmt(v), fmt(vg), u)
    console.print(t)
