"""The `denavit` command line (typer + rich). Units are declared at this edge: ``--deg``, ``--unit``."""

from __future__ import annotations

import dataclasses
import json
import sys
from pathlib import Path
from typing import Annotated, Optional

import numpy as np
import typer
from rich.console import Console
from rich.table import Table as RichTable
from rich.text import Text
from scipy.spatial.transform import Rotation

from . import _core
from .errors import DenavitError
from .robotfile import Robot, builtin_names, dumps, inertials_for_table, load, save
from .io.units import angle_scale, column_scale, length_scale

app = typer.Typer(
    add_completion=False,
    no_args_is_help=True,
    help="Find the true kinematic geometry of serial robots and compute with it.",
    pretty_exceptions_enable=False,
)
# markup off: units in headers ("a [mm]"), file paths and messages are printed as written; style only through say()
console = Console(markup=False)
err_console = Console(stderr=True, markup=False)


def say(style: str, head: str, rest: str = "", err: bool = False) -> None:
    """Print `head` in a rich `style` followed by plain `rest`."""
    (err_console if err else console).print(Text.assemble((head, style), rest))


ModelArg = Annotated[str, typer.Argument(help="A built-in name (see `denavit models`), a robot file (.toml) or a URDF.")]
JsonOpt = Annotated[bool, typer.Option("--json", help="Print JSON instead of tables.")]


def fail(msg: str) -> None:
    say("bold red", "error:", f" {msg}", err=True)
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


def parse_home(text: str | None, robot: Robot, as_: float) -> np.ndarray:
    """--home in angle units (rad/deg scale `as_`), else the robot file's home, else zeros."""
    n = len(robot.names)
    if text:
        h = np.array(parse_numbers(text, "--home")) * as_
    elif robot.home is not None:
        h = np.asarray(robot.home, dtype=float)
    else:
        h = np.zeros(n)
    if h.shape != (n,):
        fail(f"--home: expected {n} values, got {h.size}")
    return h


def parse_ranges(text: str | None, n: int, as_: float, default: str) -> np.ndarray:
    """--ranges: 'paper90' / 'paper30' (Hayat Table II) or start,end pairs per joint in angle units."""
    from .sweeps import PAPER_RANGES_DEG  # noqa: PLC0415

    key = (text or default).lower()
    if key in ("paper90", "paper30"):
        if n != 6:
            fail("--ranges paper90/paper30 are Hayat Table II for a 6-joint robot; give start,end pairs for this one")
        return np.radians(np.array(PAPER_RANGES_DEG[int(key[-2:])]))
    vals = parse_numbers(text, "--ranges")
    if len(vals) != 2 * n:
        fail(f"--ranges: expected {2 * n} values (start,end per joint), got {len(vals)}")
    return np.array(vals).reshape(n, 2) * as_


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
    say("bold", robot.name, f" ({robot.description}) — lengths in {unit}")
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


def parse_pose(text: str, deg: bool, ls: float, what: str = "--pose") -> np.ndarray:
    """A pose from the command line: 16 (or 12) numbers, the rows of the 4x4 matrix, or 6 numbers
    x,y,z,roll,pitch,yaw with R = Rz(yaw) Ry(pitch) Rx(roll) (URDF's rpy); positions scaled by ``ls``
    (metres per unit), angles in deg or rad."""
    v = parse_numbers(text, what)
    if len(v) in (12, 16):
        T = np.eye(4)
        T[: len(v) // 4] = np.reshape(v, (len(v) // 4, 4))
        T[:3, 3] *= ls
        return T
    if len(v) == 6:
        T = np.eye(4)
        T[:3, :3] = Rotation.from_euler("xyz", v[3:], degrees=deg).as_matrix()
        T[:3, 3] = np.array(v[:3]) * ls
        return T
    fail(f"{what}: expected 16 or 12 numbers (rows of the 4x4 pose) or 6 (x,y,z,roll,pitch,yaw), got {len(v)}")
    raise AssertionError


@app.command()
def ik(
    model: ModelArg,
    pose: Annotated[str, typer.Option("--pose", help="Target T_world_tool: 16 (or 12) numbers, the rows of the 4x4 pose, or \"x,y,z,roll,pitch,yaw\" with R = Rz(yaw) Ry(pitch) Rx(roll).")],
    q0: Annotated[Optional[str], typer.Option("--q0", help="Start configuration, one value per joint (default zeros).")] = None,
    deg: Annotated[bool, typer.Option("--deg", help="Angles (revolute joints, roll/pitch/yaw) in degrees (default radians).")] = False,
    unit: Annotated[str, typer.Option("--unit", help="Length unit of --pose, prismatic values and the position error: m, mm, ...")] = "m",
    method: Annotated[str, typer.Option("--method", help="lm (Levenberg-Marquardt) | newton (Newton-Raphson)")] = "lm",
    tol_position: Annotated[float, typer.Option("--tol-position", help="Largest accepted position error, in --unit.")] = 1e-10,
    tol_rotation: Annotated[float, typer.Option("--tol-rotation", help="Largest accepted rotation error, rad.")] = 1e-10,
    restarts: Annotated[int, typer.Option("--restarts", help="Further attempts from seeded random configurations.")] = 50,
    seed: Annotated[int, typer.Option("--seed")] = 0,
    no_limits: Annotated[bool, typer.Option("--no-limits", help="Ignore the joint limits.")] = False,
    json_out: JsonOpt = False,
) -> None:
    """Inverse kinematics: joint values that put the tool at --pose. Success is judged from the measured final
    error against the tolerances; exit code 1 when the target is not met (the residual is printed)."""
    robot = load(model)
    m = robot.model()
    ls, as_ = length_scale(unit), angle_scale("deg" if deg else "rad")
    T = parse_pose(pose, deg, ls)
    start = parse_q(q0, robot, deg, unit)
    r = _core.ik(m, T, start, method=method, tol_position=tol_position * ls, tol_rotation=tol_rotation,
                 restarts=restarts, seed=seed, respect_limits=not no_limits)
    scale = np.array([as_ if k == "revolute" else ls for k in robot.table.kinds])
    q_out = r.q / scale
    if json_out:
        print(json.dumps({"model": robot.name, "units": {"length": unit, "angle": "deg" if deg else "rad"}, "success": r.success,
                          "q": q_out.tolist(), "iterations": r.iterations, "restarts": r.restarts,
                          "position_error": r.position_error / ls, "rotation_error_rad": r.rotation_error,
                          "T_world_tool": pose_rows(_core.fk(m, r.q), ls)}, indent=2))
    else:
        verdict = ("solved", "bold green") if r.success else ("not solved", "bold red")
        console.print(Text.assemble((robot.name, "bold"), " — ", verdict, f": position error {r.position_error / ls:.3e} {unit}, "
                                    f"rotation error {r.rotation_error:.3e} rad ({r.iterations} iterations, {r.restarts} restarts)"))
        t = RichTable(title=f"q ({'deg' if deg else 'rad'})")
        for c in ("joint", "q"):
            t.add_column(c, justify="right")
        for n, v in zip(robot.names, q_out):
            t.add_row(n, fmt(v))
        console.print(t)
    if not r.success:
        raise typer.Exit(1)


def parse_rates(text: str | None, what: str, robot: Robot, deg: bool, unit: str) -> np.ndarray:
    """Joint velocities or accelerations in their declared units (deg or rad per s / s^2; --unit for prismatic)."""
    n = robot.table.params.shape[0]
    values = parse_numbers(text, what)
    if not values:
        return np.zeros(n)
    if len(values) != n:
        fail(f"{what}: expected {n} joint values for {robot.name}, got {len(values)}")
    a, l = angle_scale("deg" if deg else "rad"), length_scale(unit)
    return np.array([v * (a if k == "revolute" else l) for v, k in zip(values, robot.table.kinds)])


@app.command()
def dynamics(
    model: ModelArg,
    q: Annotated[Optional[str], typer.Option("--q", help="Joint values, one per joint (default zeros).")] = None,
    qd: Annotated[Optional[str], typer.Option("--qd", help="Joint velocities per second (default zeros).")] = None,
    qdd: Annotated[Optional[str], typer.Option("--qdd", help="Joint accelerations per second squared (default zeros).")] = None,
    deg: Annotated[bool, typer.Option("--deg", help="Revolute values (and their rates) in degrees (default radians).")] = False,
    unit: Annotated[str, typer.Option("--unit", help="Length unit of prismatic values and their rates: m, mm, ...")] = "m",
    gravity: Annotated[str, typer.Option("--gravity", help="Gravity in world, m/s^2.")] = "0,0,-9.81",
    f_ext: Annotated[Optional[str], typer.Option("--f-ext", help="Wrench on the tool by the environment, \"fx,fy,fz,nx,ny,nz\" in N and N m, tool-frame axes, moment about the tool origin.")] = None,
    json_out: JsonOpt = False,
) -> None:
    """Inverse dynamics (recursive Newton-Euler): the joint torques (N m) / forces (N) for q, qd, qdd.

    Uses the link inertias of the robot file (\\[joints.inertia]); without them every link is massless and a
    warning says so. Also prints the gravity part of the torques.
    """
    robot = load(model)
    m = robot.model()
    qv, qdv, qddv = parse_q(q, robot, deg, unit), parse_rates(qd, "--qd", robot, deg, unit), parse_rates(qdd, "--qdd", robot, deg, unit)
    g = parse_numbers(gravity, "--gravity")
    if len(g) != 3:
        fail(f"--gravity: expected 3 values (m/s^2, world), got {len(g)}")
    f = parse_numbers(f_ext, "--f-ext") if f_ext else None
    if f is not None and len(f) != 6:
        fail(f"--f-ext: expected 6 values fx,fy,fz,nx,ny,nz (N, N m, tool frame), got {len(f)}")
    tau = _core.rnea(m, qv, qdv, qddv, gravity=g, f_ext=f)
    tau_g = _core.gravity_torques(m, qv, gravity=g)
    units = ["N m" if k == "revolute" else "N" for k in robot.table.kinds]
    warning = None if robot.inertials is not None else f"{robot.name} carries no inertial parameters ([joints.inertia]): every link is massless"
    if json_out:
        a, l = (angle_scale("deg") if deg else 1.0), length_scale(unit)
        back = np.array([a if k == "revolute" else l for k in robot.table.kinds])
        doc = {
            "model": robot.name,
            "units": {"angle": "deg" if deg else "rad", "length": unit, "time": "s", "torque": "N m", "force": "N"},
            "q": (qv / back).tolist(), "qd": (qdv / back).tolist(), "qdd": (qddv / back).tolist(),
            "gravity": g, "f_ext": f, "tau": tau.tolist(), "tau_gravity": tau_g.tolist(), "tau_units": units,
        }
        if warning:
            doc["warning"] = warning
        print(json.dumps(doc, indent=2))
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


def table_rows(table: _core.Table, length: str, angle: str) -> list[dict]:
    """The table's rows in display units (:func:`units.column_scale`), keyed by column name."""
    scales = [column_scale(table, k, length, angle)[0] for k in range(len(table.columns))]
    return [{c: float(v / s) for c, s, v in zip(table.columns, scales, row)} for row in table.params]


def print_table(table: _core.Table, names: list[str], length: str, angle: str, title: str) -> None:
    t = RichTable(title=title)
    t.add_column("joint")
    for k, c in enumerate(table.columns):
        t.add_column(f"{c} [{column_scale(table, k, length, angle)[1]}]", justify="right")
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
    base_link: Annotated[Optional[str], typer.Option("--base-link", help="URDF input: the chain's base link (default: the root link).")] = None,
    tip_link: Annotated[Optional[str], typer.Option("--tip-link", help="URDF input: the chain's tip link (default: the single leaf).")] = None,
    json_out: JsonOpt = False,
) -> None:
    """Express a robot in another convention through its joint axes, with the FK-parity check.

    IN is a built-in name, a robot file or a URDF; ``--to urdf`` writes URDF (meshes, inertials and limits
    of a URDF input carried through), the others print the table with units and the consecutive-axes
    diagnostics, or write a robot file with ``-o``.
    """
    to = to.lower()
    if base_link is not None or tip_link is not None:
        if not str(model).lower().endswith(".urdf"):
            fail(f"--base-link/--tip-link apply to a URDF input, got {model!r}")
        from .urdf import load_urdf  # noqa: PLC0415

        robot = load_urdf(model, base_link=base_link, tip_link=tip_link)
    else:
        robot = load(model)
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
                description=f"{robot.description} -> {to}", source=robot.source, home=robot.home, extra=robot.extra)
    if robot.inertials is not None:
        try:  # the same physical links, re-expressed in the new convention's frames
            new = dataclasses.replace(new, inertials=inertials_for_table(m, ex.table, robot.names, robot.lower, robot.upper))
        except DenavitError as e:
            say("bold yellow", "warning:", f" link inertias not carried over (the {to} table does not reproduce the joint axes exactly): {e}", err=True)
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
def show(
    model: ModelArg,
    length: str = "mm",
    angle: str = "deg",
    report: Annotated[Optional[Path], typer.Option("--report", help="Write a self-contained HTML report: 3-D frames of two conventions, origin paths, tables.")] = None,
    plot: Annotated[Optional[Path], typer.Option("--plot", help="Write the static figures (PNG) into this folder.")] = None,
    compare: Annotated[Optional[str], typer.Option("--compare", help="Drawn beside the robot in --report/--plot: a convention (dh|mdh|edh|poe) or another robot (built-in name or file). Default edh (mdh for an ED-H robot).")] = None,
    q: Annotated[Optional[str], typer.Option("--q", help="Configuration drawn in --report/--plot, one value per joint (default: the file's home, else zeros).")] = None,
    deg: Annotated[bool, typer.Option("--deg", help="--q revolute values in degrees (default radians).")] = False,
) -> None:
    """Print a robot file's table as read (with units); optionally draw its frames beside another convention's."""
    robot = load(model)
    print_table(robot.table, robot.names, length, angle, f"{robot.name} ({robot.convention}) — {robot.source}")
    if report or plot:
        from . import report as rep  # noqa: PLC0415

        qv = parse_q(q, robot, deg, length) if q else None
        if plot:
            for f in rep.write_model_figures(robot, plot, compare=compare, q=qv, length=length):
                console.print(f"wrote {f}")
        if report:
            rep.write_model_report(robot, report, compare=compare, q=qv, length=length, angle=angle)
            console.print(f"wrote {report}")


@app.command(name="export")
def export_cmd(model: ModelArg, length: str = "mm", angle: str = "deg") -> None:
    """Print a robot file (TOML) in the given units."""
    print(dumps(load(model), length, angle), end="")


EXAMPLES = {"kr5": "kr5_90deg.csv", "kr5-90": "kr5_90deg.csv", "kr5-30": "kr5_30deg.csv"}


def example_path(name: str) -> Path:
    from importlib import resources  # noqa: PLC0415

    key = name.lower()
    if key not in EXAMPLES:
        fail(f"--example: unknown example {name!r}: expected one of {', '.join(EXAMPLES)}")
    return Path(str(resources.files("denavit.data").joinpath(EXAMPLES[key])))


@app.command()
def identify(
    data: Annotated[Optional[Path], typer.Argument(help="Sweeps: long-form CSV, JSON, or a folder of j1.csv..jN.csv.")] = None,
    example: Annotated[Optional[str], typer.Option("--example", help="Run on data shipped with the package: kr5 (90 deg protocol), kr5-30.")] = None,
    nominal: Annotated[Optional[str], typer.Option("--nominal", help="Nominal model (built-in name or file): signs, free origins, names, limits.")] = None,
    method: Annotated[str, typer.Option("--method", help="auto | kasa | hyper | geometric | readings | global")] = "auto",
    convention: Annotated[str, typer.Option("--convention", help="dh | mdh | edh | poe")] = "dh",
    json_path: Annotated[Optional[Path], typer.Option("--json", help="Write the result as JSON to this file.")] = None,
    length: Annotated[Optional[str], typer.Option("--length", help="Length unit of the data if not declared in it; also of the output.")] = None,
    angle: Annotated[Optional[str], typer.Option("--angle", help="Angle unit of the data if not declared in it.")] = None,
    home: Annotated[Optional[str], typer.Option("--home", help="Per-joint files: the locked configuration, e.g. \"90,-90,90,0,90,0\" (--angle units).")] = None,
    direction: Annotated[Optional[str], typer.Option("--direction", help="Per-joint files: +1/-1 per joint (or one for all): did the joint value increase over the recording?")] = None,
    loss: Annotated[str, typer.Option("--loss", help="linear | soft_l1 | huber (robust loss)")] = "linear",
    max_sigma: Annotated[Optional[float], typer.Option("--max-sigma", help="Required axis-position accuracy (1 sigma) in --length units (default mm): sweeps predicted worse are an error.")] = None,
    report: Annotated[Optional[Path], typer.Option("--report", help="Write a self-contained HTML report.")] = None,
    plot: Annotated[Optional[Path], typer.Option("--plot", help="Write the static figures (PNG) into this folder.")] = None,
    save_model: Annotated[Optional[Path], typer.Option("--save", help="Write the identified robot as a robot file (.toml, in the output units).")] = None,
    base: Annotated[Optional[str], typer.Option("--base", help="The robot's base frame in the measurement frame, \"x,y,z,roll,pitch,yaw\" (R = Rz(yaw) Ry(pitch) Rx(roll); output length unit, deg) or the 16 numbers of the 4x4 matrix (default: the measurement frame).")] = None,
    urdf: Annotated[Optional[Path], typer.Option("--urdf", help="Write the identified robot as URDF: the exact geometry (ED-H frames on the body, whatever --convention), with a URDF nominal's meshes, inertials and limits.")] = None,
) -> None:
    """Identify the joint axes and parameters from joint sweeps (Hayat et al.), beside the nominal values."""
    from . import identify as ident  # noqa: PLC0415
    from . import sweeps as sw  # noqa: PLC0415

    if example:
        data = example_path(example)
        nominal = nominal or "kr5"
    if data is None:
        fail("give the sweep data (a file or folder) or --example kr5")
    with console.status("reading sweeps..."):
        if data.is_dir():
            if not home or not length:
                fail("a folder of per-joint files needs --home and --length (and --angle, default deg)")
            dirs = parse_numbers(direction, "--direction") or [1.0]
            sweeps = sw.read_joint_files(data, home=parse_numbers(home, "--home"), length=length, angle=angle or "deg", direction=dirs if len(dirs) > 1 else dirs[0])
        elif data.suffix.lower() == ".json":
            sweeps = sw.read_json(data)
        else:
            # units the file declares win; --length/--angle are then only the output's
            sweeps = sw.read_long_csv(data, **({} if _declares_units(data) else {"length": length, "angle": angle}))
    nom = load(nominal) if nominal else None
    with console.status(f"fitting {sweeps.n_joints} sweeps ({method})...") as status:
        ms = None if max_sigma is None else max_sigma * length_scale(length or sweeps.units.get("length", "mm"))
        T_world_base = None if base is None else parse_pose(base, True, length_scale(length or sweeps.units.get("length", "m")), "--base")
        result = ident.identify(sweeps, method=method, convention=convention.lower(), nominal=nom, loss=loss, max_sigma=ms, T_world_base=T_world_base, progress=status.update)
    out_len = length or sweeps.units.get("length", "m")
    doc = ident.to_json(result, out_len, "deg")
    print_identification(doc, result, out_len)
    if json_path:
        ident.write_json(result, json_path, out_len, "deg")
        console.print(f"wrote {json_path}")
    if save_model or urdf:
        names = nom.names if nom else [f"j{i + 1}" for i in range(sweeps.n_joints)]
        lower = nom.lower if nom else np.full(sweeps.n_joints, -np.pi)
        upper = nom.upper if nom else np.full(sweeps.n_joints, np.pi)
        identified = Robot(name=f"{nom.name if nom else 'robot'}_identified", table=result.table, names=names, lower=lower, upper=upper,
                           description=f"identified from {sweeps.source} ({result.method} fit, {result.convention})", source=str(sweeps.source), home=sweeps.home,
                           extra=nom.extra if nom else {})  # a URDF nominal's meshes, inertials and limits ride along
        if save_model:
            save(identified, save_model, out_len, "deg")
            console.print(f"wrote {save_model}")
        if urdf:
            from .urdf import save_urdf  # noqa: PLC0415

            save_urdf(result.model(convention="edh"), urdf, identified)  # the exact geometry, frames on the body
            console.print(f"wrote {urdf}")
    if report or plot:
        from . import report as rep  # noqa: PLC0415

        if plot:
            for f in rep.write_figures(result, plot):
                console.print(f"wrote {f}")
        if report:
            rep.write_report(result, report)
            console.print(f"wrote {report}")


def print_identification(doc: dict, result, length: str) -> None:
    nt = result.nominal_table
    say("bold", f"Identified {doc['convention'].upper()} parameters", f" (method {doc['method']}; data {doc['source']})")
    t = RichTable(caption=f"lengths in {length}, angles in deg; sigma = one standard deviation propagated from the fits")
    for c in ("joint", "param", "nominal", "identified", "sigma", "difference"):
        t.add_column(c, justify="right" if c not in ("joint", "param") else "left")
    ls, as_ = length_scale(length), angle_scale("deg")
    cols = result.table.columns
    for i, row in enumerate(doc["parameters"]):
        for k, c in enumerate(cols):
            a = result.table.angle_columns[k]
            nom = nt.params[i, k] / (as_ if a else ls) if nt is not None else None
            diff = row[c] - nom if nom is not None else None
            if diff is not None and a:
                diff = (diff + 180.0) % 360.0 - 180.0
            t.add_row(row["joint"] if k == 0 else "", c, fmt(nom, 3) if nom is not None else "-", fmt(row[c], 3), f"{row[c + '_sigma']:.3f}",
                      fmt(diff, 3) if diff is not None else "-", end_section=k == len(cols) - 1)
    console.print(t)
    at = RichTable(title="Joint axes (measurement frame)")
    for c in ("joint", f"radius [{length}]", "arc [deg]", f"rms [{length}]", f"sigma across [{length}]", "sigma dir [deg]", "outliers"):
        at.add_column(c, justify="right")
    for j in doc["joints"]:
        r = j["circle"]["radius"]
        at.add_row(j["joint"], f"{r:.3f}" if r is not None else "-", f"{j['arc_deg']:.1f}", f"{j['residuals']['rms']:.4f}", f"{j['axis']['sigma_point_perp']:.4f}",
                   f"{j['axis']['sigma_direction_deg']:.5f}", str(len(j["residuals"]["outliers"])))
    console.print(at)
    b = doc["bounding_box"]
    console.print(f"Measuring volume (minimum oriented bounding box, Hayat Table IV): {b['lengths'][0]:.3f} x {b['lengths'][1]:.3f} x {b['lengths'][2]:.3f} {length}, {b['volume_m3']:.4f} m^3; orientation (columns = box axes):")
    for row in b["orientation"]:
        console.print("  " + "  ".join(f"{v:7.3f}" for v in row))
    for note in doc["notes"]:
        say("yellow", "note:", f" {note}")


@app.command()
def simulate(
    model: ModelArg,
    output: Annotated[Path, typer.Option("-o", "--output", help="Long-form CSV to write.")],
    home: Annotated[Optional[str], typer.Option("--home", help="Home configuration in --angle units (default: the model file's home, else zeros).")] = None,
    ranges: Annotated[Optional[str], typer.Option("--ranges", help="Per-joint start,end pairs in --angle units, or 'paper90' / 'paper30' (Hayat Table II, the default).")] = None,
    points: Annotated[int, typer.Option("--points", help="Points per sweep.")] = 30,
    tool: Annotated[str, typer.Option("--tool", help="Tool point in the flange frame, in --length units.")] = "50,30,100",
    noise: Annotated[float, typer.Option("--noise", help="Point noise (1 sigma per coordinate), --length units.")] = 0.02,
    noise_q: Annotated[float, typer.Option("--noise-q", help="Joint-reading noise (1 sigma), --angle units.")] = 0.0,
    seed: Annotated[int, typer.Option("--seed")] = 0,
    length: Annotated[str, typer.Option("--length")] = "mm",
    angle: Annotated[str, typer.Option("--angle")] = "deg",
) -> None:
    """Simulate joint sweeps of a model (for planning a measurement and for tests); writes the long-form CSV."""
    from . import sweeps as sw  # noqa: PLC0415

    robot = load(model)
    m = robot.model()
    ls, as_ = length_scale(length), angle_scale(angle)
    n = m.nq
    h = parse_home(home, robot, as_)
    r = parse_ranges(ranges, n, as_, "paper90")
    tp = np.array(parse_numbers(tool, "--tool")) * ls
    if tp.shape != (3,):
        fail(f"--tool: expected 3 values, got {tp.size}")
    s = sw.simulate(m, home=h, ranges=r, points_per_sweep=points, tool_point=tp, noise=noise * ls, noise_q=noise_q * as_, seed=seed)
    from .io.output import write_text  # noqa: PLC0415

    write_text(output, sw.to_long_csv(s, length, angle, f"simulated sweeps of {robot.name}: seed {seed}, noise {noise} {length}, readings noise {noise_q} {angle}"))
    console.print(f"wrote {output}: {n} sweeps x {points} points")


def _calib_unit(unit: str, length: str, angle: str) -> tuple[str, float]:
    """Display unit and scale (SI per display unit) of a calibration parameter."""
    if unit == "length":
        return length, length_scale(length)
    if unit == "angle":
        return angle, angle_scale(angle)
    return "1", 1.0


@app.command()
def calibrate(
    data: Annotated[Path, typer.Argument(help="Measurements: CSV 'q1..qn,x,y,z[,rx,ry,rz]', a long-form sweep CSV (with 'joint'), or JSON.")],
    nominal: Annotated[str, typer.Option("--nominal", help="Nominal model (built-in name, robot file or URDF).")],
    convention: Annotated[str, typer.Option("--convention", help="edh | mdh (Hayati angle where axes are near-parallel) | dh")] = "edh",
    fix: Annotated[Optional[str], typer.Option("--fix", help="Parameters to hold at their nominal values: names or patterns, comma-separated (e.g. 'base_*,tool_z').")] = None,
    json_path: Annotated[Optional[Path], typer.Option("--json", help="Write the result as JSON to this file.")] = None,
    save: Annotated[Optional[Path], typer.Option("--save", help="Write the calibrated robot file (.toml, ED-H) to this path.")] = None,
    loss: Annotated[str, typer.Option("--loss", help="linear | soft_l1 | huber | cauchy | arctan (robust loss)")] = "linear",
    start: Annotated[str, typer.Option("--start", help="nominal | circles (circle-point identification of sweep data)")] = "nominal",
    holdout: Annotated[float, typer.Option("--holdout", help="Fraction of the poses held out to validate the fit.")] = 0.2,
    scale: Annotated[bool, typer.Option("--scale", help="Also estimate a scale per joint.")] = False,
    tool: Annotated[Optional[str], typer.Option("--tool", help="Tool point in the flange frame, --length units (default: the nominal model's tool).")] = None,
    noise: Annotated[Optional[float], typer.Option("--noise", help="Known point noise (1 sigma per coordinate), --length units (default: from the residuals).")] = None,
    length: Annotated[str, typer.Option("--length", help="Length unit of the output (and of the data if not declared in it).")] = "mm",
    angle: Annotated[str, typer.Option("--angle", help="Angle unit of the output (and of the data if not declared in it).")] = "deg",
    seed: Annotated[int, typer.Option("--seed", help="Seed of the held-out split.")] = 0,
) -> None:
    """Calibrate the whole model from measured points or poses at known joint readings (one least-squares fit)."""
    from . import calibration as cal  # noqa: PLC0415
    from .io.measurements import read_measurements  # noqa: PLC0415

    robot = load(nominal)
    units = {} if _declares_units(data) else {"length": length, "angle": angle}
    meas = read_measurements(data, kinds=list(robot.table.kinds), **units)
    ls = length_scale(length)
    tp = None
    if tool is not None:
        tp = np.array(parse_numbers(tool, "--tool")) * ls
        if tp.shape != (3,):
            fail(f"--tool: expected 3 values (x, y, z), got {tp.size}")
    fixes = [f.strip() for f in (fix or "").split(",") if f.strip()]
    with console.status(f"calibrating {robot.name} ({convention}) from {meas.n} {'poses' if meas.kind == 'pose' else 'points'}..."):
        res = cal.calibrate(meas, robot, convention=convention.lower(), fix=fixes, loss=loss, start=start, holdout=holdout, scale=scale, tool=tp,
                            noise=None if noise is None else noise * ls, seed=seed)
    print_calibration(res, length, angle)
    if json_path:
        cal.write_json(res, json_path, length, angle)
        console.print(f"wrote {json_path}")
    if save:
        save_robot = res.robot()
        from .robotfile import save as save_file  # noqa: PLC0415

        save_file(save_robot, save, length, angle)
        console.print(f"wrote {save}")


def _declares_units(path: Path) -> bool:
    """Whether a data file states its units (a '# units:' line or a JSON 'units' entry)."""
    try:
        head = path.read_text(encoding="utf-8")[:4096].lower()
    except OSError:
        return True  # let the reader report the problem
    return "# units" in head or '"units"' in head


def print_calibration(res, length: str, angle: str) -> None:
    pz = res.parametrization
    meas = res.measurements
    say("bold", f"Calibration of {pz.robot.name}", f" ({res.convention}, {meas.n} {'poses' if meas.kind == 'pose' else 'points'} from {meas.source}; "
        f"{res.elapsed * 1e3:.1f} ms, {res.evaluations} evaluations{'' if res.converged else ', NOT converged'})")
    t = RichTable(caption="sigma: one standard deviation (covariance of the fit); change: calibrated - nominal")
    for c in ("parameter", "unit", "nominal", "calibrated", "sigma", "change", "status"):
        t.add_column(c, justify="left" if c in ("parameter", "unit", "status") else "right")
    for k, name in enumerate(res.names):
        u, s = _calib_unit(pz.units[k], length, angle)
        nom, val, sig = res.nominal[k] / s, res.values[k] / s, res.sigma[k] / s
        t.add_row(name, u, fmt(nom, 4), fmt(val, 4), "-" if not np.isfinite(sig) else f"{sig:.4g}", fmt(val - nom, 4), res.status[k])
    console.print(t)
    ana = res.identifiability
    console.print(f"Identifiability: {ana.summary()}")
    if ana.unidentifiable:
        ut = RichTable(title="Parameters the data cannot identify (held at their start values)")
        ut.add_column("parameter")
        ut.add_column("why")
        for u in ana.unidentifiable:
            ut.add_row(u.name, u.reason)
        console.print(ut)
    ls = length_scale(length)
    console.print(f"Residuals: rms {res.rms / ls:.4g} {length} (noise estimate {res.noise / ls:.3g} {length} per coordinate)"
                  + (f", rotation rms {np.degrees(res.rms_rotation):.3g} deg" if meas.kind == "pose" else ""))
    v = res.validation
    if v is not None:
        console.print(f"Held-out validation ({v.n_test} of {v.n_train + v.n_test} poses): tool-position error rms {v.before_rms / ls:.4g} -> {v.after_rms / ls:.4g} {length}, "
                      f"max {v.before_max / ls:.4g} -> {v.after_max / ls:.4g} {length} (before: nominal geometry with base and tool fitted)")
    for note in res.notes:
        say("yellow", "note:", f" {note}")


@app.command()
def plan(
    model: ModelArg,
    ranges: Annotated[Optional[str], typer.Option("--ranges", help="Sweeps: per-joint start,end pairs in --angle units, or 'paper30' / 'paper90' (Hayat Table II).")] = None,
    home: Annotated[Optional[str], typer.Option("--home", help="Home configuration of the sweeps in --angle units (default: the model file's home, else zeros).")] = None,
    points: Annotated[int, typer.Option("--points", help="Points per sweep.")] = 30,
    tool: Annotated[str, typer.Option("--tool", help="Tool point in the flange frame, --length units.")] = "50,30,100",
    noise: Annotated[float, typer.Option("--noise", help="Point noise (1 sigma per coordinate), --length units.")] = 0.02,
    convention: Annotated[str, typer.Option("--convention", help="edh | mdh | dh")] = "edh",
    fix: Annotated[Optional[str], typer.Option("--fix", help="Parameters held fixed (names or patterns, comma-separated).")] = None,
    random: Annotated[Optional[int], typer.Option("--random", help="Plan N configurations spread over the joint limits instead of sweeps.")] = None,
    candidates: Annotated[Optional[Path], typer.Option("--candidates", help="CSV of candidate configurations (header q1..qn, --angle units; '# units:' line honoured).")] = None,
    select: Annotated[Optional[int], typer.Option("--select", help="Pick this many most informative poses from the candidates (D-optimal).")] = None,
    length: Annotated[str, typer.Option("--length")] = "mm",
    angle: Annotated[str, typer.Option("--angle")] = "deg",
    json_out: JsonOpt = False,
) -> None:
    """Predict every parameter's sigma (Cramer-Rao bound) and the measuring volume of a protocol, before measuring."""
    from . import calibration as cal  # noqa: PLC0415

    robot = load(model)
    n = len(robot.names)
    ls, as_ = length_scale(length), angle_scale(angle)
    tp = np.array(parse_numbers(tool, "--tool")) * ls
    if tp.shape != (3,):
        fail(f"--tool: expected 3 values, got {tp.size}")
    protocol, q = None, None
    if candidates is not None or random is not None:
        if candidates is not None:
            q = _read_configurations(candidates, robot, angle)
        else:
            if random < 1:
                fail(f"--random: expected a positive count, got {random}")
            q = cal.configurations(robot, random)
    else:
        h = parse_home(home, robot, as_)
        r = parse_ranges(ranges, n, as_, "paper30")
        protocol = cal.Protocol(h, r, points, tp)
    fixes = [f.strip() for f in (fix or "").split(",") if f.strip()]
    with console.status("planning..."):
        p = cal.plan(robot, protocol, q=q, noise=noise * ls, convention=convention.lower(), fix=fixes, tool=tp, select=select)
    pz = p.parametrization
    if json_out:
        doc = {"model": robot.name, "convention": pz.convention, "units": {"length": length, "angle": angle}, "noise": noise, "n_poses": len(p.q),
               "parameters": [{"name": nm, "unit": _calib_unit(pz.units[k], length, angle)[0],
                               "sigma": None if not np.isfinite(p.sigma[k]) else p.sigma[k] / _calib_unit(pz.units[k], length, angle)[1]} for k, nm in enumerate(p.names)],
               "axis_sigma": [{"joint": nm, "position": a[0] / ls, "direction_deg": np.degrees(a[1]),
                               **({"per_circle_position": c[0] / ls, "per_circle_direction_deg": np.degrees(c[1])} if c is not None else {})}
                              for nm, a, c in zip(robot.names, p.axis_sigma, p.per_circle_sigma if p.per_circle_sigma is not None else [None] * n)],
               "bounding_box": {"lengths": (p.box.lengths / ls).tolist(), "volume_m3": p.box.volume},
               "identifiability": {"rank": p.identifiability.rank, "condition_number": p.identifiability.condition_number, "observability": p.identifiability.observability,
                                   "unidentifiable": [{"name": u.name, "structural": u.structural, "reason": u.reason} for u in p.identifiability.unidentifiable]},
               "selected": None if p.selected is None else p.selected.tolist()}
        print(json.dumps(doc, indent=2))
        return
    what = f"{len(p.q)} poses" + (f" ({select} selected of the candidates)" if select else "") if protocol is None else f"sweeps of {points} points"
    say("bold", f"Plan for {robot.name}", f" ({pz.convention}): {what}, noise {noise} {length} per coordinate")
    t = RichTable(caption="Cramer-Rao bound (one sigma) of every parameter; '-': not identifiable (see below)")
    for c in ("parameter", "unit", "sigma"):
        t.add_column(c, justify="right" if c == "sigma" else "left")
    for k, nm in enumerate(p.names):
        u, s = _calib_unit(pz.units[k], length, angle)
        t.add_row(nm, u, "-" if not np.isfinite(p.sigma[k]) else f"{p.sigma[k] / s:.4g}")
    console.print(t)
    at = RichTable(title="Joint axes at home: predicted sigma across the axis and of its direction")
    cols = ["joint", f"position [{length}]", "direction [deg]"] + ([f"per-circle position [{length}]", "ratio"] if p.per_circle_sigma is not None else [])
    for c in cols:
        at.add_column(c, justify="right")
    for j, nm in enumerate(robot.names):
        row = [nm, f"{p.axis_sigma[j, 0] / ls:.4g}", f"{np.degrees(p.axis_sigma[j, 1]):.4g}"]
        if p.per_circle_sigma is not None:
            row += [f"{p.per_circle_sigma[j, 0] / ls:.4g}", f"{p.per_circle_sigma[j, 0] / p.axis_sigma[j, 0]:.2f}"]
        at.add_row(*row)
    console.print(at)
    b = p.box
    console.print(f"Measuring volume (minimum oriented bounding box): {b.lengths[0] / ls:.1f} x {b.lengths[1] / ls:.1f} x {b.lengths[2] / ls:.1f} {length}, {b.volume:.4g} m^3")
    console.print(f"Identifiability: {p.identifiability.summary()}")
    red = [u.name for u in p.identifiability.unidentifiable if u.structural]
    if red:
        console.print(f"Redundant in the {pz.convention} parametrisation (held at nominal; reasons with --json): {', '.join(red)}")
    for u in p.identifiability.unidentifiable:
        if not u.structural:
            say("yellow", "not identifiable from this protocol:", f" {u.name}: {u.reason}")
    if p.selected is not None:
        console.print(f"Selected candidates (0-based, in the order chosen): {', '.join(map(str, p.selected.tolist()))}")
    for note in p.notes:
        say("yellow", "note:", f" {note}")


def _read_configurations(path: Path, robot: Robot, angle: str) -> np.ndarray:
    """Candidate configurations from a CSV with header q1..qn (angle units from a '# units:' line or --angle)."""
    import re  # noqa: PLC0415

    if not path.exists():
        fail(f"{path}: no such file")
    lines = path.read_text(encoding="utf-8").splitlines()
    unit = angle
    rows, header = [], None
    for ln, line in enumerate(lines, 1):
        s = line.strip()
        m = re.match(r"#\s*units\s*:.*angle\s*=\s*(\w+)", s, re.IGNORECASE)
        if m:
            unit = m.group(1)
        if not s or s.startswith("#"):
            continue
        cells = [c.strip() for c in re.split(r"[;,]", s)]
        if header is None:
            header = [c.lower() for c in cells]
            continue
        try:
            rows.append((ln, [float(c) for c in cells]))
        except ValueError:
            fail(f"{path}:{ln}: expected numbers, got {s!r}")
    n = len(robot.names)
    need = [f"q{i + 1}" for i in range(n)]
    if header is None or any(c not in header for c in need):
        fail(f"{path}: header must name q1..q{n}, got {header}")
    idx = [header.index(c) for c in need]
    scale = np.array([angle_scale(unit, str(path)) if k == "revolute" else 1.0 for k in robot.table.kinds])
    out = []
    for ln, r in rows:
        if len(r) != len(header):
            fail(f"{path}:{ln}: expected {len(header)} values, got {len(r)}")
        out.append([r[i] for i in idx])
    if not out:
        fail(f"{path}: no configurations")
    return np.array(out) * scale


def main() -> None:
    """Entry point: every DenavitError becomes a one-line message and exit code 2."""
    try:
        app()
    except DenavitError as e:
        say("bold red", "error:", f" {e}", err=True)
        sys.exit(2)


if __name__ == "__main__":
    main()
