"""``identify``: joint axes and parameters from joint sweeps (Hayat et al.)."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Annotated

import typer

from ..errors import DenavitError
from ..io.units import angle_scale, cell_scale, length_scale
from .common import commands
from .console import console, fail, num, print_rows, say, spread, status, wrote
from .options import (
    CONVENTION,
    BaseLinkOpt,
    ColumnsOpt,
    ConventionOpt,
    CouplingOpt,
    JsonOpt,
    NominalAliasOpt,
    TargetOpt,
    TipLinkOpt,
    TrackerNoiseOpt,
    TrackerPositionOpt,
    VerboseOpt,
)
from .outputs import check_outputs, emit_json, json_target, require_plot_extra, save_urdf_of
from .values import (
    convention_name,
    deprecated,
    load_robot,
    model_first,
    parse_numbers,
    parse_point,
    parse_pose,
    positive,
    warn_limits,
)

#: The sweeps shipped with the package: --example name -> (file in denavit.data, Hayat Table II protocol in deg). All
#: are simulated from :data:`TRUE_ROBOT` (examples/make_kr5_example.py), not measured.
EXAMPLES = {"kr5": ("kr5_90deg.csv", 90), "kr5-90": ("kr5_90deg.csv", 90), "kr5-30": ("kr5_30deg.csv", 30)}
#: The simulated "true" robot the examples were measured from (a robot file beside them; its [simulation] table says
#: how: the nominal, its designed tool point in mm, the noise).
TRUE_ROBOT = "kr5_true.toml"


def _data_file(name: str) -> Path:
    from importlib import resources  # noqa: PLC0415

    return Path(str(resources.files("denavit.data").joinpath(name)))


def example_path(name: str) -> Path:
    """The sweep file of the shipped example ``name`` (one of :data:`EXAMPLES`)."""
    key = name.lower()
    if key not in EXAMPLES:
        fail(f"--example: unknown example {name!r}: expected one of {', '.join(EXAMPLES)}")
    return _data_file(EXAMPLES[key][0])


def example_truth():
    """The robot the examples were simulated from (:data:`TRUE_ROBOT`, a :class:`~denavit.Robot`, SI), its
    ``extra["simulation"]`` saying how."""
    from ..io.robots import load  # noqa: PLC0415

    return load(_data_file(TRUE_ROBOT))


DataArg = Annotated[
    Path | None,
    typer.Argument(
        metavar="MODEL",
        help="The nominal model (built-in name, robot file or URDF: signs, free origins, names, limits, joint kinds), "
        "then DATA; one argument alone is DATA, identified without a nominal.",
    ),
]
MoreDataArg = Annotated[
    Path | None,
    typer.Argument(metavar="DATA", help="The sweeps: long-form CSV, JSON, a folder of j1.csv..jN.csv, or a recording."),
]

ExampleOpt = Annotated[
    str | None,
    typer.Option(
        "--example",
        help='Run on sweeps shipped with the package, simulated from a "true" KR5 (kr5_true.toml beside them): kr5 '
        "(90 deg protocol), kr5-30; the nominal is then the built-in kr5 unless MODEL says otherwise.",
    ),
]
MethodOpt = Annotated[str, typer.Option("--method", help="auto | kasa | hyper | geometric | readings | global")]
DataLengthOpt = Annotated[
    str | None,
    typer.Option(
        "--length",
        help="Length unit of what is typed and printed (default mm), and of the data where they declare none (then "
        "required): mm | m | cm | um | in. JSON stays SI.",
    ),
]
DataAngleOpt = Annotated[
    str | None,
    typer.Option(
        "--angle",
        help="Angle unit of what is typed and printed (default deg), and of the data where they declare none: deg | "
        "rad. JSON stays SI.",
    ),
]
HomeOpt = Annotated[
    str | None,
    typer.Option(
        "--home",
        help='Per-joint files: the locked configuration, e.g. "90,-90,90,0,90,0" (--angle units; prismatic joints '
        "--length).",
    ),
]
DirectionOpt = Annotated[
    str | None,
    typer.Option(
        "--direction",
        help="Per-joint files: +1/-1 per joint (or one for all): did the joint value increase over the recording?",
    ),
]
LossOpt = Annotated[
    str,
    typer.Option(
        "--loss",
        help="soft_l1 (default: one blunder does not move an axis; free on clean data) | huber | linear (plain least "
        "squares)",
    ),
]
MaxSigmaOpt = Annotated[
    float | None,
    typer.Option(
        "--max-sigma",
        help="Required axis-position accuracy (1 sigma) in --length units: sweeps predicted worse are an error.",
    ),
]
ReportOpt = Annotated[Path | None, typer.Option("--report", help="Write a self-contained HTML report.")]
PlotOpt = Annotated[Path | None, typer.Option("--plot", help="Write the static figures (PNG) into this folder.")]
SaveOpt = Annotated[
    Path | None,
    typer.Option(
        "--save",
        help="Write the identified robot as a robot file (.toml, in the output units), in --convention: ED-H (exact "
        "except the tilt of a pair the nominal has parallel when within 3 sigma of zero, its noise), POE (exact), DH "
        "or MDH (lossy where axes are near-parallel); the error it carries stated in the file.",
    ),
]
SaveConventionOpt = Annotated[
    str | None,
    typer.Option(
        "--save-convention",
        help="Deprecated: --convention sets the table --save writes. (--save a table of this convention instead.)",
    ),
]
BaseOpt = Annotated[
    str | None,
    typer.Option(
        "--base",
        help="The robot's base frame in the measurement frame, x, y, z, roll, pitch, yaw (six numbers separated by "
        "commas) (R = Rz(yaw) Ry(pitch) Rx(roll); --length and --angle units), 'rotvec: x,y,z,rx,ry,rz' (the pose "
        "format fk prints) or the 16 numbers of the 4x4 matrix (default: the measurement frame).",
    ),
]
UrdfOpt = Annotated[
    Path | None,
    typer.Option(
        "--urdf",
        help="Write the identified robot as URDF: the ED-H geometry (frames on the body, whatever --convention; exact "
        "except a near-parallel pair's tilt within 3 sigma, as --save's ED-H), with a URDF nominal's meshes, "
        "inertials and limits.",
    ),
]
FormatOpt = Annotated[
    str,
    typer.Option(
        "--format",
        help="sweeps (long CSV, JSON, jN.csv folder) | tracker | rtde | rsi | bag | columns | auto (from the content).",
    ),
]
SweepOpt = Annotated[
    str | None,
    typer.Option(
        "--sweep",
        help="Tracker export: where each point's sweep comes from: 'group' or a point-name pattern such as "
        "'J{joint}_{index}'.",
    ),
]
RotationNoiseOpt = Annotated[
    float | None,
    typer.Option(
        "--rotation-noise",
        help="6-DoF poses: the orientation noise (1 sigma per component), in --angle units, weighting the "
        "orientations against the points (default: estimated).",
    ),
]
KeepDwellOpt = Annotated[
    bool,
    typer.Option(
        "--keep-dwell",
        help="Keep the rows where the motion stands still at a sweep's ends (left out of the fits by default, with a "
        "note naming them).",
    ),
]
AllowImplausibleOpt = Annotated[
    bool,
    typer.Option(
        "--allow-implausible",
        help="Keep a fit that is implausible against the nominal MODEL (mirror image, two joints exchanged, most axes "
        "far: a unit slip or the wrong robot), with a note, instead of the error.",
    ),
]
ReadingsOpt = Annotated[
    Path | None,
    typer.Option(
        "--readings",
        help="A second recording with the joint readings on another clock (e.g. a controller log beside a tracker "
        "export): aligned from the motion.",
    ),
]
PayloadOpt = Annotated[
    str | None,
    typer.Option(
        "--payload",
        help=(
            "The payload on the flange for every sweep where the data give none (a sweep file's payload_mass,"
            " payload_x, payload_y, payload_z columns): its mass with a unit (kg, g) and optionally its centre of mass"
            ' in the flange frame, e.g. "5 kg @ 0,0,80 mm" (--length units without one). With a payload the joints\''
            " compliance under gravity is a candidate of the joint fit (it needs the nominal's link masses)."
        ),
    ),
]


@commands.command()
def identify(
    data: DataArg = None,
    sweep_data: MoreDataArg = None,
    example: ExampleOpt = None,
    nominal: NominalAliasOpt = None,
    method: MethodOpt = "auto",
    convention: ConventionOpt = CONVENTION,
    json_path: JsonOpt = None,
    length: DataLengthOpt = None,
    angle: DataAngleOpt = None,
    home: HomeOpt = None,
    direction: DirectionOpt = None,
    loss: LossOpt = "soft_l1",
    max_sigma: MaxSigmaOpt = None,
    report: ReportOpt = None,
    plot: PlotOpt = None,
    save_model: SaveOpt = None,
    save_convention: SaveConventionOpt = None,
    base: BaseOpt = None,
    urdf: UrdfOpt = None,
    data_format: FormatOpt = "auto",
    columns: ColumnsOpt = None,
    sweep: SweepOpt = None,
    target: TargetOpt = None,
    tracker_noise: TrackerNoiseOpt = None,
    tracker_position: TrackerPositionOpt = None,
    rotation_noise: RotationNoiseOpt = None,
    coupling: CouplingOpt = None,
    keep_dwell: KeepDwellOpt = False,
    allow_implausible: AllowImplausibleOpt = False,
    readings: ReadingsOpt = None,
    base_link: BaseLinkOpt = None,
    tip_link: TipLinkOpt = None,
    payload: PayloadOpt = None,
    verbose: VerboseOpt = False,
) -> None:
    """Identify the joint axes and parameters from joint sweeps (Hayat et al.), beside the nominal values."""
    require_plot_extra(report=report, plot=plot)  # before any work: the plot extra's modules
    from ..api import identify as identify_sweeps  # noqa: PLC0415
    from ..io.results import to_json  # noqa: PLC0415

    check_outputs(**{"--save": save_model, "--urdf": urdf, "--json": json_path})
    json_path = json_target(json_path)
    out_len, out_ang = length or "mm", angle or "deg"
    nominal, data = model_first(data, sweep_data, nominal, "identify", required=False)
    if example:
        if data is not None and nominal is None:  # `identify MODEL --example kr5`: the argument is the model
            nominal, data = str(data), None
        if data is not None:
            fail(f"--example {example}: the data are the example's; give MODEL alone, got {data}")
        data = example_path(example)
        nominal = nominal or "kr5"
    if data is None:
        fail("give the sweep data (a file or folder) or --example kr5")
    convention = convention_name(convention)
    if save_convention is not None:
        if not save_model:
            fail(f"--save-convention {save_convention}: it sets the table --save writes; give --save FILE too")
        convention_name(save_convention)
    nom = load_robot(str(nominal), base_link, tip_link, "MODEL") if nominal else None
    from ..io.payload import parse_payload  # noqa: PLC0415

    pl = None if payload is None else parse_payload(payload, out_len)
    with status("reading sweeps..."):
        sweeps = read_sweeps(
            data,
            nom,
            data_format=data_format,
            columns=columns,
            sweep=sweep,
            target=target,
            readings=readings,
            length=length,
            angle=out_ang,
            home=home,
            direction=direction,
        )
    with status(f"fitting {sweeps.n_joints} sweeps ({method})...") as st:
        result = identify_sweeps(
            sweeps,
            nom,
            method=method,
            convention=convention,
            loss=loss,
            progress=st.update,
            keep_dwell=keep_dwell,
            allow_implausible=allow_implausible,
            payload=pl,
            **fit_options(
                sweeps, out_len, out_ang, coupling, max_sigma, base, rotation_noise, tracker_noise, tracker_position
            ),
        )
    if json_path:
        emit_json(to_json(result), json_path)
    truth = example_truth() if example else None
    if json_path != "-":
        doc = to_json(result)
        print_measured(doc, result, out_len, out_ang, example, truth)
        print_identification(doc, result, out_len, out_ang, verbose)
        if nom is not None:
            print_accuracy(result, out_len, truth)
    if save_convention is not None:
        deprecated("--save-convention", "--convention, which sets the table --save writes")
    saved_as = convention_name(save_convention) if save_convention is not None else convention
    write_outputs(result, save_model, saved_as, urdf, report, plot, out_len, out_ang)
    if json_path != "-":
        print_next(example, nominal, save_model, verbose)


def read_sweeps(
    data: Path, nom, *, data_format: str, columns, sweep, target, readings, length, angle: str, home, direction
):
    """The sweeps of DATA by :func:`denavit.api.read_sweeps` (the same reading as a Python user's), with the options'
    values in SI and what the reader found printed (a recording's notes, clock alignment, segmentation); an error
    about an option's value names the option."""
    import numpy as np  # noqa: PLC0415

    from ..api import read_sweeps as api_read_sweeps  # noqa: PLC0415
    from ..io.units import joint_scale  # noqa: PLC0415

    kinds = list(nom.table.kinds) if nom else None
    h = parse_numbers(home, "--home") or None
    if h is not None:
        if kinds is not None and len(h) != len(kinds):
            fail(f"--home: expected {len(kinds)} values (one per joint of {nom.name}), got {len(h)}")
        h = np.array(h) * joint_scale(kinds or ["revolute"] * len(h), length or "mm", angle, "--home")
    d = parse_numbers(direction, "--direction") or None

    def inform(kind: str, text: str) -> None:
        if kind == "segments":
            console.print(text, soft_wrap=True)
        else:
            say("dim", f"{kind}:", f" {text}")

    options = {
        "home": "--home" + (f" {home}" if home else ""),
        "direction": "--direction" + (f" {direction}" if direction else ""),
    }
    try:
        sweeps = api_read_sweeps(
            data,
            nominal=nom,
            format=data_format,
            length=length,
            angle=angle,
            home=h,
            direction=d if d is None or len(d) > 1 else d[0],
            columns=columns,
            sweep=sweep,
            target=None if target is None else target - 1,
            readings=readings,
            inform=inform,
        )
    except DenavitError as e:
        if e.what == "target" and isinstance(e.expected, int):
            fail(f"--target {target}: {data} has {e.expected} target(s) per pose: expected 1..{e.expected}")
        if e.what in options:
            fail(f"{options[e.what]}: {e}")
        raise
    if h is not None and nom is not None and len(sweeps.home) == len(nom.names):
        warn_limits(sweeps.home, nom, "--home", length or "mm", angle)
    return sweeps


def fit_options(
    sweeps, length: str, angle: str, coupling, max_sigma, base, rotation_noise, tracker_noise, tracker_position
) -> dict:
    """The fit's options typed on the command line, in SI (:func:`denavit.identification.identify`'s keywords)."""
    from ..io.robotfile import parse_coupling  # noqa: PLC0415

    if max_sigma is not None and not (math.isfinite(max_sigma) and max_sigma > 0):
        fail(f"--max-sigma: expected the required axis-position sigma, a finite value > 0 in {length}, got {max_sigma}")
    rn = (
        None
        if rotation_noise is None
        else positive(rotation_noise, "--rotation-noise", angle_scale(angle), None, angle)
    )
    if rn is not None:
        from ..limits import check_angle_noise  # noqa: PLC0415

        check_angle_noise(rn, "--rotation-noise", angle, angle_scale(angle))
    return {
        "coupling": parse_coupling(coupling, list(sweeps.kinds), "--coupling") if coupling else None,
        "max_sigma": None if max_sigma is None else max_sigma * length_scale(length),
        "T_world_base": None if base is None else parse_pose(base, angle, length_scale(length), "--base"),
        "rotation_noise": rn,
        "tracker_noise": parse_tracker_noise(tracker_noise, tracker_position, length, angle),
    }


def print_measured(doc: dict, result, length: str, angle: str, example: str | None, truth) -> None:
    """What was measured: the sweeps, their points and arcs about the home, the fit's residual; for a shipped example
    also how it was made (the protocol, the "true" robot it was simulated from, the noise)."""
    from ..io.units import joint_scale  # noqa: PLC0415

    sweeps = result.sweeps
    counts = [len(s.points) for s in sweeps.sweeps]
    each = f"{counts[0]} points each" if len(set(counts)) == 1 else f"{min(counts)}-{max(counts)} points"
    arcs = ", ".join(
        f"{j['arc_rad'] / angle_scale(angle):.3g}" if j["arc_rad"] is not None else "-" for j in doc["joints"]
    )
    js = joint_scale(list(sweeps.kinds), length, angle)
    home = ", ".join(f"{round(v / k, 2) + 0.0:g}" for v, k in zip(sweeps.home, js))  # readings: noise below 0.01
    say(
        "bold",
        "Measured",
        f": {len(counts)} sweeps, one joint each about the home {home} {angle}, {each} ({sum(counts)} in all), "
        f"arcs {arcs} {angle}; residual rms {spread(doc['rms_m'] / length_scale(length))} {length}",
    )
    console.print(f"  data: {doc['source']}", soft_wrap=True)
    if truth is None:
        return
    sim, ls = truth.extra.get("simulation", {}), length_scale(length)
    tool = ", ".join(num(v / ls, length) for v in truth.table.T_last_tool[:3, 3])
    design = ", ".join(f"{v * 1e-3 / ls:g}" for v in sim["nominal_tool_mm"])
    say(
        "yellow",
        "  simulated, not measured:",
        f' Hayat et al.\'s {EXAMPLES[example.lower()][1]} deg protocol (Table II) on a "true" KR5 that differs from '
        f"the nominal by {sim['errors']}, a point {tool} {length} off its flange (designed {design}), tracker noise "
        f"{sim['tracker_noise_mm'] * 1e-3 / ls:g} {length}, joint-reading noise "
        f"{math.radians(sim['reading_noise_deg']) / angle_scale(angle):g} {angle}",
    )
    console.print(f"  true robot: {truth.path}", soft_wrap=True)


def print_accuracy(result, length: str, truth=None) -> None:
    """How accurate the models are at the tool point over configurations spread within the joint limits
    (:func:`denavit.accuracy.identification_accuracy`): the identified model's predicted 1 sigma and the
    nominal model's error as the identified model sees it; with ``truth`` (the robot a shipped example was simulated
    from) the true error of the nominal model (its designed tool point, the measurement frame its base) and of the
    identified model (its table, as --save writes it) at the same configurations."""
    import numpy as np  # noqa: PLC0415

    from .. import _core  # noqa: PLC0415
    from ..accuracy import identification_accuracy  # noqa: PLC0415

    with status("predicting the accuracy over the joint limits ..."):
        acc = identification_accuracy(result)
    s, ls = acc.summary(), length_scale(length)

    def line(what: str, e) -> list[str]:
        rms, worst = float(np.sqrt(np.mean(e**2))) / ls, float(np.max(e)) / ls
        return [what, f"{spread(rms)} {length} (max {spread(worst)})"]

    ident = result.robot(convention=result.convention)
    q_ident = ident.joint_values(acc.q) if ident.has_reading_model else acc.q
    name, rows = result.nominal.name, []
    if truth is not None:
        p_true = _core.fk_batch(truth.model(), acc.q)[:, :3, 3]
        design = np.eye(4)
        design[:3, 3] = np.asarray(truth.extra["simulation"]["nominal_tool_mm"], dtype=float) * 1e-3
        p_nom = _core.fk_batch(result.nominal.model().with_tool(design), acc.q)[:, :3, 3]
        p_id = _core.fk_batch(ident.model(), q_ident)[:, :3, 3]
        rows += [
            line(
                f"nominal model ({name}, tool as designed) against the true robot:",
                np.linalg.norm(p_nom - p_true, axis=1),
            ),
            line(
                f"identified model ({result.convention.upper()} table) against the true robot:",
                np.linalg.norm(p_id - p_true, axis=1),
            ),
        ]
    else:
        rows.append(line(f"nominal model ({name}) against the identified one:", acc.nominal))
    rows.append(line("identified model, predicted (1 sigma):", acc.identified))
    say(
        "bold",
        "Accuracy",
        f" at the tool point, rms (max) over {s['configurations']} configurations spread within the joint limits" + ":",
    )
    width = max(len(r[0]) for r in rows)
    for what, value in rows:
        console.print(f"  {what:<{width}} {value}", soft_wrap=True)


def print_next(example: str | None, nominal, save_model, verbose: bool) -> None:
    """One next step: keep the identified robot (--save), or, kept, correct a program's positions with it."""
    if save_model and nominal and str(save_model) != "-":
        step = (
            f"denavit compensate {nominal} PROGRAM --identified {save_model}  (PROGRAM: a robot program or a CSV of "
            "positions; the commands that bring the real robot to them: docs/compensation.md)"
        )
    elif example:
        step = f"denavit identify --example {example} --save {example}_identified.toml  (keeps the identified robot)"
    else:
        step = "run again with --save ROBOT.toml to keep the identified robot" + (
            " (then denavit compensate)" if nominal else ""
        )
    say("bold", "Next:", f" {step}")
    if not verbose:
        say("dim", "(--verbose: the joint axes, the measuring volume and the fit's choices)")


def write_outputs(result, save_model, convention: str, urdf, report, plot, length: str, angle: str) -> None:
    """--save (in ``convention``: the identified ED-H / POE geometry, or a DH / MDH table, its carried error written
    in the file),
    --urdf (the ED-H geometry, frames on the body; a URDF nominal's meshes and limits ride along), --plot, --report."""
    if save_model:
        from ..fleet.checksum import saved_checksum  # noqa: PLC0415
        from ..io.results import save  # noqa: PLC0415

        table = convention if convention in ("dh", "mdh") else None
        save(result, save_model, table, length, angle)
        written = result.robot(None, table) if str(save_model) == "-" else None
        wrote(save_model, f" (model checksum {saved_checksum(save_model, written)})")
    if urdf:
        save_urdf_of(result.model(convention="edh"), urdf, result.robot())
    if report or plot:
        from .. import report as rep  # noqa: PLC0415

        if plot:
            with status(f"drawing the figures into {plot} ..."):
                files = rep.write_figures(result, plot, length=length)
            for f in files:
                wrote(f)
        if report:
            with status(f"writing the report {report} ..."):
                rep.write_report(result, report, length=length, angle=angle)
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
        "--tracker-noise: expected the range and the angle noise (1 sigma), two values separated by a comma, each a "
        f'number > 0 with an optional unit, e.g. "5 um, 1 arcsec" (bare numbers in {length} and {angle})'
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


#: The notes that are the fit's choices in the statistics' words (the model choice by BIC and marginal likelihood,
#: scale estimates in ppm, a DH table's Hayati beta): shown with --verbose.
DETAIL_NOTES = ("auto:", "Hayati")


def print_identification(doc: dict, result, length: str, angle: str, verbose: bool = False) -> None:
    """The identified table beside the nominal and, with ``verbose``, the joint axes and the measuring volume, in
    ``length`` / ``angle`` (``doc``: the result's SI document, :func:`denavit.identification.to_json`); the notes
    (those of :data:`DETAIL_NOTES` with ``verbose``)."""
    print_parameters(doc, result, length, angle)
    if verbose:
        print_axes(doc, length, angle)
    tf = doc["tool_frame"]
    as_, ls = angle_scale(angle), length_scale(length)
    if tf["orientation_from"] != "nominal":
        rpy = ", ".join(f"{v / as_:.6g}" for v in tf["rpy_rad"])
        say(
            "bold",
            "Tool frame",
            f" at home (measurement frame): orientation from {tf['orientation_from']} ({tf['how']}): roll, pitch, yaw "
            f"{rpy} {angle} (R = Rz Ry Rx), 1 sigma {spread(tf['sigma_rad'] / as_)} {angle}"
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
    from ..message import render  # noqa: PLC0415

    for note in result.notes:  # in --length / --angle (a denavit.message.Message), the same as doc["notes"] else
        text = render(note, (ls, length), (as_, angle))
        if verbose or not any(word in text for word in DETAIL_NOTES):
            say("yellow", "note:", f" {text}")
    if not verbose:
        _compliance_note(result)


def _compliance_note(result) -> None:
    """Without --verbose, one note in place of the joint fit's choice of the joints' compliance (issue 37)."""
    chose = any("joint compliance fitted" in str(n) for n in result.notes)
    if result.compliance is not None:
        fitted = [j for j, s in enumerate(result.compliance["sigma"]) if s == s]  # not NaN: fitted
        names = (
            result.nominal.names
            if result.nominal is not None
            else [f"j{i + 1}" for i in range(len(result.compliance["k"]))]
        )
        joints = ", ".join(f"{j + 1} ({names[j]})" for j in fitted)
        say("yellow", "note:", f" the joints' compliance under gravity fitted at joints {joints} (--verbose: why)")
    elif chose:
        say("yellow", "note:", " the joints taken as rigid: their compliance under gravity not fitted (--verbose: why)")


def print_parameters(doc: dict, result, length: str, angle: str) -> None:
    """The identified table beside the nominal (``doc``: the result's SI document)."""
    import numpy as np  # noqa: PLC0415

    nt = result.nominal_table
    as_ = angle_scale(angle)
    say("bold", f"Identified {doc['convention'].upper()} parameters", f" (method {doc['method']})")
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


def print_axes(doc: dict, length: str, angle: str) -> None:
    """The joint axes' fits (radius, arc, residuals, sigmas, outliers, readings) and the measuring volume."""
    ls, as_ = length_scale(length), angle_scale(angle)
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
        "Measuring volume (minimum oriented bounding box, Hayat Table IV): "
        f"{' x '.join(num(v / ls, length) for v in b['lengths_m'])} {length}, {b['volume_m3']:.4g} m^3; "
        "orientation (columns = box axes):"
    )
    for row in b["orientation"]:
        console.print("  " + "  ".join(f"{v:7.3f}" for v in row))
