"""The robot record: a model in one convention's table, with the names, limits, home, inertias and provenance
a robot file or a URDF carries, and where to find robots (:func:`load`, :func:`resolve`, :func:`builtin_names`).

The file formats live in the edge layer: TOML robot files in :mod:`denavit.io.robotfile`, URDF in
:mod:`denavit.io.urdf`. Everything here is SI (m, rad, kg).
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path

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
    compliance_flange: np.ndarray | None = None
    """(4, 4) the frame a payload's centre of mass is given in (the robot's mechanical flange), in the model's flange
    frame (a robot file's ``[compliance] flange``, written by calibrate --save where its table's last frame is not the
    flange); None: the model's flange."""
    prior: str | None = None
    """The calibration priors' widths this robot's maker or user states (a robot file's ``[prior]`` table), in the
    grammar of ``calibrate --prior`` with explicit units (``"length=0.5mm, a_5=2mm"``); None: the defaults
    (:mod:`denavit.calibration.priors`). An explicit ``prior=`` / ``--prior`` wins."""
    notes: list = field(default_factory=list)
    """What the reader chose on the user's behalf (e.g. a URDF's tip link), one line each, for the user to see."""

    def __repr__(self) -> str:
        dyn = "inertial parameters" if self.inertials is not None else "no inertial parameters"
        return f"Robot({self.name!r}, {self.convention}, {len(self.names)} joints {', '.join(self.names)}; {dyn}; source {self.source or self.path or '-'})"

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
    """The readings that give the joint values ``q`` (N, n) under a reading model: the inverse of :func:`joint_values`."""
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


def builtin_names() -> list[str]:
    """Names of the built-in robot files."""
    return sorted(p.name[:-5] for p in resources.files("denavit.models").iterdir() if p.name.endswith(".toml"))


def resolve(name_or_path: str | os.PathLike) -> Path:
    """The file of a built-in name or a path; a clear error listing the built-ins otherwise."""
    p = Path(name_or_path)
    if p.suffix and p.exists():
        return p
    if p.exists() and p.is_file():
        return p
    key = str(name_or_path).lower().replace("-", "_")
    if key in builtin_names():
        return Path(str(resources.files("denavit.models").joinpath(key + ".toml")))
    raise DenavitError(
        f"unknown model {str(name_or_path)!r}: expected a built-in name ({', '.join(builtin_names())}) or an existing robot file (.toml) or URDF (.urdf)"
    )


def load(
    name_or_path: str | os.PathLike,
    *,
    base_link: str | None = None,
    tip_link: str | None = None,
    chain_only: bool = False,
    locked: dict | None = None,
) -> Robot:
    """The :class:`Robot` of a built-in name, a robot file (.toml, :mod:`denavit.io.robotfile`) or a URDF
    (.urdf, :mod:`denavit.io.urdf`; ``base_link`` / ``tip_link`` pick its chain; the links off it are merged
    into the chain's dynamics, their movable joints at ``locked`` ({joint: value}, default 0), unless
    ``chain_only``). SI inside."""
    path = resolve(name_or_path)
    if path.suffix.lower() == ".urdf":
        from .io.urdf import load_urdf  # noqa: PLC0415 (yourdfpy and lxml load only for a URDF)

        return load_urdf(path, base_link=base_link, tip_link=tip_link, chain_only=chain_only, locked=locked)
    if base_link is not None or tip_link is not None or chain_only or locked:
        raise DenavitError(f"{path}: base_link/tip_link/chain_only/locked apply to a URDF, got a robot file")
    from .io.robotfile import read  # noqa: PLC0415

    return read(path)
