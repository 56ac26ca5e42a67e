"""The `denavit` command line (typer + rich). Units are declared at this edge: ``--deg``, ``--unit``."""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Annotated, Optional

import numpy as np
import typer
from rich.console import Console
from rich.table import Table as RichTable

from . import _core
from .errors import DenavitError
from .robotfile import Robot, builtin_names, dumps, load, save
from .units import angle_scale, length_scale

app = typer.Typer(
    add_completion=False,
    no_args_is_help=True,
    help="Find the true kinematic geometry of serial robots and compute with it.",
    pretty_exceptions_enable=False,
)
console = Console()
err_console = Console(stderr=True)

ModelArg = Annotated[str, typer.Argument(help="A built-in name (see `denavit models`), a robot file (.toml) or a URDF.")]
JsonOpt = Annotated[bool, typer.Option("--json", help="Print JSON instead of tables.")]


def fail(msg: str) -> None:
    err_console.print(f"[bold red]error:[/] {msg}")
    raise typer.Exit(2)


def parse_numbers(text: str | None, what: str) -> list[float]:
    """Numbers separated by commas and/or spaces ("90,-90,90" or "90 -90 90")."""
    if not text:
        return []
    try:
        return [float(t) for t in text.replace(",", " ").split()]
    except ValueError:
        fail(f"{what}: expected numbers separated by commas or spaces, got {text!r}")
        raise


def parse_q(text: str | None, robot: Robot, deg: bool, unit: str) -> np.ndarray:
    """Joint values from the CLI in their declared units (deg/rad for revolute, --unit for prismatic)."""
    n = robot.table.params.shape[0]
    values = parse_numbers(text, "--q")
    if not values:
        return np.zeros(n)
    if len(values) != n:
        fail(f"--q: expected {n} joint values for {robot.name}, got {len(values)}")
    a, l = angle_scale("deg" if deg else "rad"), length_scale(unit)
    return np.array([v * (a if k == "revolute" else l) for v, k in zip(values, robot.table.kinds)])


def pose_rows(T: np.ndarray, ls: float) -> list[list[float]]:
    M = np.array(T, dtype=float)
    M[:3, 3] /= ls
    return M.tolist()


def fmt(v: float, nd: int = 6) -> str:
    return f"{v:.{nd}f}" if abs(v) >= 1e-12 else f"{0.0:.{nd}f}"


@app.command()
def models(json_out: JsonOpt = False) -> None:
    """List the built-in robots."""
    rows = []
    for name in builtin_names():
        r = load(name)
        rows.append({"name": name, "convention": r.convention, "joints": len(r.names), "description": r.description, "source": r.source})
    if json_out:
        print(json.dumps(rows, indent=2))
        return
    t = RichTable(title="Built-in robots")
    for c in ("name", "convention", "joints", "description"):
        t.add_column(c)
    for r in rows:
        t.add_row(r["name"], r["convention"], str(r["joints"]), r["description"])
    console.print(t)


@app.command()
def fk(
    model: ModelArg,
    q: Annotated[Optional[str], typer.Option("--q", help="Joint values, one per joint, e.g. \"90,-90,90,0,90,0\" (default zeros).")] = None,
    deg: Annotated[bool, typer.Option("--deg", help="Revolute joint values in degrees (default radians).")] = False,
    unit: Annotated[str, typer.Option("--unit", help="Length unit of the output and of prismatic values: m, mm, ...")] = "m",
    json_out: JsonOpt = False,
) -> None:
    """Forward kinematics: the tool pose and every joint frame (T_world_joint)."""
    robot = load(model)
    m = robot.model()
    qv = parse_q(q, robot, deg, unit)
    ls = length_scale(unit)
    T = _core.fk(m, qv)
    frames = _core.joint_frames(m, qv)
    if json_out:
        print(json.dumps({"model": robot.name, "units": {"length": unit, "angle": "deg" if deg else "rad"}, "q": (qv / (angle_scale("deg") if deg else 1)).tolist(),
                          "T_world_tool": pose_rows(T, ls), "T_world_joint": {n: pose_rows(F, ls) for n, F in zip(robot.names, frames)}}, indent=2))
        return
    console.print(f"[bold]{robot.name}[/] ({robot.description}) — lengths in {unit}")
    t = RichTable(title="T_world_tool")
    for c in ("", "x", "y", "z", "p"):
        t.add_column(c, justify="right")
    for i, row in enumerate(pose_rows(T, ls)[:3]):
        t.add_row("xyz"[i], *(fmt(v) for v in row))
    console.print(t)
    ft = RichTable(title="Joint frames (origin, z axis) in world")
    for c in ("joint", "x", "y", "z", "z_x", "z_y", "z_z"):
        ft.add_column(c, justify="right")
    for n, F in zip(robot.names, frames):
        ft.add_row(n, *(fmt(v / ls) for v in F[:3, 3]), *(fmt(v) for v in F[:3, 2]))
    console.print(ft)


def table_rows(table: _core.Table, length: str, angle: str) -> list[dict]:
    ls, as_ = length_scale(length), angle_scale(angle)
    rows = []
    for row, kind in zip(table.params, table.kinds):
        rows.append({c: float(v / (as_ if a else (ls if table.convention != "poe" or c.startswith("v") else 1.0))) for c, a, v in zip(table.columns, table.angle_columns, row)})
    return rows


def print_table(table: _core.Table, names: list[str], length: str, angle: str, title: str) -> None:
    t = RichTable(title=title)
    t.add_column("joint")
    for c, a in zip(table.columns, table.angle_columns):
        t.add_column(f"{c} [{angle if a else length}]", justify="right")
    for n, row in zip(names, table_rows(table, length, angle)):
        t.add_row(n, *(fmt(v, 4) for v in row.values()))
    console.print(t)


@app.command()
def convert(
    model: ModelArg,
    to: Annotated[str, typer.Option("--to", help="dh | mdh | edh | poe | urdf")],
    output: Annotated[Optional[Path], typer.Option("-o", "--output", help="Write a robot file (.toml) or URDF instead of printing.")] = None,
    length: Annotated[str, typer.Option("--length", help="Length unit of the output.")] = "mm",
    angle: Annotated[str, typer.Option("--angle", help="Angle unit of the output.")] = "deg",
    parallel_tol: Annotated[float, typer.Option(help="Axes with sin(angle) below this are parallel.")] = 1e-3,
    json_out: JsonOpt = False,
) -> None:
    """Express a robot in another convention through its joint axes, with the FK-parity check."""
    robot = load(model)
    to = to.lower()
    m = robot.model()
    if to == "urdf":
        from .urdf import dumps_urdf, save_urdf  # noqa: PLC0415

        if output is None:
            print(dumps_urdf(m, robot))
        else:
            save_urdf(m, output, robot)
            console.print(f"wrote {output}")
        return
    nominal = robot.table if robot.convention == to else None
    ex = _core.extract(_core.axes(m, np.zeros(m.nq)), to, parallel_tol=parallel_tol, nominal=nominal)
    new = Robot(name=robot.name, table=ex.table, names=robot.names, lower=robot.lower, upper=robot.upper,
                description=f"{robot.description} -> {to}", source=robot.source, home=robot.home)
    if output is not None:
        save(new, output, length, angle)
        console.print(f"wrote {output}")
        return
    if json_out:
        print(json.dumps({"model": robot.name, "convention": to, "units": {"length": length, "angle": angle},
                          "rows": [{"joint": n, **r} for n, r in zip(robot.names, table_rows(ex.table, length, angle))],
                          "pairs": [{"joint": p.joint, "relation": p.relation, "angle_rad": p.angle, "distance_m": p.distance, "hayati_beta_rad": p.hayati_beta} for p in ex.pairs],
                          "max_tool_position_error_m": ex.max_position_error, "max_tool_rotation_error_rad": ex.max_rotation_error}, indent=2))
        return
    print_table(ex.table, robot.names, length, angle, f"{robot.name} in {to}")
    pt = RichTable(title="Consecutive axes")
    for c in ("pair", "relation", "angle [deg]", f"distance [{length}]", "Hayati beta [deg]"):
        pt.add_column(c, justify="right")
    for p in ex.pairs:
        pt.add_row(f"{p.joint}-{p.joint + 1}", p.relation, fmt(np.degrees(p.angle), 6), fmt(p.distance / length_scale(length), 6), fmt(np.degrees(p.hayati_beta), 6))
    console.print(pt)
    console.print(f"FK parity: max tool error {ex.max_position_error / length_scale(length):.3e} {length}, {np.degrees(ex.max_rotation_error):.3e} deg")


@app.command()
def show(model: ModelArg, length: str = "mm", angle: str = "deg") -> None:
    """Print a robot file's table as read (with units)."""
    robot = load(model)
    print_table(robot.table, robot.names, length, angle, f"{robot.name} ({robot.convention}) — {robot.source}")


@app.command(name="export")
def export_cmd(model: ModelArg, length: str = "mm", angle: str = "deg") -> None:
    """Print a robot file (TOML) in the given units."""
    print(dumps(load(model), length, angle), end="")


def main() -> None:
    """Entry point: every DenavitError becomes a one-line message and exit code 2."""
    try:
        app()
    except DenavitError as e:
        err_console.print(f"[bold red]error:[/] {e}")
        sys.exit(2)


if __name__ == "__main__":
    main()
