"""``simulate``: joint sweeps of a model, written as the long-form CSV."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Annotated

import typer

from ..io.units import angle_scale, length_scale
from .common import commands
from .console import fail, spread, wrote
from .options import AngleOpt, BaseLinkOpt, LengthOpt, ModelArg, TipLinkOpt
from .plan import NOISE_M, TOOL_M
from .values import check_noises, count, load_robot, parse_joint_values, parse_point, parse_ranges, positive

#: The default orientation noise of simulated 6-DoF poses (rad): 0.005 deg, a 6-DoF probe's (T-Mac class) order.
NOISE_ROT_RAD = math.radians(0.005)


@commands.command()
def simulate(
    model: ModelArg,
    output: Annotated[Path, typer.Option("-o", "--output", help="Long-form CSV to write ('-': standard output).")],
    home: Annotated[
        str | None,
        typer.Option(
            "--home",
            help=(
                "Home configuration in --angle units, prismatic joints in --length (default: the model file's home,"
                " else zeros)."
            ),
        ),
    ] = None,
    ranges: Annotated[
        str | None,
        typer.Option(
            "--ranges",
            help=(
                "Per-joint start,end pairs in --angle units (prismatic: --length), or 'paper90' (the default) /"
                " 'paper30' (Hayat Table II)."
            ),
        ),
    ] = None,
    points: Annotated[int, typer.Option("--points", help="Points per sweep.")] = 30,
    tool: Annotated[
        str | None,
        typer.Option(
            "--tool", help="Tool point in the flange frame, in --length units (default 50,30,100 mm whatever the unit)."
        ),
    ] = None,
    noise: Annotated[
        float | None,
        typer.Option(
            "--noise",
            help="Point noise (1 sigma per coordinate), in --length units (default 0.02 mm whatever the unit).",
        ),
    ] = None,
    noise_q: Annotated[float, typer.Option("--noise-q", help="Joint-reading noise (1 sigma), in --angle units.")] = 0.0,
    seed: Annotated[int, typer.Option("--seed", help="Seed of the noise.")] = 0,
    length: LengthOpt = "mm",
    angle: AngleOpt = "deg",
    targets: Annotated[
        str | None,
        typer.Option(
            "--targets",
            help=(
                'Several targets per pose (2-4 SMRs on a nest): their points in the flange frame, "x,y,z; x,y,z; ..."'
                " in --length units (replaces --tool; written as columns x2,y2,z2,... and a '# nest:' line)."
            ),
        ),
    ] = None,
    poses: Annotated[
        bool,
        typer.Option(
            "--poses",
            help=(
                "6-DoF poses: also write each pose's orientation (the flange's, at the tool point) as a quaternion"
                " qw,qx,qy,qz."
            ),
        ),
    ] = False,
    noise_rot: Annotated[
        float | None,
        typer.Option(
            "--noise-rot",
            help=(
                "Orientation noise of --poses (1 sigma per component of a rotation vector), in --angle units (default"
                " 0.005 deg whatever the unit)."
            ),
        ),
    ] = None,
    coupling: Annotated[
        str | None,
        typer.Option(
            "--coupling",
            help=(
                "The readings written are a controller's whose joint values are, e.g., \"q3=r3+r2\" (a Fanuc's J3;"
                " docs/robot-files.md); default: the robot file's \\[couplings]."
            ),
        ),
    ] = None,
    base_link: BaseLinkOpt = None,
    tip_link: TipLinkOpt = None,
) -> None:
    """Simulate joint sweeps of a model (for planning a measurement and for tests); writes the long-form CSV."""
    from dataclasses import replace  # noqa: PLC0415

    import numpy as np  # noqa: PLC0415

    from .. import sweeps as sw  # noqa: PLC0415
    from ..io.robotfile import parse_coupling  # noqa: PLC0415
    from ..io.sweeps import WRITE_ROWS, write_long_csv  # noqa: PLC0415

    count(points, "--points", "points", least=3, counted="points per sweep")
    robot = load_robot(model, base_link, tip_link)
    m = robot.model()
    ls, as_ = length_scale(length), angle_scale(angle)
    h = parse_joint_values(home, "--home", robot, length, angle, default=robot.home)
    r = parse_ranges(ranges, robot, length, angle, "paper90")
    tp = parse_point(tool, "--tool", ls, TOOL_M)
    nest = _nest(targets, ls)
    sigma_rot = positive(noise_rot, "--noise-rot", as_, NOISE_ROT_RAD, angle)
    sigma = positive(noise, "--noise", ls, NOISE_M, length)
    sigma_q = positive(noise_q, "--noise-q", as_, 0.0, angle)
    check_noises(
        m,
        nest if nest is not None else tp,
        length,
        angle,
        ("--noise", sigma, "length"),
        ("--noise-rot", sigma_rot, "angle"),
        ("--noise-q", sigma_q, "joint"),
    )
    s, pieces = sw.simulation(  # written a piece at a time as it is made (issue 41)
        m,
        home=h,
        ranges=r,
        points_per_sweep=points,
        tool_point=tp,
        noise=sigma,
        noise_q=sigma_q,
        seed=seed,
        targets=nest,
        poses=poses,
        noise_rot=sigma_rot,
        rows=WRITE_ROWS,
    )
    C = parse_coupling(coupling, list(m.kinds), "--coupling") if coupling else robot.coupling
    if C is not None:  # the controller reports readings r = C^-1 q
        from ..identification import decoupled  # noqa: PLC0415

        R = np.linalg.inv(C)
        s, pieces = decoupled(s, R), (replace(p, q=p.q @ R.T) for p in pieces)  # each piece as decoupled does
    write_long_csv(
        output,
        s,
        length,
        angle,
        f"simulated sweeps of {robot.name}: seed {seed}, noise {spread(sigma / ls)} {length}, readings noise"
        f" {spread(sigma_q / as_)} {angle}",
        pieces,
    )
    what = (f", {len(nest)} targets per pose" if nest is not None and len(nest) > 1 else "") + (
        ", 6-DoF poses" if poses else ""
    )
    wrote(output, f": {m.nq} sweeps x {points} points{what}")


def _nest(targets: str | None, ls: float):
    """``--targets``' points (K, 3) m, or None."""
    import numpy as np  # noqa: PLC0415

    if targets is None:
        return None
    parts = [p for p in targets.split(";") if p.strip()]
    nest = np.array([parse_point(p, f"--targets (target {k + 1})", ls, TOOL_M) for k, p in enumerate(parts)])
    if not 1 <= len(nest) <= 16:
        fail(f"--targets: expected 1 to 16 points 'x,y,z' separated by ';', got {len(nest)}")
    return nest
