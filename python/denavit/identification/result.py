"""The result of an identification (:class:`Identification`) and its JSON document (:func:`to_json`, :func:`write_json`)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path

import numpy as np

from .. import _core
from ..errors import DenavitError
from ..fitting import AxisFit, BoundingBox, oriented_bounding_box
from ..fitting.joint import TrackerNoise
from ..geometry import matrix_rotvec
from ..io.output import json_text, write_text
from ..robot import Robot
from ..sweeps import SweepSet
from .frames import (
    EDH_PARALLEL_SIGMAS,
    PARALLEL_TOL,
    TOOL_ORIENTATION,
    _edh_parallel_tol,
    _parameter_cov,
    nominal_convention_table,
    origins,
)

METHODS = ("auto", "kasa", "hyper", "geometric", "readings", "global")
#: The conventions whose tables hold any pair of joint axes exactly (docs/conventions.md): what :meth:`Identification.save` writes by default.
#: Against a nominal, ED-H drops the tilt of a pair the nominal has parallel when it is within ``EDH_PARALLEL_SIGMAS``
#: of zero (its carried error says how much); POE is exact always.
EXACT = ("edh", "poe")
#: A carried tool-position error (m) at most this is round-off: the table is the identified geometry.
ROUND_OFF = 1e-9


@dataclass(frozen=True)
class Identification:
    """The result of :func:`identify` (SI inside; measurement frame = ``world``)."""

    method: str
    convention: str
    axes: _core.JointAxes
    fits: list[AxisFit]  # per joint: the per-sweep fit, or the global fit's view of it
    extraction: _core.Extraction
    sigma: np.ndarray  # (n, k) one-sigma of every table parameter
    axis_cov: np.ndarray  # (6n+3, 6n+3) covariance of [c1, n1, ..., cn, nn, tool point at home]
    tool_point: np.ndarray  # (3,) tool point at home in world (m)
    sweeps: SweepSet
    nominal: Robot | None = None
    nominal_table: _core.Table | None = None
    rms: float = 0.0
    notes: list[str] = field(default_factory=list)
    param_cov: np.ndarray | None = (
        None  # (n k + 3 [+ n],) covariance of the table's parameters (row-major), the tool translation (, the reading scales)
    )
    reading_scale: np.ndarray | None = (
        None  # (n,) the readings' scale errors when auto fitted them (0 where not fitted), about the home
    )
    axis_scale_cov: np.ndarray | None = (
        None  # (6n+3+n,) covariance of [c1, n1, ..., tool point, reading scales] when they were fitted
    )
    coupling: np.ndarray | None = (
        None  # (n, n) joint values from the readings (q = coupling @ reading) the sweeps were decoupled with
    )
    tool_orientation: str = "nominal"  # where the tool frame's orientation came from: "nominal", "poses", "nest" or "targets" (TOOL_ORIENTATION)
    tool_rotation_cov: np.ndarray | None = (
        None  # (3, 3) rad^2: covariance of the tool frame's orientation at home (a small rotation in world), None if from the nominal
    )
    target_points: np.ndarray | None = None  # (k, 3) m: each target's point at home in world (several targets per pose)
    tracker_noise: TrackerNoise | None = (
        None  # the tracker's range/angle noise model the joint fit weighted the points by (None: isotropic)
    )

    @property
    def tool_rotation_sigma(self) -> float:
        """RMS (1-sigma) angle of the tool frame's orientation error at home (rad), ``sqrt(trace(tool_rotation_cov))``;
        nan when the orientation is the nominal's (not identified)."""
        return (
            math.nan if self.tool_rotation_cov is None else float(math.sqrt(max(np.trace(self.tool_rotation_cov), 0.0)))
        )

    def __repr__(self) -> str:
        n_pts = sum(len(s.points) for s in self.sweeps.sweeps)
        name = self.nominal.name if self.nominal else "no nominal"
        err = self.extraction.max_position_error
        return (
            f"Identification({self.convention}, method {self.method}, {self.axes.nq} joints, {n_pts} points of {self.sweeps.source or 'sweeps'}, nominal {name})\n"
            f"  rms {self.rms * 1e3:.4g} mm; the {self.convention} table carries a tool error up to {err * 1e3:.3g} mm; {len(self.notes)} notes"
        )

    @cached_property
    def box(self) -> BoundingBox:
        """The minimum-volume oriented bounding box of all measured points (the measuring volume, Hayat et al.
        Table IV), computed when first asked for (it costs more than the rest of :func:`identify`)."""
        return oriented_bounding_box(self.sweeps.all_points, where=self.sweeps.source)

    @property
    def table(self) -> _core.Table:
        return self.extraction.table

    def model(self, name: str = "identified", convention: str | None = None) -> _core.Model:
        """The identified model in its table's convention, or in ``convention`` (extracted from the same axes,
        e.g. "edh" for the exact geometry whatever a DH table could represent)."""
        names = self.nominal.names if self.nominal else [f"j{i + 1}" for i in range(self.axes.nq)]
        lower = self.nominal.lower if self.nominal else None
        upper = self.nominal.upper if self.nominal else None
        return self._extraction(convention).table.to_model(name, names, lower, upper)

    def _extraction(self, convention: str | None) -> _core.Extraction:
        """The identified axes in ``convention`` (None: the result's own table)."""
        convention = None if convention is None else _core.convention_info(convention)["name"]
        if convention is None or convention == self.convention:
            return self.extraction
        return _core.extract(self.axes, convention, **self._extract_options(convention))

    def _extract_options(self, convention: str) -> dict:
        """The extraction options of a table in another convention than the result's (:meth:`_extraction`)."""
        nominal = nominal_convention_table(self.nominal, convention, self.sweeps.home)
        tol = (
            _edh_parallel_tol(self.fits, self.nominal, self.sweeps.home, PARALLEL_TOL)
            if convention == "edh"
            else PARALLEL_TOL
        )
        return {"nominal": nominal, "origins": origins(nominal, convention, self.sweeps.home), "parallel_tol": tol}

    def parameter_covariance(self, convention: str | None = None) -> np.ndarray:
        """The SI covariance of [the ``convention`` table's parameters (row-major), the tool's translation in its last
        frame (, the reading scales when auto fitted them)] (default: the result's own table, :attr:`param_cov`):
        the axes' covariance propagated through the core's extraction of that table, as for the result's own."""
        conv = self.convention if convention is None else _core.convention_info(convention)["name"]
        if conv == self.convention:
            return self.param_cov
        x = np.concatenate(
            [np.concatenate([self.axes.points[j], self.axes.directions[j]]) for j in range(self.axes.nq)]
            + [self.tool_point]
        )
        cov = self.axis_cov if self.axis_scale_cov is None else self.axis_scale_cov
        return _parameter_cov(
            x, cov, self.axes, self.sweeps, conv, self._extract_options(conv), self._extraction(conv).table.params
        )

    def robot(self, name: str | None = None, convention: str | None = None) -> Robot:
        """The identified robot as a :class:`Robot` (for :meth:`save` and :func:`denavit.io.urdf.save_urdf`): the
        nominal's names, limits and extras (a URDF nominal's meshes and limits ride along), the sweeps' home.

        convention : the table's convention; default :data:`EXACT` (the result's own table when it is ED-H or POE,
            else ED-H: against a nominal exact except a near-parallel pair's tilt within its noise, POE exact always).
            A DH or MDH table cannot hold a near-parallel pair's tilt (Hayati beta): ask for one by name.
        """
        conv = (
            _core.convention_info(convention)["name"]
            if convention is not None
            else (self.convention if self.convention in EXACT else "edh")
        )
        n = self.axes.nq
        names = list(self.nominal.names) if self.nominal else [f"j{i + 1}" for i in range(n)]
        limits = np.array([_core.default_limits(k) for k in self.sweeps.kinds])
        lower = self.nominal.lower if self.nominal else limits[:, 0]
        upper = self.nominal.upper if self.nominal else limits[:, 1]
        # compensate predicts the error after compensation from the covariance, and commands the readings through
        # the coupling and the reading scales (about the sweeps' home, where the identified offsets hold)
        return Robot(
            name=name or f"{self.nominal.name if self.nominal else 'robot'}_identified",
            table=self._extraction(conv).table,
            names=names,
            lower=lower,
            upper=upper,
            description=f"identified from {self.sweeps.source} ({self.method} fit, {conv})",
            source=str(self.sweeps.source),
            home=self.sweeps.home,
            extra=dict(self.nominal.extra) if self.nominal else {},
            covariance=self.parameter_covariance(conv),
            coupling=self.coupling,
            reading_scale=self.reading_scale,
            reading_reference=None if self.reading_scale is None else np.asarray(self.sweeps.home, dtype=float),
        )

    def carried_error(self, convention: str | None = None, count: int = 256) -> tuple[float, int]:
        """(max tool-position deviation in m, configurations checked) of the table :meth:`robot` writes in
        ``convention`` from the identified geometry (the exact ED-H model of the axes): over the home and ``count``
        configurations spread over the joint limits (:func:`denavit.calibration.configurations`)."""
        from ..calibration.parametrization import configurations  # noqa: PLC0415 (scipy's Halton sequence)

        conv = (
            _core.convention_info(convention)["name"]
            if convention is not None
            else (self.convention if self.convention in EXACT else "edh")
        )
        model = self.model(convention=conv)  # the table :meth:`robot` writes (without its covariance, which costs)
        exact = _core.extract(self.axes, "edh", fidelity=False).table.to_model()
        q = np.vstack([self.sweeps.home, configurations(model, count)])
        d = _core.fk_batch(model, q)[:, :3, 3] - _core.fk_batch(exact, q)[:, :3, 3]
        return float(np.linalg.norm(d, axis=1).max()), len(q)

    def save(
        self,
        path,
        convention: str | None = None,
        length: str = "m",
        angle: str = "deg",
        name: str | None = None,
        *,
        force: bool = False,
    ) -> None:
        """Write the identified robot as a robot file (.toml; :mod:`denavit.io.robotfile`), by default the ED-H or POE
        geometry (:meth:`robot`: POE exact, ED-H exact except a near-parallel pair's tilt within its noise, which it drops
        against the nominal), a lossy DH / MDH table only when ``convention`` asks for one. The file states in a comment
        whether it is exact and the tool-position error its table carries against the identified geometry (:meth:`carried_error`).

        A path ending in ``.urdf`` gets the URDF of the ED-H geometry instead (frames on the body; a URDF
        nominal's meshes and limits ride along; :func:`denavit.io.urdf.save_urdf`), in SI as URDF requires.

        The file is written whole or not at all, keeping the owner and mode of a file it replaces; ``force``:
        replace a read-only file, write through one with several hard links (:mod:`denavit.io.output`).
        """
        from ..io.robotfile import dumps  # noqa: PLC0415

        suffix = Path(str(path)).suffix.lower()
        if str(path) != "-" and suffix not in ("", ".toml", ".urdf"):  # a .json name had received TOML without a word
            raise DenavitError(
                f"{path}: expected a robot file name ending in .toml (or .urdf for a URDF), got a {suffix} name"
            )
        if suffix == ".urdf":
            from ..io.urdf import save_urdf  # noqa: PLC0415 (lxml loads for a URDF only)

            if convention is not None and _core.convention_info(convention)["name"] != "edh":
                raise DenavitError(
                    f"{path}: a URDF holds the exact geometry (ED-H frames on the body), got convention {convention!r}: save a robot file (.toml) for a {convention} table"
                )
            save_urdf(self.model(convention="edh"), path, self.robot(name), force=force)
            return
        robot = self.robot(name, convention)
        err, count = self.carried_error(convention)
        if robot.convention in EXACT and err <= ROUND_OFF:
            how = f"exactly (its {robot.convention} table holds any pair of joint axes)"
        elif robot.convention in EXACT:
            how = f"exactly except {_DROPPED_TILT}; save as poe for the exact geometry"
        else:
            how = f"in a {robot.convention} table, which cannot hold a near-parallel pair's tilt (save as poe for the exact geometry)"
        note = (
            f"# The identified geometry, {how}.\n# Carried error: max tool-position deviation {err * 1e3:.3g} mm from the identified geometry "
            f"over {count} configurations (the home and {count - 1} spread over the joint limits).\n"
        )
        write_text(path, note + dumps(robot, length, angle), force=force)


#: What an ED-H table against the nominal leaves out (docs/conventions.md, "ED-H").
_DROPPED_TILT = f"the tilt of a pair of axes the nominal has parallel, dropped when within {EDH_PARALLEL_SIGMAS:g} sigma of zero, its noise"


def _finite(v: float) -> float | None:
    """``v`` as a float, or None where it is not finite (JSON has no NaN)."""
    return float(v) if np.isfinite(v) else None


def to_json(result: Identification, *, box: bool = True) -> dict:
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
        "tracker_noise": None
        if (tn := result.tracker_noise) is None
        else {"sigma_range_m": tn.sigma_range, "sigma_angle_rad": tn.sigma_angle, "position_m": list(tn.position)},
        "notes": result.notes,
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


def write_json(result: Identification, path, *, box: bool = True, force: bool = False) -> None:
    """Write the result as JSON in SI (whole or not at all); ``box`` as in :func:`to_json`, ``force`` as in
    :func:`denavit.io.output.write_text`."""
    write_text(path, json_text(to_json(result, box=box)), force=force)
