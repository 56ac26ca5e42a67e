"""The options several commands share, declared once as typed annotations (``Annotated[..., typer.Option(...)]``):
the same name, meaning and default in every command (docs/cli.md, "Options by command")."""

from __future__ import annotations

from typing import Annotated

import typer

ModelArg = Annotated[
    str, typer.Argument(help="A built-in name (see `denavit models`), a robot file (.toml) or a URDF.")
]


LengthOpt = Annotated[
    str,
    typer.Option(
        "--length", help="Length unit of what is typed and printed: mm (default) | m | cm | um | in. JSON stays SI."
    ),
]


AngleOpt = Annotated[
    str, typer.Option("--angle", help="Angle unit of what is typed and printed: deg (default) | rad. JSON stays SI.")
]


JsonOpt = Annotated[
    str | None,
    typer.Option(
        "--json",
        metavar="[PATH]",
        help="Write the result as JSON (SI: m, rad) to PATH; '-' or no PATH: standard output, instead of the tables.",
    ),
]


BaseLinkOpt = Annotated[
    str | None, typer.Option("--base-link", help="URDF model: the chain's base link (default: the root link).")
]


TipLinkOpt = Annotated[
    str | None,
    typer.Option(
        "--tip-link",
        help=(
            "URDF model: the chain's tip link (default: the single leaf, REP-199's tool0, or the leaf through the most"
            " moving joints; echoed)."
        ),
    ),
]


ChainOnlyOpt = Annotated[
    bool,
    typer.Option(
        "--chain-only",
        help="URDF model: the chain alone, without the links off it (in the dynamics and in a URDF written).",
    ),
]


ForceOpt = Annotated[
    bool,
    typer.Option(
        "--force",
        help=(
            "Replace an output file that is read-only, and write through one with several hard links (in place: every"
            " name gets the new content); without it both are refused. A replaced file keeps its owner and mode."
        ),
    ),
]

VerboseOpt = Annotated[
    bool,
    typer.Option(
        "--verbose",
        help=(
            "Every parameter the data (or the protocol) cannot identify, with the reason, and the fit's choices in "
            "full (default: their names in a few lines)."
        ),
    ),
]

#: The one default parametrisation of every command that fits or plans (identify, calibrate, plan).
CONVENTION = "edh"

ConventionOpt = Annotated[
    str,
    typer.Option(
        "--convention",
        help=(
            "The parametrisation fitted, printed and saved: edh (exact: a near-parallel pair's tilt is a parameter of "
            "its own) | dh | mdh (lossy where axes are near-parallel, the error carried stated) | poe (identify only); "
            "aliases: sdh, craig, modified-dh."
        ),
    ),
]

TargetOpt = Annotated[
    int | None,
    typer.Option(
        "--target",
        help=(
            "Data with several targets per pose (markers, SMRs on a nest): this target alone, 1-based (default: every "
            "target in one fit; validate without a nest: target 1)."
        ),
    ),
]

NominalAliasOpt = Annotated[
    str | None,
    typer.Option("--nominal", help="Deprecated: the nominal MODEL is the first argument (`COMMAND MODEL DATA`)."),
]

ColumnsOpt = Annotated[
    str | None,
    typer.Option("--columns", help='Column map of a delimited recording, e.g. "t,q1..q6,x,y,z" (--format columns).'),
]

CouplingOpt = Annotated[
    str | None,
    typer.Option(
        "--coupling",
        help=(
            "Joint values from the controller's readings, e.g. \"q3=r3+r2\" (a Fanuc's J3; ';' between joints; "
            "robot-files.md in docs); default: the robot file's \\[couplings]."
        ),
    ),
]

TrackerNoiseOpt = Annotated[
    str | None,
    typer.Option(
        "--tracker-noise",
        help=(
            "The tracker's range/angle noise (1 sigma): the distance's, then each angle's, e.g. \"5 um, 1 arcsec\" (a"
            " number without a unit is in --length / --angle units; angles also in arcsec): each point is weighted by"
            " its covariance (noise along the line of sight from the tracker, angle x range across it), the scale"
            " estimated from the data (calibrate: not with --noise). Default: isotropic point noise."
        ),
    ),
]

TrackerPositionOpt = Annotated[
    str | None,
    typer.Option(
        "--tracker-position",
        help=(
            "With --tracker-noise: the tracker's position in the data's frame, x,y,z in --length units (default "
            "0,0,0: a tracker export's own frame)."
        ),
    ),
]

#: Where batches of independent jobs run (fleet run, plan --monte-carlo; docs/fleet.md): a Dask cluster.
SchedulerOpt = Annotated[
    str | None,
    typer.Option(
        "--scheduler", help="A running Dask scheduler, e.g. tcp://HOST:8786 (default: a local cluster of processes)."
    ),
]

WorkersOpt = Annotated[
    int | None,
    typer.Option(
        "--workers",
        help="Worker processes of the local Dask cluster (default: one per core; 0: no cluster, in this process).",
    ),
]
