"""Results in files: an identification or a calibration saved as a robot file or URDF (:func:`save`), and the JSON
documents of identifications, calibrations and validations (:func:`to_json`, :func:`write_json`), in SI with the unit
in every scalar key's name (docs/cli.md, "--json"). Written whole or not at all (:mod:`denavit.io.output`)."""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import numpy as np

from .. import _core
from ..calibration.result import Calibration
from ..calibration.validate import ModelValidation
from ..errors import DenavitError
from ..fitting import BoundingBox
from ..geometry import matrix_rotvec
from ..identification.frames import TOOL_ORIENTATION
from ..identification.result import _DROPPED_TILT, EXACT, ROUND_OFF, Identification
from .output import json_text, write_text
from .robotfile import TRAINING_TABLE, dumps, training_table


def to_json(result, **options) -> dict:
    """The JSON document of an :class:`~denavit.identification.Identification` (``box``: with its bounding box,
    default True), a :class:`~denavit.calibration.Calibration` or a
    :class:`~denavit.calibration.validate.ModelValidation`.
    """
    if isinstance(result, Identification):
        return _identification_json(result, **options)
    if options:
        raise DenavitError(
            f"to_json: options {sorted(options)} apply to an identification, got a {type(result).__name__}"
        )
    if isinstance(result, Calibration):
        return _calibration_json(result)
    if isinstance(result, ModelValidation):
        return _validation_json(result)
    raise DenavitError(
        f"to_json: expected an Identification, a Calibration or a ModelValidation, got {type(result).__name__}"
    )


def write_json(result, path, *, force: bool = False, **options) -> None:
    """Write :func:`to_json` of ``result`` to ``path`` (whole or not at all; ``force``: replace a read-only file,
    write through one with several hard links, :func:`denavit.io.output.write_text`)."""
    write_text(path, json_text(to_json(result, **options)), force=force)


def save(
    result: Identification | Calibration,
    path,
    convention: str | None = None,
    length: str = "m",
    angle: str = "deg",
    name: str | None = None,
    *,
    force: bool = False,
) -> None:
    """Write an identification's or a calibration's robot as a robot file (.toml; :mod:`denavit.io.robotfile`): the
    :class:`~denavit.robot.Robot` of :func:`saved_robot`. By default the ED-H geometry (an identification's POE when it
    was identified in POE: exact; ED-H exact except a near-parallel pair's tilt within its noise, which it drops
    against the nominal), a lossy DH / MDH table only when ``convention`` asks for one. The file states in a comment
    whether it is exact and the tool-position error its table carries against the identified or calibrated geometry
    (``carried_error``). A calibration's file carries its covariance, compliances and the training poses' joint ranges
    (``[training]``: :func:`denavit.validate` flags poses outside them), as ``calibrate --save`` writes it.

    A path ending in ``.urdf`` gets the URDF of the ED-H geometry instead (frames on the body; a URDF
    nominal's meshes and limits ride along; :func:`denavit.io.urdf.save_urdf`), in SI as URDF requires.

    The file is written whole or not at all, keeping the owner and mode of a file it replaces; ``force``:
    replace a read-only file, write through one with several hard links (:mod:`denavit.io.output`).
    """
    if not isinstance(result, (Identification, Calibration)):
        raise DenavitError(f"save: expected an Identification or a Calibration, got {type(result).__name__}")
    suffix = Path(str(path)).suffix.lower()
    if str(path) != "-" and suffix not in ("", ".toml", ".urdf"):  # a .json name had received TOML without a word
        raise DenavitError(
            f"{path}: expected a robot file name ending in .toml (or .urdf for a URDF), got a {suffix} name"
        )
    if suffix == ".urdf":
        from .urdf import save_urdf  # noqa: PLC0415 (lxml loads for a URDF only)

        if convention is not None and _core.convention_info(convention)["name"] != "edh":
            raise DenavitError(
                f"{path}: a URDF holds the exact geometry (ED-H frames on the body), got convention {convention!r}:"
                f" save a robot file (.toml) for a {convention} table"
            )
        model = result.model(convention="edh") if isinstance(result, Identification) else result.model()
        save_urdf(model, path, result.robot(name, "edh"), force=force)
        return
    robot = saved_robot(result, name, convention, length, angle)
    err, count = result.carried_error(robot.convention)
    what = "calibrated" if isinstance(result, Calibration) else "identified"
    if robot.convention in EXACT and err <= ROUND_OFF:
        how = f"exactly (its {robot.convention} table holds any pair of joint axes)"
    elif robot.convention in EXACT:
        how = f"exactly except {_DROPPED_TILT}; save as poe for the exact geometry"
    else:
        how = (
            f"in a {robot.convention} table, which cannot hold a near-parallel pair's tilt (save as poe for the exact"
            " geometry)"
        )
    note = (
        f"# The {what} geometry, {how}.\n# Carried error: max tool-position deviation {err * 1e3:.3g} mm from the"
        f" {what} geometry over {count} configurations (the home and {count - 1} spread over the joint limits).\n"
    )
    write_text(path, note + dumps(robot, length, angle), force=force)


def saved_robot(result: Identification | Calibration, name=None, convention=None, length="m", angle="deg"):
    """The :class:`~denavit.robot.Robot` :func:`save` writes to a robot file: the result's robot in ``convention``
    (default ED-H; an identification's own exact one), a calibration's with its ``[training]`` joint ranges in the
    file's units ``length`` and ``angle``."""
    if isinstance(result, Identification):
        return result.robot(name, convention)
    robot = result.robot(name, convention or "edh")
    training = training_table(result.measurements.q, result.parametrization.robot.table.kinds, length, angle)
    return replace(robot, extra={**robot.extra, TRAINING_TABLE: training})


def _finite(v: float) -> float | None:
    """``v`` as a float, or None where it is not finite (JSON has no NaN)."""
    return float(v) if np.isfinite(v) else None


def _identification_json(result: Identification, *, box: bool = True) -> dict:
    """The JSON document of a result, in SI with the unit in every scalar key's name (docs/cli.md, "--json").

    Lengths in m (``_m``), angles in rad (``_rad``); the parameter rows are keyed by the convention's columns
    in SI; a joint's ``reading_sigma`` is ``_rad`` for a revolute joint and ``_m`` for a prismatic one.
    ``box``: include the measuring volume (``"bounding_box"``, :attr:`Identification.box`, computed now if it
    was not yet); ``box=False`` leaves it out and does not compute it.
    """
    t = result.table
    names = result.nominal.names if result.nominal else [f"j{i + 1}" for i in range(result.axes.nq)]
    rows = []
    for i, (row, sig) in enumerate(zip(t.params, result.sigma, strict=True)):
        r = {"joint": names[i]}
        for c, v, s in zip(t.columns, row, sig, strict=True):
            r[c] = float(v)
            r[f"{c}_sigma"] = float(s)
        rows.append(r)
    joints = []
    for i, (f, kind) in enumerate(zip(result.fits, result.sweeps.kinds, strict=True)):
        joints.append(
            {
                "joint": names[i],
                "kind": kind,
                "axis": {
                    "point_m": np.asarray(result.axes.points[i]).tolist(),
                    "direction": np.asarray(result.axes.directions[i]).tolist(),
                    "sigma_point_perp_m": f.sigma_point_perp,
                    "sigma_direction_rad": f.sigma_direction,
                },
                "circle": {"centre_m": f.point.tolist(), "normal": f.direction.tolist(), "radius_m": _finite(f.radius)},
                "residuals": {
                    "rms_m": f.rms,
                    "max_m": float(np.max(np.abs(f.residuals))),
                    "n_points": int(f.n_points),
                    "outliers": [int(k) for k in np.flatnonzero(f.outliers)],
                    "per_point_m": np.asarray(f.residuals).tolist(),
                },
                "arc_rad": _finite(f.arc),
                ("reading_sigma_rad" if kind == "revolute" else "reading_sigma_m"): _finite(f.reading_sigma),
                # the joint turns (1 + value) times its reading's motion (fitted by auto where the data shows it)
                "reading_scale": {"value": f.scale - 1, "sigma": f.scale_sigma} if np.isfinite(f.scale_sigma) else None,
            }
        )
    return {
        "units": {"length": "m", "angle": "rad"},
        "frame": "measurement",
        "method": result.method,
        "convention": t.convention,
        "source": result.sweeps.source,
        "home": np.asarray(result.sweeps.home, dtype=float).tolist(),
        "joints": joints,
        "parameters": rows,
        "pairs": [
            {
                "joint": p.joint,
                "relation": p.relation,
                "angle_rad": p.angle,
                "distance_m": p.distance,
                "hayati_beta_rad": p.hayati_beta,
            }
            for p in result.extraction.pairs
        ],
        "tool_point_home_m": np.asarray(result.tool_point).tolist(),
        "tool_frame": _tool_frame_json(result),
        **({"targets_home_m": np.asarray(result.target_points).tolist()} if result.target_points is not None else {}),
        "T_world_base": np.asarray(t.T_world_base).tolist(),
        "T_last_tool": np.asarray(t.T_last_tool).tolist(),
        "max_tool_position_error_m": result.extraction.max_position_error,
        **({"bounding_box": _box_json(result.box)} if box else {}),
        "rms_m": result.rms,
        # the tracker's range/angle noise model the joint fit weighted the points by (null: isotropic point noise)
        "tracker_noise": (
            None
            if (tn := result.tracker_noise) is None
            else {"sigma_range_m": tn.sigma_range, "sigma_angle_rad": tn.sigma_angle, "position_m": list(tn.position)}
        ),
        "compliance": _compliance_json(result),
        "notes": result.notes,
    }


def _compliance_json(result: Identification) -> dict | None:
    """The joints' compliances the joint fit freed (issue 37): a row per joint with its ``unit`` (rad/(N m) revolute,
    m/N prismatic), ``value`` and ``sigma`` (null where not fitted), ``held`` (fitted negative, held at its bound 0;
    its sigma still the data's), the covariance over every joint (SI), the gravity torques at home (SI: N m); null for a
    rigid fit."""
    c = result.compliance
    if c is None:
        return None
    kinds = result.sweeps.kinds
    names = result.nominal.names if result.nominal is not None else [f"j{j + 1}" for j in range(len(c["k"]))]
    return {
        "joints": [
            {
                "joint": names[j],
                "unit": "rad/(N m)" if kinds[j] == "revolute" else "m/N",
                "value": float(c["k"][j]),
                "sigma": _finite(c["sigma"][j]),
                "held": bool(c["held"][j]),
            }
            for j in range(len(c["k"]))
        ],
        "covariance_si": [[_finite(v) for v in row] for row in np.asarray(c["cov"], dtype=float)],
        "torque_home_si": [float(v) for v in c["torque_home"]],
    }


def _tool_frame_json(result: Identification) -> dict:
    """The tool frame's orientation at home: where it came from, R_world_tool, its roll-pitch-yaw (rad) and its
    covariance (a small rotation in world, rad^2; null when it is the nominal's)."""
    from ..geometry import matrix_rpy  # noqa: PLC0415

    R = np.asarray(result.axes.T_world_tool)[:3, :3]
    c = result.tool_rotation_cov
    turn = None
    if result.nominal is not None:  # the angle from the nominal's flange orientation at home
        R_nom = _core.fk(result.nominal.model().with_tool(np.eye(4)), result.sweeps.home)[:3, :3]
        turn = float(np.linalg.norm(matrix_rotvec(R @ R_nom.T)))
    return {
        "orientation_from": result.tool_orientation,
        "how": TOOL_ORIENTATION[result.tool_orientation],
        "R_world_tool": R.tolist(),
        "rpy_rad": np.asarray(matrix_rpy(R)).tolist(),
        "sigma_rad": result.tool_rotation_sigma if c is not None else None,
        "cov_rad2": c.tolist() if c is not None else None,
        "angle_from_nominal_flange_rad": turn,
    }


def _box_json(b: BoundingBox) -> dict:
    return {
        "lengths_m": b.lengths.tolist(),
        "volume_m3": b.volume,
        "centre_m": b.center.tolist(),
        "orientation": b.axes.tolist(),
    }


def _json_unit(unit: str) -> str:
    """A calibration parameter's unit as its JSON row names it: m, rad, 1, or a compliance's own."""
    return {"length": "m", "angle": "rad", "ratio": "1"}.get(unit, unit)


def _calibration_json(cal: Calibration) -> dict:
    """The JSON document of a calibration, in SI with the unit in every scalar key's name (docs/cli.md,
    "--json"); a parameter row's ``unit`` (m, rad or 1) is that of its ``nominal``, ``value`` and ``sigma``."""
    pz = cal.parametrization
    rows = []
    for c, nm in enumerate(cal.names):
        rows.append(
            {
                "name": nm,
                "unit": _json_unit(pz.units[c]),
                "nominal": float(cal.nominal[c]),
                "value": float(cal.values[c]),
                "sigma": None if not np.isfinite(cal.sigma[c]) else float(cal.sigma[c]),
                "status": cal.status[c],
                "prior_sigma": (
                    None
                    if cal.prior_sigma is None or not np.isfinite(cal.prior_sigma[c])
                    else float(cal.prior_sigma[c])
                ),
            }
        )
    ana = cal.identifiability
    m = cal.model()
    v = cal.validation
    return {
        "units": {"length": "m", "angle": "rad"},
        "frame": "measurement",
        "source": cal.measurements.source,
        "nominal": pz.robot.name,
        "convention": cal.convention,
        "measure": pz.measure,
        "n_poses": cal.measurements.n,
        "loss": cal.loss,
        "parameters": rows,
        "identifiability": {
            "rank": ana.rank,
            "candidates": ana.candidates,
            "base_parameters": ana.base_parameters,
            "condition_number": ana.condition_number,
            "observability": ana.observability,
            "unidentifiable": [
                {
                    "name": u.name,
                    "structural": u.structural,
                    "reason": u.reason,
                    "combination": u.combination,
                    # the sigma the data would give it (beyond the plausible size of its error), in its row's unit
                    "unit": _json_unit(pz.units[pz.index(u.name)]),
                    "sigma": u.sigma,
                }
                for u in ana.unidentifiable
            ],
        },
        "covariance": {"names": cal.free_names, "matrix_si": _finite_or_none(cal.covariance)},
        "correlation": _finite_or_none(cal.correlation),
        "residuals": {
            "rms_m": cal.rms,
            "max_m": float(np.max(np.linalg.norm(cal.residuals[:, :3], axis=1))) if cal.residuals.size else 0.0,
            "rms_rotation_rad": None if math.isnan(cal.rms_rotation) else cal.rms_rotation,
            "noise_estimate_m": cal.noise,
            "outliers": [cal.measurements.where[i] for i in cal.outliers],
        },
        "model_choice": None if cal.model_choice is None else cal.model_choice.to_json(),
        "validation": (
            None
            if v is None
            else {
                "n_train": v.n_train,
                "n_test": v.n_test,
                "before_rms_m": v.before_rms,
                "before_max_m": v.before_max,
                "after_rms_m": v.after_rms,
                "after_max_m": v.after_max,
            }
        ),
        "model": {
            "T_world_base": np.asarray(m.T_world_base).tolist(),
            "T_last_flange": np.asarray(m.T_last_flange).tolist(),
            "T_flange_tool": np.asarray(m.T_flange_tool).tolist(),
            "placements": np.asarray(m.placements).tolist(),
            "offsets": np.asarray(m.offsets, dtype=float).tolist(),
        },
        "converged": cal.converged,
        "evaluations": cal.evaluations,
        "elapsed_s": cal.elapsed,
        "notes": cal.notes,
    }


def _finite_or_none(a: np.ndarray) -> list:
    """A nested list with non-finite entries as None (JSON has no NaN)."""
    return [[float(v) if math.isfinite(v) else None for v in row] for row in np.asarray(a, dtype=float)]


def _validation_json(v: ModelValidation) -> dict:
    """The JSON document of a validation (SI, docs/cli.md "validate")."""
    per = []
    for i in range(v.n):
        per.append(
            {
                "where": v.where[i],
                "q": v.q[i].tolist(),
                "error_m": float(v.errors[i]),
                "error_xyz_m": v.error_vectors[i].tolist(),
                **({"rotation_error_rad": float(v.rotation_errors[i])} if v.rotation_errors is not None else {}),
                "sigma_predicted_m": None if v.sigma is None else float(v.sigma[i]),
                "flags": list(v.flags[i]),
                "outside_joints": [v.joint_names[j] for j in v.outside[i]],
            }
        )
    iso = None
    if v.groups:
        iso = {
            "n_poses": len(v.groups),
            "ap_max_m": max(g.ap for g in v.groups),
            "rp_max_m": max(g.rp for g in v.groups),
            "poses": [
                {
                    "n_poses": g.n,
                    "where": [v.where[i] for i in g.indices],
                    "ap_m": g.ap,
                    "rp_m": g.rp,
                    "barycentre_m": g.barycentre.tolist(),
                    "commanded_m": g.commanded.tolist(),
                }
                for g in v.groups
            ],
        }
    return {
        "units": {"length": "m", "angle": "rad"},
        "model": v.model_name,
        "source": v.source,
        "measure": v.measure,
        "registration": v.registration,
        "n_poses": v.n,
        "rms_m": v.rms,
        "max_m": v.max,
        "percentiles_m": {f"p{p}_m": e for p, e in v.percentiles.items()},
        "rms_rotation_rad": v.rms_rotation,
        "flagged": v.n_flagged,
        "sigma_limit_m": v.sigma_limit,
        "training_range": (
            None
            if v.training_lower is None
            else {"lower": v.training_lower.tolist(), "upper": v.training_upper.tolist()}
        ),
        "T_world_base": v.T_world_base.tolist(),
        "T_flange_tool": v.T_flange_tool.tolist(),
        "iso9283": iso,
        "per_pose": per,
        "notes": list(v.notes),
    }
