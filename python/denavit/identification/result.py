"""The result of an identification (:class:`Identification`); saved and written as JSON by :mod:`denavit.io.results`."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from .. import _core
from ..fitting import AxisFit, BoundingBox, oriented_bounding_box
from ..fitting.joint import TrackerNoise
from ..robot import Robot, inertials_for_table
from ..sweeps import SweepSet
from .frames import (
    EDH_PARALLEL_SIGMAS,
    PARALLEL_TOL,
    _edh_parallel_tol,
    _parameter_cov,
    _parameter_jacobian,
    nominal_convention_table,
    origins,
)

METHODS = ("auto", "kasa", "hyper", "geometric", "readings", "global")
#: The conventions whose tables hold any pair of joint axes exactly (docs/conventions.md): what
#: :meth:`Identification.save` writes by default.
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
        # (n k + 3 [+ n],) covariance of the table's parameters (row-major), the tool translation (, the reading scales)
        None
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
    # where the tool frame's orientation came from: "nominal", "poses", "nest" or "targets" (TOOL_ORIENTATION)
    tool_orientation: str = "nominal"
    tool_rotation_cov: np.ndarray | None = (
        # (3, 3) rad^2: covariance of the tool frame's orientation at home (a small rotation in world), None if from the
        # nominal
        None
    )
    target_points: np.ndarray | None = None  # (k, 3) m: each target's point at home in world (several targets per pose)
    tracker_noise: TrackerNoise | None = (
        None  # the tracker's range/angle noise model the joint fit weighted the points by (None: isotropic)
    )
    # the joints' compliances when the joint fit freed them (issue 37; identify's compliance, run._compliance_of)
    compliance: dict | None = None

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
            f"Identification({self.convention}, method {self.method}, {self.axes.nq} joints, {n_pts} points of"
            f" {self.sweeps.source or 'sweeps'}, nominal {name})\n  rms {self.rms * 1e3:.4g} mm; the {self.convention}"
            f" table carries a tool error up to {err * 1e3:.3g} mm; {len(self.notes)} notes"
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
        o = origins(nominal, convention, self.sweeps.home, self.axes)
        return {"nominal": nominal, "origins": o, "parallel_tol": tol}

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
        table = self._extraction(conv).table
        c = self.compliance
        # the compliances (>= 0: the joint fit's bound, run._compliance_of) with the nominal's link inertials in the
        # convention's link frames i, put on the identified table's (its offsets the undeflected arm's:
        # run._link_home), as a robot file's [compliance]
        inertials = (
            inertials_for_table(
                self.nominal.model(),
                nominal_convention_table(self.nominal, conv, self.sweeps.home),
                names,
                lower,
                upper,
            )
            if c is not None and self.nominal.inertials is not None
            else None
        )
        cov, cross = self._compliant_covariance(conv, table) if inertials is not None else (None, None)
        # compensate predicts the error after compensation from the covariance, and commands the readings through
        # the coupling and the reading scales (about the sweeps' home, where the identified offsets hold)
        return Robot(
            name=name or f"{self.nominal.name if self.nominal else 'robot'}_identified",
            table=table,
            names=names,
            lower=lower,
            upper=upper,
            description=f"identified from {self.sweeps.source} ({self.method} fit, {conv})",
            source=str(self.sweeps.source),
            home=self.sweeps.home,
            extra=dict(self.nominal.extra) if self.nominal else {},
            covariance=self.parameter_covariance(conv) if cov is None else cov,
            coupling=self.coupling,
            reading_scale=self.reading_scale,
            reading_reference=None if self.reading_scale is None else np.asarray(self.sweeps.home, dtype=float),
            inertials=inertials,
            compliance=None if inertials is None else np.asarray(c["k"], dtype=float),
            compliance_covariance=None if inertials is None else np.asarray(c["cov"], dtype=float),
            compliance_cross=cross,
            compliance_flange=None if inertials is None else self._flange(table),
        )

    def _compliant_covariance(self, conv: str, table) -> tuple[np.ndarray, np.ndarray | None]:
        """(the covariance of ``table``'s entries, their cross-covariance with the compliances) of :meth:`robot`: the
        joint fit's covariance of the axes (and reading scales) with the compliances (``compliance["cross"]``), through
        the extraction's Jacobian, by the compliances too: the table's offsets are the links' at home, the home less
        ``k`` times the torques there (run._link_home). (None for the cross when the result does not carry it.)"""
        c = self.compliance
        base = self.parameter_covariance(conv)
        if c.get("cross") is None:
            return base, None
        n = self.axes.nq
        cov = self.axis_cov if self.axis_scale_cov is None else self.axis_scale_cov
        x = np.concatenate(
            [np.concatenate([self.axes.points[j], self.axes.directions[j]]) for j in range(n)] + [self.tool_point]
        )
        opts = self._extract_options(conv)
        J = _parameter_jacobian(
            x, len(cov), self.axes, self.sweeps, conv, opts, table.params, torque_home=c["torque_home"]
        )
        Ja, Jk = J[:, : len(cov)], J[:, len(cov) :]
        X, Ck = np.asarray(c["cross"], dtype=float)[: len(cov)], np.asarray(c["cov"], dtype=float)
        JX = Ja @ X
        return base + JX @ Jk.T + Jk @ JX.T + Jk @ Ck @ Jk.T, JX + Jk @ Ck

    def _flange(self, table) -> np.ndarray | None:
        """The mechanical flange (where a payload's centre of mass is given: the nominal's) in ``table``'s last frame,
        at the links' home (run._link_home), as calibrate --save writes it (a robot file's ``[compliance] flange``);
        None where they coincide."""
        q = self.sweeps.home - self.compliance["k"] * self.compliance["torque_home"]
        m = self.nominal.model()
        F = np.linalg.inv(np.asarray(table.frames(q))[-1]) @ np.asarray(_core.joint_frames(m, q))[-1] @ m.T_last_flange
        return None if np.allclose(F, np.eye(4), rtol=0, atol=1e-12) else F

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


#: What an ED-H table against the nominal leaves out (docs/conventions.md, "ED-H").
_DROPPED_TILT = (
    f"the tilt of a pair of axes the nominal has parallel, dropped when within {EDH_PARALLEL_SIGMAS:g} sigma of zero,"
    " its noise"
)
