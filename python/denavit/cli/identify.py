"""``identify``: joint axes and parameters from joint sweeps (Hayat et al.)."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Annotated

import typer

from ..io.units import angle_scale, cell_scale, length_scale
from .common import (
    BaseLinkOpt,
    JsonOpt,
    TipLinkOpt,
    check_outputs,
    commands,
    console,
    convention_name,
    emit_json,
    fail,
    json_target,
    load_robot,
    num,
    parse_numbers,
    parse_point,
    parse_pose,
    positive,
    print_rows,
    require_plot_extra,
    say,
    spread,
    status,
    warn_limits,
    wrote,
)

EXAMPLES = {"kr5": "kr5_90deg.csv", "kr5-90": "kr5_90deg.csv", "kr5-30": "kr5_30deg.csv"}


def example_path(name: str) -> Path:
    from importlib import resources  # noqa: PLC0415

    key = name.lower()
    if key not in EXAMPLES:
        fail(f"--example: unknown example {name!r}: expected one of {', '.join(EXAMPLES)}")
    return Path(str(resources.files("denavit.data").joinpath(EXAMPLES[key])))


@commands.command()
def identify(
    data: Annotated[
        Path | None, typer.Argument(help="Sweeps: long-form CSV, JSON, or a folder of j1.csv..jN.csv.")
    ] = None,
    example: Annotated[
        str | None,
        typer.Option(
            "--example",
            help="Run on data shipped with the package: kr5 (90 deg protocol), kr5-30; the nominal is then the built-in kr5 unless --nominal says otherwise.",
        ),
    ] = None,
    nominal: Annotated[
        str | None,
        typer.Option(
            "--nominal", help="Nominal model (built-in name or file): signs, free origins, names, limits, joint kinds."
        ),
    ] = None,
    method: Annotated[
        str, typer.Option("--method", help="auto | kasa | hyper | geometric | readings | global")
    ] = "auto",
    convention: Annotated[
        str, typer.Option("--convention", help="dh | mdh | edh | poe (or an alias: sdh, craig, ...)")
    ] = "dh",
    json_path: JsonOpt = None,
    length: Annotated[
        str | None,
        typer.Option(
            "--length",
            help="Length unit of what is typed and printed (default mm), and of the data where they declare none (then required): mm | m | cm | um | in. JSON stays SI.",
        ),
    ] = None,
    angle: Annotated[
        str | None,
        typer.Option(
            "--angle",
            help="Angle unit of what is typed and printed (default deg), and of the data where they declare none: deg | rad. JSON stays SI.",
        ),
    ] = None,
    home: Annotated[
        str | None,
        typer.Option(
            "--home",
            help='Per-joint files: the locked configuration, e.g. "90,-90,90,0,90,0" (--angle units; prismatic joints --length).',
        ),
    ] = None,
    direction: Annotated[
        str | None,
        typer.Option(
            "--direction",
            help="Per-joint files: +1/-1 per joint (or one for all): did the joint value increase over the recording?",
        ),
    ] = None,
    loss: Annotated[
        str,
        typer.Option(
            "--loss",
            help="soft_l1 (default: one blunder does not move an axis; free on clean data) | huber | linear (plain least squares)",
        ),
    ] = "soft_l1",
    max_sigma: Annotated[
        float | None,
        typer.Option(
            "--max-sigma",
            help="Required axis-position accuracy (1 sigma) in --length units: sweeps predicted worse are an error.",
        ),
    ] = None,
    report: Annotated[Path | None, typer.Option("--report", help="Write a self-contained HTML report.")] = None,
    plot: Annotated[
        Path | None, typer.Option("--plot", help="Write the static figures (PNG) into this folder.")
    ] = None,
    save_model: Annotated[
        Path | None,
        typer.Option(
            "--save",
            help="Write the identified robot as a robot file (.toml, in the output units): the identified geometry (ED-H: exact except the tilt of a pair the nominal has parallel when within 3 sigma of zero, its noise; POE with --convention poe: exact), its carried error stated in the file.",
        ),
    ] = None,
    save_convention: Annotated[
        str | None,
        typer.Option(
            "--save-convention",
            help="--save a table of this convention instead (dh | mdh: lossy where axes are near-parallel; the file states the error it carries).",
        ),
    ] = None,
    base: Annotated[
        str | None,
        typer.Option(
            "--base",
            help="The robot's base frame in the measurement frame, x, y, z, roll, pitch, yaw (six numbers separated by commas) (R = Rz(yaw) Ry(pitch) Rx(roll); --length and --angle units) or the 16 numbers of the 4x4 matrix (default: the measurement frame).",
        ),
    ] = None,
    urdf: Annotated[
        Path | None,
        typer.Option(
            "--urdf",
            help="Write the identified robot as URDF: the ED-H geometry (frames on the body, whatever --convention; exact except a near-parallel pair's tilt within 3 sigma, as --save's ED-H), with a URDF nominal's meshes, inertials and limits.",
        ),
    ] = None,
    data_format: Annotated[
        str,
        typer.Option(
            "--format",
            help="sweeps (long CSV, JSON, jN.csv folder) | tracker | rtde | rsi | bag | columns | auto (from the content).",
        ),
    ] = "auto",
    columns: Annotated[
        str | None,
        typer.Option(
            "--columns", help='Column map of a delimited recording, e.g. "t,q1..q6,x,y,z" (--format columns).'
        ),
    ] = None,
    sweep: Annotated[
        str | None,
        typer.Option(
            "--sweep",
            help="Tracker export: where each point's sweep comes from: 'group' or a point-name pattern such as 'J{joint}_{index}'.",
        ),
    ] = None,
    target: Annotated[
        int | None,
        typer.Option(
            "--target",
            help="Data with several targets per pose (SMRs on a nest): fit this one alone, 1-based (default: every target, one fit with shared axes).",
        ),
    ] = None,
    tracker_noise: Annotated[
        str | None,
        typer.Option(
            "--tracker-noise",
            help="The tracker's range/angle noise (1 sigma): the distance's, then each angle's, e.g. \"5 um, 1 arcsec\" (a number without a unit is in --length / --angle units; angles also in arcsec): the joint fit weights each point by its covariance (noise along the line of sight from the tracker, angle x range across it), the scale estimated from the data. Default: isotropic point noise.",
        ),
    ] = None,
    tracker_position: Annotated[
        str | None,
        typer.Option(
            "--tracker-position",
            help="With --tracker-noise: the tracker's position in the data's frame, x,y,z in --length units (default 0,0,0: a tracker export's own frame).",
        ),
    ] = None,
    rotation_noise: Annotated[
        float | None,
        typer.Option(
            "--rotation-noise",
            help="6-DoF poses: the orientation noise (1 sigma per component), in --angle units, weighting the orientations against the points (default: estimated).",
        ),
    ] = None,
    coupling: Annotated[
        str | None,
        typer.Option(
            "--coupling",
            help="Joint values from the controller's readings, e.g. \"q3=r3+r2\" (a Fanuc's J3; ';' between joints; robot-files.md in docs); default: the robot file's \\[couplings].",
        ),
    ] = None,
    keep_dwell: Annotated[
        bool,
        typer.Option(
            "--keep-dwell",
            help="Keep the rows where the motion stands still at a sweep's ends (left out of the fits by default, with a note naming them).",
        ),
    ] = False,
    allow_implausible: Annotated[
        bool,
        typer.Option(
            "--allow-implausible",
            help="Keep a fit that is implausible against --nominal (mirror image, two joints exchanged, most axes far: a unit slip or the wrong robot), with a note, instead of the error.",
        ),
    ] = False,
    readings: Annotated[
        Path | None,
        typer.Option(
            "--readings",
            help="A second recording with the joint readings on another clock (e.g. a controller log beside a tracker export): aligned from the motion.",
        ),
    ] = None,
    base_link: BaseLinkOpt = None,
    tip_link: TipLinkOpt = None,
) -> None:
    """Identify the joint axes and parameters from joint sweeps (Hayat et al.), beside the nominal values."""
    require_plot_extra(report=report, plot=plot)  # before any work: the plot extra's modules
    from ..api import input_path, is_sweep_file  # noqa: PLC0415
    from ..identification import identify as identify_sweeps  # noqa: PLC0415
    from ..identification import to_json  # noqa: PLC0415
    from ..io import sweeps as swio  # noqa: PLC0415

    check_outputs(**{"--save": save_model, "--urdf": urdf, "--json": json_path})
    json_path = json_target(json_path)
    out_len, out_ang = length or "mm", angle or "deg"
    if example:
        data = example_path(example)
        nominal = nominal or "kr5"
    if data is None:
        fail("give the sweep data (a file or folder) or --example kr5")
    convention = convention_name(convention)
    if save_convention is not None:
        if not save_model:
            fail(f"--save-convention {save_convention}: it sets the table --save writes; give --save FILE too")
        convention_name(save_convention)
    nom = load_robot(nominal, base_link, tip_link, "--nominal") if nominal else None
    kinds = list(nom.table.kinds) if nom else None
    with status("reading sweeps..."):
        if (
            data_format not in ("auto", "sweeps")
            or readings is not None
            or (data_format == "auto" and not is_sweep_file(input_path(data)))
        ):
            sweeps = read_recording_sweeps(
                data,
                data_format,
                columns=columns,
                sweep=sweep,
                target=target,
                readings=readings,
                length=length,
                angle=angle,
                home=parse_numbers(home, "--home") or None,
                direction=parse_numbers(direction, "--direction") or None,
                nominal=nom,
            )
        elif data.is_dir():
            if not home or not length:
                fail("a folder of per-joint files needs --home and --length (and --angle, default deg)")
            dirs = parse_numbers(direction, "--direction") or [1.0]
            sweeps = swio.read_joint_files(
                data,
                home=parse_numbers(home, "--home"),
                length=length,
                angle=out_ang,
                direction=dirs if len(dirs) > 1 else dirs[0],
                kinds=kinds,
            )
            if nom is not None and len(sweeps.home) == len(nom.names):
                warn_limits(sweeps.home, nom, "--home", out_len, out_ang)
        else:
            for given, flag in ((home, "--home"), (direction, "--direction")):
                if given is not None:
                    fail(
                        f"{flag} {given}: {data} is a sweep file with its joint readings (and its home); {flag} applies to a folder of per-joint files or a recording"
                    )
            # units the file declares win; --length/--angle fill in what it does not declare (and are the output's):
            # an undeclared length is refused unless --length is given (no guess), an undeclared angle is --angle's
            # (default deg), as docs/cli.md says
            if data.suffix.lower() == ".json":
                sweeps = swio.read_json(data, length=length, angle=out_ang)
            else:
                sweeps = swio.read_long_csv(data, length=length, angle=out_ang, kinds=kinds)
        if target is not None and not (
            data_format not in ("auto", "sweeps")
            or readings is not None
            or (data_format == "auto" and not is_sweep_file(input_path(data)))
        ):
            if not 1 <= target <= sweeps.n_targets:
                fail(
                    f"--target {target}: {data} has {sweeps.n_targets} target(s) per pose: expected 1..{sweeps.n_targets}"
                )
            sweeps = sweeps.target(target - 1)
    from ..io.robotfile import parse_coupling  # noqa: PLC0415

    C = parse_coupling(coupling, list(sweeps.kinds), "--coupling") if coupling else None
    with status(f"fitting {sweeps.n_joints} sweeps ({method})...") as st:
        if max_sigma is not None and not (math.isfinite(max_sigma) and max_sigma > 0):
            fail(
                f"--max-sigma: expected the required axis-position sigma, a finite value > 0 in {out_len}, got {max_sigma}"
            )
        ms = None if max_sigma is None else max_sigma * length_scale(out_len)
        T_world_base = None if base is None else parse_pose(base, out_ang, length_scale(out_len), "--base")
        rn = (
            None
            if rotation_noise is None
            else positive(rotation_noise, "--rotation-noise", angle_scale(out_ang), None, out_ang)
        )
        if rn is not None:
            from ..limits import check_angle_noise  # noqa: PLC0415

            check_angle_noise(rn, "--rotation-noise", out_ang, angle_scale(out_ang))
        tn = parse_tracker_noise(tracker_noise, tracker_position, out_len, out_ang)
        result = identify_sweeps(
            sweeps,
            method=method,
            convention=convention,
            nominal=nom,
            loss=loss,
            max_sigma=ms,
            T_world_base=T_world_base,
            keep_dwell=keep_dwell,
            coupling=C,
            rotation_noise=rn,
            tracker_noise=tn,
            allow_implausible=allow_implausible,
            progress=st.update,
        )
    if json_path:
        emit_json(to_json(result), json_path)
    if json_path != "-":
        print_identification(to_json(result), result, out_len, out_ang)
        if nom is not None:
            from ..compensation import identification_accuracy  # noqa: PLC0415

            with status("predicting the accuracy over the joint limits ..."):
                s = identification_accuracy(result).summary()
            ls_out = length_scale(out_len)
            say(
                "bold",
                "Accuracy",
                f" over {s['configurations']} configurations within the limits: nominal model error rms {spread(s['nominal']['rms'] / ls_out)} {out_len} "
                f"(max {spread(s['nominal']['max'] / ls_out)}); identified model, predicted 1 sigma: rms {spread(s['identified']['rms'] / ls_out)} {out_len} "
                f"(max {spread(s['identified']['max'] / ls_out)})",
            )
    if save_model:  # the ED-H / POE geometry unless a lossy table is asked for, its carried error written in the file
        result.save(save_model, None if save_convention is None else convention_name(save_convention), out_len, out_ang)
        wrote(save_model)
    if urdf:
        from ..io.urdf import save_urdf  # noqa: PLC0415

        save_urdf(
            result.model(convention="edh"), urdf, result.robot()
        )  # the ED-H geometry, frames on the body; a URDF nominal's meshes and limits ride along
        wrote(urdf)
    if report or plot:
        from .. import report as rep  # noqa: PLC0415

        if plot:
            with status(f"drawing the figures into {plot} ..."):
                files = rep.write_figures(result, plot, length=out_len)
            for f in files:
                wrote(f)
        if report:
            with status(f"writing the report {report} ..."):
                rep.write_report(result, report, length=out_len, angle=out_ang)
            wrote(report)


#: Angle units of ``--tracker-noise`` beyond --angle's (a tracker maker's spec is in arcsec), radians per unit.
TRACKER_ANGLE = {"arcsec": math.pi / 648000}


def parse_tracker_noise(text: str | None, position: str | None, length: str, angle: str):
    """``--tracker-noise "RANGE, ANGLE"`` (each a number with an optional unit: a length unit, an angle unit or arcsec;
    bare numbers in ``length`` / ``angle``) and ``--tracker-position "x,y,z"`` (``length``) as a
    :class:`~denavit.fitting.joint.TrackerNoise` (SI), or None without ``text``; bad input is a one-line error."""
    import re  # noqa: PLC0415

    from ..fitting.joint import TrackerNoise  # noqa: PLC0415
    from ..io.delimited import NUMBER  # noqa: PLC0415
    from ..io.units import ANGLE, LENGTH  # noqa: PLC0415

    if text is None:
        if position is not None:
            fail("--tracker-position: needs --tracker-noise (the tracker's range and angle noise)")
        return None
    expected = (
        f"--tracker-noise: expected the range and the angle noise (1 sigma), two values separated by a comma, each a number > 0 with an "
        f'optional unit, e.g. "5 um, 1 arcsec" (bare numbers in {length} and {angle})'
    )
    items = text.split(",")
    if len(items) != 2:
        fail(f"{expected}, got {text[:80]!r}")
    values = []
    for item, default, units, what in (
        (items[0], length, LENGTH, "range"),
        (items[1], angle, {**ANGLE, **TRACKER_ANGLE}, "angle"),
    ):
        m = re.fullmatch(rf"\s*({NUMBER.pattern})\s*([A-Za-z]*)\s*", item)
        if m is None:
            fail(f"{expected}, got {item.strip()[:40]!r} for the {what} noise")
        unit = m.group(2).lower() or default
        if unit not in units:
            fail(f"--tracker-noise: the {what} noise's unit must be one of {', '.join(units)}, got {m.group(2)!r}")
        v = float(m.group(1))
        if not (math.isfinite(v) and v > 0):
            fail(f"--tracker-noise: expected a finite {what} noise > 0, got {item.strip()[:40]!r}")
        values.append(v * units[unit])
    from ..limits import check_angle_noise, check_lengths  # noqa: PLC0415

    check_lengths(values[0], "--tracker-noise: the range noise", length, length_scale(length))
    check_angle_noise(values[1], "--tracker-noise: the angle noise", angle, ANGLE.get(angle, 1.0))
    return TrackerNoise(
        values[0], values[1], tuple(parse_point(position, "--tracker-position", length_scale(length), (0.0, 0.0, 0.0)))
    )


def read_recording_sweeps(
    data: Path, data_format: str, *, columns, sweep, target: int, readings, length, angle, home, direction, nominal
):
    """A recording (tracker export, controller log, ROS bag, delimited file) as sweeps: read, aligned with a
    second clock's readings if given, segmented, one target picked; the format, alignment and segmentation
    are printed as found."""
    import numpy as np  # noqa: PLC0415

    from ..io.recordings import read_recording  # noqa: PLC0415
    from ..recording import align, segment, to_sweepset  # noqa: PLC0415

    fmt_ = "auto" if data_format in ("auto", "sweeps") else data_format
    kinds = list(nominal.table.kinds) if nominal else None
    # an angle the file does not declare is --angle's, deg by default (as for sweep files); a length must be given
    rec = read_recording(data, fmt_, columns=columns, length=length, angle=angle or "deg", sweep=sweep, kinds=kinds)
    for note in rec.notes:
        say("dim", "note:", f" {note}")
    if readings is not None:
        other = read_recording(readings, "auto", columns=columns, length=length, angle=angle or "deg", kinds=kinds)
        rec, al = align(rec, other)
        say("dim", "clocks:", f" {al}")
    seg = segment(rec)
    console.print(seg.table(angle or "deg"), soft_wrap=True)
    if home is not None:
        from ..io.units import joint_scale  # noqa: PLC0415

        n = seg.n_joints
        home = np.asarray(home, dtype=float) * joint_scale(
            kinds or ["revolute"] * n, length or "mm", angle or "deg", "--home"
        )
    return to_sweepset(
        rec,
        seg,
        target=None if target is None else target - 1,
        home=home,
        kinds=kinds,
        direction=(direction if direction is None or len(direction) > 1 else direction[0]) or 1,
    )


def print_identification(doc: dict, result, length: str, angle: str) -> None:
    """The identified table beside the nominal, the joint axes and the measuring volume, in ``length`` / ``angle``
    (``doc``: the result's SI document, :func:`denavit.identification.to_json`)."""
    import numpy as np  # noqa: PLC0415

    nt = result.nominal_table
    ls, as_ = length_scale(length), angle_scale(angle)
    say("bold", f"Identified {doc['convention'].upper()} parameters", f" (method {doc['method']})")
    console.print(f"  data: {doc['source']}", soft_wrap=True)
    cols = result.table.columns
    rows = []
    for i, row in enumerate(doc["parameters"]):
        for k, c in enumerate(cols):
            scale, unit = cell_scale(result.table, i, k, length, angle)
            value = row[c] / scale
            nom = nt.params[i, k] / cell_scale(nt, i, k, length, angle)[0] if nt is not None else None
            diff = value - nom if nom is not None else None
            if diff is not None and result.table.angle_columns[k]:
                diff = (diff + np.pi / as_) % (2 * np.pi / as_) - np.pi / as_
            rows.append(
                [
                    row["joint"],
                    c,
                    unit,
                    num(nom, unit) if nom is not None else "-",
                    num(value, unit),
                    spread(row[c + "_sigma"] / scale),
                    num(diff, unit) if diff is not None else "-",
                ]
            )
    print_rows(
        None,
        ["joint", "param", "unit", "nominal", "identified", "sigma", "difference"],
        rows,
        labels=2,
        left=(2,),
        group=True,
        caption="sigma = one standard deviation propagated from the fits; difference = identified - nominal",
    )
    scaled = any(j["reading_scale"] is not None for j in doc["joints"])
    heads = [
        "joint",
        f"radius [{length}]",
        f"arc [{angle}]",
        f"rms [{length}]",
        f"sigma across [{length}]",
        f"sigma dir [{angle}]",
        "outliers",
        "reading sigma [arcsec]",
        *(["reading scale [ppm]"] if scaled else []),
    ]
    arows = []
    for j in doc["joints"]:
        r, arc = j["circle"]["radius_m"], j["arc_rad"]
        rs, sc = j.get("reading_sigma_rad"), j["reading_scale"]
        arows.append(
            [
                j["joint"],
                num(r / ls, length) if r is not None else "-",
                f"{arc / as_:.4g}" if arc is not None else "-",
                spread(j["residuals"]["rms_m"] / ls),
                spread(j["axis"]["sigma_point_perp_m"] / ls),
                spread(j["axis"]["sigma_direction_rad"] / as_),
                str(len(j["residuals"]["outliers"])),
                f"{math.degrees(rs) * 3600:.3g}" if rs is not None else "-",
                *([f"{sc['value'] * 1e6:+.4g} +/- {sc['sigma'] * 1e6:.2g}" if sc else "-"] if scaled else []),
            ]
        )
    print_rows("Joint axes (measurement frame)", heads, arows)
    b = doc["bounding_box"]
    console.print(
        f"Measuring volume (minimum oriented bounding box, Hayat Table IV): {' x '.join(num(v / ls, length) for v in b['lengths_m'])} {length}, {b['volume_m3']:.4g} m^3; "
        "orientation (columns = box axes):"
    )
    for row in b["orientation"]:
        console.print("  " + "  ".join(f"{v:7.3f}" for v in row))
    tf = doc["tool_frame"]
    if tf["orientation_from"] != "nominal":
        rpy = ", ".join(f"{v / as_:.6g}" for v in tf["rpy_rad"])
        say(
            "bold",
            "Tool frame",
            f" at home (measurement frame): orientation from {tf['orientation_from']} ({tf['how']}): roll, pitch, yaw {rpy} {angle} "
            f"(R = Rz Ry Rx), 1 sigma {spread(tf['sigma_rad'] / as_)} {angle}"
            + (
                f"; {tf['angle_from_nominal_flange_rad'] / as_:.4g} {angle} from the nominal flange's"
                if tf["angle_from_nominal_flange_rad"] is not None
                else ""
            ),
        )
    if doc.get("targets_home_m"):
        console.print(
            f"  targets at home [{length}]: "
            + "; ".join(", ".join(num(v / ls, length) for v in p) for p in doc["targets_home_m"]),
            soft_wrap=True,
        )
    for note in doc["notes"]:
        say("yellow", "note:", f" {note}")
