"""``convert``: a robot in another convention (or URDF), through its joint axes."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path
from typing import Annotated

import typer

from ..io.units import angle_scale, length_scale
from .common import commands
from .console import console, fail, num, print_rows, print_table, say, spread, table_rows, wrote
from .options import AngleOpt, BaseLinkOpt, ChainOnlyOpt, JsonOpt, LengthOpt, ModelArg, TipLinkOpt
from .outputs import SI_UNITS, check_outputs, emit_json, json_target
from .values import load_robot


@commands.command()
def convert(
    model: ModelArg,
    to: Annotated[str, typer.Option("--to", help="dh | mdh | edh | poe | urdf (or an alias: sdh, craig, ...)")],
    output: Annotated[
        Path | None,
        typer.Option(
            "-o", "--output", help="Write a robot file (.toml) or URDF instead of printing ('-': standard output)."
        ),
    ] = None,
    length: LengthOpt = "mm",
    angle: AngleOpt = "deg",
    parallel_tol: Annotated[
        float, typer.Option(help="Axes with sin(angle) below this (unitless) are parallel.")
    ] = 1e-3,
    base_link: BaseLinkOpt = None,
    tip_link: TipLinkOpt = None,
    chain_only: ChainOnlyOpt = False,
    json_out: JsonOpt = None,
) -> None:
    """Express a robot in another convention through its joint axes, with the FK-parity check.

    IN is a built-in name, a robot file or a URDF; ``--to urdf`` writes URDF (meshes, inertials and limits
    of a URDF input carried through), the others print the table with units and the consecutive-axes
    diagnostics, or write a robot file with ``-o``.
    """
    import numpy as np  # noqa: PLC0415

    from .. import _core  # noqa: PLC0415
    from ..fleet.checksum import model_checksum, saved_checksum  # noqa: PLC0415

    check_outputs(**{"-o": output, "--json": json_out})
    json_out = json_target(json_out)
    to = to.lower()
    if not (math.isfinite(parallel_tol) and 0.0 <= parallel_tol < 1.0):
        fail(
            f"--parallel-tol {parallel_tol}: expected the sine of an angle, 0 <= value < 1 "
            "(default 1e-3, about 0.057 deg)"
        )
    robot = load_robot(model, base_link, tip_link, chain_only=chain_only)
    m = robot.model()
    if to == "urdf":
        from ..io.urdf import dumps_urdf, save_urdf  # noqa: PLC0415

        if json_out:  # it had been ignored without a word
            fail(
                "--json: --to urdf writes URDF (XML), which has no JSON form; the JSON table is of a convention "
                "(--to dh | mdh | edh | poe)"
            )

        if output is None:
            print(dumps_urdf(m, robot))
            say("dim", f"model checksum {model_checksum(m)}", err=True)
        else:
            save_urdf(m, output, robot)
            wrote(output, f" (model checksum {saved_checksum(output)})")
        return
    to = _core.convention_info(to)["name"]
    nominal = robot.table if robot.convention == to else None
    ex = _core.extract(_core.axes(m, np.zeros(m.nq)), to, parallel_tol=parallel_tol, nominal=nominal)
    # the readings' model, the compliances and the prior do not depend on the table; the covariance, the compliances'
    # flange and the link inertias follow it (conversion.converted_robot)
    from ..conversion import converted_robot  # noqa: PLC0415

    new, warning = converted_robot(robot, ex.table, parallel_tol=parallel_tol, nominal=nominal)
    new = dataclasses.replace(new, description=f"{robot.description} -> {to}")
    if warning:
        say("bold yellow", "warning:", f" {warning}", err=True)
    if json_out:  # (also beside -o: the table as written, in SI)
        emit_json(
            {
                "model": robot.name,
                "convention": to,
                "units": SI_UNITS,
                "rows": [{"joint": n, **r} for n, r in zip(robot.names, table_rows(ex.table, "m", "rad"))],
                "pairs": [
                    {
                        "joint": p.joint,
                        "relation": p.relation,
                        "angle_rad": p.angle,
                        "distance_m": p.distance,
                        "hayati_beta_rad": p.hayati_beta,
                    }
                    for p in ex.pairs
                ],
                "max_tool_position_error_m": ex.max_position_error,
                "max_tool_rotation_error_rad": ex.max_rotation_error,
                "model_checksum": model_checksum(new),
            },
            json_out,
        )
    if output is not None:
        from ..io.robotfile import save  # noqa: PLC0415

        save(new, output, length, angle)
        wrote(output, f" (model checksum {saved_checksum(output, new)})")
        return
    if json_out == "-":
        return
    ls, as_ = length_scale(length), angle_scale(angle)
    print_table(ex.table, robot.names, length, angle, f"{robot.name} in {to}")
    print_rows(
        "Consecutive axes",
        ["pair", "relation", f"angle [{angle}]", f"distance [{length}]", f"Hayati beta [{angle}]"],
        [
            [
                f"{p.joint}-{p.joint + 1}",
                p.relation,
                num(p.angle / as_, angle),
                num(p.distance / ls, length),
                num(p.hayati_beta / as_, angle),
            ]
            for p in ex.pairs
        ],
        labels=2,
    )
    console.print(
        f"FK parity: max tool error {spread(ex.max_position_error / ls)} {length}, "
        f"{spread(ex.max_rotation_error / as_)} {angle}"
    )
    console.print(f"Model checksum {model_checksum(new)} (of the geometry, the same in any convention)")
