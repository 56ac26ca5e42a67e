"""The identification itself (:func:`identify`): the steps of the other modules in order."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import replace

import numpy as np

from .. import _core
from ..errors import DegenerateError, DenavitError
from ..fitting.checks import check_loss, check_positive, check_sweep_labels, misfit_notes, nominal_plausibility
from ..fitting.joint import TrackerNoise, as_tracker_noise, start_homes
from ..message import Length, Message
from ..progress import Stage
from ..robot import Robot
from ..sweeps import SweepSet
from .choice import _choose
from .frames import (
    PARALLEL_TOL,
    SHORT_ARC_SIGMA,
    _axes_from,
    _edh_parallel_tol,
    _oriented_by_nominal,
    _parameter_cov,
    _short_arc_notes,
    _tool_frame,
    nominal_convention_table,
    origins,
)
from .prepare import (
    PER_SWEEP_SHARE,
    _drop_dwell,
    _locked_notes,
    _per_sweep,
    _tool_point_geometric,
    decoupled,
    sweep_where,
)
from .result import _DROPPED_TILT, METHODS, ROUND_OFF, Identification


def identify(
    sweeps: SweepSet,
    *,
    method: str = "auto",
    convention: str = "dh",
    nominal: Robot | None = None,
    T_world_base=None,
    loss: str = "soft_l1",
    parallel_tol: float = PARALLEL_TOL,
    intersect_tol: float | None = None,
    max_sigma: float | None = None,
    keep_dwell: bool = False,
    coupling=None,
    rotation_noise: float | None = None,
    tracker_noise: TrackerNoise | tuple | None = None,
    allow_implausible: bool = False,
    compliance=None,
    payload=None,
    progress: Callable[[str], None] | None = None,
) -> Identification:
    """Identify the joint axes and the parameter table of ``convention`` from ``sweeps``.

    method : "auto" (chosen by the evidence, with a note saying which and why: without readings "geometric";
        with readings the joint fit with one home point ("global") or one per sweep ("readings": the home drifted,
        the drift added to the sigmas), the readings' scale errors (one population) and the joints' compliances each
        only where it pays for itself with the others chosen (:func:`~denavit.identification.choice._select`), or the
        "geometric" circles when the readings are worth nothing against the points), "kasa" (the paper's eq. 1-9),
        "hyper" (Al-Sharadqah & Chernov 2009), "geometric" (orthogonal distance), "readings" (per sweep, points as
        rotations of one rigid point by the recorded angles), "global".
    nominal : a robot of any convention; breaks sign ties, fixes free origins and the last frame
        (docs/conventions.md), gives names and limits.
    T_world_base : (4, 4) base frame in the measurement frame (default: the measurement frame itself). When
        given, the nominal stands on it (its base frame is the robot base); otherwise the nominal's world is
        taken as the measurement frame.
    loss : "soft_l1" (default), "huber" or "linear": per-point robust loss of the geometric, readings and global
        fits (its scale 3 robust sigmas of the misfits); outlying points are flagged in each fit's ``outliers``, never
        dropped. The robust default is free on clean data (the axes and sigmas of 0.02 mm Gaussian noise are those of
        "linear" within a few percent) and keeps one blunder from moving an axis (a 5 mm blunder moved one by 0.74
        mm with "linear"; issue 16).
    max_sigma : float, metres, optional
        The accuracy asked for: a sweep whose predicted axis-position uncertainty (1 sigma, across the axis)
        exceeds it is an error that names the sweep and the predicted value (e.g. an arc too short).
    keep_dwell : keep the dwell rows in the fits. By default the rows where the motion stands still (within the
        point noise) at the ends of a sweep are left out of the fits (they would weigh one end of the arc many
        times over), with a note naming them; the result's ``sweeps`` are the rows fitted.
    coupling : (n, n), optional
        Joint values from the controller's readings, ``q = coupling @ reading`` (default: the nominal's
        ``coupling``, from its robot file's ``[couplings]``; else the readings are the joint values).
    rotation_noise : float, rad, optional
        6-DoF poses: the orientation noise (1 sigma per component of the rotation vector) that weights the
        orientation residuals against the points; default estimated from the data (a variance component).
    tracker_noise : :class:`~denavit.fitting.joint.TrackerNoise` or (sigma_range m, sigma_angle rad[, position (3,)
        m]), optional
        The tracker's range/angle noise model: each point's noise is sigma_range along the line of sight from the
        tracker (at ``position`` in the data's frame, default the origin: a tracker's own frame) and sigma_angle
        times the range across it; the joint fit weights every point by the inverse of that covariance, whose
        overall scale stays estimated from the data (its shape only is declared). Default: isotropic point noise.
        The geometric circles weight their points by it too; the other per-sweep methods (kasa, hyper: algebraic;
        readings) take the points as isotropic (with a note).

    Several targets per pose (:attr:`~denavit.sweeps.Sweep.targets`, 2-4 SMRs on a nest) and 6-DoF poses
    (:attr:`~denavit.sweeps.Sweep.rotations`) are one joint fit with shared axes (methods "global", "readings",
    and "auto" with readings; :func:`~denavit.fitting.joint.fit_sweeps`), and the tool frame's orientation is then
    identified with its covariance (:attr:`Identification.tool_orientation`, :data:`TOOL_ORIENTATION`). The
    per-sweep methods fit the first target alone.
    allow_implausible : keep a fit that is implausible against the nominal (the axes its mirror image, matching it
        with two joints exchanged, or most pairs of axes far from its: a unit slip, the wrong robot), with a note;
        by default it is an error (issue 16: such fits had come back with small sigmas and no word).
    compliance, payload : the joints' compliance under gravity in the joint fit (issue 37; :func:`_elastic`).
    progress : called with a short message as each stage starts, a :class:`denavit.progress.Stage` (a ``str``) whose
        ``fraction`` is the share of the work done before it (the CLI shows a bar with the percentage and time left).
    """
    progress = progress or (lambda _stage: None)
    nominal, convention, tracker = _checked(sweeps, method, nominal, loss, max_sigma, convention, tracker_noise)
    coupling = coupling if coupling is not None else (nominal.coupling if nominal is not None else None)
    if coupling is not None:
        sweeps = decoupled(sweeps, coupling)
    check_sweep_labels(sweeps, [sweep_where(x, sweeps.source) for x in sweeps.sweeps])
    notes = _locked_notes(sweeps)
    if not keep_dwell:
        sweeps = _drop_dwell(sweeps, notes)
    method, fits, cov, p_home, rms, joint, scales = _fit_axes(
        sweeps, method, loss, max_sigma, rotation_noise, tracker, notes, progress, (nominal, compliance, payload)
    )
    _noise_model_notes(sweeps, method, joint, tracker, notes)
    elastic = _compliance_of(joint, sweeps, nominal, T_world_base, notes)
    base = np.eye(4) if T_world_base is None else np.asarray(T_world_base, dtype=float)
    if T_world_base is not None and nominal is not None:  # the nominal's base frame is the robot base given
        nominal = _standing_at(nominal, base)
    nominal_table = nominal_convention_table(nominal, convention, sweeps.home)
    orientation, rot_cov, cov_full, target_points = _tool_orientation(sweeps, joint, nominal, cov, notes)
    if nominal is not None and not sweeps.has_readings:
        fits = _oriented_by_nominal(sweeps, fits, nominal, notes)
    x = np.concatenate([np.concatenate([f.point, f.direction]) for f in fits] + [p_home])
    tol = _edh_parallel_tol(fits, nominal, sweeps.home, parallel_tol) if convention == "edh" else parallel_tol
    lower, upper = (nominal.lower, nominal.upper) if nominal is not None else (None, None)
    ax = _axes_from(x, sweeps, orientation[1], base, lower, upper, _link_home(sweeps, elastic))
    opts = dict(parallel_tol=tol, nominal=nominal_table, origins=origins(nominal_table, convention, sweeps.home, ax))
    if intersect_tol is not None:
        opts["intersect_tol"] = intersect_tol
    ex = _core.extract(ax, convention, **opts)
    short = _short_arc_notes(sweeps, fits, notes)
    _misfit_notes(sweeps, fits, joint, notes)
    if nominal is not None:
        nominal_plausibility(
            ex,
            fits,
            nominal,
            sweeps.home,
            nominal.names,
            sweeps.source,
            notes,
            short,
            SHORT_ARC_SIGMA,
            allow_implausible,
            lone_axis=not sweeps.has_readings,
        )
    p_ref = ex.table.params
    full_cov, cov_all = _with_scales(cov, cov_full, scales)
    progress(Stage(f"{convention} parameters and their sigmas", 0.9))
    param_cov = _parameter_cov(x, cov_all, ax, sweeps, convention, opts, p_ref, n_rot=len(cov_full) - len(cov))
    sigma = np.sqrt(np.clip(np.diag(param_cov), 0, None))[: p_ref.size].reshape(p_ref.shape)
    _parallel_notes(ex, convention, notes)
    result = Identification(
        method,
        convention,
        ax,
        fits,
        ex,
        sigma,
        cov,
        p_home,
        sweeps,
        nominal,
        nominal_table,
        rms,
        notes,
        param_cov,
        reading_scale=None if scales is None else scales[0],
        axis_scale_cov=full_cov,
        coupling=coupling,
        tool_orientation=orientation[0],
        tool_rotation_cov=rot_cov,
        target_points=target_points,
        tracker_noise=tracker if joint is not None or method == "geometric" else None,
        compliance=elastic,
    )
    _carried_note(result, convention, notes)
    return result


def _standing_at(robot: Robot, base: np.ndarray) -> Robot:
    """``robot`` with its base at ``base`` (T_world_base)."""
    t = robot.table
    return replace(robot, table=_core.Table(t.convention, t.params, t.kinds, base, t.T_last_tool))


def _checked(sweeps, method: str, nominal, loss: str, max_sigma, convention: str, tracker_noise):
    """identify's arguments checked (a one-line error on bad input): (the nominal as a Robot or None, the
    convention's name, the tracker noise model or None)."""
    if not isinstance(sweeps, SweepSet):
        raise DenavitError(
            f"identify: expected a SweepSet, got {type(sweeps).__name__}: denavit.identify(path, nominal=...) reads "
            "files and names"
        )
    if nominal is not None and not isinstance(nominal, Robot):
        from ..robot import robot_of  # noqa: PLC0415

        nominal = robot_of(nominal)  # a Model, as calibrate takes
    if method not in METHODS:
        raise DenavitError(f"unknown method {method!r}: expected one of {', '.join(METHODS)}")
    check_loss(loss, None, "identify")
    check_positive("max_sigma", max_sigma, "identify")
    convention = _core.convention_info(convention)["name"]
    tracker = as_tracker_noise(tracker_noise)
    n = sweeps.n_joints
    if nominal is not None and len(nominal.names) != n:
        raise DenavitError(f"nominal model {nominal.name} has {len(nominal.names)} joints, the data has {n}")
    return nominal, convention, tracker


def _elastic(sweeps: SweepSet, nominal, compliance, payload, notes: list[str]):
    """(the sweeps with ``payload`` on every sweep without its own, the nominal's model whose inertials give the gravity
    torques when the joints' compliance is considered, else None), with the one-line note why not where it was asked.

    ``compliance``: None (considered when the sweeps carry a payload, or ``payload`` is given), True (considered),
    False. One ``k_i`` per joint whose gravity torque changes in the data, in the joint fit: fitted with "global",
    chosen by the evidence with "auto" (:func:`~denavit.identification.choice._select`). It needs the nominal's
    link inertials. The axes are then those of the arm at home under its own weight (no payload); the result's
    ``compliance`` (:func:`_compliance_of`) holds the compliances and the torques at home. ``payload``: a mass in kg at
    the flange, ``(kg, (x, y, z) m)`` or (4,) ``[kg, m, m, m]`` (:func:`denavit.calibration.compliance.as_payload`)."""
    from ..calibration.compliance import as_payload  # noqa: PLC0415

    if compliance not in (None, True, False):
        raise DenavitError(f"identify: compliance: expected None, True or False, got {compliance!r}")
    if payload is not None:
        sweeps = replace(
            sweeps,
            sweeps=[
                s if s.payload is not None else replace(s, payload=as_payload(payload, len(s.points)))
                for s in sweeps.sweeps
            ],
        )
    asked = compliance is True or (compliance is None and any(s.payload is not None for s in sweeps.sweeps))
    if not asked:
        return sweeps, None
    if nominal is None or nominal.inertials is None or not np.any(np.asarray(nominal.inertials["masses"]) > 0):
        name = "no nominal robot" if nominal is None else f"{nominal.name} carries no link masses"
        notes.append(
            f"joint compliance not modelled: {name} ([joints.inertia] in a robot file, <inertial> in a URDF) to give "
            "the gravity torques the joints twist under"
        )
        return sweeps, None
    if not sweeps.has_readings:
        notes.append("joint compliance not modelled: it needs the joint fit, and the sweeps carry no joint readings")
        return sweeps, None
    return sweeps, nominal.model()


def _compliance_of(joint, sweeps: SweepSet, nominal, T_world_base, notes: list[str]) -> dict | None:
    """The identified compliances (the joint fit's, where it fitted them): ``k`` (n,) rad/(N m) (m/N prismatic; 0
    where not fitted; >= 0), ``sigma`` (n,) (nan where not fitted), ``cov`` (n, n), ``cross`` (6n+3+n, n) their
    covariance with [c_1, n_1, ..., tool point, reading scales] (the joint fit's: zero rows for scales not fitted; the
    tool rotation's not carried), ``held`` (n,) those fitted negative
    and held at the bound 0 (with their sigmas: :meth:`~denavit.fitting.elastic._Compliances.bound_compliances`),
    ``torque_home`` (n,) N m the gravity torques at home without a payload (the axes fitted are the arm's under them:
    joint i's link sits at ``q_i - k_i (tau_i(q, payload) - torque_home_i)`` about them); None when not fitted. A note
    for each compliance held at 0, saying how far below it the fit had put it (beyond 2 sigma: the data or the torque
    model are off), and one when ``T_world_base`` turns the base from the nominal's vertical (:func:`_tilt_note`)."""
    if joint is None or not np.any(np.isfinite(joint["compliance_sigma"])):
        return None
    k, sigma = np.array(joint["compliance"], dtype=float), joint["compliance_sigma"]
    held = np.asarray(joint["compliance_held"], dtype=bool)
    names = nominal.names if nominal is not None else [f"j{j + 1}" for j in range(len(k))]
    from ..calibration.compliance import compliance_units, held_note  # noqa: PLC0415

    units = compliance_units(sweeps.kinds)
    for j in np.flatnonzero(held):
        notes.append(held_note(f"joint {j + 1} ({names[j]})", units[j], joint["compliance_negative"][j], sigma[j]))
    if T_world_base is not None:
        _tilt_note(nominal, np.asarray(T_world_base, dtype=float), notes)
    n6, X = 6 * len(k), np.asarray(joint["compliance_cross"], dtype=float)
    H = (len(X) - n6 - len(k)) // 3  # (its home points averaged, as in the axes' covariance; the scales' rows last)
    cross = np.vstack([X[:n6], X[n6 : n6 + 3 * H].reshape(H, 3, -1).mean(axis=0), X[n6 + 3 * H :]])
    return {
        "k": k,
        "sigma": sigma,
        "cov": joint["compliance_cov"],
        "cross": cross,
        "held": held,
        "torque_home": joint["torque_home"],
    }


#: The angle (rad) between the measurement frame's z and the robot base's vertical above which the saved robot's
#: gravity (-z of its world, docs/cli.md "Joint compliance, payload and gravity") gets a note: 0.1 deg (its torques
#: then off by 0.17 % of their size across the tilt).
TILT_NOTE = math.radians(0.1)


def _tilt_note(nominal, T_world_base: np.ndarray, notes: list[str]) -> None:
    """A note when the measurement frame is not level: the joint fit's gravity torques are the nominal's (gravity along
    -z of its world, the robot base's vertical), but the saved robot stands on ``T_world_base`` in the measurement
    frame and its torques take gravity along that frame's -z."""
    up = np.asarray(nominal.table.T_world_base, dtype=float)[2, :3]  # the nominal world's z in its base frame
    saved = T_world_base[2, :3]  # the measurement frame's z in the base frame
    tilt = math.acos(min(max(float(up @ saved), -1.0), 1.0))
    if tilt > TILT_NOTE:
        notes.append(
            f"the measurement frame's z is {math.degrees(tilt):.3g} deg from the robot base's vertical (--base): the "
            "compliances were fitted with gravity down the base's vertical, but the saved robot's torques take it "
            "along -z of its world, the measurement frame (compensate, validate at a payload): level the tracker"
        )


def _misfit_notes(sweeps: SweepSet, fits: list, joint, notes: list[str]) -> None:
    """The circle check's notes (:func:`~denavit.fitting.checks.misfit_notes`), on the points less the deflection the
    joint fit's compliances model where it fitted them."""
    wheres = [sweep_where(s, sweeps.source) for s in sweeps.sweeps]
    misfit_notes(sweeps, fits, wheres, notes, None if joint is None else joint.get("deflection"))


def _link_home(sweeps: SweepSet, elastic: dict | None) -> np.ndarray:
    """The links' joint values at the readings' home: the home itself for rigid joints; with compliances the home
    less each joint's deflection under the arm's own weight there, ``q_home - k tau(q_home)``, so that the table's
    offsets are those of the undeflected arm and its model plus the compliances predicts as calibrate's does
    (:class:`denavit.calibration.compliance.Elastic`: the link at ``q - k tau(q, payload)``)."""
    home = np.asarray(sweeps.home, dtype=float)
    return home if elastic is None else home - elastic["k"] * elastic["torque_home"]


def _fit_axes(sweeps: SweepSet, method: str, loss: str, max_sigma, rotation_noise, tracker, notes, progress, elastic):
    """The axes: the per-sweep fits, and with readings the joint fit (auto's choice, :func:`_choose`; ``elastic`` (the
    nominal, compliance, payload): the joints' compliance, :func:`_elastic`). Returns (method, fits, cov of [c_1, n_1,
    ..., p], the tool point at home, rms, the joint fit's result or None, scales)."""
    sweeps, torque_model = _elastic(sweeps, *elastic, notes)
    n = sweeps.n_joints
    chosen = method
    if method == "auto":
        method = "global" if sweeps.has_readings else "geometric"
        if method == "geometric":
            notes.append("auto: geometric (per-sweep circles): the data has no joint readings")
    fits = _per_sweep(sweeps, method, loss, max_sigma if method != "global" else None, progress, tracker)
    homes0, R0 = start_homes(sweeps, [(f.point, f.direction) for f in fits]) if sweeps.has_readings else (None, None)
    p_home = homes0[0] if sweeps.has_readings else _tool_point_geometric(sweeps, fits)
    cov, joint, scales = None, None, None
    if method == "global":
        what = f"{sweeps.n_targets} targets per pose" if sweeps.n_targets > 1 else "shared tool point"
        poses = ", 6-DoF poses" if sweeps.has_rotations else ""
        progress(Stage(f"one fit of all {len(sweeps.sweeps)} sweeps ({what}{poses})", PER_SWEEP_SHARE))
        method, gfits, gcov, gp, grms, joint, scales = _choose(
            sweeps, fits, homes0, R0, loss, notes, chosen, rotation_noise, tracker, torque_model
        )
        if gfits is None:  # the readings are worthless: the per-sweep geometric circles
            fits = _per_sweep(sweeps, method, loss, max_sigma, progress, tracker)
            p_home = _tool_point_geometric(sweeps, fits)
        else:
            fits, cov, p_home, rms = gfits, gcov, gp, grms
            for s, f in zip(sweeps.sweeps, fits, strict=True):
                if max_sigma is not None and f.sigma_point_perp > max_sigma:
                    raise DegenerateError(
                        f"{sweep_where(s, sweeps.source)}: predicted axis-position uncertainty "
                        f"{f.sigma_point_perp * 1e3:.3g} mm (1 sigma) exceeds the requested {max_sigma * 1e3:.3g} mm; "
                        f"the sweep covers {np.degrees(f.arc):.1f} deg: sweep a longer arc or measure more points"
                    )
    if cov is None:
        cov = np.zeros((6 * n + 3, 6 * n + 3))
        for j, f in enumerate(fits):
            cov[6 * j : 6 * j + 6, 6 * j : 6 * j + 6] = f.cov
        # the tool point: the spread of its per-point estimates
        cov[6 * n :, 6 * n :] = (
            np.eye(3) * float(np.mean([f.rms for f in fits])) ** 2 / max(sum(f.n_points for f in fits), 1)
        )
        rms = float(math.sqrt(np.mean([f.rms**2 for f in fits])))
    return method, fits, cov, p_home, rms, joint, scales


def _noise_model_notes(sweeps: SweepSet, method: str, joint, tracker, notes: list[str]) -> None:
    """Notes on what weights the points (the tracker's noise model) and on the targets and poses a per-sweep fit
    leaves out."""
    if tracker is not None:
        model = (
            f"the tracker's noise model (range {tracker.sigma_range * 1e6:.3g} um, angles "
            f"{math.degrees(tracker.sigma_angle) * 3600:.3g} arcsec, tracker at "
            f"{', '.join(f'{v:.4g}' for v in tracker.position)} m)"
        )
        if joint is not None:
            notes.append(
                Message(
                    "{model} weights the points (its shape; the scale from the data): point noise {sigma:.3g} RMS per"
                    " coordinate, {times:.3g} times the declared",
                    model=model,
                    sigma=Length(joint["sigma"]),
                    times=joint["sigma"] / math.sqrt(joint["tracker_ref2"]),
                )
            )
        elif method == "geometric":
            notes.append(f"{model} weights each circle's points (its shape; the scale from the data)")
        else:
            notes.append(
                f"{model} is used by the joint fit (method global or auto, with readings) and the geometric circles; "
                f"the {method} fit takes the points as isotropic"
            )
    if joint is None and (sweeps.n_targets > 1 or sweeps.has_rotations):
        notes.append(
            f"the {method} fit uses the first target's points alone: {sweeps.n_targets} targets per pose"
            f"{' and 6-DoF poses' if sweeps.has_rotations else ''} are one fit with shared axes in the joint fit "
            "(method global or auto, with readings)"
        )


def _tool_orientation(sweeps: SweepSet, joint, nominal, cov: np.ndarray, notes: list[str]):
    """The tool frame at home and, from the joint fit, the tool rotation's covariance. Returns ((the tool
    orientation, its rotation tool_R), the rotation's covariance or None, the covariance of [axes, tool point (, tool
    rotation)], the targets' home points or None)."""
    n = sweeps.n_joints
    if nominal is not None:  # the nominal flange orientation at home
        tool_R = _core.fk(nominal.model().with_tool(np.eye(4)), sweeps.home)[:3, :3]
    else:
        tool_R = np.eye(3)
    tool_R, orientation, G_rot = _tool_frame(sweeps, joint, tool_R, notes)
    rot_cov, target_points = None, None
    if joint is not None and sweeps.n_targets > 1:
        ph = joint["home"].mean(axis=0)
        target_points = np.vstack([ph, ph + joint["offsets"]])
    full = cov
    if G_rot is not None:
        # the covariance of [axes, tool point, tool rotation]: the chosen cov, and the rotation's from the joint fit
        ca = joint["cov_all"]
        n6, H = 6 * n, joint["n_homes"]
        Gf = np.zeros((n6 + 6, ca.shape[0]))
        Gf[:n6, :n6] = np.eye(n6)
        for k in range(H):
            Gf[n6 : n6 + 3, n6 + 3 * k : n6 + 3 * k + 3] = np.eye(3) / H
        Gf[n6 + 3 :] = G_rot
        full = Gf @ ca @ Gf.T
        full[: n6 + 3, : n6 + 3] = cov
        rot_cov = full[n6 + 3 :, n6 + 3 :]
    return (orientation, tool_R), rot_cov, full, target_points


def _with_scales(cov: np.ndarray, cov_full: np.ndarray, scales):
    """(the covariance of [axes, tool point, reading scales] or None, that of [axes, tool point (, tool rotation)
    (, reading scales)]): the scales' covariance with the axes kept; the tool rotation's with the scales is not
    carried (the scales come from the same fit; their cross terms with the rotation are dropped)."""
    if scales is None:
        return None, cov_full
    full_cov = np.block([[cov, scales[1]], [scales[1].T, scales[2]]])
    n_r = len(cov_full) - len(cov)
    cross = np.vstack([scales[1], np.zeros((n_r, scales[1].shape[1]))])
    return full_cov, np.block([[cov_full, cross], [cross.T, scales[2]]])


def _parallel_notes(ex, convention: str, notes: list[str]) -> None:
    """A note per pair of axes taken as parallel whose misalignment DH and MDH cannot represent."""
    for pd in ex.pairs:
        if pd.relation == "parallel" and abs(pd.hayati_beta) > 0 and convention in ("dh", "mdh"):
            notes.append(
                f"axes {pd.joint}-{pd.joint + 1} treated as parallel: misalignment {math.degrees(pd.hayati_beta):.2e} "
                f"deg (Hayati beta) is not representable in {convention}"
            )


def _carried_note(result: Identification, convention: str, notes: list[str]) -> None:
    """What the table carries, measured as --save states it (Identification.carried_error): a note when the
    convention's table carries a tool-position error."""
    if convention not in ("dh", "mdh", "edh"):
        return
    carried = result.carried_error()[0] if convention == "edh" else result.carried_error(convention)[0]
    if carried > 1e-6:
        edh = carried if convention == "edh" else result.carried_error("edh")[0]
        if convention != "edh":
            exact = "POE is exact; " + (
                "ED-H carries {edh:.4g}: it is exact except " + _DROPPED_TILT if edh > ROUND_OFF else "ED-H is exact"
            )
        else:
            exact = f"it is exact except {_DROPPED_TILT}; POE is exact"
        notes.append(
            Message(
                "the {convention} table carries a tool-position error up to {carried:.4g} (" + exact + ")",
                convention=convention,
                carried=Length(carried),
                edh=Length(edh),
            )
        )
