"""Several targets per pose in one calibration: marker clusters, SMR nests (2-4 targets on the last body, each
measured at every pose), as :func:`denavit.identification.identify` reads them (a sweep file's ``x2, y2, z2, ...``
columns and ``# nest:`` line, a sweep JSON's ``"targets"`` and ``"nest"``, :func:`denavit.sweeps.simulate`'s
``targets``), or :class:`TargetMeasurements` at arbitrary poses.

The model. The calibration chain of the nominal robot in the chosen convention ends at the flange (the tool
frame = the flange, its parameters held: the targets carry it); every target ``k`` has its own point ``t_k``
(3 parameters ``target{k}_x, _y, _z``, m, in the flange frame); target ``k`` at pose ``i`` is predicted at
``R_i t_k + o_i`` (``(R_i, o_i)`` the flange pose). Its Jacobian rows are the flange's linear rows plus
``w x (R_i t_k)`` (the angular rows crossed with the lever arm) and, for ``t_k``, ``R_i``. Every point is one
3-D residual (whitened by the tracker's noise model when given, as calibrate's points); base, kinematics and the
targets' points are one least-squares fit. Registration first, in closed form
(:func:`denavit.calibration.registration.register`: Kabsch, then every target's point by linear least squares,
alternated), so the tracker may stand anywhere; held-out validation leaves whole poses out.

The tool frame of the result (``Calibration.model()``'s ``T_flange_tool``): the nest's frame when the nest is
declared (the targets in the tool frame: the rigid transform that best puts the nest onto the fitted points,
Kabsch), else its origin at target 1 and its orientation from the targets' points (x from target 1 to target 2, z across
the plane of targets
1-3), else (two targets) the flange's, as identify's tool frame at home. Small rotations about the current
estimate parametrise nothing here: the targets' points are translations, free of any singularity.

One target alone gives the point a single-target calibration fits; several give the flange's orientation at
every pose as well, so the wrist's parameters are better determined and the predictions better.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np

from .. import _core
from ..errors import DenavitError, check_seed
from ..geometry import kabsch
from ..robot import robot_of
from .identifiability import analyze, parameter_status
from .least_squares import covariance, fit_parameters, residuals, weights
from .measurements import Measurements, check_finite, joint_kinds
from .parametrization import Parametrization, configurations, parametrize, resolve_fix
from .registration import register
from .result import OUTLIER_SIGMAS, Calibration, Validation, correlation_notes

#: The parameters of target k (1-based) are named ``target{k}_x``, ``_y``, ``_z``.
TARGET_PREFIX = "target"


@dataclass(frozen=True, eq=False)
class TargetMeasurements:
    """Several targets measured at every pose: ``q`` (N, n) joint readings (rad / m), ``targets`` (N, K, 3) the
    targets' measured points (m, measurement frame; K >= 2), ``nest`` (K, 3) m their positions in the tool frame
    when declared, else None."""

    q: np.ndarray
    targets: np.ndarray
    nest: np.ndarray | None = None
    source: str = "targets"
    where: list = field(default_factory=list)
    units: dict = field(default_factory=lambda: {"length": "m", "angle": "rad"})
    kinds: tuple | None = None

    def __post_init__(self):
        q = np.asarray(self.q, dtype=float)
        t = np.asarray(self.targets, dtype=float)
        if q.ndim != 2 or t.ndim != 3 or t.shape[0] != q.shape[0] or t.shape[2] != 3 or t.shape[1] < 2:
            raise DenavitError(
                f"{self.source}: expected q (N, n) and targets (N, K, 3) with K >= 2 targets per pose, got shapes"
                f" {q.shape} and {t.shape}"
            )
        check_finite(q, "q (joint readings)", self.source, self.where, cols="joint")
        check_finite(t.reshape(len(t), -1), "targets", self.source, self.where)
        if self.nest is not None and np.shape(self.nest) != (t.shape[1], 3):
            raise DenavitError(
                f"{self.source}: nest of shape {np.shape(self.nest)}: expected ({t.shape[1]}, 3), one point per target"
            )
        object.__setattr__(self, "q", q)
        object.__setattr__(self, "targets", t)
        object.__setattr__(self, "kinds", joint_kinds(self.kinds, q.shape[1], f"{self.source}: kinds"))
        object.__setattr__(self, "where", list(self.where) or [f"pose {i + 1}" for i in range(len(q))])

    @property
    def n(self) -> int:
        return self.q.shape[0]

    @property
    def nq(self) -> int:
        return self.q.shape[1]

    @property
    def n_targets(self) -> int:
        return self.targets.shape[1]

    @property
    def kind(self) -> str:
        """``"point"``: the targets are points (as :attr:`Measurements.kind`)."""
        return "point"

    @property
    def points(self) -> np.ndarray:
        """(N, 3) target 1's points."""
        return self.targets[:, 0]

    def subset(self, idx) -> TargetMeasurements:
        idx = np.asarray(idx, dtype=int)
        return TargetMeasurements(
            self.q[idx], self.targets[idx], self.nest, self.source, [self.where[i] for i in idx], self.units, self.kinds
        )

    def expanded(self, whitening=None, with_index: bool = True) -> Measurements:
        """One row per measured point (pose-major: pose i, target k at row ``i K + k``); ``with_index``: the readings
        carry the target's index as a last column (what :class:`TargetParametrization` evaluates)."""
        K = self.n_targets
        q = np.repeat(self.q, K, axis=0)
        if with_index:
            q = np.hstack([q, np.tile(np.arange(K, dtype=float), self.n)[:, None]])
        where = [f"{w}, target {k + 1}" for w in self.where for k in range(K)]
        return Measurements(
            q,
            self.targets.reshape(-1, 3),
            None,
            self.source,
            where,
            self.units,
            None,
            None if with_index else self.kinds,
            whitening,
        )

    @classmethod
    def from_sweeps(cls, sweeps) -> TargetMeasurements:
        """The targets of every sweep point with their joint readings."""
        if not sweeps.has_readings:
            raise DenavitError(
                f"{sweeps.source}: calibration needs the joint readings of every point; these sweeps have none"
                " (per-joint files): use denavit.identify"
            )
        q = np.vstack([s.q for s in sweeps.sweeps])
        t = np.concatenate([s.targets for s in sweeps.sweeps])
        where = [
            w
            for s in sweeps.sweeps
            for w in s.where or [f"sweep {s.joint}, point {k + 1}" for k in range(len(s.points))]
        ]
        return cls(
            q,
            t,
            None if sweeps.nest is None else np.asarray(sweeps.nest, dtype=float),
            sweeps.source or "sweeps",
            where,
            dict(sweeps.units),
            sweeps.kinds,
        )


def several_targets(meas) -> bool:
    """Whether ``meas`` (Measurements, SweepSet or TargetMeasurements) holds several targets per pose."""
    if isinstance(meas, TargetMeasurements):
        return True
    sweeps = (
        meas
        if hasattr(meas, "n_targets") and hasattr(meas, "sweeps") and not isinstance(meas, Measurements)
        else getattr(meas, "sweeps", None)
    )
    return sweeps is not None and getattr(sweeps, "n_targets", 1) > 1


def as_target_measurements(meas) -> TargetMeasurements:
    if isinstance(meas, TargetMeasurements):
        return meas
    if isinstance(
        meas, Measurements
    ):  # read from sweeps: their targets, at the Measurements' readings (a coupling applied to them kept)
        tm = TargetMeasurements.from_sweeps(meas.sweeps)
        return TargetMeasurements(meas.q, tm.targets, tm.nest, tm.source, tm.where, tm.units, tm.kinds)
    return TargetMeasurements.from_sweeps(meas)


def sweep_poses(meas):
    """6-DoF sweeps of one target (a probe's or the controller's poses: :attr:`denavit.sweeps.Sweep.rotations`), a
    SweepSet or Measurements read from one, as pose Measurements (their orientations used, as identify uses them);
    anything else as it is."""
    sweeps = meas if hasattr(meas, "has_rotations") else getattr(meas, "sweeps", None)
    if (
        sweeps is None
        or not getattr(sweeps, "has_rotations", False)
        or sweeps.n_targets != 1
        or getattr(meas, "poses", None) is not None
    ):
        return meas
    pts = Measurements.from_sweeps(sweeps)
    T = np.tile(np.eye(4), (pts.n, 1, 1))
    T[:, :3, :3] = np.concatenate([s.rotations for s in sweeps.sweeps])
    T[:, :3, 3] = pts.points
    q = (
        meas.q if isinstance(meas, Measurements) else pts.q
    )  # (the rows of from_sweeps: a caller's coupled readings kept)
    return Measurements(q, None, T, pts.source, pts.where, pts.units, sweeps, pts.kinds)


def pick_target(meas, target: int | None):
    """``meas`` with the target asked: ``target`` None keeps every target (a :class:`TargetMeasurements` when there are
    several), a 0-based index keeps that one alone (Measurements of its points)."""
    if target is None:
        return as_target_measurements(meas) if several_targets(meas) else meas
    if several_targets(meas):
        tm = as_target_measurements(meas)
        if not 0 <= target < tm.n_targets:
            raise DenavitError(f"{tm.source}: target {target + 1} out of range: expected 1..{tm.n_targets} (1-based)")
        return Measurements(
            tm.q, tm.targets[:, target], None, f"{tm.source}, target {target + 1}", tm.where, tm.units, kinds=tm.kinds
        )
    if target != 0:
        raise DenavitError(
            f"{getattr(meas, 'source', 'data')}: target {target + 1} out of range: the data hold one target per pose"
        )
    return meas


def as_measurements(data, kinds, *, points=None, poses=None, target: int | None = None):
    """The measurements of ``data`` (Measurements, a SweepSet, TargetMeasurements, or joint readings ``q`` (N, n) rad /
    m with ``points`` (N, 3) m or ``poses`` (N, 4, 4)); several targets per pose: every one (``target`` None, a
    TargetMeasurements) or the one asked (0-based). Files are read by :mod:`denavit.io` (:func:`denavit.calibrate`
    and :func:`denavit.validate` take paths)."""
    from ..limits import floats  # noqa: PLC0415
    from ..sweeps import SweepSet  # noqa: PLC0415

    if isinstance(data, (Measurements, SweepSet, TargetMeasurements)):
        return pick_target(data, target) if target is not None else data
    if isinstance(data, str) or hasattr(data, "__fspath__"):
        got = f"the path {str(data)!r} (denavit.calibrate and denavit.validate read files)"
    elif points is None and poses is None:
        got = type(data).__name__
    else:
        got = None
    if got is not None:
        raise DenavitError(
            "measurements: expected Measurements, a SweepSet, a path, or joint readings q with points= or poses=, got"
            f" {got}"
        )
    return Measurements(
        floats(data, "measurements: q"),
        None if points is None else floats(points, "measurements: points"),
        None if poses is None else floats(poses, "measurements: poses"),
        "arrays",
        kinds=None if kinds is None else tuple(kinds),
    )


def recording_poses(rec, target: int | None = None, kinds=None):
    """The poses where the robot of a recording stood still (:func:`denavit.recording.static_poses`): every target
    (a :class:`TargetMeasurements`) when ``target`` is None and the recording has several, else the target asked
    (0-based; default the first) as :class:`Measurements`."""
    from ..recording import static_poses  # noqa: PLC0415

    K = getattr(rec, "n_targets", 1)
    kinds = None if kinds is None else tuple(kinds)
    units = {"length": "m", "angle": "rad"}
    if target is not None or K == 1:
        q, pts, where = static_poses(rec, target=0 if target is None else target)
        return Measurements(q, pts, None, str(rec.source), where, units, kinds=kinds)
    per = [static_poses(rec, target=k) for k in range(K)]
    q, where = per[0][0], per[0][2]
    return TargetMeasurements(q, np.stack([p[1] for p in per], axis=1), None, str(rec.source), where, units, kinds)


def _tool_frame(points: np.ndarray, nest: np.ndarray | None) -> tuple[np.ndarray, str]:
    """``T_flange_tool`` from the targets' points in the flange (K, 3) (module docstring) and where its orientation
    came from."""
    T = np.eye(4)
    T[:3, 3] = points[0]
    if nest is not None:  # the nest is the targets in the tool frame: the tool frame is where it best fits them
        return kabsch(nest, points), "nest"
    if len(points) >= 3:
        x = points[1] - points[0]
        z = np.cross(x, points[2] - points[0])
        if np.linalg.norm(x) > 1e-9 and np.linalg.norm(z) > 1e-9 * np.linalg.norm(x):
            x, z = x / np.linalg.norm(x), z / np.linalg.norm(z)
            T[:3, :3] = np.column_stack([x, np.cross(z, x), z])
            return T, "targets"
    return T, "flange"


@dataclass(frozen=True, eq=False)
class TargetParametrization:
    """The calibration chain of the nominal (tool = flange, held) and K targets' points in the flange frame
    (module docstring). Has the attributes of :class:`~denavit.calibration.parametrization.Parametrization` the
    calibration uses; readings with one more column than the robot's joints give each row's target (0-based),
    readings without it are evaluated at the tool frame's origin (target 1)."""

    chain_pz: Parametrization
    n_targets: int
    x0: np.ndarray
    names: list
    units: list
    order: list
    rules: dict
    nest: np.ndarray | None = None

    measure = "point"

    @classmethod
    def build(
        cls, robot, convention: str, n_targets: int, start: np.ndarray, scale: bool = False, nest=None
    ) -> TargetParametrization:
        pz = parametrize(robot, convention, measure="pose", tool=np.eye(4), scale=scale)
        P0 = pz.n_params
        tnames = [f"{TARGET_PREFIX}{k + 1}_{a}" for k in range(n_targets) for a in "xyz"]
        names = list(pz.names) + tnames
        units = list(pz.units) + ["length"] * len(tnames)
        tcols = list(range(P0, P0 + len(tnames)))
        base = [c for c in pz.order if pz.names[c].startswith("base_")]
        order = base + tcols + [c for c in pz.order if c not in base]
        why = "the targets' points in the flange frame carry the tool (several targets per pose)"
        rules = dict(pz.rules) | {nm: why for nm in pz.names if nm.startswith("tool_")}
        x0 = np.concatenate([pz.x0, np.asarray(start, dtype=float).ravel()])
        return cls(
            pz, n_targets, x0, names, units, order, rules, None if nest is None else np.asarray(nest, dtype=float)
        )

    @property
    def convention(self) -> str:
        return self.chain_pz.convention

    @property
    def robot(self):
        return self.chain_pz.robot

    @property
    def n_params(self) -> int:
        return len(self.names)

    @property
    def nq(self) -> int:
        return self.chain_pz.nq

    def index(self, name: str) -> int:
        try:
            return self.names.index(name)
        except ValueError:
            raise DenavitError(f"unknown parameter {name!r}: expected one of {', '.join(self.names)}") from None

    def inputs(self, meas: Measurements) -> np.ndarray:
        """What :meth:`evaluate` takes as the readings of ``meas`` (:meth:`Parametrization.inputs`): its ``q``, with
        each row's target as a last column (:meth:`TargetMeasurements.expanded`)."""
        return meas.q

    def target_points(self, x) -> np.ndarray:
        """(K, 3) the targets' points in the flange frame (m)."""
        return np.asarray(x, dtype=float)[self.chain_pz.n_params :].reshape(self.n_targets, 3)

    def evaluate(self, x, q, jacobian: bool = True, *, rows: int = 6, columns=None, weights=None):
        """(poses (N, 4, 4): the flange's rotation at each row's target point, Jacobian (N, rows, len(columns)) or
        None) as :meth:`Parametrization.evaluate`."""
        x = np.asarray(x, dtype=float)
        q = np.atleast_2d(np.asarray(q, dtype=float))
        n, P0 = self.nq, self.chain_pz.n_params
        k = q[:, n].astype(int) if q.shape[1] == n + 1 else np.zeros(len(q), dtype=int)
        cols = list(range(self.n_params)) if columns is None else [int(c) for c in columns]
        chain_cols = [c for c in cols if c < P0]
        F, J0 = self.chain_pz.evaluate(
            x[:P0], q[:, :n], jacobian and bool(chain_cols), rows=6, columns=chain_cols or None
        )
        arm = np.einsum("nij,nj->ni", F[:, :3, :3], self.target_points(x)[k])
        poses = np.array(F)
        poses[:, :3, 3] += arm
        if not jacobian:
            return poses, None
        J = np.zeros((len(q), rows, len(cols)))
        at = {c: i for i, c in enumerate(chain_cols)}
        for j, c in enumerate(cols):
            if c < P0:
                v, w = J0[:, :3, at[c]], J0[:, 3:, at[c]]
                J[:, :3, j] = v + np.cross(w, arm)
                if rows == 6:
                    J[:, 3:, j] = w
            else:
                t, a = divmod(c - P0, 3)
                on = k == t
                J[on, :3, j] = F[on, :3, a]
        if weights is not None:
            J *= np.asarray(weights, dtype=float)[:rows][None, :, None]
        return poses, J

    def base_pose(self, x) -> np.ndarray:
        return self.chain_pz.base_pose(np.asarray(x, dtype=float)[: self.chain_pz.n_params])

    def rebased(self, x, T_world_new_old) -> tuple[TargetParametrization, np.ndarray]:
        P0 = self.chain_pz.n_params
        pz, xc = self.chain_pz.rebased(np.asarray(x, dtype=float)[:P0], T_world_new_old)
        return (
            TargetParametrization(
                pz, self.n_targets, self.x0, self.names, self.units, self.order, self.rules, self.nest
            ),
            np.concatenate([xc, np.asarray(x, dtype=float)[P0:]]),
        )

    def tool(self, x) -> tuple[np.ndarray, str]:
        """``T_flange_tool`` of the result and where its orientation came from (module docstring)."""
        return _tool_frame(self.target_points(x), self.nest)

    def model(self, x, name: str = "calibrated") -> _core.Model:
        m = self.chain_pz.model(np.asarray(x, dtype=float)[: self.chain_pz.n_params], name)
        return m.with_tool(self.tool(x)[0])


def calibrate_targets(
    meas,
    nominal,
    *,
    convention: str = "edh",
    fix=(),
    loss: str = "linear",
    start: str = "nominal",
    scale: bool = False,
    tool=None,
    noise: float | None = None,
    tracker_noise=None,
    holdout: float = 0.0,
    seed: int = 0,
):
    """One least-squares fit of base, kinematics and every target's point in the flange frame (module docstring).

    ``meas``: :class:`TargetMeasurements`, a SweepSet with several targets, or Measurements read from one. The
    options are :func:`denavit.calibration.calibrate`'s (``tool``: the targets' start in the flange frame, a point
    (3,) for all of them or (K, 3), m; default the nominal's tool point, or the nest in the nominal tool frame when
    declared). Returns a :class:`~denavit.calibration.Calibration` whose ``measurements`` hold one row per measured
    point (``where`` names the target).
    """
    t0 = time.perf_counter()
    tm = as_target_measurements(meas)
    robot = robot_of(nominal)
    n, K = len(robot.names), tm.n_targets
    _check_target_options(tm, robot, loss, start, holdout, noise)
    notes = [
        f"{tm.n} poses x {K} targets: one fit with every target's point in the flange frame (target{{k}}_x, _y, _z)"
    ]
    sweeps = meas if hasattr(meas, "has_rotations") else getattr(meas, "sweeps", None)
    if sweeps is not None and getattr(sweeps, "has_rotations", False):
        notes.append(
            "the poses' orientations (qw, qx, qy, qz) are not used: the targets' points determine the flange's"
            " orientation at every pose"
        )
    start_pts = _start_points(tm, robot, tool)
    pz = TargetParametrization.build(robot, convention, K, start_pts, scale, tm.nest)
    x = pz.x0.copy()
    user_fixed = resolve_fix(pz, fix)
    for c, v in user_fixed.items():
        if v is not None:
            x[c] = v
    rule_fixed = {pz.index(nm) for nm in pz.rules}
    candidates = [c for c in range(pz.n_params) if c not in user_fixed and c not in rule_fixed]
    Wh, ref = _target_whitening(tm, tracker_noise, noise)
    train_idx, test_idx = _pose_split(tm, holdout, seed, len(candidates), notes)

    def rows(idx):
        sub = tm.subset(idx)
        return sub.expanded(None if Wh is None else Wh[idx].reshape(-1, 3, 3))

    train = rows(train_idx)
    sig_p = noise if noise is not None else ref if ref is not None else 1e-5
    w = weights("point", sig_p, sig_p)
    # 1) registration in closed form (the base, then every target's point), then base and targets fitted
    base_idx = [c for c in candidates if pz.names[c].startswith("base_")]
    tcols = [c for c in candidates if pz.names[c].startswith(TARGET_PREFIX)]
    pz, x, reg_notes = register(pz, x, train, base_free=len(base_idx) == 6, tool_free=tcols)
    notes += reg_notes
    reg_free = base_idx + tcols
    reg = analyze(pz, x, train, reg_free, w, explain=False)
    x_reg, _ = fit_parameters(pz, x, reg.kept_idx, train, w, "linear", None)
    # 2) identifiability: structural (spread configurations, the targets in turn) and of these data
    count = max(2 * pz.n_params, 60)
    qr = np.hstack([configurations(robot, count), (np.arange(count) % K)[:, None].astype(float)])
    struct = analyze(
        pz, x_reg, Measurements(qr, np.zeros((count, 3)), None, "spread configurations"), candidates, w, explain=False
    )
    still = [j for j in range(n) if np.ptp(train.q[:, j]) < 1e-9]
    hint = "".join(f"; joint {j + 1} ({robot.names[j]}) never moves in the data" for j in still)
    ana = analyze(pz, x_reg, train, candidates, w, struct, hint)
    if 3 * train.n <= struct.rank:
        raise DenavitError(
            f"{tm.source}: too few measurements: {train.n} points give {3 * train.n} equations for the {struct.rank}"
            f" parameters this model can identify; need at least {struct.rank // 3 + 1} points, or fix parameters"
        )
    # 3) the fit
    free = ana.kept_idx
    x_hat, sol = fit_parameters(pz, x_reg, free, train, w, "linear", None)
    r, Jf, _ = residuals(pz, x_hat, train, w, columns=free)
    known = noise is not None
    s2 = 1.0 if known else float(np.sum(r**2)) / max(len(r) - len(free), 1)
    cov = covariance(Jf, s2)
    sd = np.sqrt(np.clip(np.diag(cov), 0, None))
    with np.errstate(invalid="ignore", divide="ignore"):
        corr = cov / np.outer(sd, sd)
    sigma = np.full(pz.n_params, np.nan)
    sigma[free] = sd
    structural = {u.name for u in struct.unidentifiable}
    dropped = {u.name for u in ana.unidentifiable}
    status = parameter_status(pz, free, user_fixed, structural, dropped)
    res_si = r.reshape(-1, 3) / w[0]
    everything = tm.expanded()
    pos_all = np.linalg.norm(pz.evaluate(x_hat, everything.q, False)[0][:, :3, 3] - everything.points, axis=1)
    train_rows = (train_idx[:, None] * K + np.arange(K)).ravel()
    pos = pos_all[train_rows]
    rms = float(np.sqrt(np.mean(pos**2)))
    robust = float(np.median(np.linalg.norm(res_si, axis=1))) / math.sqrt(2.366)
    outliers = train_rows[np.flatnonzero(pos > OUTLIER_SIGMAS * max(robust, 1e-300))]
    validation = _target_validation(pz, tm, rows, train.n, test_idx, x_reg, x_hat)
    _target_notes(notes, pz, x_hat, everything, rms, sol, corr, free, outliers)
    shown = Measurements(
        np.repeat(tm.q, K, axis=0), everything.points, None, tm.source, everything.where, tm.units, None, tm.kinds
    )
    noise_est = math.sqrt(s2) * sig_p if not known else sig_p
    return Calibration(
        pz,
        list(pz.names),
        x_hat,
        sigma,
        status,
        pz.x0,
        x_reg,
        [pz.names[c] for c in free],
        cov,
        corr,
        ana,
        res_si,
        rms,
        math.nan,
        outliers,
        validation,
        shown,
        loss,
        sol is None or sol.status > 0,
        0 if sol is None else int(sol.nfev),
        time.perf_counter() - t0,
        float(noise_est),
        notes,
    )


def _check_target_options(tm, robot, loss: str, start: str, holdout: float, noise) -> None:
    """One-line errors for data that do not fit the nominal and options the several-targets fit does not take."""
    n = len(robot.names)
    if tm.nq != n:
        raise DenavitError(
            f"{tm.source}: the data has {tm.nq} joint readings per pose but the nominal model {robot.name} has {n}"
            f" joints ({', '.join(robot.names)})"
        )
    if tm.kinds is not None and tuple(tm.kinds) != tuple(robot.table.kinds):
        raise DenavitError(
            f"{tm.source}: joint kinds {list(tm.kinds)} differ from the nominal {robot.name}'s"
            f" {list(robot.table.kinds)}"
        )
    if loss != "linear" or start != "nominal":
        raise DenavitError(
            f"{tm.source}: several targets per pose are fitted with loss 'linear' from start 'nominal', got loss"
            f" {loss!r}, start {start!r}"
        )
    if not 0.0 <= holdout < 0.9:
        raise DenavitError(f"holdout: expected a fraction in [0, 0.9), got {holdout}")
    if noise is not None and not (isinstance(noise, (int, float)) and math.isfinite(noise) and noise > 0):
        raise DenavitError(f"noise: expected the known one-sigma noise, a finite value > 0 (m), got {noise!r}")


def _start_points(tm, robot, tool) -> np.ndarray:
    """(K, 3) the targets' start points in the flange frame: ``tool`` as given, else the nest in the nominal's tool
    frame, else the nominal's tool point for every target."""
    K = tm.n_targets
    m_nom = robot.model()
    T_tool_nom = np.asarray(m_nom.T_flange_tool, dtype=float)
    if tool is not None:
        t = np.asarray(tool, dtype=float)
        if t.shape not in ((3,), (K, 3)) or not np.all(np.isfinite(t)):
            raise DenavitError(
                f"tool: expected the targets' start in the flange frame, a point (3,) or ({K}, 3) (m), got shape"
                f" {t.shape}"
            )
        start_pts = np.broadcast_to(t, (K, 3)).copy()
    elif tm.nest is not None:
        start_pts = tm.nest @ T_tool_nom[:3, :3].T + T_tool_nom[:3, 3]
    else:
        start_pts = np.tile(T_tool_nom[:3, 3], (K, 1))
    return start_pts


def _target_whitening(tm, tracker_noise, noise):
    """(each point's whitening (N, K, 3, 3) from the tracker's noise model, its mean per-coordinate sigma, m), or
    (None, None) without one."""
    from ..fitting.joint import as_tracker_noise  # noqa: PLC0415

    tracker = as_tracker_noise(tracker_noise)
    if tracker is None:
        return None, None
    if noise is not None:
        raise DenavitError(
            f"noise = {noise!r} and tracker_noise: give one (the tracker's model declares the shape of each point's"
            " noise, its scale is estimated from the residuals)"
        )
    Wh, ref = tracker.whitening(tm.targets.reshape(-1, 3))
    Wh = Wh.reshape(tm.n, tm.n_targets, 3, 3)
    return Wh, ref


def _pose_split(tm, holdout: float, seed: int, n_candidates: int, notes: list):
    """(the training poses' indices, the held-out poses' indices): whole poses, every target with its pose."""
    K = tm.n_targets
    test_idx = np.zeros(0, dtype=int)
    train_idx = np.arange(tm.n)
    if holdout > 0:
        n_test = int(round(holdout * tm.n))
        perm = np.random.default_rng(check_seed(seed)).permutation(tm.n)
        if n_test >= 1 and 3 * K * (tm.n - n_test) > n_candidates + 1:
            test_idx, train_idx = np.sort(perm[:n_test]), np.sort(perm[n_test:])
        else:
            notes.append(f"holdout {holdout} skipped: {tm.n} poses are too few to hold any out")
    return train_idx, test_idx


def _target_validation(pz, tm, rows, n_train: int, test_idx, x_reg, x_hat) -> Validation | None:
    """The held-out poses' point errors before (the registered nominal) and after calibration."""
    K = tm.n_targets
    if not test_idx.size:
        return None
    test = rows(test_idx)
    before = np.linalg.norm(pz.evaluate(x_reg, test.q, False)[0][:, :3, 3] - test.points, axis=1)
    after = np.linalg.norm(pz.evaluate(x_hat, test.q, False)[0][:, :3, 3] - test.points, axis=1)
    test_rows = (test_idx[:, None] * K + np.arange(K)).ravel()
    return Validation(
        n_train,
        test.n,
        float(np.sqrt(np.mean(before**2))),
        float(before.max()),
        float(np.sqrt(np.mean(after**2))),
        float(after.max()),
        test_rows,
    )


def _target_notes(notes, pz, x_hat, everything, rms, sol, corr, free, outliers) -> None:
    """What the user should know about the several-targets fit, added to ``notes``."""
    _, frm = pz.tool(x_hat)
    notes.append(
        "tool frame: "
        + (
            "the nest's (fitted onto the targets' points)"
            if frm == "nest"
            else "origin at target 1, orientation "
            + (
                "from the targets (x from target 1 to 2, z across targets 1-3)"
                if frm == "targets"
                else "the flange's (two targets)"
            )
        )
    )
    size = max(float(np.max(np.linalg.norm(everything.points - everything.points.mean(axis=0), axis=1))), 1e-3)
    if rms > 0.01 * size:
        notes.insert(
            0,
            f"the fit explains little of the data: rms {rms * 1e3:.4g} mm against a measured volume of {size * 1e3:.4g}"
            " mm radius (are the joint readings in the units declared, the joints in the nominal's order, the targets"
            " in the same order at every pose?)",
        )
    if sol is not None and sol.status <= 0:
        notes.append(f"the least-squares solver stopped without meeting its tolerances ({sol.message})")
    notes.extend(correlation_notes(corr, [pz.names[c] for c in free]))
    if outliers.size:
        notes.append(
            f"{outliers.size} point(s) with a misfit above {OUTLIER_SIGMAS} robust sigmas:"
            f" {', '.join(everything.where[i] for i in outliers[:5])}{' ...' if outliers.size > 5 else ''}"
        )


__all__ = [
    "TargetMeasurements",
    "TargetParametrization",
    "as_target_measurements",
    "calibrate_targets",
    "pick_target",
    "recording_poses",
    "several_targets",
    "sweep_poses",
]
