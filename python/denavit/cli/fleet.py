"""``fleet``: every robot's calibrations in one registry, and manifests of jobs run on Dask (:mod:`denavit.fleet`;
docs/fleet.md). Its sub-commands (add, run, status, diff, export) are a typer app of their own, handed the
arguments after ``fleet``."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from ..fleet.registry import DEFAULT_PATH
from .common import commands
from .console import console, print_rows, say, wrote
from .options import AngleOpt, JsonOpt, LengthOpt, SchedulerOpt, WorkersOpt
from .outputs import emit_json, json_target

RegistryOpt = Annotated[
    Path, typer.Option("--registry", help="The registry file (SQLite; created if absent).", show_default=True)
]

app = typer.Typer(
    add_completion=False,
    no_args_is_help=True,
    rich_markup_mode="rich",
    pretty_exceptions_enable=False,
    help="Every robot's calibrations in one registry (docs/fleet.md): add models, run a manifest of jobs on Dask, "
    "the fleet's status, the changes between two calibrations, a registered model exported.",
)


@commands.command(
    context_settings={"allow_extra_args": True, "ignore_unknown_options": True, "help_option_names": []},
    add_help_option=False,
)
def fleet(ctx: typer.Context) -> None:
    """Every robot's calibrations in one registry: fleet add | run | status | diff | export (fleet --help)."""
    typer.main.get_command(app).main(list(ctx.args), prog_name="denavit fleet")


def _open(path: Path):
    from ..fleet.registry import Registry  # noqa: PLC0415

    return Registry(path)


@app.command()
def add(
    robot_id: Annotated[str, typer.Argument(help="The robot: its serial number or name.")],
    model: Annotated[
        str, typer.Argument(help="A built-in name, robot file (.toml), URDF or UR kinematics file: the model as given.")
    ],
    family: Annotated[
        str | None, typer.Option("--family", help="The model family (default: the model's name).")
    ] = None,
    registry: RegistryOpt = Path(DEFAULT_PATH),
) -> None:
    """Register a nominal model or a factory calibration for a robot."""
    from ..fleet.history import add_model  # noqa: PLC0415

    with _open(registry) as reg:
        entry, added = add_model(reg, robot_id, model, family)
    say(
        "bold",
        f"{robot_id}: ",
        f"{'registered' if added else 'registered already'} {model}, model {entry.model_checksum}",
    )


@app.command()
def run(
    manifest: Annotated[Path, typer.Argument(help="The manifest (TOML, [[robot]] tables: docs/fleet.md).")],
    scheduler: SchedulerOpt = None,
    workers: WorkersOpt = None,
    registry: RegistryOpt = Path(DEFAULT_PATH),
) -> None:
    """Run a manifest's jobs as Dask tasks and register their results (a rerun adds nothing)."""
    from rich.progress import Progress  # noqa: PLC0415

    from ..fleet.runner import connect, disconnect, run_manifest  # noqa: PLC0415
    from .console import err_console  # noqa: PLC0415

    client = connect(scheduler, workers)
    try:
        with _open(registry) as reg, Progress(console=err_console, transient=True) as bar:
            task = bar.add_task("jobs", total=None)
            summary = run_manifest(
                manifest, reg, client=client, progress=lambda d, t: bar.update(task, completed=d, total=t)
            )
    finally:
        disconnect(client)
    say(
        "bold",
        f"{summary.added} entries added",
        f" ({summary.added_ok} ok, {summary.added_failed} failed), {summary.skipped} registered already"
        + (f", {len(summary.lost)} lost (run again)" if summary.lost else "")
        + f"; {registry}",
    )
    for line in summary.lost:
        say("yellow", "lost: ", line, err=True)
    if summary.lost:
        raise typer.Exit(1)


def _figure(latest: dict) -> str:
    for key, what in (("held_out_rms_m", "held-out"), ("rms_m", "rms"), ("predicted_error_m", "predicted")):
        if latest.get(key) is not None:
            return f"{what} {latest[key] * 1e3:.4g} mm"
    return "-"


@app.command()
def status(registry: RegistryOpt = Path(DEFAULT_PATH), json_out: JsonOpt = None) -> None:
    """The latest model, accuracy and drift of every robot."""
    from ..fleet.history import status as fleet_status  # noqa: PLC0415

    json_out = json_target(json_out)
    with _open(registry) as reg:
        doc = fleet_status(reg)
    if json_out is not None:
        emit_json({**doc, "units": {"length": "m", "angle": "rad"}}, json_out)
        if json_out == "-":
            return
    rows = []
    for r in doc["robots"]:
        latest, drift = r["latest"], r["drift"]
        verdict = "-" if drift is None else ("CHANGED" if drift["metrics"]["changed"] else "unchanged")
        rows.append(
            [
                r["id"],
                r["family"],
                str(r["entries"]),
                latest["job"],
                latest["status"],
                (r["model"] or {}).get("model_checksum") or "-",
                _figure(latest) if latest["status"] == "ok" else (latest["error"] or ""),
                verdict,
            ]
        )
    print_rows(
        f"{len(rows)} robots in {registry}",
        ["robot", "family", "entries", "latest job", "status", "model", "figure / error", "drift"],
        rows,
        left=(1, 3, 4, 5, 6, 7),
        prose=(6,),
    )


@app.command()
def diff(
    robot_id: Annotated[str, typer.Argument(help="The robot.")],
    entries: Annotated[
        list[int] | None, typer.Argument(help="Two entry numbers A B (default: its two latest models).")
    ] = None,
    registry: RegistryOpt = Path(DEFAULT_PATH),
    length: LengthOpt = "mm",
    angle: AngleOpt = "deg",
    json_out: JsonOpt = None,
) -> None:
    """The parameter changes between two calibrations of a robot, with their sigmas: what changed beyond noise."""
    from ..fleet.history import CHANGE_SIGMAS  # noqa: PLC0415
    from ..fleet.history import diff as fleet_diff  # noqa: PLC0415
    from ..io.units import angle_scale, length_scale  # noqa: PLC0415

    if entries and len(entries) != 2:
        raise typer.BadParameter(f"expected two entries A B or none, got {len(entries)}", param_hint="ENTRIES")
    json_out = json_target(json_out)
    with _open(registry) as reg:
        d = fleet_diff(reg, robot_id, *(entries or (None, None)))
    if json_out is not None:
        emit_json({**d.to_json(), "units": {"length": "m", "angle": "rad"}}, json_out)
        if json_out == "-":
            return
    ls, as_ = length_scale(length), angle_scale(angle)
    rows = []
    for k, name in enumerate(d.names):
        s = as_ if d.angle[k] else ls
        sig = d.sigma[k]
        rows.append(
            [
                name,
                f"{d.value_a[k] / s:.6g}",
                f"{d.value_b[k] / s:.6g}",
                f"{d.change[k] / s:+.4g}",
                "-" if not sig == sig else f"{sig / s:.3g}",
                "CHANGED" if d.changed[k] else "",
            ]
        )
    conv = f"{d.a.convention}" + (f", B converted from {d.converted_from}" if d.converted_from else "")
    print_rows(
        f"{robot_id}: entry {d.a.seq} ({d.a.model_checksum}) -> {d.b.seq} ({d.b.model_checksum}), {conv}, "
        f"{angle} / {length}",
        ["parameter", "A", "B", "change", "sigma", f"> {CHANGE_SIGMAS:g} sigma"],
        rows,
        left=(5,),
    )
    console.print(f"{int(d.changed.sum())} of {len(d.names)} parameters changed beyond {CHANGE_SIGMAS:g} sigma")


@app.command()
def export(
    robot_id: Annotated[str, typer.Argument(help="The robot.")],
    entry: Annotated[int | None, typer.Option("--entry", help="The entry (default: the latest model).")] = None,
    output: Annotated[
        Path | None,
        typer.Option("-o", "--output", help="Write a robot file (.toml) or URDF (.urdf) instead of printing."),
    ] = None,
    length: LengthOpt = "mm",
    angle: AngleOpt = "deg",
    registry: RegistryOpt = Path(DEFAULT_PATH),
) -> None:
    """A robot's registered model (its latest, or --entry) as a robot file or URDF, with its model checksum."""
    from ..fleet.history import robot_of  # noqa: PLC0415
    from ..io.robotfile import dumps, save  # noqa: PLC0415

    with _open(registry) as reg:
        e = reg.entry(robot_id, entry)
    robot = robot_of(e)
    if output is None:
        console.print(dumps(robot, length, angle), end="", soft_wrap=True, highlight=False)
    elif output.suffix.lower() == ".urdf":
        from ..io.urdf import save_urdf  # noqa: PLC0415

        save_urdf(robot.model(), output, robot)
        wrote(output)
    else:
        save(robot, output, length, angle)
        wrote(output)
    say("dim", f"model checksum {e.model_checksum}", f" (registry entry {e.seq}, {e.job}, {e.created})", err=True)
