"""``plan``: predicted sigmas (Cramer-Rao bound) and measuring volume of a protocol, before measuring."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import numpy as np
import typer
from rich.table import Table as RichTable

from ..io.configurations import read_configurations
from ..io.output import json_text
from ..io.units import length_scale
from ..robot import load
from .common import JsonOpt, ModelArg, app, calib_unit, console, convention_name, fail, parse_joint_values, parse_numbers, parse_ranges, say


@app.command()
def plan(
    model: ModelArg,
    ranges: Annotated[str | None, typer.Option("--ranges", help="Sweeps: per-joint start,end pairs in --angle units (prismatic: --length), or 'paper30' / 'paper90' (Hayat Table II).")] = None,
    home: Annotated[str | None, typer.Option("--home", help="Home configuration of the sweeps in --angle units, prismatic joints in --length (default: the model file's home, else zeros).")] = None,
    points: Annotated[int, typer.Option("--points", help="Points per sweep.")] = 30,
    tool: Annotated[str, typer.Option("--tool", help="Tool point in the flange frame, --length units.")] = "50,30,100",
    noise: Annotated[float, typer.Option("--noise", help="Point noise (1 sigma per coordinate), --length units.")] = 0.02,
    convention: Annotated[str, typer.Option("--convention", help="edh | mdh | dh")] = "edh",
    fix: Annotated[str | None, typer.Option("--fix", help="Parameters held fixed (names or patterns, comma-separated).")] = None,
    random: Annotated[int | None, typer.Option("--random", help="Plan N configurations spread over the joint limits instead of sweeps.")] = None,
    candidates: Annotated[Path | None, typer.Option("--candidates", help="CSV of candidate configurations (header q1..qn, --angle / --length units unless a '# units:' line declares them).")] = None,
    select: Annotated[int | None, typer.Option("--select", help="Pick this many most informative poses from the candidates (D-optimal).")] = None,
    length: Annotated[str, typer.Option("--length")] = "mm",
    angle: Annotated[str, typer.Option("--angle")] = "deg",
    json_out: JsonOpt = False,
) -> None:
    """Predict every parameter's sigma (Cramer-Rao bound) and the measuring volume of a protocol, before measuring."""
    from .. import calibration as cal  # noqa: PLC0415

    robot = load(model)
    n = len(robot.names)
    ls = length_scale(length)
    convention = convention_name(convention)
    tp = np.array(parse_numbers(tool, "--tool")) * ls
    if tp.shape != (3,):
        fail(f"--tool: expected 3 values, got {tp.size}")
    protocol, q = None, None
    if candidates is not None or random is not None:
        if candidates is not None:
            q = read_configurations(candidates, robot.table.kinds, length=length, angle=angle)
        else:
            if random < 1:
                fail(f"--random: expected a positive count, got {random}")
            q = cal.configurations(robot, random)
    else:
        h = parse_joint_values(home, "--home", robot, length, angle, default=robot.home)
        r = parse_ranges(ranges, robot, length, angle, "paper30")
        protocol = cal.Protocol(h, r, points, tp)
    fixes = [f.strip() for f in (fix or "").split(",") if f.strip()]
    with console.status("planning..."):
        p = cal.plan(robot, protocol, q=q, noise=noise * ls, convention=convention, fix=fixes, tool=tp, select=select)
    pz = p.parametrization
    if json_out:
        doc = {"model": robot.name, "convention": pz.convention, "units": {"length": length, "angle": angle}, "noise": noise, "n_poses": len(p.q),
               "parameters": [{"name": nm, "unit": calib_unit(pz.units[k], length, angle)[0],
                               "sigma": None if not np.isfinite(p.sigma[k]) else p.sigma[k] / calib_unit(pz.units[k], length, angle)[1]} for k, nm in enumerate(p.names)],
               "axis_sigma": [{"joint": nm, "position": a[0] / ls, "direction_deg": np.degrees(a[1]),
                               **({"per_circle_position": c[0] / ls, "per_circle_direction_deg": np.degrees(c[1])} if c is not None else {})}
                              for nm, a, c in zip(robot.names, p.axis_sigma, p.per_circle_sigma if p.per_circle_sigma is not None else [None] * n)],
               "bounding_box": {"lengths": (p.box.lengths / ls).tolist(), "volume_m3": p.box.volume},
               "identifiability": {"rank": p.identifiability.rank, "condition_number": p.identifiability.condition_number, "observability": p.identifiability.observability,
                                   "unidentifiable": [{"name": u.name, "structural": u.structural, "reason": u.reason} for u in p.identifiability.unidentifiable]},
               "selected": None if p.selected is None else p.selected.tolist()}
        print(json_text(doc), end="")
        return
    what = f"{len(p.q)} poses" + (f" ({select} selected of the candidates)" if select else "") if protocol is None else f"sweeps of {points} points"
    say("bold", f"Plan for {robot.name}", f" ({pz.convention}): {what}, noise {noise} {length} per coordinate")
    t = RichTable(caption="Cramer-Rao bound (one sigma) of every parameter; '-': not identifiable (see below)")
    for c in ("parameter", "unit", "sigma"):
        t.add_column(c, justify="right" if c == "sigma" else "left")
    for k, nm in enumerate(p.names):
        u, s = calib_unit(pz.units[k], length, angle)
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
