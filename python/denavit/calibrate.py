"""Calibration beyond circles: one least-squares fit of the whole kinematic model, its identifiability, its
uncertainty, and the planning of measurements.

Data are measured tool points (or full tool poses) at arbitrary joint configurations whose readings are
known, in any measurement frame (``world``); the joint sweeps of the circle-point method (Hayat et al.) are one
case of it (:meth:`Measurements.from_sweeps`). The model is a chain of elementary factors (``Rx, Ry, Rz`` in
rad, ``Tx, Ty, Tz`` in m) with named parameters, generated from a nominal robot in a chosen convention; the
identification Jacobian of every parameter is computed analytically in the Rust core
(``denavit_core::calibration``) in one forward pass per pose.

Parametrisations (chain order, base to tool; joint numbers 1-based, subscripts as in the papers)
--------------------------------------------------------------------------------------------------
* base: ``Tx(base_tx) Ty(base_ty) Tz(base_tz) · R0 · Rx(base_rx) Ry(base_ry) Rz(base_rz)``: the convention's
  frame 0 in ``world``; ``R0`` is the nominal (or registered) base rotation, the three angles small
  corrections about the base axes (0 at the start), so no Euler singularity is ever met.
* ``edh`` (Guo et al. eq. 1-2), link *i*: ``Rx(alpha_{i-1}) Tx(a_{i-1}) Ty(b_{i-1}) Tz(c_{i-1}) [Ry(beta_{i-1})]
  Rz(offset_i + q_i)``; prismatic: ``... Tz(c_{i-1}) [Ry(beta_{i-1})] Rz(theta_i) Tz(offset_i + q_i)``. Where axes
  *i-1*, *i* are near-parallel, ED-H's common-normal direction ``x_{i-1}`` cannot turn smoothly with the axes (a
  tilt of axis *i* about ``y_{i-1}`` would turn it by 90 degrees), so a tilt ``beta_{i-1}`` about ``y`` at frame
  *i*'s origin is added (after Hayati & Mirmirani 1985); the direction of ``x_{i-1}`` then becomes a free choice
  (a joint offset is reported redundant).
* ``mdh`` (Craig) with Hayati's angle (Hayati & Mirmirani 1985) where axes *i-1*, *i* are near-parallel
  (``|sin| < NEAR_PARALLEL_SIN``, as in docs/conventions.md): ``Rx(alpha_{i-1}) Tx(a_{i-1}) [Ry(beta_{i-1})]
  Tz(d_i) Rz(offset_i + q_i)`` (``Tz`` commutes with ``Rz``); where ``beta_{i-1}`` is used, ``d_{i-1}`` (the
  position of frame *i-1* along its axis, undefined for parallel axes) is fixed at its nominal value.
* ``dh`` (Denavit & Hartenberg), link *i*: ``Rz(offset_i + q_i) Tz(d_i) Tx(a_i) Rx(alpha_i)``. Refused (with the
  reason) when consecutive axes are near-parallel: a DH table has no parameter for a tilt about ``y`` there
  and its ``d`` diverges (Hayati & Mirmirani 1985).
* tool point: ``F · Tx(tool_x) Ty(tool_y) Tz(tool_z)``, the measured point in the flange frame (docs/conventions.md
  "Frames": DH frame *n* for a DH robot), ``F`` the nominal flange fixed in the convention's last frame; tool frame
  (pose data): ``F · Tx Ty Tz · R0 · Rx(tool_rx) Ry(tool_ry) Rz(tool_rz)``.
* joint scale (optional): ``q_i -> q_i (1 + scale_i)``.

Identifiability: the (weighted) identification Jacobian ``J`` with unit-norm columns is reduced by a greedy
Gram-Schmidt in a fixed preference order (base, tool, link geometry, joint offsets, scales, translations along
joint axes last): a parameter whose column is (numerically) a combination of the columns kept before it is
*not identifiable*; it is named with that combination, fixed at its start value and reported, never returned
as a silent number. The kept set is a set of base parameters (Khalil & Dombre 2002, ch. 11). Parameters
redundant for *any* data (checked on configurations spread over the joint limits) are told apart from those
these measurements cannot separate. Observability indices of the kept, column-normalised ``J`` with singular
values ``s_1 >= ... >= s_L`` over ``m`` poses (Sun & Hollerbach 2008, "Observability index selection for robot
calibration", ICRA): O1 ``(s_1 ... s_L)^(1/L) / sqrt(m)`` (Borm & Menq 1991), O2 ``s_L / s_1`` (Driels & Pathre
1990), O3 ``s_L`` (Nahvi, Hollerbach & Hayward 1994), O4 ``s_L^2 / s_1`` (noise amplification, Nahvi &
Hollerbach 1996), O5 ``1 / (1/s_1 + ... + 1/s_L)`` (Sun & Hollerbach 2008).

Uncertainty: ``cov = s^2 (J^T J)^-1`` over the free parameters (``s^2`` from the residuals, or the declared
noise), i.e. the Cramér-Rao bound of Gaussian noise evaluated at the solution; :func:`plan` evaluates the same
bound at the nominal model before anything is measured.
"""

from __future__ import annotations

import fnmatch
import json
import math
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from scipy.linalg import cho_factor, cho_solve
from scipy.optimize import least_squares
from scipy.spatial.transform import Rotation

from . import _core, fitting
from .errors import DegenerateError, DenavitError
from .io.output import write_text
from .robotfile import Robot
from .sweeps import PAPER_HOME_DEG, PAPER_RANGES_DEG, SweepSet
from .io.units import angle_scale, length_scale

CONVENTIONS = ("edh", "mdh", "dh")
LOSSES = ("linear", "soft_l1", "huber", "cauchy", "arctan")
# Above this |sin(angle)| consecutive axes are never near-parallel (extract.rs NEAR_PARALLEL_SIN, about 2.9 deg).
NEAR_PARALLEL_SIN = 0.05
# A unit-norm Jacobian column whose part independent of the columns kept before it is shorter than this is
# not identifiable (its sigma would exceed 1e6 times the sigma it has alone).
RANK_TOL = 1e-6
# Points whose 3-D misfit exceeds this many robust sigmas are flagged (4-sigma tail of a 1-D deviation for a
# 3-D misfit, as in denavit.fitting).
OUTLIER_SIGMAS = 4.70
# The base is first registered (Kabsch) to the data when the nominal model at its nominal base misses the measured
# points by more than this (m, RMS): the measurement frame is then not the robot's base frame.
REGISTER_RMS = 0.02
_PRIMES = (2, 3, 5, 7, 11, 13, 17, 19, 23, 29, 31, 37, 41, 43, 47, 53)


# ------------------------------------------------------------------------------------------------ data


@dataclass(frozen=True, eq=False)
class Measurements:
    """Measured tool points or poses at known joint configurations.

    Attributes
    ----------
    q : ndarray, shape (N, n), rad / m
        Joint readings of each pose.
    points : ndarray, shape (N, 3), metres, frame ``world`` (the measurement frame), or None
        Measured tool points.
    poses : ndarray, shape (N, 4, 4), metres, frame ``world``, or None
        Measured tool poses ``T_world_tool`` (then ``points`` are their origins).
    source : str
        Where the data came from (for messages).
    where : list of str, length N
        Where each pose came from ("file:line").
    units : dict
        Units of the source file (informative; everything here is SI).
    sweeps : SweepSet or None
        The sweeps these measurements were made of, if any (for ``start="circles"``).
    kinds : tuple of str, length n, or None
        Joint kinds (``"revolute"`` / ``"prismatic"``) of the readings; read from a file, the kinds they were
        converted with from its units (revolute: angle unit, prismatic: length unit). :func:`calibrate`
        refuses a nominal model of other kinds. None: not stated (readings given in SI).
    """

    q: np.ndarray
    points: np.ndarray | None = None
    poses: np.ndarray | None = None
    source: str = "measurements"
    where: list = field(default_factory=list)
    units: dict = field(default_factory=lambda: {"length": "m", "angle": "rad"})
    sweeps: SweepSet | None = None
    kinds: tuple | None = None

    def __post_init__(self):
        q = _as_array(self.q, "q", self.source)
        if q.ndim != 2 or q.shape[0] < 1:
            raise DenavitError(f"{self.source}: q must have shape (N, n) with one row per pose, got shape {q.shape}")
        object.__setattr__(self, "kinds", _joint_kinds(self.kinds, q.shape[1], f"{self.source}: kinds"))
        _check_finite(q, "q (joint readings)", self.source, self.where, cols="joint")
        n = q.shape[0]
        poses = self.poses
        points = self.points
        if poses is not None:
            poses = _as_array(poses, "poses", self.source)
            if poses.shape != (n, 4, 4):
                raise DenavitError(f"{self.source}: poses must have shape ({n}, 4, 4) (one per row of q), got shape {poses.shape}")
            _check_finite(poses.reshape(n, 16), "poses", self.source, self.where)
            err = np.abs(np.einsum("nji,njk->nik", poses[:, :3, :3], poses[:, :3, :3]) - np.eye(3)).max(axis=(1, 2))
            bad = np.flatnonzero((err > 1e-6) | (np.abs(poses[:, 3] - [0, 0, 0, 1]).max(axis=1) > 0))
            if bad.size:
                raise DenavitError(f"{_row(self.source, self.where, bad[0])}: pose is not a rigid transform (|R^T R - I| = {err[bad[0]]:.2e}, last row {poses[bad[0], 3].tolist()})")
            points = poses[:, :3, 3].copy()
        elif points is not None:
            points = _as_array(points, "points", self.source)
            if points.shape != (n, 3):
                raise DenavitError(f"{self.source}: points must have shape ({n}, 3) (one per row of q), got shape {points.shape}")
            _check_finite(points, "points", self.source, self.where, cols="xyz")
        else:
            raise DenavitError(f"{self.source}: give measured points (N, 3) or poses (N, 4, 4) with the joint readings q")
        object.__setattr__(self, "q", q)
        object.__setattr__(self, "points", points)
        object.__setattr__(self, "poses", poses)
        object.__setattr__(self, "where", list(self.where) or [f"pose {k + 1}" for k in range(n)])

    @property
    def n(self) -> int:
        """Number of poses N."""
        return self.q.shape[0]

    @property
    def nq(self) -> int:
        """Number of joints."""
        return self.q.shape[1]

    @property
    def kind(self) -> str:
        """``"point"`` or ``"pose"``."""
        return "pose" if self.poses is not None else "point"

    def subset(self, idx) -> Measurements:
        """The measurements of the rows ``idx``."""
        idx = np.asarray(idx, dtype=int)
        return Measurements(self.q[idx], None if self.poses is not None else self.points[idx], None if self.poses is None else self.poses[idx],
                            self.source, [self.where[i] for i in idx], self.units, None, self.kinds)

    @classmethod
    def from_sweeps(cls, sweeps: SweepSet) -> Measurements:
        """The points of every sweep with their joint readings (all joints recorded at every point)."""
        if not sweeps.has_readings:
            raise DenavitError(f"{sweeps.source}: calibration needs the joint readings of every point; these sweeps have none (per-joint files): use denavit.identify")
        q = np.vstack([s.q for s in sweeps.sweeps])
        p = np.vstack([s.points for s in sweeps.sweeps])
        where = [w for s in sweeps.sweeps for w in (s.where or [f"sweep {s.joint}, point {k + 1}" for k in range(len(s.points))])]
        return cls(q, p, None, sweeps.source or "sweeps", where, dict(sweeps.units), sweeps, sweeps.kinds)


def _as_array(a, what: str, source: str) -> np.ndarray:
    try:
        return np.array(a, dtype=float)
    except (TypeError, ValueError) as exc:
        raise DenavitError(f"{source}: {what} must be an array of numbers ({exc})") from None


def _joint_kinds(kinds, n: int, where: str) -> tuple | None:
    """``kinds`` as a tuple of n joint kinds (None stays None), or an error saying what was expected."""
    if kinds is None:
        return None
    if isinstance(kinds, str) or not hasattr(kinds, "__len__"):
        raise DenavitError(f"{where}: expected a list of {n} joint kinds ('revolute' or 'prismatic'), got {kinds!r}")
    if len(kinds) != n:
        raise DenavitError(f"{where}: expected {n} joint kinds (one per joint reading), got {len(kinds)}: {list(kinds)}")
    for j, k in enumerate(kinds):
        if k not in ("revolute", "prismatic"):
            raise DenavitError(f"{where}: joint {j + 1}: expected 'revolute' or 'prismatic', got {k!r}")
    return tuple(kinds)


def _row(source: str, where: list, i: int) -> str:
    return where[i] if where and i < len(where) else f"{source}, row {i + 1}"


def _check_finite(a: np.ndarray, what: str, source: str, where: list, cols: str | None = None) -> None:
    bad = np.argwhere(~np.isfinite(a))
    if bad.size:
        i, j = bad[0]
        col = f"{cols} {j + 1}" if cols == "joint" else (f"column {'xyz'[j]}" if cols == "xyz" and j < 3 else f"entry {j}")
        raise DenavitError(f"{_row(source, where, i)}: {what} must be finite, got {a[i, j]} ({col}); {len(bad)} non-finite value(s) in all")


def read_measurements(path, *, length: str | None = None, angle: str | None = None, kinds=None) -> Measurements:
    """Read measurements from a file.

    Joint readings are in the angle unit for revolute joints and in the length unit for prismatic ones:
    ``kinds`` (one ``"revolute"`` / ``"prismatic"`` per joint, e.g. the nominal robot's ``table.kinds``; a JSON
    file may state them as ``"kinds"``) says which; without them every joint is read as revolute and
    :func:`calibrate` refuses a nominal model with a prismatic joint.

    * CSV with a ``joint`` column: the long-form sweep file of :func:`denavit.sweeps.read_long_csv`.
    * CSV with header ``q1,...,qn,x,y,z`` (points) or ``q1,...,qn,x,y,z,rx,ry,rz`` (poses; ``rx, ry, rz`` the
      rotation vector of ``R_world_tool`` in angle units): one row per pose. Units from a
      ``# units: length=mm angle=deg`` line or ``length`` / ``angle``.
    * JSON: ``{"units": {...}, "q": [[...]], "points": [[x, y, z]...]}`` (or ``"poses"``: 4x4 matrices with
      translations in length units), or a sweep JSON (``"sweeps"``).
    """
    from . import sweeps as sw  # noqa: PLC0415

    p = Path(path)
    if not p.exists():
        raise DenavitError(f"{p}: no such file")
    if p.suffix.lower() == ".json":
        try:
            doc = json.loads(p.read_text(encoding="utf-8"))
        except json.JSONDecodeError as e:
            raise DenavitError(f"{p}:{e.lineno}: not valid JSON: {e.msg}") from None
        if "sweeps" in doc:
            return Measurements.from_sweeps(sw.read_json(p))  # its own "kinds"
        units = dict(doc.get("units") or {})
        if length:
            units["length"] = length
        if angle:
            units["angle"] = angle
        ls, as_ = _scales(units, str(p))
        if "q" not in doc:
            raise DenavitError(f"{p}: expected 'q' (joint readings, one row per pose) and 'points' or 'poses'")
        q = _as_array(doc["q"], "q", str(p))
        if q.ndim != 2:
            raise DenavitError(f"{p}: q must have shape (N, n) with one row per pose, got shape {q.shape}")
        given = _joint_kinds(kinds, q.shape[1], f"{p}: kinds given")
        stated = _joint_kinds(doc.get("kinds"), q.shape[1], f"{p}: 'kinds'")
        if given and stated and given != stated:
            raise DenavitError(f"{p}: 'kinds' {list(stated)} differ from the kinds given {list(given)}")
        kinds = stated or given or ("revolute",) * q.shape[1]
        q = q * [as_ if k == "revolute" else ls for k in kinds]
        if "poses" in doc:
            T = _as_array(doc["poses"], "poses", str(p))
            if T.ndim == 3:
                T[:, :3, 3] *= ls
            return Measurements(q, None, T, str(p), [], units, kinds=kinds)
        return Measurements(q, _as_array(doc.get("points"), "points", str(p)) * ls, None, str(p), [], units, kinds=kinds)
    text = p.read_text(encoding="utf-8")
    lines = text.splitlines()
    header = next((ln for ln in lines if ln.strip() and not ln.lstrip().startswith("#")), "")
    cols = [c.strip().lower() for c in header.replace(";", ",").split(",")]
    if "joint" in cols:
        return Measurements.from_sweeps(sw.read_long_csv(p, length=length, angle=angle, kinds=None if kinds is None else list(kinds)))
    units = sw._units_comment(lines)
    if length:
        units["length"] = length
    if angle:
        units["angle"] = angle
    ls, as_ = _scales(units, str(p))
    qcols = sorted((c for c in cols if c[:1] == "q" and c[1:].isdigit()), key=lambda c: int(c[1:]))
    need = [f"q{i}" for i in range(1, len(qcols) + 1)] + ["x", "y", "z"]
    missing = [c for c in need if c not in cols]
    if missing or not qcols:
        raise DenavitError(f"{p}: header must be 'q1,...,qn,x,y,z' (optionally ',rx,ry,rz'), or a sweep file with a 'joint' column; missing {', '.join(missing) or 'q columns'}, got {header.strip()!r}")
    kinds = _joint_kinds(kinds, len(qcols), f"{p}: kinds given") or ("revolute",) * len(qcols)
    has_rot = all(c in cols for c in ("rx", "ry", "rz"))
    delim = ";" if header.count(";") > header.count(",") else ","
    q, pts, rot, where = [], [], [], []
    started = False
    for ln, line in enumerate(lines, 1):
        s = line.strip()
        if not s or s.startswith("#"):
            continue
        if not started:
            started = True
            continue
        w = f"{p}:{ln}"
        cells = [c.strip() for c in s.split(delim)]
        if len(cells) != len(cols):
            raise DenavitError(f"{w}: expected {len(cols)} values, got {len(cells)}")
        vals = {}
        for c, v in zip(cols, cells):
            try:
                vals[c] = float(v)
            except ValueError:
                raise DenavitError(f"{w}: column {c!r} must be a number, got {v!r}") from None
        q.append([vals[f"q{i}"] for i in range(1, len(qcols) + 1)])
        pts.append([vals[c] * ls for c in "xyz"])
        if has_rot:
            rot.append([vals[c] * as_ for c in ("rx", "ry", "rz")])
        where.append(w)
    if not q:
        raise DenavitError(f"{p}: no data rows after the header")
    q = np.array(q) * [as_ if k == "revolute" else ls for k in kinds]
    pts = np.array(pts)
    _check_finite(q, "q (joint readings)", str(p), where, cols="joint")
    if has_rot:
        rv = np.array(rot)
        _check_finite(rv, "rotation vector", str(p), where)
        T = np.tile(np.eye(4), (len(q), 1, 1))
        T[:, :3, :3] = Rotation.from_rotvec(rv).as_matrix()
        T[:, :3, 3] = pts
        return Measurements(q, None, T, str(p), where, units, kinds=kinds)
    return Measurements(q, pts, None, str(p), where, units, kinds=kinds)


def _scales(units: dict, where: str) -> tuple[float, float]:
    if "length" not in units or "angle" not in units:
        raise DenavitError(f"{where}: units not declared: add a line '# units: length=mm angle=deg' (or \"units\" in JSON), or pass length/angle (got {units or 'none'})")
    return length_scale(units["length"], where), angle_scale(units["angle"], where)


def to_csv(meas: Measurements, length: str = "mm", angle: str = "deg", comment: str = "") -> str:
    """The CSV text of measurements (``q1..qn,x,y,z`` and ``rx,ry,rz`` for poses), units declared; readings of
    prismatic joints (``meas.kinds``) in the length unit."""
    ls, as_ = length_scale(length), angle_scale(angle)
    qs = np.array([ls if k == "prismatic" else as_ for k in (meas.kinds or ("revolute",) * meas.nq)])
    out = [f"# {c}" for c in comment.splitlines()] + [f"# units: length={length} angle={angle}"]
    cols = [f"q{i + 1}" for i in range(meas.nq)] + ["x", "y", "z"] + (["rx", "ry", "rz"] if meas.kind == "pose" else [])
    out.append(",".join(cols))
    rv = Rotation.from_matrix(meas.poses[:, :3, :3]).as_rotvec() / as_ if meas.kind == "pose" else None
    for k in range(meas.n):
        row = [*(meas.q[k] / qs), *(meas.points[k] / ls)] + ([*rv[k]] if rv is not None else [])
        out.append(",".join(f"{v:.12g}" for v in row))
    return "\n".join(out) + "\n"


# ------------------------------------------------------------------------------------------------ model


def _as_robot(nominal) -> Robot:
    if isinstance(nominal, Robot):
        return nominal
    if isinstance(nominal, (str, Path)):
        from .robotfile import load  # noqa: PLC0415

        return load(nominal)
    if isinstance(nominal, _core.Model):
        ex = _core.extract(_core.axes(nominal, np.zeros(nominal.nq)), "edh")
        return Robot(nominal.name, ex.table, list(nominal.names), np.array(nominal.lower), np.array(nominal.upper))
    raise DenavitError(f"nominal: expected a Robot, a Model, a built-in name or a robot file, got {type(nominal).__name__}")


@dataclass(frozen=True, eq=False)
class Parametrization:
    """A calibration model: the chain of elementary factors of a nominal robot in one convention.

    ``x0`` are the nominal values; :meth:`evaluate` gives tool poses and identification Jacobians (Rust);
    :meth:`model` the kinematic :class:`denavit.Model` of any parameter vector (joint scales aside).
    """

    convention: str
    measure: str
    names: list
    x0: np.ndarray
    units: list  # per parameter: "length" | "angle" | "ratio"
    order: list  # preference order of the rank-revealing analysis (indices)
    rules: dict  # parameters fixed by the parametrisation itself -> why
    factors: list  # (axis, param, joint, T or None)
    chain: _core.CalibrationChain
    robot: Robot
    joint_factor: list  # factor index of each joint
    tool_start: int  # factors[tool_start:] form T_flange_tool (after the flange: dh's link n factors come before)
    base_end: int  # factors[:base_end] form the base

    @property
    def n_params(self) -> int:
        return len(self.names)

    @property
    def nq(self) -> int:
        return len(self.joint_factor)

    def index(self, name: str) -> int:
        try:
            return self.names.index(name)
        except ValueError:
            raise DenavitError(f"unknown parameter {name!r}: expected one of {', '.join(self.names)}") from None

    def evaluate(self, x, q, jacobian: bool = True):
        """Tool poses (N, 4, 4) and identification Jacobians (N, 6, P) (rows [v; w], world) at x for q (N, n)."""
        return self.chain.evaluate(np.asarray(x, dtype=float), np.atleast_2d(np.asarray(q, dtype=float)), jacobian)

    def _product(self, x, lo: int, hi: int) -> np.ndarray:
        T = np.eye(4)
        for axis, p, j, F in self.factors[lo:hi]:
            T = T @ (F if axis == "fixed" else _elementary(axis, x[p]))
        return T

    def base_pose(self, x) -> np.ndarray:
        """``T_world_frame0`` (the convention's frame 0 in world) of parameters x."""
        return self._product(x, 0, self.base_end)

    def model(self, x, name: str = "calibrated") -> _core.Model:
        """The kinematic model of parameters x (joint names and limits of the nominal robot; joint scales are
        not part of a model: see :attr:`Calibration.scales`)."""
        x = np.asarray(x, dtype=float)
        placements, offsets = [], []
        prev = self.base_end
        for jf in self.joint_factor:
            placements.append(self._product(x, prev, jf))
            offsets.append(x[self.factors[jf][1]])
            prev = jf + 1
        # the flange (docs/conventions.md "Frames"): dh's link n (Tz Tx Rx) after the last joint, else the last joint frame
        flange = self._product(x, prev, self.tool_start)
        tool = self._product(x, self.tool_start, len(self.factors))
        return _core.Model.from_placements(np.array(placements), self.robot.table.kinds, offsets=offsets, lower=self.robot.lower, upper=self.robot.upper,
                                           names=self.robot.names, T_world_base=_orthonormal(self.base_pose(x)), T_last_flange=_orthonormal(flange),
                                           T_flange_tool=_orthonormal(tool), name=name)

    def rebased(self, x, T_world_new_old) -> tuple[Parametrization, np.ndarray]:
        """The same parametrisation with the base moved by ``T_world_new_old`` (a change of measurement frame),
        and x with base translations updated and base angles reset to 0."""
        B = T_world_new_old @ self.base_pose(x)
        x = np.array(x, dtype=float)
        factors = list(self.factors)
        for k in range(self.base_end):
            axis, p, j, F = factors[k]
            if axis == "fixed":
                R = np.eye(4)
                R[:3, :3] = B[:3, :3]
                factors[k] = ("fixed", -1, -1, _orthonormal(R))
            elif axis.startswith("t"):
                x[p] = B["xyz".index(axis[1]), 3]
            else:
                x[p] = 0.0
        return _replace_factors(self, factors), x


def _orthonormal(T: np.ndarray) -> np.ndarray:
    U, _, Vt = np.linalg.svd(T[:3, :3])
    out = np.array(T, dtype=float)
    out[:3, :3] = U @ np.diag([1, 1, np.linalg.det(U @ Vt)]) @ Vt
    out[3] = [0, 0, 0, 1]
    return out


def _elementary(axis: str, s: float) -> np.ndarray:
    T = np.eye(4)
    if axis[0] == "t":
        T["xyz".index(axis[1]), 3] = s
        return T
    T[:3, :3] = Rotation.from_rotvec(np.eye(3)["xyz".index(axis[1])] * s).as_matrix()
    return T


def _make_chain(factors, n_params, nq, scales) -> _core.CalibrationChain:
    fixed = [F for a, _, _, F in factors if a == "fixed"]
    return _core.CalibrationChain([a for a, _, _, _ in factors], [max(p, 0) for _, p, _, _ in factors], [j for _, _, j, _ in factors],
                                  np.array(fixed).reshape(-1, 4, 4), n_params, nq, scales)


def _replace_factors(pz: Parametrization, factors) -> Parametrization:
    scales = [pz.names.index(f"scale_{j + 1}") if f"scale_{j + 1}" in pz.names else -1 for j in range(pz.nq)]
    chain = _make_chain(factors, pz.n_params, pz.nq, scales)
    return Parametrization(pz.convention, pz.measure, pz.names, pz.x0, pz.units, pz.order, pz.rules, factors, chain, pz.robot, pz.joint_factor, pz.tool_start, pz.base_end)


def _pairs_near_parallel(model: _core.Model) -> list[tuple[int, float]]:
    """(i, angle) of consecutive axes i, i+1 (1-based) within NEAR_PARALLEL_SIN of parallel (or anti-parallel)."""
    ax = _core.axes(model, np.zeros(model.nq))
    out = []
    for i in range(model.nq - 1):
        s = np.linalg.norm(np.cross(ax.directions[i], ax.directions[i + 1]))
        if s < NEAR_PARALLEL_SIN:
            out.append((i + 1, math.asin(min(s, 1.0))))
    return out


def parametrize(nominal, convention: str = "edh", *, measure: str = "point", tool=None, scale: bool = False) -> Parametrization:
    """The calibration model of ``nominal`` in ``convention`` (see the module docstring for the factors).

    Parameters
    ----------
    nominal : Robot, Model, built-in name or robot file
    convention : {"edh", "mdh", "dh"}
        ``mdh`` uses Hayati's angle ``beta`` where consecutive axes are near-parallel; ``dh`` is refused there.
    measure : {"point", "pose"}
        Measured tool points (tool = 3 translations) or full tool poses (tool = 6 parameters).
    tool : array_like, optional
        Point: the tool point (3,) in the flange frame (docs/conventions.md: DH frame n for a DH robot), metres; pose: ``T_flange_tool``
        (4, 4). Default: the nominal model's tool.
    scale : bool
        Add a scale parameter per joint (``q -> q (1 + scale)``).
    """
    conv = str(convention).lower()
    if conv not in CONVENTIONS:
        hint = " (product-of-exponentials calibration is not available yet: use edh)" if conv == "poe" else ""
        raise DenavitError(f"unknown calibration convention {convention!r}: expected one of {', '.join(CONVENTIONS)}{hint}")
    if measure not in ("point", "pose"):
        raise DenavitError(f"measure: expected 'point' or 'pose', got {measure!r}")
    robot = _as_robot(nominal)
    m = robot.model()
    n = m.nq
    kinds = list(m.kinds)
    near = _pairs_near_parallel(m)
    near_set = {i for i, _ in near}
    if conv == "dh" and near:
        lst = ", ".join(f"{i}-{i + 1} ({math.degrees(a):.3g} deg)" for i, a in near)
        raise DegenerateError(
            f"standard DH cannot calibrate {robot.name}: axes {lst} are parallel within {math.degrees(math.asin(NEAR_PARALLEL_SIN)):.2g} deg; "
            "a DH link can tilt the next axis only about their common normal (alpha); a tilt about the other perpendicular direction "
            "(Hayati's beta) sends the common normal, hence d, to infinity, so the fit cannot represent the robot or diverges "
            "(Hayati & Mirmirani 1985): use convention 'mdh' (Hayati angle beta) or 'edh'")
    ref = robot.table if robot.table.convention == conv else None
    ex = _core.extract(_core.axes(m, np.zeros(n)), conv, nominal=ref)
    table = ex.table
    P = table.params
    # tool in the convention's last frame
    F_flange = (_core.joint_frames(m, np.zeros(n))[-1] if n else np.asarray(m.T_world_base)) @ m.T_last_flange
    C_last = table.frames(np.zeros(n))[-1]
    T_tool_flange = np.asarray(m.T_flange_tool) if tool is None or measure == "point" else np.asarray(tool, dtype=float)
    if measure == "point" and tool is not None:
        tp = np.asarray(tool, dtype=float)
        if tp.shape != (3,) or not np.all(np.isfinite(tp)):
            raise DenavitError(f"tool: expected the tool point (3,) in the flange frame (m), got {np.asarray(tool).tolist()}")
        T_tool_flange = np.array(m.T_flange_tool)
        T_tool_flange[:3, 3] = tp
    if measure == "pose" and tool is not None and T_tool_flange.shape != (4, 4):
        raise DenavitError(f"tool: expected T_flange_tool (4, 4) for pose measurements, got shape {T_tool_flange.shape}")

    names, x0, units, factors, groups, along = [], [], [], [], [], []
    rules = {}

    def add(axis, name, value, unit, group, joint=-1, is_along=False):
        factors.append((axis, len(names), joint, None))
        names.append(name)
        x0.append(float(value))
        units.append(unit)
        groups.append(group)
        along.append(is_along)

    def fixed(T):
        factors.append(("fixed", -1, -1, _orthonormal(np.asarray(T, dtype=float))))

    B = np.asarray(table.T_world_base)
    for a in "xyz":
        add(f"t{a}", f"base_t{a}", B["xyz".index(a), 3], "length", "base")
    R0 = np.eye(4)
    R0[:3, :3] = B[:3, :3]
    fixed(R0)
    for a in "xyz":
        add(f"r{a}", f"base_r{a}", 0.0, "angle", "base")
    base_end = len(factors)
    joint_factor = []
    for k in range(n):
        i = k + 1
        r = P[k]
        rev = kinds[k] == "revolute"
        if conv == "edh":  # alpha, a, b, c, theta
            add("rx", f"alpha_{k}", r[0], "angle", "link")
            add("tx", f"a_{k}", r[1], "length", "link")
            add("ty", f"b_{k}", r[2], "length", "link")
            if rev:
                add("tz", f"c_{k}", r[3], "length", "link", is_along=True)
                if k in near_set:  # axes k, k+1 (1-based) near-parallel: tilt about y at frame k+1's origin
                    add("ry", f"beta_{k}", 0.0, "angle", "link")
                joint_factor.append(len(factors))
                add("rz", f"offset_{i}", r[4], "angle", "offset", k)
            else:
                if k in near_set:
                    add("ry", f"beta_{k}", 0.0, "angle", "link")
                add("rz", f"theta_{i}", r[4], "angle", "link")
                joint_factor.append(len(factors))
                add("tz", f"offset_{i}", r[3], "length", "offset", k)
        elif conv == "mdh":  # alpha, a, theta, d
            add("rx", f"alpha_{k}", r[0], "angle", "link")
            add("tx", f"a_{k}", r[1], "length", "link")
            if k in near_set:  # axes k, k+1 (1-based) near-parallel: Hayati angle
                add("ry", f"beta_{k}", 0.0, "angle", "link")
            if rev:
                add("tz", f"d_{i}", r[3], "length", "link", is_along=True)
                if i in near_set:
                    rules[f"d_{i}"] = (f"axes {i} and {i + 1} are near-parallel: their common normal, hence the position of frame {i} along axis {i}, "
                                       f"is undefined; Hayati's beta_{i} is used instead and d_{i} is fixed (Hayati & Mirmirani 1985)")
                joint_factor.append(len(factors))
                add("rz", f"offset_{i}", r[2], "angle", "offset", k)
            else:
                add("rz", f"theta_{i}", r[2], "angle", "link")
                joint_factor.append(len(factors))
                add("tz", f"offset_{i}", r[3], "length", "offset", k)
        else:  # dh: d, theta, a, alpha; link i = Rz(theta + q) Tz(d) Tx(a) Rx(alpha)
            if rev:
                joint_factor.append(len(factors))
                add("rz", f"offset_{i}", r[1], "angle", "offset", k)
                add("tz", f"d_{i}", r[0], "length", "link", is_along=True)
            else:
                add("rz", f"theta_{i}", r[1], "angle", "link")
                joint_factor.append(len(factors))
                add("tz", f"offset_{i}", r[0], "length", "offset", k)
            add("tx", f"a_{i}", r[2], "length", "link")
            add("rx", f"alpha_{i}", r[3], "angle", "link")
    fixed(np.linalg.inv(C_last) @ F_flange)  # the nominal flange in the convention's last frame: the tool is in the flange
    tool_start = len(factors)
    for a in "xyz":
        add(f"t{a}", f"tool_{a}", T_tool_flange["xyz".index(a), 3], "length", "tool")
    Rt = np.eye(4)
    Rt[:3, :3] = T_tool_flange[:3, :3]
    fixed(Rt)
    if measure == "pose":
        for a in "xyz":
            add(f"r{a}", f"tool_r{a}", 0.0, "angle", "tool")
    scales = [-1] * n
    if scale:
        for k in range(n):
            scales[k] = len(names)
            names.append(f"scale_{k + 1}")
            x0.append(0.0)
            units.append("ratio")
            groups.append("scale")
            along.append(False)
    P_ = len(names)
    rank_of = {"base": 0, "tool": 1, "link": 2, "offset": 3, "scale": 4}
    order = sorted(range(P_), key=lambda c: (5, -c) if along[c] else (rank_of[groups[c]], c))
    chain = _make_chain(factors, P_, n, scales)
    pz = Parametrization(conv, measure, names, np.array(x0), units, order, rules, factors, chain, robot, joint_factor, tool_start, base_end)
    # the chain must reproduce the nominal model (with the tool); where the convention's table lost something
    # (an MDH table has no tilt about y), the parameters are fitted to the nominal model's kinematics.
    Q = configurations(robot, max(3 * P_, 60))
    truth = _core.fk_batch(m.with_tool(T_tool_flange), Q)
    pred, _ = pz.evaluate(pz.x0, Q, False)
    err = np.abs(pred[:, :3, 3] - truth[:, :3, 3]).max() + (np.abs(pred[:, :3, :3] - truth[:, :3, :3]).max() if measure == "pose" else 0.0)
    if err > 1e-10:
        target = Measurements(Q, None, truth, "nominal model") if measure == "pose" else Measurements(Q, truth[:, :3, 3], None, "nominal model")
        free = [c for c in range(P_) if names[c] not in rules and not names[c].startswith("scale_")]
        ana = _analyze(pz, pz.x0, target, free, np.ones(6), explain=False)
        x, _ = _solve(pz, pz.x0, ana.kept_idx, target, np.ones(6), "linear", None)
        pz = Parametrization(conv, measure, names, x, units, order, rules, factors, chain, robot, joint_factor, tool_start, base_end)
        pred, _ = pz.evaluate(pz.x0, Q, False)
        err = np.abs(pred[:, :3, 3] - truth[:, :3, 3]).max()
        if err > 1e-8:
            raise DegenerateError(f"the {conv} calibration chain cannot reproduce the nominal model {robot.name}: tool error {err * 1e3:.3g} mm after fitting it; use convention 'edh'")
    return pz


def configurations(nominal, count: int, *, skip: int = 1) -> np.ndarray:
    """``count`` deterministic configurations spread over the joint limits (a Halton sequence; revolute limits
    clipped to +-pi), shape (count, n)."""
    robot = _as_robot(nominal)
    lo = np.array(robot.lower, dtype=float)
    hi = np.array(robot.upper, dtype=float)
    rev = np.array([k == "revolute" for k in robot.table.kinds])
    lo = np.where(rev, np.maximum(lo, -math.pi), lo)
    hi = np.where(rev, np.minimum(hi, math.pi), hi)
    return lo + (hi - lo) * _halton(count, len(lo), skip)


_HALTON: dict = {}


def _halton(count: int, n: int, skip: int) -> np.ndarray:
    """(count, n) points of the Halton sequence in [0, 1) (bases the first primes), from index ``skip``."""
    key = (count, n, skip)
    if key not in _HALTON:
        out = np.empty((count, n))
        for j in range(n):
            b = _PRIMES[j % len(_PRIMES)]
            k = np.arange(skip, skip + count, dtype=float) + (j // len(_PRIMES)) * 7
            f, r = 1.0, np.zeros(count)
            while np.any(k > 0):
                f /= b
                r += f * (k % b)
                k = np.floor(k / b)
            out[:, j] = r
        if len(_HALTON) > 64:
            _HALTON.clear()
        _HALTON[key] = out
        out.flags.writeable = False
    return _HALTON[key]


# ------------------------------------------------------------------------------------------------ analysis


@dataclass(frozen=True)
class Unidentifiable:
    """A parameter the data cannot identify, and why.

    ``combination`` maps the kept parameters whose joint effect equals this parameter's to the coefficients
    (SI units of the kept parameter per unit of this one); ``structural`` is True when no data could
    identify it in this parametrisation (it is redundant), False when these measurements cannot.
    """

    name: str
    reason: str
    structural: bool
    combination: dict


@dataclass(frozen=True, eq=False)
class Identifiability:
    """Rank, base parameters, conditioning and observability of the identification Jacobian.

    Attributes
    ----------
    candidates : list of str
        The parameters analysed (not fixed by the user or the parametrisation).
    rank : int
        Numerical rank of the column-normalised Jacobian (tolerance :data:`RANK_TOL`).
    base_parameters : list of str
        The identifiable set kept (``rank`` names).
    unidentifiable : list of Unidentifiable
    singular_values : ndarray
        Of the column-normalised Jacobian of the base parameters, descending.
    condition_number : float
        ``s_1 / s_L``.
    observability : dict
        ``O1`` ... ``O5`` (module docstring).
    n_poses : int
    """

    candidates: list
    rank: int
    base_parameters: list
    unidentifiable: list
    singular_values: np.ndarray
    condition_number: float
    observability: dict
    n_poses: int
    kept_idx: list = field(default_factory=list, repr=False)

    def summary(self) -> str:
        o = self.observability
        return (f"rank {self.rank} of {len(self.candidates)} candidate parameters over {self.n_poses} poses; condition number {self.condition_number:.3g}; "
                + ", ".join(f"{k} {v:.3g}" for k, v in o.items()))


def _weights(measure: str, sigma_p: float, sigma_r: float) -> np.ndarray:
    return np.array([1 / sigma_p] * 3 + ([1 / sigma_r] * 3 if measure == "pose" else [0.0] * 3))


def _rows(pz: Parametrization, jac: np.ndarray, w: np.ndarray) -> np.ndarray:
    """Weighted Jacobian rows (3N or 6N, P)."""
    k = 6 if pz.measure == "pose" else 3
    return (jac[:, :k, :] * w[:k, None]).reshape(-1, jac.shape[2])


def _gram(A: np.ndarray) -> np.ndarray:
    """``A^T A`` by einsum. The matrices here are tall and thin (3N x P): a multithreaded BLAS / LAPACK call on
    them can be a hundred times slower than this on a loaded machine, so every factorisation below works on
    the small P x P Gram matrix instead."""
    return np.einsum("ij,ik->jk", A, A)


def _rank_reveal(J: np.ndarray, order: list, tol: float = RANK_TOL):
    """Rank-revealing Cholesky of the Gram matrix of the unit-norm columns, in preference order (the same
    decisions as a Gram-Schmidt QR in that order): a column whose squared distance from the span of the columns
    kept before it is below ``tol**2`` is dropped. Returns (kept, dropped, zero columns, column norms, L, G)
    with ``G`` the Gram matrix of the unit-norm columns and ``L`` (k x k, lower) its Cholesky factor on kept."""
    G = _gram(J)
    norms = np.sqrt(np.clip(np.diag(G), 0, None))
    top = norms.max() if norms.size else 0.0
    safe = np.where(norms > 0, norms, 1.0)
    G = G / np.outer(safe, safe)
    # right-looking elimination in preference order: S is the Schur complement of the kept columns
    S = G.copy()
    cols = []
    kept, dropped, zero = [], [], set()
    for c in order:
        if not norms[c] > 1e-12 * top:
            dropped.append(c)
            zero.add(c)
            continue
        d = S[c, c]
        if d < tol**2:
            dropped.append(c)
            continue
        l = S[:, c] / math.sqrt(d)
        S -= np.outer(l, l)
        cols.append(l)
        kept.append(c)
    L = np.array(cols).T[kept] if kept else np.zeros((0, 0))  # G[kept][:, kept] = L L^T, lower triangular
    return kept, dropped, zero, norms, L, G


def _combinations(G: np.ndarray, L: np.ndarray, kept: list, dropped: list, norms: np.ndarray) -> dict:
    """For each dropped column: the kept columns whose combination reproduces it (SI coefficients per unit of
    the dropped parameter), largest first, at most 4, ignoring terms below 2 % of a unit-norm column."""
    cols = [c for c in dropped if norms[c] > 0]
    if not kept or not cols:
        return {}
    coef = cho_solve((L, True), G[np.ix_(kept, cols)], check_finite=False)
    out = {}
    for i, c in enumerate(cols):
        d = {}
        for k in np.argsort(-np.abs(coef[:, i]))[:4]:
            if abs(coef[k, i]) < 0.02:
                break
            d[kept[k]] = float(coef[k, i] * norms[c] / norms[kept[k]])
        out[c] = d
    return out


def _analyze(pz: Parametrization, x, meas: Measurements, candidates: list, w: np.ndarray, structural: Identifiability | None = None, joint_hint: str = "",
             explain: bool = True) -> Identifiability:
    """Rank-revealing analysis of the weighted identification Jacobian at x (module docstring); with
    ``explain=False`` only the kept / dropped sets (no reasons, no singular values).

    With ``structural`` (the analysis of the same candidates on configurations spread over the joint limits),
    the parameters it keeps come first: a structural dependency holds for any data, so what these data drop
    beyond it are parameters the structural analysis kept, and holding exactly those fixed restores full rank.
    """
    _, jac = pz.evaluate(x, meas.q, True)
    J = _rows(pz, jac, w)
    cand = set(candidates)
    order = [c for c in pz.order if c in cand]
    if structural is not None:
        first = set(structural.kept_idx)
        order = [c for c in order if c in first] + [c for c in order if c not in first]
    kept, dropped, zero, norms, L, G = _rank_reveal(J, order)
    combs = _combinations(G, L, kept, dropped, norms) if explain else {}
    un = []
    for c in dropped:
        name = pz.names[c]
        comb = combs.get(c, {})
        struct = structural is not None and c not in structural.kept_idx
        reason = _reason(pz, name, c in zero, comb, struct, joint_hint) if explain else ""
        un.append(Unidentifiable(name, reason, struct, {pz.names[k]: v for k, v in comb.items()}))
    names_order = [pz.names[c] for c in order]
    if not explain:
        return Identifiability(names_order, len(kept), [pz.names[c] for c in kept], un, np.zeros(0), math.nan, {}, meas.n, kept)
    # the unit-norm kept columns are Q L^T (Q orthonormal): their singular values are those of L
    sv = np.linalg.svd(L, compute_uv=False) if kept else np.zeros(0)
    m = meas.n
    if sv.size and sv[-1] > 0:
        obs = {"O1": float(np.exp(np.mean(np.log(sv))) / math.sqrt(m)), "O2": float(sv[-1] / sv[0]), "O3": float(sv[-1]),
               "O4": float(sv[-1] ** 2 / sv[0]), "O5": float(1.0 / np.sum(1.0 / sv))}
        cond = float(sv[0] / sv[-1])
    else:
        obs = {k: 0.0 for k in ("O1", "O2", "O3", "O4", "O5")}
        cond = math.inf
    return Identifiability(names_order, len(kept), [pz.names[c] for c in kept], un, sv, cond, obs, m, kept)


def _fmt_coef(name: str, v: float, pz: Parametrization, dropped: str) -> str:
    u = {"length": "m", "angle": "rad", "ratio": ""}
    ku, du = u[pz.units[pz.names.index(name)]], u[pz.units[pz.names.index(dropped)]]
    unit = "" if ku == du else f" {ku}/{du}" if du else f" {ku}"
    return f"{v:+.4g}{unit} x {name}"


def _reason(pz: Parametrization, name: str, zero: bool, comb: dict, structural: bool, joint_hint: str) -> str:
    if zero:
        why = "the measurements do not depend on it at all"
        if name.startswith("tool_r") and pz.measure == "point":
            why += " (a rotation of the tool about its own measured point)"
    else:
        terms = ", ".join(_fmt_coef(pz.names[k], v, pz, name) for k, v in comb.items())
        why = f"its effect on every measurement equals that of {terms}" if terms else "its effect is a combination of many parameters"
    kept = [pz.names[k] for k in comb]
    hints = []
    if name.startswith(("c_", "d_")) and (pz.convention == "edh" and name.startswith("c_") or pz.convention != "edh"):
        j = int(name.split("_")[1]) + (1 if pz.convention == "edh" else 0)
        hints.append(f"it slides joint frame {j}'s origin along axis {j}, which "
                     + ("the tool absorbs" if any(k.startswith("tool_") for k in kept) else "the following links absorb"))
    if any(k.startswith("base_") for k in kept) and not name.startswith("base_"):
        hints.append("the base frame, which is identified, already places joint frame 1")
    if name == f"offset_{pz.nq}" and any(k.startswith("tool_") for k in kept):
        hints.append("the tool's position about the last axis sets the same angle")
    if name.startswith("offset_") and pz.convention == "edh" and f"beta_{int(name.split('_')[1]) - 1}" in pz.names:
        i = int(name.split("_")[1])
        hints.append(f"axes {i - 1} and {i} are near-parallel, so the direction of x_{i - 1} (their common normal) is a free choice, "
                     f"which offset_{i - 1} and the translations of link {i} absorb")
    lead = "redundant in the " + pz.convention + " parametrisation (no data can identify it)" if structural else "not determined by these measurements"
    tail = f"; {'; '.join(hints)}" if hints else ""
    return f"{lead}: {why}{tail}{joint_hint}; fixed at its start value"


# ------------------------------------------------------------------------------------------------ solver


def _residual(pz: Parametrization, x, meas: Measurements, w: np.ndarray, jacobian: bool = True):
    poses, jac = pz.evaluate(x, meas.q, jacobian)
    rp = poses[:, :3, 3] - meas.points
    if pz.measure == "pose":
        rr = Rotation.from_matrix(np.einsum("nij,nkj->nik", poses[:, :3, :3], meas.poses[:, :3, :3])).as_rotvec()
        r = np.hstack([rp * w[0], rr * w[3]])
    else:
        r = rp * w[0]
    return r.ravel(), (None if jac is None else _rows(pz, jac, w)), poses


def _solve(pz: Parametrization, x_start, free: list, meas: Measurements, w: np.ndarray, loss: str, f_scale: float | None, max_nfev: int | None = None):
    """Least squares over the parameters ``free`` (indices) from ``x_start``; returns (x, scipy result)."""
    x_base = np.array(x_start, dtype=float)
    free = list(free)
    if not free:
        return x_base, None
    cache = {}
    x0 = x_base[free].copy()

    # the unknowns are the changes from the start: MINPACK's first step is bounded by 100 |x| in scaled
    # units, which is useless when the start is (nearly) zero but not exactly
    def full(z):
        x = x_base.copy()
        x[free] = x0 + z
        return x

    def evaluate(z):
        key = z.tobytes()
        if key not in cache:
            cache.clear()
            r, J, _ = _residual(pz, full(z), meas, w)
            cache[key] = (r, J[:, free])
        return cache[key]

    z0 = np.zeros(len(free))
    method = "lm" if loss == "linear" and len(evaluate(z0)[0]) >= len(free) else "trf"
    kw = {} if loss == "linear" else {"loss": loss, "f_scale": f_scale or 1.0}
    # copies: MINPACK may write into the arrays it is given, which must not corrupt the cache
    sol = least_squares(lambda z: evaluate(z)[0].copy(), z0, jac=lambda z: evaluate(z)[1].copy(), method=method, x_scale="jac",
                        xtol=1e-12, ftol=1e-12, gtol=1e-12, max_nfev=max_nfev or 100 * (len(free) + 1), **kw)
    return full(sol.x), sol


def _kabsch(P: np.ndarray, M: np.ndarray) -> np.ndarray:
    """The rigid transform W minimising |W P - M| (Kabsch / Umeyama without scale)."""
    cp, cm = P.mean(axis=0), M.mean(axis=0)
    H = (P - cp).T @ (M - cm)
    U, _, Vt = np.linalg.svd(H)
    D = np.diag([1, 1, np.sign(np.linalg.det(Vt.T @ U.T)) or 1.0])
    R = Vt.T @ D @ U.T
    W = np.eye(4)
    W[:3, :3] = R
    W[:3, 3] = cm - R @ cp
    return W


def _register(pz: Parametrization, x, meas: Measurements, base_free: bool):
    """Move the base so the nominal model's tool points best match the measured ones (a change of the
    measurement frame), when that improves the fit; returns the new parametrisation and x."""
    if not base_free or meas.n < 3:
        return pz, x
    pred, _ = pz.evaluate(x, meas.q, False)
    P = pred[:, :3, 3]
    if np.linalg.matrix_rank(P - P.mean(axis=0), tol=1e-9) < 2:
        return pz, x
    W = _kabsch(P, meas.points)
    before = np.sqrt(np.mean(np.sum((P - meas.points) ** 2, axis=1)))
    after = np.sqrt(np.mean(np.sum((P @ W[:3, :3].T + W[:3, 3] - meas.points) ** 2, axis=1)))
    if before > REGISTER_RMS and after < 0.5 * before:
        return pz.rebased(x, W)
    return pz, x


# ------------------------------------------------------------------------------------------------ results


@dataclass(frozen=True)
class Validation:
    """Tool-position errors (m) on held-out poses, before (nominal geometry, base and tool fitted on the
    training poses) and after calibration."""

    n_train: int
    n_test: int
    before_rms: float
    before_max: float
    after_rms: float
    after_max: float
    test_indices: np.ndarray


@dataclass(frozen=True, eq=False)
class Calibration:
    """The result of :func:`calibrate` (SI inside; ``world`` = the measurement frame).

    ``values`` / ``sigma`` / ``status`` are per parameter (``names``); ``sigma`` is NaN for parameters not
    estimated (``status`` "fixed" by the user or the parametrisation, or "unidentifiable": see
    ``identifiability.unidentifiable`` for the reason). ``covariance`` and ``correlation`` are over
    ``free_names`` (in that order).
    """

    parametrization: Parametrization
    names: list
    values: np.ndarray
    sigma: np.ndarray
    status: list
    nominal: np.ndarray
    start: np.ndarray
    free_names: list
    covariance: np.ndarray
    correlation: np.ndarray
    identifiability: Identifiability
    residuals: np.ndarray
    rms: float
    rms_rotation: float
    outliers: np.ndarray
    validation: Validation | None
    measurements: Measurements
    loss: str
    converged: bool
    evaluations: int
    elapsed: float
    noise: float
    notes: list = field(default_factory=list)

    @property
    def convention(self) -> str:
        return self.parametrization.convention

    def value(self, name: str) -> tuple[float, float]:
        """(value, sigma) of one parameter (SI)."""
        k = self.parametrization.index(name)
        return float(self.values[k]), float(self.sigma[k])

    @property
    def scales(self) -> dict:
        """Joint scale corrections (``q -> q (1 + scale)``), when estimated."""
        return {n: float(v) for n, v in zip(self.names, self.values) if n.startswith("scale_")}

    def model(self, name: str | None = None) -> _core.Model:
        """The calibrated kinematic model (world = the measurement frame)."""
        return self.parametrization.model(self.values, name or f"{self.parametrization.robot.name} calibrated")

    def table(self, convention: str | None = None) -> _core.Table:
        """The calibrated model as a parameter table (default: the calibration convention; an MDH table
        cannot hold Hayati angles: prefer ``edh`` or :meth:`model` then)."""
        conv = convention or self.convention
        m = self.model()
        nom = self.parametrization.robot.table
        return _core.extract(_core.axes(m, np.zeros(m.nq)), conv, nominal=nom if nom.convention == conv else None).table

    def robot(self, name: str | None = None, convention: str = "edh") -> Robot:
        """A :class:`Robot` of the calibrated model (for :func:`denavit.robotfile.save`)."""
        r = self.parametrization.robot
        return Robot(name or f"{r.name}_calibrated", self.table(convention), list(r.names), r.lower, r.upper,
                     description=f"{r.name} calibrated from {self.measurements.source} ({self.convention}, {self.measurements.n} poses)", source=self.measurements.source, home=r.home)


def _table_residuals(res: np.ndarray, measure: str) -> np.ndarray:
    return res.reshape(-1, 6 if measure == "pose" else 3)


def calibrate(
    meas: Measurements | SweepSet,
    nominal,
    *,
    convention: str = "edh",
    fix=(),
    loss: str = "linear",
    f_scale: float | None = None,
    start: str = "nominal",
    scale: bool = False,
    tool=None,
    noise: float | None = None,
    noise_rot: float | None = None,
    holdout: float = 0.0,
    seed: int = 0,
) -> Calibration:
    """Fit the whole kinematic model to measured tool points or poses (one least-squares problem).

    Parameters
    ----------
    meas : Measurements or SweepSet
        Joint readings and measured points / poses in the measurement frame.
    nominal : Robot, Model, built-in name or robot file
        The nominal robot: the parametrisation, the start, names and limits.
    convention : {"edh", "mdh", "dh"}
        Parametrisation (module docstring).
    fix : iterable of str, or dict
        Parameters to hold at their start values, by name or shell pattern (``"base_*"``, ``"tool_z"``); a dict
        maps names to values (SI) to hold them at.
    loss : {"linear", "soft_l1", "huber", "cauchy", "arctan"}
        scipy's robust losses (per residual coordinate); ``f_scale`` (m) defaults to 3 robust sigmas of a
        first linear fit.
    start : {"nominal", "circles"}
        Start from the nominal model (base registered to the data), or from the circle-point identification
        (:func:`denavit.identify.identify`, global fit; sweep data only).
    scale : bool
        Also estimate a scale per joint.
    tool : array_like, optional
        Tool point (3,) in the flange frame, m (points), or ``T_flange_tool`` (4, 4) (poses); default nominal.
    noise, noise_rot : float, optional
        Known one-sigma noise per coordinate (m) and of the rotation (rad); default: estimated from the residuals.
    holdout : float
        Fraction of the poses held out of the fit to validate it (position error before / after).
    seed : int
        Seed of the held-out split.

    Returns
    -------
    Calibration
    """
    t0 = time.perf_counter()
    if isinstance(meas, SweepSet):
        meas = Measurements.from_sweeps(meas)
    if not isinstance(meas, Measurements):
        raise DenavitError(f"calibrate: expected Measurements or a SweepSet, got {type(meas).__name__}")
    robot = _as_robot(nominal)
    n = len(robot.names)
    if meas.nq != n:
        raise DenavitError(f"{meas.source}: the data has {meas.nq} joint readings per pose but the nominal model {robot.name} has {n} joints ({', '.join(robot.names)})")
    for j, (got, want) in enumerate(zip(meas.kinds or robot.table.kinds, robot.table.kinds)):
        if got != want:
            unit = meas.units.get("angle" if got == "revolute" else "length", "?")
            raise DenavitError(f"{meas.source}: joint {j + 1} ({robot.names[j]}) of {robot.name} is {want}, but its readings were read as {got} (in {unit}): "
                               f"pass kinds={list(robot.table.kinds)} to read_measurements (or state \"kinds\" in a JSON file)")
    if loss not in LOSSES:
        raise DenavitError(f"unknown loss {loss!r}: expected one of {', '.join(LOSSES)}")
    if not 0.0 <= holdout < 0.9:
        raise DenavitError(f"holdout: expected a fraction in [0, 0.9), got {holdout}")
    if start not in ("nominal", "circles"):
        raise DenavitError(f"start: expected 'nominal' or 'circles', got {start!r}")
    notes: list[str] = []
    pz = parametrize(robot, convention, measure=meas.kind, tool=tool, scale=scale)
    x = pz.x0.copy()
    user_fixed = _resolve_fix(pz, fix)
    for k, v in user_fixed.items():
        if v is not None:
            x[k] = v
    rule_fixed = {pz.index(nm) for nm in pz.rules}
    candidates = [c for c in range(pz.n_params) if c not in user_fixed and c not in rule_fixed]

    # held-out split
    test_idx = np.zeros(0, dtype=int)
    train = meas
    if holdout > 0:
        n_test = int(round(holdout * meas.n))
        perm = np.random.default_rng(seed).permutation(meas.n)
        if n_test >= 1 and 3 * (meas.n - n_test) > len(candidates) + 1:
            test_idx = np.sort(perm[:n_test])
            train = meas.subset(np.sort(perm[n_test:]))
        else:
            notes.append(f"holdout {holdout} skipped: {meas.n} poses are too few to hold any out")

    # weights (1/sigma); pose data without declared noise: re-estimated after a first fit
    sig_p = noise if noise is not None else 1e-5
    sig_r = noise_rot if noise_rot is not None else 1e-5
    w = _weights(pz.measure, sig_p, sig_r)

    # 1) register the measurement frame, then fit base and tool only: the nominal geometry at its best
    base_idx = [c for c in candidates if pz.names[c].startswith("base_")]
    pz, x = _register(pz, x, train, base_free=len(base_idx) == 6)
    reg_free = [c for c in candidates if pz.names[c].startswith(("base_", "tool_"))]
    reg = _analyze(pz, x, train, reg_free, w, explain=False)
    x_reg, _ = _solve(pz, x, reg.kept_idx, train, w, "linear", None)

    # 2) identifiability: structural (configurations over the joint limits) and of these data
    rich = Measurements(configurations(robot, max(2 * pz.n_params, 60)), np.zeros((max(2 * pz.n_params, 60), 3)), None, "spread configurations")
    if pz.measure == "pose":
        rich = Measurements(rich.q, None, np.tile(np.eye(4), (rich.n, 1, 1)), rich.source)
    struct = _analyze(pz, x_reg, rich, candidates, w, explain=False)
    structural = {u.name for u in struct.unidentifiable}
    still = [j for j in range(n) if np.ptp(train.q[:, j]) < 1e-9]
    hint = "".join(f"; joint {j + 1} ({robot.names[j]}) never moves in the data" for j in still)
    ana = _analyze(pz, x_reg, train, candidates, w, struct, hint)
    data_only = [u.name for u in ana.unidentifiable if not u.structural]
    n_eq = train.n * (6 if pz.measure == "pose" else 3)
    if n_eq <= struct.rank:
        per = 6 if pz.measure == "pose" else 3
        raise DenavitError(f"{meas.source}: too few measurements: {train.n} {'poses' if per == 6 else 'points'} give {n_eq} equations for the {struct.rank} parameters "
                           f"this model can identify ({', '.join(struct.base_parameters)}); need at least {struct.rank // per + 1} "
                           f"{'poses' if per == 6 else 'points'} (many more to average the noise), or fix parameters")
    if still and data_only:
        vals = ", ".join(f"q{j + 1} = {train.q[0, j]:.6g}" for j in still)
        raise DenavitError(f"{meas.source}: joint(s) {', '.join(f'{j + 1} ({robot.names[j]})' for j in still)} never move in the data ({vals} in all {train.n} poses): "
                           f"the data cannot identify {', '.join(data_only)} (beyond the parameters redundant in any case); move the joint(s), "
                           f"or hold these fixed: fix={[u.name for u in ana.unidentifiable]}")

    # 3) start
    x_start = x_reg.copy()
    if start == "circles":
        x_start = _circle_start(pz, x_reg, meas, robot, convention, ana.kept_idx, notes)
    # 4) the fit
    free = ana.kept_idx
    x_hat, sol = _solve(pz, x_start, free, train, w, "linear", None)
    r, J, _ = _residual(pz, x_hat, train, w)
    if pz.measure == "pose" and (noise is None or noise_rot is None):
        rr = _table_residuals(r, "pose")
        dof = max(len(r) - len(free), 1) / len(r)
        sig_p = noise if noise is not None else float(np.sqrt(np.sum((rr[:, :3] / w[0]) ** 2) / (rr[:, :3].size * dof)))
        sig_r = noise_rot if noise_rot is not None else float(np.sqrt(np.sum((rr[:, 3:] / w[3]) ** 2) / (rr[:, 3:].size * dof)))
        sig_p, sig_r = max(sig_p, 1e-12), max(sig_r, 1e-12)
        w = _weights(pz.measure, sig_p, sig_r)
        x_hat, sol = _solve(pz, x_hat, free, train, w, "linear", None)
        r, J, _ = _residual(pz, x_hat, train, w)
    wt = np.ones_like(r)
    robust_s2 = None
    if loss != "linear":
        # f_scale: 3 robust sigmas of the misfits, re-estimated once from the robust fit (the first estimate,
        # from the linear fit, is inflated by the outliers' pull)
        for _ in range(2 if f_scale is None else 1):
            mis = np.linalg.norm(_table_residuals(r, pz.measure)[:, :3], axis=1)
            robust = float(np.median(mis)) / math.sqrt(2.366) if mis.size else 1.0  # weighted units; median of chi_3 = sqrt(2.366)
            fs = f_scale * w[0] if f_scale is not None else 3 * robust
            x_hat, sol = _solve(pz, x_hat, free, train, w, loss, fs)
            r, J, _ = _residual(pz, x_hat, train, w)
        mis = np.linalg.norm(_table_residuals(r, pz.measure)[:, :3], axis=1)
        robust_s2 = (float(np.median(mis)) / math.sqrt(2.366)) ** 2
        wt = _loss_weight(loss, (r / fs) ** 2)
    converged = sol is None or sol.status > 0
    nfev = 0 if sol is None else int(sol.nfev)
    Jf = J[:, free] * np.sqrt(wt)[:, None]
    m_eq, p = Jf.shape
    known = noise is not None and (pz.measure == "point" or noise_rot is not None)
    s2 = 1.0 if known else robust_s2 if robust_s2 is not None else float(np.sum(r**2)) / max(m_eq - p, 1)
    cov = _covariance(Jf, s2)
    sd = np.sqrt(np.clip(np.diag(cov), 0, None))
    with np.errstate(invalid="ignore", divide="ignore"):
        corr = cov / np.outer(sd, sd)
    sigma = np.full(pz.n_params, np.nan)
    sigma[free] = sd
    status = []
    dropped = {u.name for u in ana.unidentifiable}
    for c, nm in enumerate(pz.names):
        status.append("free" if c in free else "fixed" if c in user_fixed else "fixed (parametrisation)" if nm in pz.rules
                      else ("redundant" if nm in structural else "unidentifiable") if nm in dropped else "fixed")
    res_si = _table_residuals(r, pz.measure) / w[: (6 if pz.measure == "pose" else 3)]
    full_r, _, _ = _residual(pz, x_hat, meas, np.ones(6), jacobian=False)
    full_r = _table_residuals(full_r, pz.measure)
    pos = np.linalg.norm(full_r[:, :3], axis=1)
    rms = float(np.sqrt(np.mean(pos**2)))
    rms_rot = float(np.sqrt(np.mean(np.sum(full_r[:, 3:] ** 2, axis=1)))) if pz.measure == "pose" else math.nan
    mis = np.linalg.norm(res_si[:, :3], axis=1)
    robust = float(np.median(mis)) / math.sqrt(2.366) if mis.size else 0.0
    outliers = np.flatnonzero(pos > OUTLIER_SIGMAS * max(robust, 1e-300))
    # validation
    validation = None
    if test_idx.size:
        test = meas.subset(test_idx)
        before = np.linalg.norm(_residual(pz, x_reg, test, np.ones(6), jacobian=False)[2][:, :3, 3] - test.points, axis=1)
        after = np.linalg.norm(_residual(pz, x_hat, test, np.ones(6), jacobian=False)[2][:, :3, 3] - test.points, axis=1)
        validation = Validation(train.n, test.n, float(np.sqrt(np.mean(before**2))), float(before.max()), float(np.sqrt(np.mean(after**2))), float(after.max()), test_idx)
    # notes
    if not converged:
        notes.append(f"the least-squares solver stopped without meeting its tolerances ({sol.message})")
    size = max(float(np.max(np.linalg.norm(meas.points - meas.points.mean(axis=0), axis=1))), 1e-3)
    lengths = [c for c in free if pz.units[c] == "length" and not pz.names[c].startswith("base_")]
    far = [pz.names[c] for c in lengths if abs(x_hat[c] - pz.x0[c]) > 10 * size]
    if far:
        notes.append(f"parameters moved by more than 10 x the measured volume ({', '.join(far)}): the fit may have diverged; check the nominal model and the units")
    strong = _strong_correlations(corr, [pz.names[c] for c in free])
    if strong:
        notes.append("strongly correlated (their combination is far better determined than either): "
                     + ", ".join(f"{a} / {b} (rho {rho:+.5f})" for a, b, rho in strong))
    if outliers.size:
        notes.append(f"{outliers.size} pose(s) with a tool-position misfit above {OUTLIER_SIGMAS} robust sigmas: {', '.join(meas.where[i] for i in outliers[:5])}{' ...' if outliers.size > 5 else ''}")
    noise_est = math.sqrt(s2) * sig_p if not known else sig_p
    return Calibration(pz, list(pz.names), x_hat, sigma, status, pz.x0, x_start, [pz.names[c] for c in free], cov, corr, ana, res_si, rms, rms_rot, outliers,
                       validation, meas, loss, converged, nfev, time.perf_counter() - t0, float(noise_est), notes)


def _loss_weight(loss: str, z: np.ndarray) -> np.ndarray:
    """rho'(z) of scipy.optimize.least_squares' losses, z = (residual / f_scale)^2 (the IRLS weights)."""
    if loss == "soft_l1":
        return 1.0 / np.sqrt(1.0 + z)
    if loss == "huber":
        return np.where(z <= 1.0, 1.0, 1.0 / np.sqrt(np.maximum(z, 1.0)))
    if loss == "cauchy":
        return 1.0 / (1.0 + z)
    if loss == "arctan":
        return 1.0 / (1.0 + z**2)
    return np.ones_like(z)


def _covariance(J: np.ndarray, s2: float) -> np.ndarray:
    """``s2 (J^T J)^-1`` from the Gram matrix of the column-scaled J (stable for mixed units; see :func:`_gram`)."""
    if J.shape[1] == 0:
        return np.zeros((0, 0))
    G = _gram(J)
    d = np.sqrt(np.clip(np.diag(G), 0, None))
    d = np.where(d > 0, d, 1.0)
    A = G / np.outer(d, d)
    try:
        inv = cho_solve(cho_factor(A, lower=True, check_finite=False), np.eye(len(A)), check_finite=False)
    except np.linalg.LinAlgError:  # singular: the pseudo-inverse (callers pass identifiable columns only)
        ev, V = np.linalg.eigh(A)
        inv = (V / np.maximum(ev, ev.max() * 1e-15)) @ V.T
    return s2 * inv / np.outer(d, d)


def _strong_correlations(corr: np.ndarray, names: list, limit: float = 0.999) -> list:
    out = []
    for i in range(len(names)):
        for j in range(i + 1, len(names)):
            if abs(corr[i, j]) > limit:
                out.append((names[i], names[j], float(corr[i, j])))
    return sorted(out, key=lambda t: -abs(t[2]))[:5]


def _resolve_fix(pz: Parametrization, fix) -> dict:
    out = {}
    items = fix.items() if isinstance(fix, dict) else ((f, None) for f in ([fix] if isinstance(fix, str) else fix))
    for pat, value in items:
        pat = str(pat).strip()
        if not pat:
            continue
        hits = [c for c, nm in enumerate(pz.names) if fnmatch.fnmatchcase(nm, pat)]
        if not hits:
            raise DenavitError(f"fix: {pat!r} matches no parameter of the {pz.convention} model of {pz.robot.name}: expected names or patterns of {', '.join(pz.names)}")
        for c in hits:
            out[c] = None if value is None else float(value)
    return out


def _circle_start(pz: Parametrization, x, meas: Measurements, robot: Robot, convention: str, free: list, notes: list) -> np.ndarray:
    """Start values from the circle-point identification (global fit of the sweeps): the chain is fitted to
    the identified model's predictions at the measured configurations."""
    from . import identify as ident  # noqa: PLC0415

    if meas.sweeps is None:
        raise DenavitError(f"{meas.source}: start='circles' needs sweep data (Measurements.from_sweeps); these are arbitrary poses: use start='nominal'")
    if pz.measure != "point":
        raise DenavitError("start='circles' works with measured points (sweeps), not poses")
    res = ident.identify(meas.sweeps, method="global", convention="edh", nominal=robot)
    m = res.model()
    tp = np.asarray(m.T_flange_tool)[:3, 3]
    T = _core.fk_batch(m.with_tool(np.eye(4)), meas.q)
    target = Measurements(meas.q, T[:, :3, :3] @ tp + T[:, :3, 3], None, "circle-point identification")
    xs, _ = _solve(pz, x, free, target, np.ones(6), "linear", None)
    notes.append(f"started from the circle-point identification (global fit, residual rms {res.rms * 1e3:.4g} mm)")
    return xs


# ------------------------------------------------------------------------------------------------ planning


@dataclass(frozen=True)
class Protocol:
    """A sweep protocol: joint *j* runs from ``ranges[j][0]`` to ``ranges[j][1]`` (rad / m, absolute) with the
    others at ``home`` (Hayat et al. Table II), ``points_per_sweep`` points each; the tool point (m) in the
    flange frame."""

    home: np.ndarray
    ranges: np.ndarray
    points_per_sweep: int = 30
    tool_point: np.ndarray = field(default_factory=lambda: np.array([0.05, 0.03, 0.10]))

    @classmethod
    def paper(cls, degrees: int = 30, points_per_sweep: int = 30, tool_point=(0.05, 0.03, 0.10)) -> Protocol:
        """Hayat et al.'s protocol (Table II, 90 or 30 degree ranges, home A1 90, A2 -90, A3 90, A4 0, A5 90, A6 0)."""
        if degrees not in PAPER_RANGES_DEG:
            raise DenavitError(f"paper protocol: expected 90 or 30 degrees, got {degrees}")
        return cls(np.radians(PAPER_HOME_DEG), np.radians(PAPER_RANGES_DEG[degrees]), points_per_sweep, np.asarray(tool_point, dtype=float))

    def configurations(self) -> np.ndarray:
        """(n * points_per_sweep, n) configurations, sweep by sweep (as :func:`denavit.sweeps.simulate`)."""
        home = np.asarray(self.home, dtype=float)
        ranges = np.asarray(self.ranges, dtype=float)
        n = len(home)
        if ranges.shape != (n, 2):
            raise DenavitError(f"protocol: expected ranges of shape ({n}, 2), got {ranges.shape}")
        if self.points_per_sweep < 3:
            raise DenavitError(f"protocol: points_per_sweep must be >= 3, got {self.points_per_sweep}")
        out = []
        for j in range(n):
            qs = np.tile(home, (self.points_per_sweep, 1))
            qs[:, j] = np.linspace(ranges[j, 0], ranges[j, 1], self.points_per_sweep)
            out.append(qs)
        return np.vstack(out)


@dataclass(frozen=True, eq=False)
class Plan:
    """Predicted uncertainty of a measurement protocol, before anything is measured.

    Attributes
    ----------
    names : list of str
        Every parameter of the parametrisation.
    sigma : ndarray, shape (P,)
        Cramér-Rao bound (one sigma) of each parameter for the given noise (NaN: not estimated; see
        ``identifiability``).
    covariance : ndarray, (F, F) over ``free_names``.
    identifiability : Identifiability
    box : fitting.BoundingBox
        Minimum oriented bounding box of the measured points (the measuring volume).
    q : ndarray, (N, n)
        Configurations of the plan (after selection).
    points : ndarray, (N, 3)
        Predicted tool points (nominal model).
    selected : ndarray of int or None
        Indices into the candidate set, in the order chosen (D-optimal greedy).
    axis_sigma : ndarray, shape (n, 2)
        Per joint: bound of the axis position across the axis (m, at the foot of the reference tool point, as
        :attr:`denavit.fitting.AxisFit.sigma_point_perp`) and of its direction (rad), at ``q_ref``.
    per_circle_sigma : ndarray, shape (n, 2) or None
        The same bounds for one readings fit per sweep (:func:`denavit.fitting.fit_axis_with_readings`,
        the best per-circle method), when a protocol of sweeps is planned.
    """

    parametrization: Parametrization
    names: list
    sigma: np.ndarray
    free_names: list
    covariance: np.ndarray
    identifiability: Identifiability
    box: fitting.BoundingBox
    q: np.ndarray
    points: np.ndarray
    noise: float
    selected: np.ndarray | None
    q_ref: np.ndarray
    axis_sigma: np.ndarray
    per_circle_sigma: np.ndarray | None
    notes: list = field(default_factory=list)

    def value(self, name: str) -> float:
        return float(self.sigma[self.parametrization.index(name)])


def plan(
    nominal,
    protocol: Protocol | None = None,
    *,
    q=None,
    noise: float = 2e-5,
    noise_rot: float | None = None,
    convention: str = "edh",
    fix=(),
    measure: str = "point",
    tool=None,
    scale: bool = False,
    select: int | None = None,
) -> Plan:
    """Predict every parameter's sigma (Cramér-Rao bound) and the measuring volume of a protocol.

    Parameters
    ----------
    nominal : Robot, Model, built-in name or robot file
    protocol : Protocol, optional
        Sweeps (ranges, points per sweep, tool point). Or give ``q``:
    q : array_like, shape (N, n), optional
        Candidate configurations; with ``select=k`` the k most informative are chosen (greedy D-optimal:
        each step adds the pose that most increases ``log det`` of the information matrix of the
        column-normalised Jacobian; Fedorov 1972).
    noise : float
        One-sigma noise per point coordinate (m); ``noise_rot`` (rad) for pose measurements.
    convention, fix, measure, tool, scale
        As in :func:`calibrate`; ``tool`` defaults to the protocol's tool point.
    """
    robot = _as_robot(nominal)
    if protocol is None and q is None:
        raise DenavitError("plan: give a protocol (sweep ranges) or candidate configurations q")
    if not noise > 0:
        raise DenavitError(f"plan: noise must be > 0 (m), got {noise}")
    n = len(robot.names)
    if protocol is not None:
        Q = protocol.configurations()
        if Q.shape[1] != n:
            raise DenavitError(f"plan: the protocol has {Q.shape[1]} joints, {robot.name} has {n}")
        tool = protocol.tool_point if tool is None else tool
        q_ref = np.asarray(protocol.home, dtype=float)
    else:
        Q = _as_array(q, "q", "plan")
        if Q.ndim != 2 or Q.shape[1] != n:
            raise DenavitError(f"plan: q must have shape (N, {n}), got {Q.shape}")
        _check_finite(Q, "q", "plan", [], cols="joint")
        q_ref = np.zeros(n)
    pz = parametrize(robot, convention, measure=measure, tool=tool, scale=scale)
    x = pz.x0
    sig_r = noise_rot if noise_rot is not None else noise
    w = _weights(measure, noise, sig_r)
    user_fixed = _resolve_fix(pz, fix)
    rule_fixed = {pz.index(nm) for nm in pz.rules}
    candidates = [c for c in range(pz.n_params) if c not in user_fixed and c not in rule_fixed]
    selected = None
    if select is not None:
        selected = select_poses(pz, Q, int(select), candidates=candidates, w=w)
        Q = Q[selected]
    poses, _ = pz.evaluate(x, Q, False)
    meas = Measurements(Q, None, poses, "plan") if measure == "pose" else Measurements(Q, poses[:, :3, 3], None, "plan")
    rich_q = configurations(robot, max(2 * pz.n_params, 60))
    rich_p, _ = pz.evaluate(x, rich_q, False)
    rich = Measurements(rich_q, None, rich_p, "spread") if measure == "pose" else Measurements(rich_q, rich_p[:, :3, 3], None, "spread")
    ana = _analyze(pz, x, meas, candidates, w, _analyze(pz, x, rich, candidates, w, explain=False))
    _, J, _ = _residual(pz, x, meas, w)
    free = ana.kept_idx
    cov = _covariance(J[:, free], 1.0)
    sigma = np.full(pz.n_params, np.nan)
    sigma[free] = np.sqrt(np.clip(np.diag(cov), 0, None))
    box = fitting.oriented_bounding_box(meas.points)
    axis_sigma = _axis_sigma(pz, x, free, cov, q_ref)
    per_circle = _per_circle(pz, protocol, noise) if protocol is not None else None
    notes = []
    if meas.n * (6 if measure == "pose" else 3) <= len(free):
        notes.append(f"{meas.n} poses give fewer equations than the {len(free)} identifiable parameters")
    return Plan(pz, list(pz.names), sigma, [pz.names[c] for c in free], cov, ana, box, Q, meas.points, noise, selected, q_ref, axis_sigma, per_circle, notes)


def axis_lines(model: _core.Model, q_ref, p_ref) -> tuple[np.ndarray, np.ndarray]:
    """Joint axes at ``q_ref`` as (n, 3) points (the foot of the point ``p_ref`` on each axis, the circle
    centre of a sweep through it) and (n, 3) unit directions."""
    F = _core.joint_frames(model, q_ref)
    o, z = F[:, :3, 3], F[:, :3, 2]
    c = o + z * np.sum((p_ref - o) * z, axis=1)[:, None]
    return c, z


def _axis_sigma(pz: Parametrization, x, free: list, cov: np.ndarray, q_ref) -> np.ndarray:
    """Per joint: sigma of the axis position across itself (at the circle centre of the tool point at q_ref)
    and of its direction, by first-order propagation (central differences of the joint frames)."""
    n = pz.nq
    p_ref = pz.evaluate(x, q_ref[None], False)[0][0, :3, 3]
    _, base_z = axis_lines(pz.model(x), q_ref, p_ref)
    D = np.zeros((6 * n, len(free)))
    for k, c in enumerate(free):
        h = 1e-7
        xp, xm = np.array(x, dtype=float), np.array(x, dtype=float)
        xp[c] += h
        xm[c] -= h
        cp, zp = axis_lines(pz.model(xp), q_ref, p_ref)
        cm, zm = axis_lines(pz.model(xm), q_ref, p_ref)
        D[:, k] = np.hstack([cp - cm, zp - zm]).ravel() / (2 * h)
    C = D @ cov @ D.T
    out = np.zeros((n, 2))
    for j in range(n):
        P = np.eye(3) - np.outer(base_z[j], base_z[j])
        out[j, 0] = math.sqrt(max(np.trace(P @ C[6 * j : 6 * j + 3, 6 * j : 6 * j + 3] @ P), 0.0))
        out[j, 1] = math.sqrt(max(np.trace(C[6 * j + 3 : 6 * j + 6, 6 * j + 3 : 6 * j + 6]), 0.0))
    return out


def _per_circle(pz: Parametrization, protocol: Protocol, noise: float) -> np.ndarray:
    """First-order axis bounds of one readings fit per noise-free simulated sweep."""
    n = pz.nq
    Q = protocol.configurations().reshape(n, protocol.points_per_sweep, n)
    out = np.full((n, 2), np.nan)
    for j in range(n):
        pts = pz.evaluate(pz.x0, Q[j], False)[0][:, :3, 3]
        if pz.robot.table.kinds[j] == "prismatic":
            f = fitting.fit_line(pts, q=Q[j][:, j], noise_sigma=noise)
        else:
            f = fitting.fit_axis_with_readings(pts, Q[j][:, j], noise_sigma=noise)
        out[j] = (f.sigma_point_perp, f.sigma_direction)
    return out


def select_poses(pz: Parametrization, q, k: int, *, candidates=None, w=None) -> np.ndarray:
    """Greedy D-optimal selection of ``k`` configurations from the candidate set ``q`` (N, n): each step adds
    the pose maximising ``log det(I + J_c M^-1 J_c^T)`` (the gain in ``log det M``, M the information matrix of
    the column-normalised Jacobian of the identifiable parameters, started at a small ridge). Returns the
    indices in the order chosen."""
    Q = _as_array(q, "q", "select")
    N = Q.shape[0]
    if not 1 <= k <= N:
        raise DenavitError(f"select: expected 1 <= k <= {N} (the number of candidates), got {k}")
    w = _weights(pz.measure, 1.0, 1.0) if w is None else w
    cand = list(range(pz.n_params)) if candidates is None else list(candidates)
    _, jac = pz.evaluate(pz.x0, Q, True)
    rows = 6 if pz.measure == "pose" else 3
    Jall = (jac[:, :rows, :] * w[:rows, None])[:, :, cand]
    kept, _, _, norms, _, _ = _rank_reveal(Jall.reshape(-1, len(cand)), [cand.index(c) for c in pz.order if c in cand])
    Jall = Jall[:, :, kept] / norms[kept]
    p = len(kept)
    M = np.eye(p) * 1e-6 * N * rows / max(p, 1)
    chosen: list[int] = []
    avail = np.ones(N, dtype=bool)
    for _ in range(k):
        Minv = np.linalg.inv(M)
        A = np.einsum("nrp,pq,nsq->nrs", Jall, Minv, Jall)
        gain = np.linalg.slogdet(np.eye(rows) + A)[1]
        gain[~avail] = -np.inf
        c = int(np.argmax(gain))
        chosen.append(c)
        avail[c] = False
        M = M + Jall[c].T @ Jall[c]
    return np.array(chosen)


# ------------------------------------------------------------------------------------------------ simulation


def simulate(model, q, *, tool=(0.05, 0.03, 0.10), noise: float = 0.0, noise_rot: float = 0.0, measure: str = "point", seed: int = 0, T_world_base=None) -> Measurements:
    """Measurements of ``model`` (a Model / Robot / name) at configurations ``q`` (N, n): the tool point (3,)
    in the flange frame (or, for ``measure="pose"``, ``T_flange_tool`` (4, 4)) with Gaussian noise ``noise``
    (m, per coordinate) and ``noise_rot`` (rad, a rotation vector per pose); ``T_world_base`` moves the robot
    in the measurement frame."""
    m = model if isinstance(model, _core.Model) else _as_robot(model).model()
    if T_world_base is not None:
        m = m.with_base(np.asarray(T_world_base, dtype=float))
    Q = np.atleast_2d(np.asarray(q, dtype=float))
    rng = np.random.default_rng(seed)
    if measure == "pose":
        T = _core.fk_batch(m.with_tool(np.asarray(tool, dtype=float)), Q)
        if noise > 0:
            T[:, :3, 3] += rng.normal(0.0, noise, (len(Q), 3))
        if noise_rot > 0:
            T[:, :3, :3] = Rotation.from_rotvec(rng.normal(0.0, noise_rot, (len(Q), 3))).as_matrix() @ T[:, :3, :3]
        return Measurements(Q, None, T, f"simulated {m.name}", kinds=m.kinds)
    F = _core.fk_batch(m.with_tool(np.eye(4)), Q)
    p = F[:, :3, :3] @ np.asarray(tool, dtype=float) + F[:, :3, 3]
    if noise > 0:
        p = p + rng.normal(0.0, noise, p.shape)
    return Measurements(Q, p, None, f"simulated {m.name}", kinds=m.kinds)


# ------------------------------------------------------------------------------------------------ output


def _unit_scale(unit: str, ls: float, as_: float) -> float:
    return ls if unit == "length" else as_ if unit == "angle" else 1.0


def to_json(cal: Calibration, length: str = "mm", angle: str = "deg") -> dict:
    """The JSON document of a calibration (units stated)."""
    ls, as_ = length_scale(length), angle_scale(angle)
    pz = cal.parametrization
    rows = []
    for c, nm in enumerate(cal.names):
        s = _unit_scale(pz.units[c], ls, as_)
        rows.append({"name": nm, "unit": {"length": length, "angle": angle, "ratio": "1"}[pz.units[c]], "nominal": cal.nominal[c] / s, "value": cal.values[c] / s,
                     "sigma": None if not np.isfinite(cal.sigma[c]) else cal.sigma[c] / s, "status": cal.status[c]})
    ana = cal.identifiability
    m = cal.model()
    v = cal.validation
    return {
        "units": {"length": length, "angle": angle},
        "frame": "measurement",
        "source": cal.measurements.source,
        "nominal": pz.robot.name,
        "convention": cal.convention,
        "measure": pz.measure,
        "n_poses": cal.measurements.n,
        "loss": cal.loss,
        "parameters": rows,
        "identifiability": {
            "rank": ana.rank, "candidates": ana.candidates, "base_parameters": ana.base_parameters, "condition_number": ana.condition_number,
            "observability": ana.observability,
            "unidentifiable": [{"name": u.name, "structural": u.structural, "reason": u.reason, "combination": u.combination} for u in ana.unidentifiable],
        },
        "covariance": {"names": cal.free_names, "matrix_si": _finite_or_none(cal.covariance)},
        "correlation": _finite_or_none(cal.correlation),
        "residuals": {"rms": cal.rms / ls, "max": float(np.max(np.linalg.norm(cal.residuals[:, :3], axis=1))) / ls if cal.residuals.size else 0.0,
                      "rms_rotation": None if math.isnan(cal.rms_rotation) else cal.rms_rotation / as_, "noise_estimate": cal.noise / ls,
                      "outliers": [cal.measurements.where[i] for i in cal.outliers]},
        "validation": None if v is None else {"n_train": v.n_train, "n_test": v.n_test, "before_rms": v.before_rms / ls, "before_max": v.before_max / ls,
                                             "after_rms": v.after_rms / ls, "after_max": v.after_max / ls},
        "model": {"T_world_base": _pose_json(np.asarray(m.T_world_base), ls), "T_last_flange": _pose_json(np.asarray(m.T_last_flange), ls),
                  "T_flange_tool": _pose_json(np.asarray(m.T_flange_tool), ls),
                  "placements": [_pose_json(P, ls) for P in np.asarray(m.placements)], "offsets": [o / (as_ if k == "revolute" else ls) for o, k in zip(m.offsets, m.kinds)]},
        "converged": cal.converged,
        "evaluations": cal.evaluations,
        "elapsed_s": cal.elapsed,
        "notes": cal.notes,
    }


def _finite_or_none(a: np.ndarray) -> list:
    """A nested list with non-finite entries as None (JSON has no NaN)."""
    return [[float(v) if math.isfinite(v) else None for v in row] for row in np.asarray(a, dtype=float)]


def _pose_json(T: np.ndarray, ls: float) -> list:
    M = np.array(T, dtype=float)
    M[:3, 3] /= ls
    return M.tolist()


def write_json(cal: Calibration, path, length: str = "mm", angle: str = "deg") -> None:
    """Write the calibration as JSON (whole or not at all)."""
    write_text(path, json.dumps(to_json(cal, length, angle), indent=2) + "\n")


__all__ = [
    "Calibration",
    "Identifiability",
    "Measurements",
    "Parametrization",
    "Plan",
    "Protocol",
    "Unidentifiable",
    "Validation",
    "axis_lines",
    "calibrate",
    "configurations",
    "parametrize",
    "plan",
    "read_measurements",
    "select_poses",
    "simulate",
    "to_csv",
    "to_json",
    "write_json",
]
