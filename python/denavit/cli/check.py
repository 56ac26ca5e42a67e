"""``check``: has a robot changed since its registered model? A chi-square test of a few measured poses
(:mod:`denavit.fleet.check`; docs/fleet.md)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from ..fleet.registry import DEFAULT_PATH
from .common import commands
from .console import console, print_rows, say, wrote
from .options import AngleOpt, JsonOpt, LengthOpt
from .outputs import emit_json, json_target


@commands.command()
def check(
    robot: Annotated[
        str,
        typer.Argument(
            help="A robot in the registry (its latest model), or a robot file with its [covariance] (calibrate --save)."
        ),
    ],
    data: Annotated[
        Path | None,
        typer.Argument(
            help="Measured tool points at known joint readings (q1..qn,x,y,z CSV or JSON, units declared), in the "
            "frame the model was calibrated in; <= 10 poses do."
        ),
    ] = None,
    noise: Annotated[float, typer.Option("--noise", help="The tracker's noise per coordinate, --length units.")] = 0.02,
    false_alarm: Annotated[
        float,
        typer.Option(
            "--false-alarm", help="The probability of declaring an unchanged robot changed (the test's level)."
        ),
    ] = 0.01,
    design: Annotated[
        int | None,
        typer.Option(
            "--design",
            help="Instead of checking: choose this many poses that see a change of any joint's offset best, and write "
            "them (-o) or print them.",
        ),
    ] = None,
    output: Annotated[Path | None, typer.Option("-o", "--output", help="With --design: the poses' CSV.")] = None,
    registry: Annotated[Path, typer.Option("--registry", help="The registry file.")] = Path(DEFAULT_PATH),
    length: LengthOpt = "mm",
    angle: AngleOpt = "deg",
    json_out: JsonOpt = None,
) -> None:
    """Check a robot against its registered model with a few measured poses: a chi-square test of the residuals
    against the model's own covariance and the tracker noise, at a stated false-alarm rate. Exit code 1 when the
    robot has changed. A registered robot's check is recorded in the registry."""
    from ..fleet import check as ck  # noqa: PLC0415
    from ..fleet.history import record_check, robot_of  # noqa: PLC0415
    from ..fleet.registry import Registry  # noqa: PLC0415
    from ..io.units import length_scale  # noqa: PLC0415

    ls = length_scale(length)
    if not noise > 0:
        raise typer.BadParameter(f"expected the tracker's noise > 0 {length}, got {noise}", param_hint="--noise")
    json_out = json_target(json_out)
    registered = not Path(robot).suffix and registry.exists()
    if registered:
        with Registry(registry) as reg:
            model = robot_of(reg.entry(robot))
    else:
        from .values import load_robot  # noqa: PLC0415

        model = load_robot(robot)
    if design is not None:
        write_design(model, design, noise * ls, false_alarm, output, length, angle)
        return
    if data is None:
        raise typer.BadParameter("expected the measured poses (or --design N)", param_hint="DATA")
    options = {"noise": noise * ls, "false_alarm": false_alarm}
    if registered:
        with Registry(registry) as reg:
            result, entry, added = record_check(reg, robot, data, **options)
    else:
        result = ck.drift_check(model, data, **options)
    if json_out is not None:
        emit_json({**result.metrics(), "units": {"length": "m", "angle": "rad"}}, json_out)
    if json_out != "-":
        print_rows(
            None,
            ["pose", "residual", "predicted sigma"],
            [
                [str(k + 1), f"{r / ls:.4g} {length}", f"{s / ls:.3g} {length}"]
                for k, (r, s) in enumerate(zip(result.residual_norms, result.predicted_sigma))
            ],
        )
        verdict = "CHANGED" if result.changed else "unchanged"
        say(
            "bold red" if result.changed else "bold green",
            f"{robot}: {verdict}",
            f" (T = {result.statistic:.4g}, threshold {result.threshold:.4g}: chi-square with {result.dof} degrees of "
            f"freedom at false alarms {false_alarm:g}; p = {result.p_value:.3g})",
        )
        if registered:
            say("dim", f"{'recorded in' if added else 'recorded already in'} {registry}", err=True)
    if result.changed:
        raise typer.Exit(1)


def write_design(model, count: int, noise: float, false_alarm: float, output, length: str, angle: str) -> None:
    """The drift check's ``count`` poses for ``model`` (:func:`denavit.fleet.check.design`; ``noise`` m) as a CSV of
    joint readings in ``length`` / ``angle`` units, written to ``output`` or printed, and the check's power against a
    0.01 degree change of each joint's offset (on stderr when the CSV went to standard output). ``check --design``
    and ``plan --check-poses``."""
    import numpy as np  # noqa: PLC0415

    from ..fleet import check as ck  # noqa: PLC0415
    from ..io.units import angle_scale, length_scale  # noqa: PLC0415

    ls, as_ = length_scale(length), angle_scale(angle)
    Q = ck.design(model, count, noise=noise)
    scale = np.array([as_ if k == "revolute" else ls for k in model.table.kinds])
    header = ",".join(f"q{j + 1}" for j in range(Q.shape[1]))
    text = f"# units: length={length} angle={angle}\n{header}\n" + "".join(
        ",".join(f"{v:.6f}" for v in row) + "\n" for row in Q / scale
    )
    if output is None:
        console.print(text, end="", highlight=False, soft_wrap=True)
    else:
        from ..io.output import write_text  # noqa: PLC0415

        write_text(output, text)
        wrote(output, f" ({count} poses for the drift check of {model.name})")
    offset = np.radians(ck.DESIGN_OFFSET_DEG)
    powers = [
        ck.power(ck.noncentrality(model, Q, d, noise), 3 * len(Q), false_alarm)
        for d in ck.offset_changes(model, Q, offset)
    ]
    say(
        "dim",
        f"power at false alarms {false_alarm:g} against a {ck.DESIGN_OFFSET_DEG:g} deg change of one joint's offset:",
        " " + ", ".join(f"{n} {100 * p:.3g} %" for n, p in zip(model.names, powers, strict=True)),
        err=output is None,
    )
