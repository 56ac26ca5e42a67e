"""``compensate``: turn a program's positions into the commands a nominal controller must be sent."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Annotated

import typer

from ..errors import DenavitError
from ..io.units import length_scale
from .common import commands
from .console import console, say, spread, status, wrote
from .options import AngleOpt, BaseLinkOpt, JsonOpt, LengthOpt, NominalAliasOpt, TipLinkOpt
from .outputs import SI_UNITS, check_outputs, emit_json, json_target, require_plot_extra
from .values import load_robot, model_first, parse_joint_values, positive

ModelArg = Annotated[
    str,
    typer.Argument(
        metavar="MODEL",
        help=(
            "The controller's model (built-in name, robot file or URDF), then POSITIONS. "
            "(`POSITIONS --nominal MODEL`: deprecated.)"
        ),
    ),
]

PositionsArg = Annotated[
    str | None,
    typer.Argument(
        metavar="POSITIONS",
        help=(
            "The program: a CSV of tool poses 'x,y,z,rx,ry,rz' (rotation vector) and/or joint rows 'q1..qn', with a "
            "'# units:' line; or a robot program (KUKA .src with its .dat, ABB .mod, FANUC .ls, URScript .script), "
            "written back with only its positions changed."
        ),
    ),
]

IdentifiedOpt = Annotated[
    str,
    typer.Option(
        "--identified",
        help="The identified robot (e.g. from identify/calibrate --save), in the same robot base frame.",
    ),
]

OutputOpt = Annotated[
    str | None,
    typer.Option(
        "-o",
        "--output",
        help=(
            "Write the compensated program (CSV: commands, their joint values, flags, errors before and predicted after"
            " per row); '-' for stdout."
        ),
    ),
]

PathOpt = Annotated[
    bool, typer.Option("--path", help="The positions form a path: warm-start along it and flag branch jumps.")
]

BranchTolOpt = Annotated[
    float | None,
    typer.Option(
        "--branch-tol",
        help=(
            "Largest joint change from the program's solution that keeps its branch, in --angle (revolute) units"
            " (default 0.1 rad = 5.7 deg whatever the unit, as in Python)."
        ),
    ),
]

ReportOpt = Annotated[
    Path | None,
    typer.Option("--report", help="Write a self-contained HTML report (summary, 3-D view, per-position errors)."),
]

FrameOpt = Annotated[
    list[str] | None,
    typer.Option(
        "--frame",
        metavar="FRAME",
        help=(
            "A numbered frame a robot program uses that lives in the controller: 'tool N=X,Y,Z,R1,R2,R3' or 'base"
            " N=...' (FANUC UT / UF, KUKA TOOL_DATA / BASE_DATA), mm and degrees in the program's own convention (KUKA"
            " A,B,C; FANUC W,P,R); repeatable."
        ),
    ),
]

Q0Opt = Annotated[
    str | None,
    typer.Option(
        "--q0",
        help=(
            "Rows without a configuration (poses without joint columns) are compensated on the nominal's solution"
            " nearest this, one value per joint in --angle units (prismatic: --length); default the nominal's home,"
            " else zeros."
        ),
    ),
]

PayloadOpt = Annotated[
    str | None,
    typer.Option(
        "--payload",
        help=(
            "The payload on the flange for every row where the positions file gives none (its payload_mass, "
            "payload_x, payload_y, payload_z columns): its mass with a unit (kg, g) and optionally its centre of mass "
            'in the flange frame, e.g. "5 kg @ 0,0,80 mm" (--length units without one). With an identified robot of '
            "compliant joints (a robot file's \\[compliance]) the commands are those that deflect onto the positions "
            "under it."
        ),
    ),
]


@commands.command()
def compensate(
    model: ModelArg,
    identified: IdentifiedOpt,
    positions: PositionsArg = None,
    nominal: NominalAliasOpt = None,
    output: OutputOpt = None,
    path: PathOpt = False,
    branch_tol: BranchTolOpt = None,
    length: LengthOpt = "mm",
    angle: AngleOpt = "deg",
    json_out: JsonOpt = None,
    report: ReportOpt = None,
    base_link: BaseLinkOpt = None,
    tip_link: TipLinkOpt = None,
    frame: FrameOpt = None,
    q0: Q0Opt = None,
    payload: PayloadOpt = None,
) -> None:
    """Compensate a program (RoboDK's "filtering"): for each position, the joint values that reach it on the
    identified robot (on the program's branch) and the pose T' = FK_nominal(q) to send to a controller that keeps
    its nominal model. Flagged rows (unreachable, branch changed, path jump) are marked, never silently kept;
    exit code 1 when any row is flagged."""
    require_plot_extra(report=report)  # before any work: the plot extra's modules

    from .. import compensation as cp  # noqa: PLC0415
    from ..io.units import angle_scale  # noqa: PLC0415

    check_outputs(**{"-o": output, "--json": json_out})
    json_out = json_target(json_out)
    nominal, positions = model_first(model, positions, nominal, "compensate", "POSITIONS")
    nom_robot = load_robot(nominal, base_link, tip_link, "MODEL")
    id_robot = load_robot(
        identified,
        base_link if str(identified).lower().endswith(".urdf") else None,
        tip_link if str(identified).lower().endswith(".urdf") else None,
        "--identified",
    )
    nom, ide = nom_robot.model(), id_robot.model()
    if nom.nq != ide.nq:
        raise DenavitError(f"--identified {identified}: {ide.nq} joints, but the nominal {nom_robot.name} has {nom.nq}")
    q0v = parse_joint_values(q0, "--q0", nom_robot, length, angle, default=nom_robot.home)
    from ..io.programs import detect  # noqa: PLC0415

    fmt = detect(positions)
    from ..io.payload import parse_payload  # noqa: PLC0415

    pl = None if payload is None else parse_payload(payload, length)
    if fmt is None and frame:
        raise DenavitError(
            f"--frame: {positions} is a CSV of positions in the robot base frame: expected no --frame "
            "(it names a robot program's numbered frames)"
        )
    if fmt is not None:
        if path:
            raise DenavitError(
                f"--path: {positions} is a robot program, whose positions each state their configuration "
                "(URScript poses: nearest the previous one): expected no --path"
            )
        pc = _compensate_program(
            positions,
            fmt,
            nom_robot,
            id_robot,
            output,
            q0v,
            positive(branch_tol, "--branch-tol", angle_scale(angle), cp.BRANCH_TOL, angle),
            json_out,
            length,
            _frames(frame or [], fmt),
            pl,
        )
        if report and pc.compensation is not None:
            from ..report import write_compensation_report  # noqa: PLC0415

            with status("writing the report ..."):
                write_compensation_report(
                    pc.compensation,
                    nom_robot,
                    id_robot,
                    report,
                    source=str(positions),
                    where=[pc.program.points[k].where for k in pc.rows],
                    length=length,
                    angle=angle,
                )
            wrote(report)
        if pc.left:
            raise typer.Exit(1)
        return
    flagged = _compensate_positions(
        positions,
        nom_robot,
        id_robot,
        output=output,
        path=path,
        branch_tol=positive(branch_tol, "--branch-tol", angle_scale(angle), cp.BRANCH_TOL, angle),
        q0v=q0v,
        payload=pl,
        json_out=json_out,
        report=report,
        length=length,
        angle=angle,
    )
    if flagged:
        raise typer.Exit(1)


def _compensate_positions(
    positions, nom_robot, id_robot, *, output, path, branch_tol, q0v, payload, json_out, report, length, angle
) -> list:
    """A positions CSV compensated: read, checked against the robot's reach, compensated, written (-o, --json, --report)
    and summarised; the flagged rows (where, why) returned."""
    import numpy as np  # noqa: PLC0415

    from .. import _core  # noqa: PLC0415
    from .. import compensation as cp  # noqa: PLC0415
    from ..io.positions import read_positions, write_compensated  # noqa: PLC0415

    nom = nom_robot.model()
    kinds = list(nom.kinds)
    prog = read_positions(positions, kinds, length=length, angle=angle)
    poses = prog.poses if prog.poses is not None else _core.fk_batch(nom, prog.q)
    # a position beyond any reach is a unit slip, not a position to flag: say so at its row
    reach = float(np.linalg.norm(_core.fk_batch(nom, _sample(nom))[:, :3, 3] - nom.T_world_base[:3, 3], axis=1).max())
    dist = np.linalg.norm(poses[:, :3, 3] - nom.T_world_base[:3, 3], axis=1)
    far = np.flatnonzero(dist > 1.5 * reach)
    if len(far):
        k = int(far[0])
        raise DenavitError(
            f"{prog.where[k]}: the position is {dist[k] / length_scale(prog.units['length']):.6g} "
            f"{prog.units['length']} from the base but {nom_robot.name} reaches about "
            f"{reach / length_scale(prog.units['length']):.4g} {prog.units['length']}"
            f" ({len(far)} such row{'s' if len(far) != 1 else ''}): "
            "is the file's length unit right?"
        )
    with status(f"compensating {len(poses)} positions ..."):
        # (the robots, not their models: the identified robot's reading model, [couplings] and [readings], applies)
        c = cp.compensate(
            nom_robot,
            id_robot,
            poses,
            q_nominal=prog.q,
            q0=q0v,
            path=path,
            branch_tol=branch_tol,
            payload=payload if prog.payload is None else prog.payload,  # the file's rows win, as calibrate's
        )
    for n in c.notes:
        if "rows without a configuration" not in n:  # (the summary's configuration line says it, in --angle)
            say("yellow", "note:", f" {n}")
    flagged = [
        (w, why)
        for w, ok, r, b, j in zip(prog.where, c.ok, c.reached, c.branch_changed, c.path_jump, strict=True)
        if not ok
        for why in [", ".join(x for x, f in (("unreachable", not r), ("branch changed", b), ("path jump", j)) if f)]
    ]
    before_rms = float(np.sqrt(np.mean(c.before[c.ok] ** 2))) if c.ok.any() else float("nan")
    # the predicted error after compensation (1 sigma), from the identified robot's covariance (identify --save)
    predicted = c.predicted_after  # (compensate's table_sigma of the robot file's [covariance], when it has one)
    if output:
        write_compensated(
            output,
            c,
            kinds,
            length=length,
            angle=angle,
            comment=f"compensated for {nom_robot.name} -> {id_robot.name} from {positions}",
            predicted_after=predicted,
            q0=q0v,
        )
        wrote(output, f" ({len(c)} rows, {len(flagged)} flagged)")
    summary = _summary(c, prog, kinds, q0v, flagged, before_rms, predicted)
    emit_json(summary, json_out)
    if json_out != "-" and output != "-":
        _print_summary(c, prog, nom_robot, id_robot, summary, flagged, before_rms, predicted, q0v, length, angle)
    if report:
        from ..report import write_compensation_report  # noqa: PLC0415

        with status("writing the report ..."):
            write_compensation_report(
                c, nom_robot, id_robot, report, source=str(positions), where=prog.where, length=length, angle=angle
            )
        wrote(report)
    return flagged


def _summary(c, prog, kinds, q0v, flagged, before_rms: float, predicted) -> dict:
    """The --json document (SI): the totals, the flagged rows, and the compensated program row by row."""
    import numpy as np  # noqa: PLC0415

    summary = {
        "positions": len(c),
        "flagged": len(flagged),
        "units": SI_UNITS,
        "before_rms_m": before_rms,
        "before_max_m": float(c.before[c.ok].max()) if c.ok.any() else None,
        "residual_max_m": float(c.residual[c.ok].max()) if c.ok.any() else None,
        "flagged_rows": [{"where": w, "why": why} for w, why in flagged],
        "notes": list(c.notes),
        "without_configuration": [w for w, a in zip(prog.where, c.assumed, strict=True) if a],
        "assumed_near": {"q": [float(v) for v in q0v]},
    }
    if predicted is not None:
        summary["predicted_after_rms_m"] = float(np.sqrt(np.mean(predicted[c.ok] ** 2))) if c.ok.any() else None
        summary["predicted_after"] = [
            {"where": w, "sigma_m": float(p)} for w, p in zip(prog.where, predicted, strict=True)
        ]
    # the compensated program, row by row (as -o writes it, in SI): the joint row and the pose to send, flags, errors
    summary["joint_units"] = ["rad" if k == "revolute" else "m" for k in kinds]
    summary["rows"] = [
        {
            "where": prog.where[k],
            "q": [float(v) for v in c.q_command[k]],
            "T_command": c.commands[k].tolist(),
            "ok": bool(c.ok[k]),
            "reached": bool(c.reached[k]),
            "branch_changed": bool(c.branch_changed[k]),
            "path_jump": bool(c.path_jump[k]),
            "before_m": float(c.before[k]),
            "before_rotation_rad": float(c.before_rotation[k]),
            "residual_m": float(c.residual[k]),
            "residual_rotation_rad": float(c.residual_rotation[k]),
            "predicted_after_m": None if predicted is None else float(predicted[k]),
            "configuration": {
                "source": "assumed" if c.assumed[k] else "program",
                "q": [float(v) for v in c.q_nominal[k]],
            },
        }
        for k in range(len(c))
    ]
    return summary


def _print_summary(c, prog, nom_robot, id_robot, summary, flagged, before_rms, predicted, q0v, length, angle) -> None:
    """The compensation in a few lines: positions and flags, the error without compensation, the configurations
    assumed, the predicted error after, the flagged rows."""
    kinds = list(nom_robot.table.kinds)
    ls = length_scale(length)
    sent = int(c.ok.sum())
    left_out = (
        f" (over the {sent} row{'s' if sent != 1 else ''} that can be sent: the {len(flagged)} flagged left out)"
        if flagged
        else ""
    )
    gain = (
        f"; error without compensation {spread(before_rms / ls)} {length} RMS, max"
        f" {spread(summary['before_max_m'] / ls)} {length}{left_out}"
        if c.ok.any()
        else "; no position can be sent (is the identified robot a calibration of the nominal?)"
    )
    say("bold", f"{nom_robot.name} -> {id_robot.name}:", f" {len(c)} positions, {len(flagged)} flagged{gain}")
    if c.assumed.any():
        from ..io.units import joint_scale  # noqa: PLC0415

        js = joint_scale(kinds, length, angle)
        say(
            "yellow",
            "configuration:",
            f" {int(c.assumed.sum())} of {len(c)} rows had none (no joint columns): each compensated on the nominal's"
            f" solution nearest --q0 ({', '.join(f'{v:.6g}' for v in q0v / js)} {angle}); that configuration is each"
            f" row's q1..q{len(kinds)} ('configuration' per row in --json). Give the program's joint values as q"
            " columns to keep its own"
            + "".join(
                f" ({n.split('; ', 1)[1]})"
                for n in c.notes
                if "rows without a configuration" in n and "unreachable on the nominal" in n
            ),
        )
    if predicted is not None and c.ok.any():
        at = "; at the flange, its position along the last axis left out: see the note" if c.flange else ""
        say(
            "bold",
            "Predicted error after compensation",
            f" (1 sigma, from {id_robot.name}'s covariance{at}): rms {summary['predicted_after_rms_m'] / ls:.4g}"
            f" {length}, max {float(predicted[c.ok].max()) / ls:.4g} {length}"
            + (" (per row in --json)" if len(c) > 20 else ""),
        )
        if len(c) <= 20:  # (a flagged row is not sent: its line below says why)
            for w, p, ok in zip(prog.where, predicted, c.ok, strict=True):
                if ok:
                    console.print(f"  {w}: {p / ls:.4g} {length}")
    for w, why in flagged[:20]:
        console.print(f"  {w}: {why}")
    if len(flagged) > 20:
        console.print(f"  ... and {len(flagged) - 20} more (all in the output's 'ok' column)")


def _frames(texts: list[str], fmt: str) -> dict:
    """{("tool" | "base", N): 4x4 (m)} of --frame 'tool N=X,Y,Z,R1,R2,R3' (mm, deg, the program's convention)."""
    import re  # noqa: PLC0415

    from ..io import programs as pg  # noqa: PLC0415

    if texts and fmt not in ("kuka", "fanuc"):
        raise DenavitError(
            f"--frame: a {fmt} program declares its frames itself (expected --frame only for KUKA or FANUC programs)"
        )
    out = {}
    for t in texts:
        m = re.fullmatch(r"\s*(tool|base|ut|uf)\s*(\d+)\s*=\s*(.*)", t, re.IGNORECASE)
        vals = None
        if m:
            try:
                vals = [float(v) for v in m.group(3).split(",")]
            except ValueError:
                vals = None
        if not m or vals is None or len(vals) != 6 or int(m.group(2)) < 1 or not all(map(math.isfinite, vals)):
            raise DenavitError(
                f"--frame {t!r}: expected 'tool N=X,Y,Z,R1,R2,R3' or 'base N=...' (N >= 1; mm and degrees)"
            )
        kind = {"ut": "tool", "uf": "base"}.get(m.group(1).lower(), m.group(1).lower())
        out[(kind, int(m.group(2)))] = pg.vendor(fmt).to_pose(vals)
    return out


def _compensate_program(
    path, fmt, nom_robot, id_robot, output, q0v, branch_tol, json_out, length, frames=None, payload=None
):
    """A robot program (KUKA .src/.dat, ABB .mod, FANUC .ls, URScript .script): read, every position compensated on
    its own configuration, written back with only the positions changed (docs/compensation.md)."""
    import numpy as np  # noqa: PLC0415

    from ..api import compensate as compensate_positions  # noqa: PLC0415
    from ..io.programs import check_output_name  # noqa: PLC0415

    if output:
        check_output_name(path, fmt, output)  # before the work
    with status(f"compensating the positions of {path} ..."):
        pc = compensate_positions(
            nom_robot, id_robot, path, frames=frames, q0=q0v, branch_tol=branch_tol, payload=payload
        )  # (read_program and compensate_program, as a Python user's call does)
    prog = pc.program
    c = pc.compensation
    if c is not None:
        for n in c.notes:
            if "rows without a configuration" not in n:
                say("yellow", "note:", f" {n}")
    for n in prog.notes:
        say("yellow", "note:", f" {n}")
    written = []
    if output:
        if output == "-" and len(prog.sources) > 1:
            raise DenavitError(
                f"-o -: {path} is a program of {len(prog.sources)} files"
                f" ({', '.join(Path(s.path).name for s in prog.sources)}): expected a path"
            )
        written = pc.write(output)
        for w in written:
            wrote(
                w,
                (
                    f" ({len(pc.new_values)} of {len(prog.points)} positions compensated"
                    f"{f', {len(pc.configs)} with their configuration rewritten' if pc.configs else ''},"
                    f" {len(pc.left)} left as they were)"
                    if w == written[0]
                    else ""
                ),
            )
    ok = c.ok if c is not None else np.zeros(0, dtype=bool)
    ls = length_scale(length)
    before = c.before[ok] if c is not None else np.zeros(0)
    summary = {
        "program": str(path),
        "format": fmt,
        "units": SI_UNITS,
        "positions": len(prog.points),
        "flagged": len(pc.left),
        "left": [{"where": w, "why": why} for w, why in pc.left],
        "relabelled": [{"where": w, "why": why} for w, why in pc.relabelled],
        "notes": list(prog.notes) + (list(c.notes) if c is not None else []),
        "before_rms_m": float(np.sqrt(np.mean(before**2))) if len(before) else None,
        "outputs": written,
        "rows": [
            {
                "where": prog.points[k].where,
                "name": prog.points[k].name,
                "kind": prog.points[k].kind,
                "configuration": {
                    "source": (
                        "program" if prog.points[k].config is not None or prog.points[k].kind == "joints" else "assumed"
                    ),
                    "stated": None if prog.points[k].config is None else prog.vendor.describe(prog.points[k].config),
                    "written": prog.vendor.describe(pc.configs[k]) if k in pc.configs else None,
                    "q": [float(v) for v in pc.q_program[i]],
                },
                "compensated": k in pc.new_values,
                "before_m": float(c.before[i]),
                "residual_m": float(c.residual[i]),
            }
            for i, k in enumerate(pc.rows)
        ],
    }
    emit_json(summary, json_out)
    if json_out != "-" and output != "-":
        gain = (
            f"; error without compensation {spread(summary['before_rms_m'] / ls)} {length} RMS"
            if summary["before_rms_m"] is not None
            else ""
        )
        say(
            "bold",
            f"{nom_robot.name} -> {id_robot.name}:",
            f" {len(prog.points)} positions ({fmt}), {len(pc.new_values)} compensated"
            f"{f' ({len(pc.configs)} with their configuration rewritten)' if pc.configs else ''}, {len(pc.left)} left"
            f" as they were{gain}",
        )
        for w, why in pc.relabelled[:20]:
            console.print(f"  {w}: {why}")
        if len(pc.relabelled) > 20:
            console.print(f"  ... and {len(pc.relabelled) - 20} more (all in --json's 'relabelled')")
        for w, why in pc.left[:20]:
            console.print(f"  {w}: {why}")
        if len(pc.left) > 20:
            console.print(f"  ... and {len(pc.left) - 20} more (all in --json's 'left')")
    return pc


def _sample(model):
    """Configurations spread over the joint limits (revolute ones within +-pi), to measure the reach."""
    import numpy as np  # noqa: PLC0415

    lo, hi = np.asarray(model.lower, dtype=float), np.asarray(model.upper, dtype=float)
    rev = np.array([k == "revolute" for k in model.kinds])
    lo, hi = np.where(rev, np.maximum(lo, -np.pi), lo), np.where(rev, np.minimum(hi, np.pi), hi)
    u = np.random.default_rng(0).random((512, model.nq))
    return lo + (hi - lo) * u
