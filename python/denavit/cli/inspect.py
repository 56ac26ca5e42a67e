"""``inspect``: what a recording holds (format, joints, rates, units, sweeps and dwell), without fitting."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from .common import commands
from .console import console
from .options import ColumnsOpt


@commands.command()
def inspect(
    recording: Annotated[
        Path,
        typer.Argument(
            help="A tracker export, a UR RTDE log, a KUKA RSI log, a ROS bag, or a delimited file (with --columns)."
        ),
    ],
    data_format: Annotated[
        str, typer.Option("--format", help="auto (from the content) | tracker | rtde | rsi | bag | columns")
    ] = "auto",
    columns: ColumnsOpt = None,
    sweep: Annotated[
        str | None,
        typer.Option("--sweep", help="Tracker export: 'group' or a point-name pattern such as 'J{joint}_{index}'."),
    ] = None,
    length: Annotated[
        str | None,
        typer.Option(
            "--length", help="Length unit of the file where it declares none (then required): mm | m | cm | um | in."
        ),
    ] = None,
    angle: Annotated[
        str | None,
        typer.Option(
            "--angle",
            help=(
                "Angle unit of the file where it declares none, and of the joint values printed (default deg): deg |"
                " rad."
            ),
        ),
    ] = None,
) -> None:
    """Print what a recording holds: the reader used, joints, targets, rates and units, and the sweeps the
    segmentation finds (joint, rows, start and end, dwell left out), for checking before `identify`."""
    from ..io.recordings import read_recording  # noqa: PLC0415
    from ..recording import segment  # noqa: PLC0415

    # as identify reads it: an angle the file does not declare is --angle's, deg by default (docs/cli.md)
    rec = read_recording(recording, data_format, columns=columns, length=length, angle=angle or "deg", sweep=sweep)
    console.print(rec.describe(), soft_wrap=True)
    from ..io.recordings.segmentation import segmentation_table  # noqa: PLC0415

    console.print(segmentation_table(segment(rec), angle or "deg"), soft_wrap=True)
