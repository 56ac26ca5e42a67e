"""Scoring a saved model on another measurement session (``denavit validate MODEL DATA``, :func:`validate`).

The job of a calibration is to predict where the robot goes at poses that were not measured; this scores that on
a session the model never saw: every pose's tool-position error (measured minus predicted), their RMS, maximum and
percentiles, each pose flagged where the model extrapolates, and ISO 9283's pose accuracy and repeatability where
the session holds repeated poses.

Registration. The data are compared with the model in the frame the model was calibrated in (``"frozen"``, the
default: the model's ``T_world_base`` and tool as saved), or, for a session measured from another placement of
the tracker, after re-fitting base and tool with the kinematic parameters frozen (``"refit"``): the base
``T_world_base`` (6) and the tool point in the flange frame (3; for 6-DoF poses also the tool's orientation) by
closed form (Horn / Kabsch alternated with the tool point's linear least squares, then the tool orientation as the
chordal mean of ``R_pred^T R_meas``) and a Gauss-Newton polish over small rotation vectors (no gimbal lock). A
refit absorbs 9 of the ``3 N`` position residuals: the expected mean square error is then ``(3 N - 9) / N``
sigma^2 instead of ``3`` sigma^2 (the noise per coordinate).

Extrapolation flags (per pose, ``flags``):

* ``"outside_training_range"``: a joint value outside the range of the training poses, when the model carries them
  (a :class:`~denavit.calibration.Calibration`: its measurements; an identification: its sweeps; a robot file
  written by ``calibrate --save``: its ``[training]`` table, :func:`training_table`); the joints are in
  ``outside_joints``.
* ``"large_predicted_sigma"``: the predicted tool-position error (1 sigma, 3-D, from the model's covariance:
  :func:`denavit.compensation.predicted_sigma` for a calibration or an identification,
  :func:`denavit.compensation.table_sigma` for a robot file's ``[covariance]``) above ``max_sigma`` (m) when given,
  else above :data:`SIGMA_FACTOR` times the median predicted sigma over the training poses (over this session's
  poses when the model carries none, or only their ranges: a robot file).

ISO 9283 (Manipulating industrial robots: performance criteria and related test methods, 1998), clause 7.2. Poses
whose joint readings agree within ``repeat_tol`` (rad / m, every joint) are visits of one commanded pose
``j = 1..n``; per group of ``n >= 2`` visits, with the attained (measured) positions ``(x_j, y_j, z_j)`` and the
commanded position ``(x_c, y_c, z_c)`` (the model's prediction at the group's readings, in the registration used):

* pose accuracy (7.2.1): ``AP_P = sqrt((x_bar - x_c)^2 + (y_bar - y_c)^2 + (z_bar - z_c)^2)``, with
  ``x_bar = (1/n) sum_j x_j`` (likewise y, z): the distance between the barycentre of the attained positions and
  the commanded position;
* pose repeatability (7.2.2): ``RP_l = l_bar + 3 S_l``, with ``l_j = sqrt((x_j - x_bar)^2 + (y_j - y_bar)^2 +
  (z_j - z_bar)^2)``, ``l_bar = (1/n) sum_j l_j`` and ``S_l = sqrt(sum_j (l_j - l_bar)^2 / (n - 1))``: the radius
  of the sphere about the barycentre that holds the attained positions.

The standard cycles each pose 30 times; fewer visits give the same statistics with more scatter (a note says so).
Orientation accuracy (AP_a, AP_b, AP_c) is not computed.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .. import _core
from ..errors import DenavitError
from ..geometry import kabsch, matrix_rotvec, pose, rotvec_matrix
from ..robot import Robot, robot_of
from .compliance import elastic_of, with_payload
from .measurements import Measurements
from .targets import as_measurements, as_target_measurements, several_targets, sweep_poses

#: ``registration`` values: keep the model's base and tool, or re-fit them with the kinematics frozen.
REGISTRATIONS = ("frozen", "refit")
#: A pose is flagged ``large_predicted_sigma`` above this many times the median predicted sigma of the training poses.
SIGMA_FACTOR = 3.0
#: Readings within this of each other on every joint (rad for a revolute joint, m for a prismatic one) are one
#: commanded pose visited again (ISO 9283 groups): 0.006 deg, about a controller's resolution of a repeated target.
REPEAT_TOL = 1e-4
#: The percentiles of the position errors reported (``percentiles_m``: ``p50_m``, ...).
PERCENTILES = (50, 90, 95, 99)
#: ISO 9283 cycles each pose this many times.
ISO_CYCLES = 30
#: Alternations of Kabsch and the tool point at most in the re-fitted registration, and Gauss-Newton steps after.
ALTERNATIONS, POLISH = 50, 20


@dataclass(frozen=True)
class PoseGroup:
    """One commanded pose visited ``n`` times (ISO 9283): its poses' indices, accuracy AP and repeatability RP (m)."""

    indices: np.ndarray
    barycentre: np.ndarray
    commanded: np.ndarray
    ap: float
    rp: float

    @property
    def n(self) -> int:
        return len(self.indices)


@dataclass(frozen=True, eq=False)
class ModelValidation:
    """The result of :func:`validate` (SI; ``world`` = the session's measurement frame).

    ``errors`` (N,) are the tool-position errors ``|measured - predicted|`` (m), ``error_vectors`` (N, 3) the
    differences, ``rotation_errors`` (N,) the angles of ``R_pred^T R_meas`` (rad; pose data, else None);
    ``sigma`` (N,) the predicted error (1 sigma, m) where the model has a covariance, else None; ``flags`` per pose
    a tuple of flag names (module docstring), ``outside`` per pose the joints (0-based) outside the training range.
    """

    model_name: str
    source: str
    measure: str
    registration: str
    q: np.ndarray
    where: list
    measured: np.ndarray
    predicted: np.ndarray
    errors: np.ndarray
    error_vectors: np.ndarray
    rotation_errors: np.ndarray | None
    sigma: np.ndarray | None
    sigma_limit: float | None
    flags: list
    outside: list
    training_lower: np.ndarray | None
    training_upper: np.ndarray | None
    groups: list
    T_world_base: np.ndarray
    T_flange_tool: np.ndarray
    joint_names: list
    notes: list = field(default_factory=list)

    @property
    def n(self) -> int:
        return len(self.errors)

    @property
    def rms(self) -> float:
        return float(np.sqrt(np.mean(self.errors**2)))

    @property
    def max(self) -> float:
        return float(self.errors.max())

    @property
    def rms_rotation(self) -> float | None:
        return None if self.rotation_errors is None else float(np.sqrt(np.mean(self.rotation_errors**2)))

    @property
    def percentiles(self) -> dict:
        """{percentile: error (m)} at :data:`PERCENTILES` (linear interpolation)."""
        return {p: float(np.percentile(self.errors, p)) for p in PERCENTILES}

    @property
    def n_flagged(self) -> int:
        return sum(1 for f in self.flags if f)

    def flagged(self, name: str) -> np.ndarray:
        """Indices of the poses flagged ``name``."""
        return np.array([i for i, f in enumerate(self.flags) if name in f], dtype=int)

    def __repr__(self) -> str:
        iso = (
            f"; ISO 9283 over {len(self.groups)} repeated poses: AP max {max(g.ap for g in self.groups) * 1e3:.4g} mm,"
            f" RP max {max(g.rp for g in self.groups) * 1e3:.4g} mm"
            if self.groups
            else ""
        )
        return (
            f"ModelValidation({self.model_name} on {self.n} {self.measure}s of {self.source}, registration"
            f" {self.registration}: tool-position error rms {self.rms * 1e3:.4g} mm, max {self.max * 1e3:.4g} mm,"
            f" {self.n_flagged} flagged{iso})"
        )


def _model_of(model):
    """(kinematic Model, name, covariance source or None, training readings or None, readings -> joint values) of
    whatever ``model`` is: a Calibration, an Identification, a Robot or a Model."""

    if hasattr(model, "parametrization") and hasattr(model, "covariance"):  # a Calibration
        sc = model.scales
        scale = np.array([sc.get(f"scale_{j + 1}", 0.0) for j in range(model.parametrization.nq)])

        def joints(q):
            return q * (1 + scale)

        return (
            model.model(),
            f"{model.parametrization.robot.name} calibrated",
            model,
            np.asarray(model.measurements.q),
            joints,
        )
    if hasattr(model, "axis_cov") and hasattr(model, "sweeps"):  # an Identification
        from ..compensation import reading_model  # noqa: PLC0415
        from ..robot import joint_values  # noqa: PLC0415

        rm = reading_model(model)
        qs = [s.q for s in model.sweeps.sweeps if getattr(s, "q", None) is not None]
        training = np.vstack(qs) if qs else None
        return (
            model.model(),
            getattr(model, "name", None) or "identified",
            model,
            training,
            (lambda q: q) if rm is None else (lambda q: joint_values(q, *rm)),
        )
    if isinstance(model, _core.Model):
        return model, model.name, None, None, lambda q: q
    robot = robot_of(model)
    return (
        robot.model(),
        robot.name,
        robot if robot.covariance is not None else None,
        robot.training,
        robot.joint_values if robot.has_reading_model else (lambda q: q),
    )


def _predicted_sigma(source, readings: np.ndarray, q: np.ndarray) -> np.ndarray:
    from ..compensation import predicted_sigma, table_sigma  # noqa: PLC0415

    if isinstance(source, Robot):
        return table_sigma(source, q)
    if hasattr(source, "parametrization"):
        return predicted_sigma(source, readings)  # the chain applies its own scales to the readings
    return predicted_sigma(source, q)


def _tool_transform(model: _core.Model, tool) -> np.ndarray:
    T = np.array(model.T_flange_tool, dtype=float)
    if tool is None:
        return T
    t = np.asarray(tool, dtype=float)
    if t.shape == (3,) and np.all(np.isfinite(t)):
        T[:3, 3] = t
        return T
    if t.shape == (4, 4) and np.all(np.isfinite(t)):
        return t
    raise DenavitError(
        f"tool: expected the tool point (3,) in the flange frame (m) or T_flange_tool (4, 4), got shape {t.shape}"
    )


def refit_registration(F: np.ndarray, meas: Measurements, T_tool: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(T_world_base, T_flange_tool) that best put the flange poses ``F`` (N, 4, 4, in the robot base frame) with
    the tool onto the measured points (and, for poses, the tool's orientation onto the measured orientations), the
    kinematics frozen: Kabsch alternated with the tool point's linear least squares, then Gauss-Newton over
    small rotation vectors of the base and the tool point (module docstring)."""
    m = meas.points
    R, o = F[:, :3, :3], F[:, :3, 3]
    t = np.array(T_tool[:3, 3], dtype=float)
    A = R.reshape(-1, 3)
    W = np.eye(4)
    for _ in range(ALTERNATIONS):
        W = kabsch(R @ t + o, m)
        rhs = ((m - W[:3, 3]) @ W[:3, :3] - o).ravel()  # R_W^T (m - t_W) - o = R_i t
        t_new = np.linalg.lstsq(A, rhs, rcond=None)[0]
        done = np.linalg.norm(t_new - t) < 1e-12
        t = t_new
        if done:
            break
    for _ in range(
        POLISH
    ):  # Gauss-Newton on [dphi_W, dt_W, dt_tool]: p = exp(dphi) R_W (R_i (t + dt_tool) + o_i) + t_W + dt_W
        p_local = R @ t + o
        p = p_local @ W[:3, :3].T + W[:3, 3]
        r = (p - m).ravel()
        J = np.zeros((len(m), 3, 9))
        pw = p - W[:3, 3]
        J[:, :, 0:3] = -_skew_batch(pw)
        J[:, :, 3:6] = np.eye(3)
        J[:, :, 6:9] = W[:3, :3] @ R
        d = np.linalg.lstsq(J.reshape(-1, 9), -r, rcond=None)[0]
        W = pose(rotvec_matrix(d[:3]) @ W[:3, :3], W[:3, 3] + d[3:6])
        t = t + d[6:9]
        if np.linalg.norm(d) < 1e-13:
            break
    T = np.array(T_tool, dtype=float)
    T[:3, 3] = t
    if meas.poses is not None:  # the tool's orientation: the chordal mean of (R_W R_i)^T R_meas
        M = np.einsum("nji,njk->ik", np.einsum("ij,njk->nik", W[:3, :3], R), meas.poses[:, :3, :3])
        U, _, Vt = np.linalg.svd(M)
        T[:3, :3] = U @ np.diag([1.0, 1.0, np.sign(np.linalg.det(U @ Vt))]) @ Vt
    return W, T


def _skew_batch(v: np.ndarray) -> np.ndarray:
    S = np.zeros((len(v), 3, 3))
    S[:, 0, 1], S[:, 0, 2], S[:, 1, 2] = -v[:, 2], v[:, 1], -v[:, 0]
    S[:, 1, 0], S[:, 2, 0], S[:, 2, 1] = v[:, 2], -v[:, 1], v[:, 0]
    return S


def repeat_groups(q: np.ndarray, tol: float = REPEAT_TOL) -> list[np.ndarray]:
    """The groups (index arrays, 2 or more poses each) of poses whose readings agree within ``tol`` on every joint
    (connected through such pairs: a KD-tree's pairs in the Chebyshev metric)."""
    from scipy.sparse import coo_matrix  # noqa: PLC0415
    from scipy.sparse.csgraph import connected_components  # noqa: PLC0415
    from scipy.spatial import cKDTree  # noqa: PLC0415

    n = len(q)
    pairs = cKDTree(q).query_pairs(tol, p=np.inf, output_type="ndarray")
    if not len(pairs):
        return []
    g = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n, n))
    _, label = connected_components(g, directed=False)
    counts = np.bincount(label)
    return [np.flatnonzero(label == k) for k in np.flatnonzero(counts >= 2)]


def iso9283(measured: np.ndarray, commanded: np.ndarray) -> tuple[float, float, np.ndarray]:
    """(AP_P, RP_l, barycentre) of one commanded position ``commanded`` (3,) visited as ``measured`` (n, 3), m
    (ISO 9283 clause 7.2.1 and 7.2.2; module docstring)."""
    bary = measured.mean(axis=0)
    ap = float(np.linalg.norm(bary - commanded))
    lj = np.linalg.norm(measured - bary, axis=1)
    s = float(np.sqrt(np.sum((lj - lj.mean()) ** 2) / (len(lj) - 1))) if len(lj) > 1 else 0.0
    return ap, float(lj.mean() + 3 * s), bary


def validate(
    model,
    data,
    *,
    registration: str = "frozen",
    tool=None,
    max_sigma: float | None = None,
    sigma_factor: float = SIGMA_FACTOR,
    repeat_tol: float = REPEAT_TOL,
    points=None,
    poses=None,
    target: int | None = None,
    payload=None,
) -> ModelValidation:
    """Score ``model`` on the measurement session ``data`` (module docstring).

    Parameters
    ----------
    model : Calibration, Identification, Robot or Model (:func:`denavit.validate` also takes a built-in name, a robot
        file or a URDF)
        The model to score (its base and tool included: the frame it was calibrated in).
    data : Measurements, SweepSet, TargetMeasurements (:func:`denavit.validate` also reads a path), or joint readings
    ``q``
        (N, n) rad / m with ``points`` (N, 3) m or ``poses`` (N, 4, 4). Several targets per pose with their nest: every
        target is scored at its nest point in the model's tool frame (one row per target); without a nest, target 1.
    registration : {"frozen", "refit"}
        Keep the model's base and tool, or re-fit them with the kinematics frozen.
    tool : array_like, optional
        The tool point (3,) in the flange frame (m), or ``T_flange_tool`` (4, 4): replaces the model's tool.
    max_sigma : float, optional
        Flag poses whose predicted sigma exceeds this (m); default ``sigma_factor`` x the training poses' median.
    repeat_tol : float
        Readings within this on every joint (rad / m) are one commanded pose (ISO 9283 groups).
    target : int, optional
        Several targets per pose: score this one alone (0-based), against the model's tool point.
    payload : float, (mass, (x, y, z)) or (N, 4), optional
        The payload (kg; its centre of mass in the flange frame, m) of every pose where the data carry none (a pose
        file's ``payload_mass`` columns): a model with compliant joints (:mod:`denavit.calibration.compliance`) is
        predicted with its joints deflected under gravity and the payload, its sigma with the compliances' covariance.

    Returns
    -------
    ModelValidation
    """

    if registration not in REGISTRATIONS:
        raise DenavitError(f"registration: expected 'frozen' or 'refit', got {registration!r}")
    for what, v in (("max_sigma", max_sigma), ("sigma_factor", sigma_factor), ("repeat_tol", repeat_tol)):
        if v is not None and not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
            raise DenavitError(f"{what}: expected a finite value > 0, got {v!r}")

    km, name, cov_source, training, joints = _model_of(model)
    n = km.nq
    data = as_measurements(data, km.kinds, points=points, poses=poses, target=target)
    notes: list[str] = []
    meas, nest_rows, per_pose = _scored_rows(data, notes)
    if meas.nq != n:
        raise DenavitError(
            f"{meas.source}: the data has {meas.nq} joint readings per pose but the model {name} has {n} joints"
            f" ({', '.join(km.names)})"
        )
    if meas.kinds is not None and tuple(meas.kinds) != tuple(km.kinds):
        raise DenavitError(
            f"{meas.source}: joint kinds {list(meas.kinds)} differ from the model {name}'s {list(km.kinds)}"
        )
    el = elastic_of(model)  # compliant joints (compliance.py): the links sit at q - k tau(q, payload)
    if el is not None and payload is not None and meas.payload is None:
        meas = with_payload(meas, payload)
    readings = np.asarray(meas.q, dtype=float)
    q = joints(readings)
    if el is not None:
        q = el.deflected(q, meas.payload)
        notes.append(
            "joints deflected under"
            f" gravity{' and the payload' if meas.payload is not None else ' (no payload declared)'} by the model's"
            " compliances"
        )
    elif payload is not None or meas.payload is not None:
        notes.append(
            f"the payload changes nothing: {name} has no joint compliances (a robot file's [compliance], a calibration"
            " that freed them): predicted as a rigid arm"
        )
    T_tool = _tool_transform(km, tool)
    T_base = np.array(km.T_world_base, dtype=float)
    if registration == "refit":
        T_base, T_tool = _refit(km, q, meas, nest_rows, T_tool, T_base, notes)
    pm = km.with_base(T_base).with_tool(T_tool)
    P = _core.fk_batch(pm, q)
    if nest_rows is not None:
        P[:, :3, 3] += np.einsum("nij,nj->ni", P[:, :3, :3], nest_rows)
    measured = np.asarray(meas.points, dtype=float)
    vec = measured - P[:, :3, 3]
    errors = np.linalg.norm(vec, axis=1)
    rot = None
    if meas.poses is not None:
        rot = np.linalg.norm(matrix_rotvec(np.einsum("nji,njk->nik", P[:, :3, :3], meas.poses[:, :3, :3])), axis=1)
    lo, hi, outside = _outside(training, joints, q, meas.n)
    sigma, limit = _sigmas(cov_source, readings, q, el, meas, max_sigma, sigma_factor, training, joints, name, notes)
    flags = []
    for i in range(meas.n):
        f = []
        if outside[i]:
            f.append("outside_training_range")
        if sigma is not None and limit is not None and sigma[i] > limit:
            f.append("large_predicted_sigma")
        flags.append(tuple(f))
    if training is None:
        notes.append(
            f"no training joint ranges: the model {name} does not carry its training poses (a calibration, an"
            " identification, or a robot file from calibrate --save with its [training] table does)"
        )
    groups = _iso_groups(readings, per_pose, repeat_tol, measured, P, notes)
    return ModelValidation(
        name,
        meas.source,
        meas.kind,
        registration,
        q,
        list(meas.where),
        measured,
        P[:, :3, 3].copy(),
        errors,
        vec,
        rot,
        sigma,
        limit,
        flags,
        outside,
        lo,
        hi,
        groups,
        T_base,
        T_tool,
        list(km.names),
        notes,
    )


def _scored_rows(data, notes: list):
    """(the measurements scored, one row per point; per row its target's point in the tool frame or None; rows per
    pose): several targets with their nest, every target; without a nest, target 1; sweeps of poses as poses."""
    from ..sweeps import SweepSet  # noqa: PLC0415

    nest_rows = None  # per row, its target's point in the tool frame (several targets with their nest)
    per_pose = 1  # rows per pose (several targets scored: one row each)
    if several_targets(data):
        tm = as_target_measurements(data)
        if tm.nest is not None:
            meas, nest_rows, per_pose = tm.expanded(with_index=False), np.tile(tm.nest, (tm.n, 1)), tm.n_targets
            notes.append(
                f"{tm.n} poses x {tm.n_targets} targets: every target scored, predicted at its nest point in the"
                " model's tool frame"
            )
        else:
            meas = Measurements(tm.q, tm.targets[:, 0], None, tm.source, tm.where, tm.units, kinds=tm.kinds)
            notes.append(
                f"{tm.n_targets} targets per pose and no nest declared: target 1 scored (the tool frame's origin of a"
                " calibration of several targets)"
            )
    else:
        data = sweep_poses(data)  # 6-DoF sweeps: poses (the orientations scored too)
        meas = Measurements.from_sweeps(data) if isinstance(data, SweepSet) else data
    return meas, nest_rows, per_pose


def _refit(km, q, meas, nest_rows, T_tool, T_base, notes: list):
    """(base, tool) re-fitted to the measurements with the kinematics frozen (:func:`refit_registration`)."""
    if meas.n < 4:
        raise DenavitError(
            f"{meas.source}: re-fitting the registration (base 6 + tool 3 parameters) needs at least 4 poses, got"
            f" {meas.n}"
        )
    F = _core.fk_batch(km.with_base(np.eye(4)).with_tool(np.eye(4)), q)
    if nest_rows is not None:  # each row's target, fixed in the tool frame: the tool's origin is what is re-fitted
        F[:, :3, 3] += np.einsum("nij,nj->ni", F[:, :3, :3], nest_rows @ T_tool[:3, :3].T)
    W, T_tool = refit_registration(F, meas, T_tool)
    moved = np.linalg.norm(W[:3, 3] - T_base[:3, 3])
    turn = np.linalg.norm(matrix_rotvec((W[:3, :3].T @ T_base[:3, :3])[None])[0])
    notes.append(
        f"registration re-fitted with the kinematics frozen: the base moved {moved * 1e3:.4g} mm and turned"
        f" {math.degrees(turn):.4g} deg from the model's; 9 of the {3 * meas.n} position residuals absorbed (expected"
        f" rms {math.sqrt(max(3 * meas.n - 9, 0) / meas.n):.3g} sigma, not {math.sqrt(3):.3g})"
    )
    return W, T_tool


def _outside(training, joints, q, n: int):
    """(the training poses' lowest and highest joint values or None, per row the joints outside them)."""
    lo = hi = None
    outside = [[] for _ in range(n)]
    if training is not None and len(training):
        tq = joints(np.asarray(training, dtype=float))
        lo, hi = tq.min(axis=0), tq.max(axis=0)
        span = np.maximum(hi - lo, 0.0)
        eps = 1e-9 + 1e-9 * span
        out = (q < lo - eps) | (q > hi + eps)
        outside = [list(np.flatnonzero(r)) for r in out]
    return lo, hi, outside


def _sigmas(cov_source, readings, q, el, meas, max_sigma, sigma_factor, training, joints, name, notes: list):
    """(per row the predicted error's sigma (m) or None, the flag's limit (m) or None)."""
    sigma = limit = None
    if cov_source is not None:
        try:
            from ..compensation import compliant_sigma  # noqa: PLC0415

            if el is not None and (isinstance(cov_source, Robot) or hasattr(cov_source, "axis_cov")):
                # (a robot file, an identification: its geometry's and compliances' covariance together)
                sigma = compliant_sigma(el, cov_source, readings, meas.payload)
            else:
                sigma = _predicted_sigma(cov_source, readings, q)
                sigma = sigma if el is None else compliant_sigma(el, sigma, readings, meas.payload)
        except DenavitError as e:
            notes.append(f"no predicted sigma: {e}")
        if sigma is not None:
            if max_sigma is not None:
                limit = float(max_sigma)
            else:
                if (
                    training is not None and len(training) and not isinstance(cov_source, Robot)
                ):  # (a robot file holds the ranges, not the poses)
                    ref = _predicted_sigma(
                        cov_source, np.asarray(training, dtype=float), joints(np.asarray(training, dtype=float))
                    )
                    what = "the training poses'"
                else:
                    ref, what = sigma, "this session's"
                limit = float(sigma_factor * np.median(ref))
                notes.append(f"large predicted sigma: above {sigma_factor:g} x {what} median ({limit * 1e3:.3g} mm)")
    elif max_sigma is not None:
        notes.append(
            f"max_sigma ignored: the model {name} carries no covariance (a calibration, an identification, or a robot"
            " file with [covariance])"
        )
    return sigma, limit


def _iso_groups(readings, per_pose: int, repeat_tol: float, measured, P, notes: list) -> list:
    """ISO 9283's accuracy and repeatability per commanded pose visited more than once."""
    groups = []
    for first in repeat_groups(
        readings[::per_pose], repeat_tol
    ):  # visits of one pose (with several targets: target 1's rows)
        idx = first * per_pose
        ap, rp, bary = iso9283(measured[idx], P[idx, :3, 3].mean(axis=0))
        groups.append(PoseGroup(idx, bary, P[idx, :3, 3].mean(axis=0), ap, rp))
    if groups and min(g.n for g in groups) < ISO_CYCLES:
        notes.append(
            f"ISO 9283 over {len(groups)} repeated poses of {min(g.n for g in groups)}-{max(g.n for g in groups)}"
            f" visits (the standard cycles each pose {ISO_CYCLES} times: fewer give the same statistics with more"
            " scatter)"
        )
    return groups


__all__ = [
    "ModelValidation",
    "PoseGroup",
    "iso9283",
    "refit_registration",
    "repeat_groups",
    "validate",
]
