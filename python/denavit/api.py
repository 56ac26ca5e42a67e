"""The top-level functions: :func:`identify`, :func:`calibrate`, :func:`plan`, :func:`simulate`,
:func:`compensate` (``denavit.identify(...)`` and so on), each taking what a user has at hand.

Data may be a path (``str`` or ``os.PathLike``) of any format the command line reads (long-form sweep CSV, sweep
JSON, a folder of ``j1.csv`` ... ``jN.csv``, measurement CSV/JSON, tracker exports, UR RTDE, KUKA RSI, ROS bags,
delimited recordings with a column map) or the object itself (:class:`~denavit.sweeps.SweepSet`,
:class:`~denavit.calibration.Measurements`, arrays); a robot may be a built-in name, a robot file, a URDF, a
:class:`~denavit.Robot` or a :class:`~denavit.Model`. Everything is SI (m, rad): the units of a file are its own
declaration, or ``length`` / ``angle`` where it declares none.

The algorithms and their results live in :mod:`denavit.identification` (``from denavit.identification import
Identification``; ``denavit.identify`` is this module's function), :mod:`denavit.calibration` and
:mod:`denavit.compensation`.
"""

from __future__ import annotations

import os

import numpy as np

from . import _core
from .errors import DenavitError
from .identification import Identification
from .identification import identify as _identify
from .io.sniff import input_path, is_measurement_file, is_sweep_file
from .limits import floats
from .robot import Robot
from .sweeps import PAPER_RANGES_DEG, SweepSet


def _robot(robot) -> Robot:
    """``robot`` (a :class:`Robot`, a :class:`Model`, a built-in name, a robot file or a URDF, as ``str`` or
    ``os.PathLike``) as a Robot (:func:`denavit.io.robots.as_robot`)."""
    from .io.robots import as_robot  # noqa: PLC0415

    return as_robot(robot)


def read_sweeps(
    data,
    *,
    nominal=None,
    format: str = "auto",
    length: str | None = None,
    angle: str | None = None,
    home=None,
    direction=None,
    columns: str | None = None,
    sweep: str | None = None,
    target: int | None = None,
    readings=None,
    inform=None,
) -> SweepSet:
    """The sweeps of ``data``: a :class:`SweepSet` as it is, or a path read as the ``identify`` command reads it.

    Our sweep files (long-form CSV with a ``joint`` column, sweep JSON, a folder of ``j1.csv`` ... ``jN.csv``) by
    :mod:`denavit.io.sweeps`; anything else as a recording (:func:`denavit.io.recordings.read_recording`,
    ``format`` "auto" detects it), segmented into sweeps (:func:`denavit.recording.segment`), aligned first with
    the joint readings of a second recording ``readings`` if given.

    nominal : robot, optional — gives the joint kinds (a prismatic joint's readings are lengths).
    home : array-like, shape (n,), rad / m — the locked configuration (needed by per-joint files, which carry no
        readings). direction : +1 / -1 (one, or one per joint; default +1) — per-joint files and recordings:
        did the joint value increase over the recording? target : 0-based, one target of a multi-target recording (or
        sweep file) alone;
        default every target (one fit with shared axes in :func:`identify`) and a recording's 6-DoF orientations.
    inform : callable(kind, text), optional — told what was found reading a recording: "note" (each reader's
        note), "clocks" (the alignment with ``readings``), "segments" (the segmentation table, angles in ``angle``).

    An error about an argument names it in its ``what`` (``home``, ``direction``, ``target``; a target out of range
    has the count per pose in ``expected``), so a caller can say which of its own options gave it.
    """
    if isinstance(data, SweepSet):
        return data if target is None else data.target(target)
    if not isinstance(data, (str, os.PathLike)):
        raise DenavitError(f"sweeps: expected a SweepSet or a path (str or os.PathLike), got {type(data).__name__}")
    from .io import sweeps as swio  # noqa: PLC0415

    p = input_path(data)
    robot = None if nominal is None else _robot(nominal)
    kinds = None if robot is None else list(robot.table.kinds)
    ours = readings is None and (format == "sweeps" or (format == "auto" and is_sweep_file(p)))
    if ours and p.is_dir():
        if home is None or length is None:
            raise DenavitError(
                f"{p}: a folder of per-joint files needs home (the configuration, one value per joint) and length "
                "(the files' unit where they declare none)",
                what="home",
            )
        return swio.read_joint_files(
            p, home=_files_home(home, kinds, length), length=length, angle="rad", direction=direction or 1, kinds=kinds
        )
    if ours:
        for name, given in (("home", home), ("direction", direction)):
            if given is not None:
                raise DenavitError(
                    f"{p} is a sweep file with its joint readings (and its home): {name} applies to a folder of "
                    "per-joint files or a recording",
                    what=name,
                )
        s = (
            swio.read_json(p, length=length, angle=angle)
            if p.suffix.lower() == ".json"
            else swio.read_long_csv(p, length=length, angle=angle, kinds=kinds)
        )
        if target is not None and not 0 <= target < s.n_targets:
            raise DenavitError(
                f"{p} has {s.n_targets} target(s) per pose: expected a target 0..{s.n_targets - 1} (0-based), got"
                f" {target}",
                what="target",
                expected=s.n_targets,
                got=target,
            )
        return s if target is None else s.target(target)
    from .io.recordings import read_recording  # noqa: PLC0415
    from .io.recordings.segmentation import segmentation_table  # noqa: PLC0415
    from .recording import align, segment, to_sweepset  # noqa: PLC0415

    inform = inform or (lambda kind, text: None)
    fmt = "auto" if format == "sweeps" else format
    rec = read_recording(p, fmt, columns=columns, length=length, angle=angle, sweep=sweep, kinds=kinds)
    for note in rec.notes:
        inform("note", note)
    if readings is not None:
        rec, al = align(
            rec, read_recording(input_path(readings), "auto", columns=columns, length=length, angle=angle, kinds=kinds)
        )
        inform("clocks", str(al))
    seg = segment(rec)
    inform("segments", segmentation_table(seg, angle or "deg"))
    return to_sweepset(rec, seg, target=target, home=home, kinds=kinds, direction=direction or 1)


def _files_home(home, kinds, length: str):
    """``home`` (rad / m) in the units :func:`denavit.io.sweeps.read_joint_files` reads it with ``angle="rad"``: a
    prismatic joint's value in the files' ``length``."""
    from .io.units import joint_scale  # noqa: PLC0415

    h = floats(home, "home")
    if kinds is None or h.shape != (len(kinds),):
        return h  # all revolute, or a count the reader refuses with its own message
    return h / joint_scale(kinds, length, "rad")


def identify(
    data,
    nominal=None,
    *,
    format: str = "auto",
    length: str | None = None,
    angle: str | None = None,
    home=None,
    direction=None,
    columns: str | None = None,
    sweep: str | None = None,
    target: int | None = None,
    readings=None,
    **options,
) -> Identification:
    """Circle-point identification (Hayat et al.) of the joint axes and parameters from joint sweeps.

    data : SweepSet or path — read by :func:`read_sweeps` (``format``, ``length``, ``angle``, ``home``,
        ``direction``, ``columns``, ``sweep``, ``target``, ``readings`` as there).
    nominal : built-in name, robot file, URDF, Robot or Model, optional — signs, free origins, names, limits.
    options : those of :func:`denavit.identification.identify` (``method``, ``convention``, ``T_world_base``,
        ``loss``, ``max_sigma``, ``keep_dwell``, ``tracker_noise``, ``progress``...).

    >>> import denavit as dv
    >>> dv.identify(dv.simulate("kr5", noise=2e-5), nominal="kr5").method
    'global'
    """
    robot = None if nominal is None else _robot(nominal)
    sweeps = read_sweeps(
        data,
        nominal=robot,
        format=format,
        length=length,
        angle=angle,
        home=home,
        direction=direction,
        columns=columns,
        sweep=sweep,
        target=target,
        readings=readings,
    )
    return _identify(sweeps, nominal=robot, **options)


def _measurements(data, robot: Robot, *, points, poses, format: str, length, angle, columns, target: int | None):
    """The measurements of ``data``; several targets per pose: every one (``target`` None, a TargetMeasurements) or
    the one asked (0-based)."""
    from .calibration.targets import as_measurements  # noqa: PLC0415

    kinds = list(robot.table.kinds)
    if isinstance(data, (str, os.PathLike)):
        return _read_measurements(
            input_path(data), kinds, format=format, length=length, angle=angle, columns=columns, target=target
        )
    return as_measurements(data, kinds, points=points, poses=poses, target=target)


def read_measurements(
    data,
    nominal,
    *,
    format: str = "auto",
    length: str | None = None,
    angle: str | None = None,
    columns: str | None = None,
    target: int | None = None,
    inform=None,
):
    """The measurements of the file ``data`` as :func:`calibrate` reads them: a measurement CSV or JSON
    (``q1..qn,x,y,z[,rx,ry,rz]``, several targets per pose ``x2,y2,z2,...``; a sweep CSV) or a recording, one pose per
    pause of the robot. nominal : robot (the joint kinds). target : 0-based, one target alone (default every one).
    inform : callable(kind, text), optional — told what a recording's reader found ("note")."""
    robot = _robot(nominal)
    return _read_measurements(
        input_path(data),
        list(robot.table.kinds),
        format=format,
        length=length,
        angle=angle,
        columns=columns,
        target=target,
        inform=inform,
    )


def _read_measurements(p, kinds: list, *, format: str, length, angle, columns, target: int | None, inform=None):
    """The measurements of the file ``p``: a measurement CSV or a recording (one pose per pause of the robot)."""
    from .calibration.targets import pick_target, recording_poses  # noqa: PLC0415

    if format == "measurements" or (format == "auto" and is_measurement_file(p)):
        from .io.measurements import read_measurements  # noqa: PLC0415

        return pick_target(read_measurements(p, kinds=kinds, length=length, angle=angle), target)
    from .io.recordings import read_recording  # noqa: PLC0415

    rec = read_recording(p, format, columns=columns, length=length, angle=angle, kinds=kinds)
    inform = inform or (lambda kind, text: None)
    for note in rec.notes:
        inform("note", note)
    meas = recording_poses(rec, target, kinds)
    inform("note", f"{meas.n} poses where the robot stood still (the median of each pause)")
    return meas


def calibrate(
    data,
    nominal,
    *,
    points=None,
    poses=None,
    format: str = "auto",
    length: str | None = None,
    angle: str | None = None,
    columns: str | None = None,
    target: int | None = None,
    **options,
):
    """One least-squares fit of the whole kinematic model (:func:`denavit.calibration.calibrate`).

    data : Measurements, SweepSet, TargetMeasurements, a path (measurement CSV ``q1..qn,x,y,z[,rx,ry,rz]`` or with
    several
        targets ``q1..qn,x,y,z,x2,y2,z2,...``, sweep CSV, JSON, or a
        recording: one pose per pause of the robot), or joint readings ``q`` (N, n) rad / m with ``points``
        (N, 3) m or ``poses`` (N, 4, 4).
    nominal : built-in name, robot file, URDF, Robot or Model.
    target : several targets per pose: fit this one alone (0-based); default every target in one fit.
    options : those of :func:`denavit.calibration.calibrate` (``convention``, ``fix``, ``loss``, ``holdout``...).
    """
    from .calibration import calibrate as _calibrate  # noqa: PLC0415

    robot = _robot(nominal)
    meas = _measurements(
        data,
        robot,
        points=points,
        poses=poses,
        format=format,
        length=length,
        angle=angle,
        columns=columns,
        target=target,
    )
    return _calibrate(meas, robot, **options)


def validate(
    model,
    data,
    *,
    points=None,
    poses=None,
    format: str = "auto",
    length: str | None = None,
    angle: str | None = None,
    columns: str | None = None,
    target: int | None = None,
    **options,
):
    """Score ``model`` on the measurement session ``data`` (:func:`denavit.calibration.validate.validate`).

    model : Calibration, Identification, Robot, Model, built-in name, robot file or URDF (its base and tool
        included: the frame it was calibrated in).
    data : what :func:`calibrate` takes (a path in any format it reads, read as ``format``, ``length``, ``angle``
        and ``columns`` say; measurement objects; or joint readings with ``points`` / ``poses``).
    target : several targets per pose: score this one alone (0-based), against the model's tool point.
    options : those of :func:`denavit.calibration.validate.validate` (``registration``, ``tool``, ``max_sigma``,
        ``payload``...).
    """
    from .calibration.validate import validate as _validate  # noqa: PLC0415

    if isinstance(model, (str, os.PathLike)):
        model = _robot(model)
    if isinstance(data, (str, os.PathLike)):
        kinds = _model_kinds(model)
        data = _read_measurements(
            input_path(data), kinds, format=format, length=length, angle=angle, columns=columns, target=target
        )
        target = None
    return _validate(model, data, points=points, poses=poses, target=target, **options)


def _model_kinds(model) -> list:
    """The joint kinds of whatever :func:`validate` scores (a Calibration's nominal robot's, as it reads files)."""
    robot = getattr(getattr(model, "parametrization", None), "robot", None)
    if robot is not None:
        return list(robot.table.kinds)
    if isinstance(model, Robot):
        return list(model.table.kinds)
    km = model if isinstance(model, _core.Model) else model.model()
    return list(km.kinds)


def protocol_ranges(robot: Robot, ranges) -> np.ndarray:
    """Sweep ranges (n, 2) start, end (rad / m) of ``ranges``: "paper90" / "paper30" (Hayat Table II, a 6-joint
    revolute arm, any case) or (n, 2) values (rad / m) as they are; used by :func:`plan`, :func:`simulate` and the
    command line's ``--ranges``."""
    n = len(robot.names)
    if isinstance(ranges, str):
        key = ranges.lower()
        if key not in ("paper90", "paper30"):
            raise DenavitError(
                f"ranges: expected 'paper90', 'paper30' or ({n}, 2) start, end values (rad / m), got {ranges!r}"
            )
        if n != 6 or "prismatic" in robot.table.kinds:
            raise DenavitError(
                f"ranges {ranges!r} are Hayat Table II for a 6-joint revolute robot; {robot.name} needs ({n}, 2) start,"
                " end values (rad / m)"
            )
        return np.radians(np.array(PAPER_RANGES_DEG[int(key[-2:])]))
    r = floats(ranges, "ranges")
    if r.shape != (n, 2):
        raise DenavitError(f"ranges: expected shape ({n}, 2) (start, end per joint, rad / m), got {r.shape}")
    return r


def _home(robot: Robot, home) -> np.ndarray:
    return floats(
        home if home is not None else (robot.home if robot.home is not None else np.zeros(len(robot.names))), "home"
    )


def plan(
    nominal,
    protocol=None,
    *,
    ranges="paper30",
    home=None,
    points_per_sweep: int = 30,
    tool_point=(0.05, 0.03, 0.10),
    q=None,
    **options,
):
    """Predicted sigmas (Cramér-Rao bound) and measuring volume before measuring (:func:`denavit.calibration.plan`).

    Without ``protocol`` or ``q``: sweeps over ``ranges`` ("paper30", "paper90" or (n, 2) rad / m) about ``home``
    (rad / m; default the robot file's home, else zeros), ``points_per_sweep`` points each, ``tool_point`` (m,
    flange frame). options : ``noise`` (m), ``convention``, ``fix``, ``select``... as there.
    """
    from .calibration import Protocol  # noqa: PLC0415
    from .calibration import plan as _plan  # noqa: PLC0415

    robot = _robot(nominal)
    if q is not None:
        q = floats(q, "plan: q")
    if protocol is None and q is None:
        protocol = Protocol(
            _home(robot, home), protocol_ranges(robot, ranges), points_per_sweep, np.asarray(tool_point, dtype=float)
        )
    return _plan(robot, protocol, q=q, **options)


def simulate(
    model,
    q=None,
    *,
    home=None,
    ranges="paper90",
    points_per_sweep: int = 30,
    tool_point=(0.05, 0.03, 0.10),
    noise: float = 0.0,
    noise_q: float = 0.0,
    seed: int = 0,
    **options,
):
    """Simulated data of ``model`` (built-in name, robot file, URDF, Robot or Model).

    Without ``q``: joint sweeps, a :class:`SweepSet` (:func:`denavit.sweeps.simulate`) over ``ranges``
    ("paper90", "paper30" or (n, 2) rad / m) about ``home`` (rad / m; default the robot file's home, else zeros),
    ``tool_point`` (m, flange frame) with point noise ``noise`` (m) and reading noise ``noise_q`` (rad / m);
    options ``targets`` ((k, 3) m: several targets per pose), ``poses`` and ``noise_rot`` (6-DoF poses).
    With ``q`` (N, n): calibration measurements at those configurations
    (:func:`denavit.calibration.simulate`; options ``measure``, ``noise_rot``, ``T_world_base``).
    """
    robot = _robot(model)
    m = model if isinstance(model, _core.Model) else robot.model()
    if q is not None:
        from .calibration import simulate as _simulate  # noqa: PLC0415

        return _simulate(m, floats(q, "simulate: q"), tool=tool_point, noise=noise, seed=seed, **options)
    wrong = sorted(set(options) - {"targets", "poses", "noise_rot"})
    if wrong:
        raise DenavitError(f"simulate: {', '.join(wrong)} apply to measurements at configurations q, not to sweeps")
    from .sweeps import simulate as _sweeps  # noqa: PLC0415

    return _sweeps(
        m,
        home=_home(robot, home),
        ranges=protocol_ranges(robot, ranges),
        points_per_sweep=points_per_sweep,
        tool_point=tool_point,
        noise=noise,
        noise_q=noise_q,
        seed=seed,
        **options,
    )


def compensate(nominal, identified, positions, **options):
    """The commands a controller that keeps ``nominal`` must be sent so that the ``identified`` robot reaches
    ``positions`` (:func:`denavit.compensation.compensate`).

    nominal, identified : built-in name, robot file, URDF, Robot, Model, or a result with ``.model()``
        (Identification, Calibration). positions : (N, 4, 4) tool poses (m), or a positions file (poses and/or joint
        rows, units declared), read by :func:`denavit.io.positions.read_positions`, or a robot program (KUKA .src with
        its .dat, ABB .mod, FANUC .ls, URScript .script): then a :class:`denavit.io.programs.ProgramCompensation`
        (write it with its ``write(OUT)``: the positions and the configurations it rewrote; ``frames=`` its numbered
        controller frames).
    """
    from .compensation import compensate as _compensate  # noqa: PLC0415

    nominal, identified = (_robot(m) if isinstance(m, (str, os.PathLike)) else m for m in (nominal, identified))
    if isinstance(positions, (str, os.PathLike)):
        from .io.programs import compensate_program, detect, read_program  # noqa: PLC0415

        if detect(input_path(positions)) is not None:  # a robot program: each position on its own configuration
            robot = nominal if hasattr(nominal, "table") else _robot(nominal)
            return compensate_program(
                read_program(input_path(positions), robot, frames=options.pop("frames", None)),
                robot,
                identified,
                **options,
            )
        from .io.positions import read_positions  # noqa: PLC0415

        nominal = (
            nominal
            if isinstance(nominal, _core.Model) or callable(getattr(nominal, "model", None))
            else _robot(nominal)
        )  # (a Robot keeps its coupling)
        nom = nominal if isinstance(nominal, _core.Model) else nominal.model()
        prog = read_positions(input_path(positions), list(nom.kinds))
        poses = prog.poses if prog.poses is not None else _core.fk_batch(nom, prog.q)
        if prog.payload is not None:  # the file's payload columns win over payload=, as calibrate's
            options["payload"] = prog.payload
        return _compensate(nominal, identified, poses, q_nominal=prog.q, **options)
    return _compensate(nominal, identified, positions, **options)


__all__ = [
    "calibrate",
    "compensate",
    "identify",
    "plan",
    "protocol_ranges",
    "read_measurements",
    "read_sweeps",
    "simulate",
]
