"""The robot record: a model in one convention's table, with the names, limits, home, inertias and provenance
a robot file or a URDF carries.

Finding and reading robots (built-in names, robot files, URDFs) is the edge layer's: :mod:`denavit.io.robots`
(:func:`~denavit.io.robots.load`, :func:`~denavit.io.robots.as_robot`). Everything here is SI (m, rad, kg).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from . import _core
from .errors import DenavitError


@dataclass(frozen=True)
class Robot:
    """A robot description: its table in one convention, joint names, limits and metadata.

    Attributes are SI (m, rad). ``home`` is an optional reference configuration (e.g. a measurement home).
    """

    name: str
    table: _core.Table
    names: list[str]
    lower: np.ndarray
    upper: np.ndarray
    description: str = ""
    source: str = ""
    home: np.ndarray | None = None
    path: str = ""
    extra: dict = field(default_factory=dict)
    inertials: dict | None = None
    """Link inertial parameters in frame i of the convention, SI: ``masses`` (n,) kg, ``coms`` (n, 3) m,
    ``inertias`` (n, 3, 3) kg m^2 about each centre of mass (None: massless links)."""
    coupling: np.ndarray | None = None
    """(n, n) the joint values from the controller's readings, ``q = coupling @ reading`` (a Fanuc's J3 read
    relative to the horizontal: ``q3 = r3 + r2``); None: the readings are the joint values."""
    covariance: np.ndarray | None = None
    """(n k + 3 [+ n], same) SI covariance of the table's parameters (row-major), the tool's translation in the last
    frame and, when :attr:`reading_scale` is given, the reading scales, from the identification or calibration that
    made the robot (a robot file's ``[covariance]``)."""
    reading_scale: np.ndarray | None = None
    """(n,) the joints' reading scale errors: joint i turns ``1 + reading_scale[i]`` times its reading's motion from
    :attr:`reading_reference` (:meth:`joint_values`; a robot file's ``[readings] scale``); None: no scale errors."""
    reading_reference: np.ndarray | None = None
    """(n,) the readings (after the coupling; rad / m) at which each joint value equals its reading, the centre of the
    scale errors (identify: the sweeps' home; calibrate: zero; a robot file's ``[readings] reference``); None: zero."""
    compliance: np.ndarray | None = None
    """(n,) the joints' compliances (rad/(N m) for a revolute joint, m/N for a prismatic one; >= 0): joint i sits at
    ``q_i - compliance_i tau_i`` under the gravity torque ``tau_i`` it holds (:mod:`denavit.calibration.compliance`; a
    robot file's ``[compliance]``); None: rigid joints."""
    compliance_covariance: np.ndarray | None = None
    """(n, n) SI covariance of :attr:`compliance` (a robot file's ``[compliance] covariance``); None: not carried."""
    compliance_cross: np.ndarray | None = None
    """(len(covariance), n) SI covariance of :attr:`covariance`'s entries (rows, in its order) with the compliances
    (columns), from the calibration that fitted them together (a robot file's ``[compliance] cross_covariance``); None:
    taken as uncorrelated (a file written before it was carried)."""
    compliance_flange: np.ndarray | None = None
    """(4, 4) the frame a payload's centre of mass is given in (the robot's mechanical flange), in the model's flange
    frame (a robot file's ``[compliance] flange``, written by calibrate --save where its table's last frame is not the
    flange); None: the model's flange."""
    prior: str | None = None
    """The calibration priors' widths this robot's maker or user states (a robot file's ``[prior]`` table), in the
    grammar of ``calibrate --prior`` with explicit units (``"length=0.5mm, a_5=2mm"``); None: the defaults
    (:mod:`denavit.calibration.priors`). An explicit ``prior=`` / ``--prior`` wins."""
    training: np.ndarray | None = None
    """(2, n) the lowest and highest joint values (SI) of the poses the calibration that made this robot was fitted on
    (a robot file's ``[training]``, written by ``calibrate --save``): :func:`denavit.validate` flags poses outside
    them; None: not carried."""
    notes: list = field(default_factory=list)
    """What the reader chose on the user's behalf (e.g. a URDF's tip link), one line each, for the user to see."""

    def __repr__(self) -> str:
        dyn = "inertial parameters" if self.inertials is not None else "no inertial parameters"
        return (
            f"Robot({self.name!r}, {self.convention}, {len(self.names)} joints {', '.join(self.names)}; {dyn}; source"
            f" {self.source or self.path or '-'})"
        )

    @property
    def convention(self) -> str:
        return self.table.convention

    def joint_values(self, readings) -> np.ndarray:
        """The joint values (N, n) of the model from the controller's readings (N, n) (rad / m), by the robot's
        reading model (:func:`joint_values`)."""
        return joint_values(readings, self.coupling, self.reading_scale, self.reading_reference)

    def readings(self, q) -> np.ndarray:
        """The controller's readings (N, n) that put the model's joints at ``q`` (N, n) (:func:`readings`)."""
        return readings(q, self.coupling, self.reading_scale, self.reading_reference)

    @property
    def has_reading_model(self) -> bool:
        """The readings are not the joint values (a coupling or reading scales)."""
        return self.coupling is not None or self.reading_scale is not None

    def model(self) -> _core.Model:
        """The model (docs/conventions.md), with the link inertias of the file if it gives them."""
        model = self.table.to_model(self.name, self.names, self.lower, self.upper)
        if self.inertials is None:
            return model
        return attach_inertials(model, self.table, self.inertials)


def joint_values(r, coupling=None, scale=None, reference=None) -> np.ndarray:
    """The joint values of readings ``r`` (N, n) under a reading model: ``q = ref + (1 + scale) (coupling @ r - ref)``
    (``ref`` the reference, default zero; no coupling: the identity; no scale: zero), rad / m."""
    q = np.asarray(r, dtype=float) @ np.asarray(coupling).T if coupling is not None else np.array(r, dtype=float)
    if scale is not None:
        ref = 0.0 if reference is None else np.asarray(reference, dtype=float)
        q = ref + (1 + np.asarray(scale, dtype=float)) * (q - ref)
    return q


def readings(q, coupling=None, scale=None, reference=None) -> np.ndarray:
    """The readings that give the joint values ``q`` (N, n) under a reading model: the inverse of
    :func:`joint_values`."""
    r = np.array(q, dtype=float)
    if scale is not None:
        ref = 0.0 if reference is None else np.asarray(reference, dtype=float)
        r = ref + (r - ref) / (1 + np.asarray(scale, dtype=float))
    return np.linalg.solve(np.asarray(coupling, dtype=float), r.T).T if coupling is not None else r


def inertials_for_table(model: _core.Model, table: _core.Table, names: list[str], lower, upper) -> dict:
    """The link inertias of ``model`` (same robot, same joint axes at q = 0) in frame i of ``table``'s
    convention, as a :attr:`Robot.inertials` dict: how a conversion carries the dynamics along."""
    target = _core.transfer_inertias(model, table.to_model("target", names, lower, upper))
    ins = target.inertias
    T = table.link_frames()  # the convention's frame i in joint frame i (the core: Table::link_frames)
    R, p = T[:, :3, :3], T[:, :3, 3]
    coms = np.einsum("nji,nj->ni", R, ins["coms"] - p)
    return {"masses": ins["masses"], "coms": coms, "inertias": R.transpose(0, 2, 1) @ ins["inertias"] @ R}


def attach_inertials(model: _core.Model, table: _core.Table, inertials: dict) -> _core.Model:
    """``model`` with inertials given in frame i of ``table``'s convention (re-expressed in the joint frames)."""
    T = table.link_frames()
    R, p = T[:, :3, :3], T[:, :3, 3]
    coms = np.einsum("nij,nj->ni", R, np.asarray(inertials["coms"], dtype=float)) + p
    inertias = R @ np.asarray(inertials["inertias"], dtype=float) @ R.transpose(0, 2, 1)
    return model.with_inertias(np.asarray(inertials["masses"], dtype=float), coms, inertias)


def robot_of(nominal) -> Robot:
    """``nominal`` (a :class:`Robot` or a :class:`denavit.Model`) as a Robot; a Model's table is its ED-H extraction
    at q = 0. Names and files are read by the edge layer (:func:`denavit.io.robots.as_robot`) or the workflows of
    :mod:`denavit.api`."""
    if isinstance(nominal, Robot):
        return nominal
    if isinstance(nominal, _core.Model):
        ex = _core.extract(_core.axes(nominal, np.zeros(nominal.nq)), "edh")
        return Robot(nominal.name, ex.table, list(nominal.names), np.array(nominal.lower), np.array(nominal.upper))
    if isinstance(nominal, str) or hasattr(nominal, "__fspath__"):
        raise DenavitError(
            f"nominal: expected a Robot or a Model, got the name or path {str(nominal)!r}: read it with"
            " denavit.load_robot, or call the workflow of the same name in denavit (which reads names and files)"
        )
    raise DenavitError(f"nominal: expected a Robot or a Model, got {type(nominal).__name__}")
