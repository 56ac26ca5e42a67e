"""``identify``: joint axes and parameters from joint sweeps (Hayat et al.)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import numpy as np
import typer
from rich.table import Table as RichTable

from ..io.units import cell_scale, length_scale
from ..robot import Robot
from .common import BaseLinkOpt, TipLinkOpt, app, console, convention_name, fail, fmt, load_robot, parse_numbers, parse_pose, say, wrote

EXAMPLES = {"kr5": "kr5_90deg.csv", "kr5-90": "kr5_90deg.csv", "kr5-30": "kr5_30deg.csv"}


def example_path(name: str) -> Path:
    from importlib import resources  # noqa: PLC0415

    key = name.lower()
    if key not in EXAMPLES:
        fail(f"--example: unknown example {name!r}: expected one of {', '.join(EXAMPLES)}")
    return Path(str(resources.files("denavit.data").joinpath(EXAMPLES[key])))


@app.command()
def identify(
    data: Annotated[Path | None, typer.Argument(help="Sweeps: long-form CSV, JSON, or a folder of j1.csv..jN.csv.")] = None,
    example: Annotated[str | None, typer.Option("--example", help="Run on data shipped with the package: kr5 (90 deg protocol), kr5-30.")] = None,
    nominal: Annotated[str | None, typer.Option("--nominal", help="Nominal model (built-in name or file): signs, free origins, names, limits, joint kinds.")] = None,
    method: Annotated[str, typer.Option("--method", help="auto | kasa | hyper | geometric | readings | global")] = "auto",
    convention: Annotated[str, typer.Option("--convention", help="dh | mdh | edh | poe (or an alias: sdh, craig, ...)")] = "dh",
    json_path: Annotated[Path | None, typer.Option("--json", help="Write the result as JSON to this file ('-': standard output).")] = None,
    length: Annotated[str | None, typer.Option("--length", help="Length unit of the data if not declared in it; also of the output.")] = None,
    angle: Annotated[str | None, typer.Option("--angle", help="Angle unit of the data if not declared in it.")] = None,
    home: Annotated[str | None, typer.Option("--home", help="Per-joint files: the locked configuration, e.g. \"90,-90,90,0,90,0\" (--angle units; prismatic joints --length).")] = None,
    direction: Annotated[str | None, typer.Option("--direction", help="Per-joint files: +1/-1 per joint (or one for all): did the joint value increase over the recording?")] = None,
    loss: Annotated[str, typer.Option("--loss", help="soft_l1 (default: one blunder does not move an axis; free on clean data) | huber | linear (plain least squares)")] = "soft_l1",
    max_sigma: Annotated[float | None, typer.Option("--max-sigma", help="Required axis-position accuracy (1 sigma) in --length units (default mm): sweeps predicted worse are an error.")] = None,
    report: Annotated[Path | None, typer.Option("--report", help="Write a self-contained HTML report.")] = None,
    plot: Annotated[Path | None, typer.Option("--plot", help="Write the static figures (PNG) into this folder.")] = None,
    save_model: Annotated[Path | None, typer.Option("--save", help="Write the identified robot as a robot file (.toml, in the output units).")] = None,
    base: Annotated[str | None, typer.Option("--base", help="The robot's base frame in the measurement frame, \"x,y,z,roll,pitch,yaw\" (R = Rz(yaw) Ry(pitch) Rx(roll); output length unit, deg) or the 16 numbers of the 4x4 matrix (default: the measurement frame).")] = None,
    urdf: Annotated[Path | None, typer.Option("--urdf", help="Write the identified robot as URDF: the exact geometry (ED-H frames on the body, whatever --convention), with a URDF nominal's meshes, inertials and limits.")] = None,
    data_format: Annotated[str, typer.Option("--format", help="sweeps (long CSV, JSON, jN.csv folder) | tracker | rtde | rsi | bag | columns | auto (from the content).")] = "auto",
    columns: Annotated[str | None, typer.Option("--columns", help="Column map of a delimited recording, e.g. \"t,q1..q6,x,y,z\" (--format columns).")] = None,
    sweep: Annotated[str | None, typer.Option("--sweep", help="Tracker export: where each point's sweep comes from: 'group' or a point-name pattern such as 'J{joint}_{index}'.")] = None,
    target: Annotated[int, typer.Option("--target", help="Recordings with several targets per pose (SMRs on a nest): which one, 1-based.")] = 1,
    coupling: Annotated[str | None, typer.Option("--coupling", help="Joint values from the controller's readings, e.g. \"q3=r3+r2\" (a Fanuc's J3; ';' between joints; docs/robot-files.md); default: the robot file's [couplings].")] = None,
    keep_dwell: Annotated[bool, typer.Option("--keep-dwell", help="Keep the rows where the motion stands still at a sweep's ends (left out of the fits by default, with a note naming them).")] = False,
    readings: Annotated[Path | None, typer.Option("--readings", help="A second recording with the joint readings on another clock (e.g. a controller log beside a tracker export): aligned from the motion.")] = None,
    base_link: BaseLinkOpt = None,
    tip_link: TipLinkOpt = None,
) -> None:
    """Identify the joint axes and parameters from joint sweeps (Hayat et al.), beside the nominal values."""
    from .. import identify as ident  # noqa: PLC0415
    from ..io import sweeps as swio  # noqa: PLC0415

    if example:
        data = example_path(example)
        nominal = nominal or "kr5"
    if data is None:
        fail("give the sweep data (a file or folder) or --example kr5")
    convention = convention_name(convention)
    nom = load_robot(nominal, base_link, tip_link, "--nominal") if nominal else None
    kinds = list(nom.table.kinds) if nom else None
    with console.status("reading sweeps..."):
        if data_format not in ("auto", "sweeps") or readings is not None or (data_format == "auto" and not _is_sweep_file(data)):
            sweeps = read_recording_sweeps(data, data_format, columns=columns, sweep=sweep, target=target, readings=readings, length=length, angle=angle,
                                           home=parse_numbers(home, "--home") or None, direction=parse_numbers(direction, "--direction") or None, nominal=nom)
        elif data.is_dir():
            if not home or not length:
                fail("a folder of per-joint files needs --home and --length (and --angle, default deg)")
            dirs = parse_numbers(direction, "--direction") or [1.0]
            sweeps = swio.read_joint_files(data, home=parse_numbers(home, "--home"), length=length, angle=angle or "deg",
                                           direction=dirs if len(dirs) > 1 else dirs[0], kinds=kinds)
        elif data.suffix.lower() == ".json":
            sweeps = swio.read_json(data, length=length, angle=angle)
        else:  # units the file declares win; --length/--angle fill in what it does not declare (and are the output's)
            sweeps = swio.read_long_csv(data, length=length, angle=angle, kinds=kinds)
    out_len = length or sweeps.units.get("length", "m")
    from ..io.robotfile import parse_coupling  # noqa: PLC0415

    C = parse_coupling(coupling, list(sweeps.kinds), "--coupling") if coupling else None
    with console.status(f"fitting {sweeps.n_joints} sweeps ({method})...") as status:
        ms = None if max_sigma is None else max_sigma * length_scale(length or sweeps.units.get("length", "mm"))
        T_world_base = None if base is None else parse_pose(base, "deg", length_scale(out_len), "--base")
        result = ident.identify(sweeps, method=method, convention=convention, nominal=nom, loss=loss, max_sigma=ms, T_world_base=T_world_base,
                                keep_dwell=keep_dwell, coupling=C, progress=status.update)
    doc = ident.to_json(result, out_len, "deg")
    print_identification(doc, result, out_len)
    if nom is not None:
        from ..compensation import identification_accuracy  # noqa: PLC0415

        s = identification_accuracy(result).summary()
        ls_out = length_scale(out_len)
        say("bold", "Accuracy", f" over {s['configurations']} configurations within the limits: nominal model error rms {s['nominal']['rms'] / ls_out:.4g} {out_len} "
            f"(max {s['nominal']['max'] / ls_out:.4g}); identified model, predicted 1 sigma: rms {s['identified']['rms'] / ls_out:.4g} {out_len} "
            f"(max {s['identified']['max'] / ls_out:.4g})")
    if json_path:
        ident.write_json(result, json_path, out_len, "deg")
        wrote(json_path)
    if save_model or urdf:
        names = nom.names if nom else [f"j{i + 1}" for i in range(sweeps.n_joints)]
        from .. import _core  # noqa: PLC0415

        limits = np.array([_core.default_limits(k) for k in sweeps.kinds])
        lower = nom.lower if nom else limits[:, 0]
        upper = nom.upper if nom else limits[:, 1]
        identified = Robot(name=f"{nom.name if nom else 'robot'}_identified", table=result.table, names=names, lower=lower, upper=upper,
                           description=f"identified from {sweeps.source} ({result.method} fit, {result.convention})", source=str(sweeps.source), home=sweeps.home,
                           extra=nom.extra if nom else {},  # a URDF nominal's meshes, inertials and limits ride along
                           covariance=result.param_cov)  # compensate predicts the error after compensation from it
        if save_model:
            from ..io.robotfile import save  # noqa: PLC0415

            save(identified, save_model, out_len, "deg")
            wrote(save_model)
        if urdf:
            from ..io.urdf import save_urdf  # noqa: PLC0415

            save_urdf(result.model(convention="edh"), urdf, identified)  # the exact geometry, frames on the body
            wrote(urdf)
    if report or plot:
        from .. import report as rep  # noqa: PLC0415

        if plot:
            for f in rep.write_figures(result, plot):
                wrote(f)
        if report:
            rep.write_report(result, report)
            wrote(report)


def _is_sweep_file(data: Path) -> bool:
    """Our own sweep formats: a folder of jN.csv (no ROS 2 metadata), JSON, or a CSV whose header has a ``joint`` column."""
    if data.is_dir():
        return not (data / "metadata.yaml").exists()
    if data.suffix.lower() == ".json":
        return True
    from ..io.delimited import rows  # noqa: PLC0415
    from ..io.text import decode, read_bytes  # noqa: PLC0415

    head = read_bytes(data, "sweep file")[:65536]
    try:
        lines = decode(head, str(data)).splitlines()
    except Exception:  # noqa: BLE001 (a binary bag, or UTF-8 cut mid-character by the 64 kB window: not ours)
        return False
    found, _ = rows(lines[:50])
    return bool(found) and "joint" in [c.lower() for c in found[0][1]]


def read_recording_sweeps(data: Path, data_format: str, *, columns, sweep, target: int, readings, length, angle, home, direction, nominal):
    """A recording (tracker export, controller log, ROS bag, delimited file) as sweeps: read, aligned with a
    second clock's readings if given, segmented, one target picked; the format, alignment and segmentation
    are printed as found."""
    from ..io.recordings import read_recording  # noqa: PLC0415
    from ..recording import align, segment, to_sweepset  # noqa: PLC0415

    fmt_ = "auto" if data_format in ("auto", "sweeps") else data_format
    kinds = list(nominal.table.kinds) if nominal else None
    rec = read_recording(data, fmt_, columns=columns, length=length, angle=angle, sweep=sweep, kinds=kinds)
    for note in rec.notes:
        say("dim", "note:", f" {note}")
    if readings is not None:
        other = read_recording(readings, "auto", columns=columns, length=length, angle=angle, kinds=kinds)
        rec, al = align(rec, other)
        say("dim", "clocks:", f" {al}")
    seg = segment(rec)
    console.print(seg.table(), soft_wrap=True)
    if home is not None:
        from ..io.units import joint_scale  # noqa: PLC0415

        n = seg.n_joints
        home = np.asarray(home, dtype=float) * joint_scale(kinds or ["revolute"] * n, length or "mm", angle or "deg", "--home")
    return to_sweepset(rec, seg, target=target - 1, home=home, kinds=kinds, direction=(direction if direction is None or len(direction) > 1 else direction[0]) or 1)


def print_identification(doc: dict, result, length: str) -> None:
    nt = result.nominal_table
    say("bold", f"Identified {doc['convention'].upper()} parameters", f" (method {doc['method']}; data {doc['source']})")
    t = RichTable(caption=f"lengths in {length}, angles in deg; sigma = one standard deviation propagated from the fits")
    for c in ("joint", "param", "nominal", "identified", "sigma", "difference"):
        t.add_column(c, justify="right" if c not in ("joint", "param") else "left")
    cols = result.table.columns
    for i, row in enumerate(doc["parameters"]):
        for k, c in enumerate(cols):
            a = result.table.angle_columns[k]
            nom = nt.params[i, k] / cell_scale(nt, i, k, length, "deg")[0] if nt is not None else None
            diff = row[c] - nom if nom is not None else None
            if diff is not None and a:
                diff = (diff + 180.0) % 360.0 - 180.0
            t.add_row(row["joint"] if k == 0 else "", c, fmt(nom, 3) if nom is not None else "-", fmt(row[c], 3), f"{row[c + '_sigma']:.3f}",
                      fmt(diff, 3) if diff is not None else "-", end_section=k == len(cols) - 1)
    console.print(t)
    at = RichTable(title="Joint axes (measurement frame)")
    scaled = any(j["reading_scale"] is not None for j in doc["joints"])
    for c in ("joint", f"radius [{length}]", "arc [deg]", f"rms [{length}]", f"sigma across [{length}]", "sigma dir [deg]", "outliers", "reading sigma [arcsec]",
              *(["reading scale [ppm]"] if scaled else [])):
        at.add_column(c, justify="right")
    for j, kind in zip(doc["joints"], result.sweeps.kinds, strict=True):
        r = j["circle"]["radius"]
        rs = j["reading_sigma_deg"]
        sc = j["reading_scale"]
        at.add_row(j["joint"], f"{r:.3f}" if r is not None else "-", f"{j['arc_deg']:.1f}", f"{j['residuals']['rms']:.4f}", f"{j['axis']['sigma_point_perp']:.4f}",
                   f"{j['axis']['sigma_direction_deg']:.5f}", str(len(j["residuals"]["outliers"])), f"{rs * 3600:.3g}" if rs is not None and kind == "revolute" else "-",
                   *([f"{sc['value'] * 1e6:+.4g} +/- {sc['sigma'] * 1e6:.2g}" if sc else "-"] if scaled else []))
    console.print(at)
    b = doc["bounding_box"]
    console.print(f"Measuring volume (minimum oriented bounding box, Hayat Table IV): {b['lengths'][0]:.3f} x {b['lengths'][1]:.3f} x {b['lengths'][2]:.3f} {length}, {b['volume_m3']:.4f} m^3; orientation (columns = box axes):")
    for row in b["orientation"]:
        console.print("  " + "  ".join(f"{v:7.3f}" for v in row))
    for note in doc["notes"]:
        say("yellow", "note:", f" {note}")
