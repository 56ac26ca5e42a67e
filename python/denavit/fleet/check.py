"""The quick drift check (``denavit check ROBOT DATA``): has the robot changed since its registered model?

A few measured tool points (<= 10 poses do) are compared with the registered model's prediction at their joint
readings, in the frame the model was calibrated in (the tracker where it stood for the calibration). Under "no
change" the stacked residual ``r = p_measured - p_model`` (3N) is Gaussian with zero mean and covariance

    S = J C J^T + sigma^2 I,

``C`` the registered model's own covariance (its robot file's ``[covariance]``: the table's parameters, the tool
point and the reading scales), ``J`` (3N x p) the tool points' derivatives with respect to those parameters (central
differences of the forward kinematics, as :func:`denavit.compensation.table_sigma`), ``sigma`` the tracker's noise
per coordinate (m). The model's error is one draw shared by every pose, so ``S`` is full, not block-diagonal. The
statistic ``T = r^T S^-1 r`` is then chi-square with 3N degrees of freedom, and the robot is declared changed when
``T`` exceeds the chi-square quantile ``1 - false_alarm``: the false-alarm rate is ``false_alarm`` exactly for a
Gaussian model error and tracker noise (the Neyman-Pearson level of the test).

A change ``delta`` (3N) of the tool points makes ``T`` noncentral chi-square with noncentrality
``lambda = delta^T S^-1 delta``; the power is ``P(chi2(3N, lambda) > threshold)``. :func:`design` picks the check's
poses from candidate configurations to maximise the smallest noncentrality over a change of any one joint's offset
(a greedy max-min design): the poses that see every joint's drift best.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .. import _core
from ..errors import DenavitError

#: The false-alarm rate of the check when none is given (probability of declaring an unchanged robot changed).
FALSE_ALARM = 0.01
#: The tracker's noise per coordinate when none is given (m): a laser tracker at a few metres.
NOISE_M = 2e-5
#: The change of one joint's offset :func:`design` chooses the poses to see (deg): 0.1-0.2 mm at a KR5's tool.
DESIGN_OFFSET_DEG = 0.01


@dataclass(frozen=True)
class DriftCheck:
    """The check's verdict: ``statistic`` ``T``, its ``threshold`` (chi-square quantile ``1 - false_alarm`` at
    ``dof``), ``p_value`` (probability of a ``T`` at least this large without a change), per pose the residual norm
    (m) and its share of ``T`` (a whitened contribution, for finding the pose that moved)."""

    statistic: float
    threshold: float
    dof: int
    p_value: float
    false_alarm: float
    noise: float
    residual_norms: np.ndarray
    predicted_sigma: np.ndarray

    @property
    def changed(self) -> bool:
        return bool(self.statistic > self.threshold)

    @property
    def n(self) -> int:
        return len(self.residual_norms)

    def metrics(self) -> dict:
        """The check as JSON (SI)."""
        return {
            "changed": self.changed,
            "statistic": float(self.statistic),
            "threshold": float(self.threshold),
            "dof": int(self.dof),
            "p_value": float(self.p_value),
            "false_alarm": float(self.false_alarm),
            "noise_m": float(self.noise),
            "poses": self.n,
            "rms_m": float(np.sqrt(np.mean(self.residual_norms**2))),
            "max_m": float(np.max(self.residual_norms)),
        }

    def __repr__(self) -> str:
        verdict = "CHANGED" if self.changed else "unchanged"
        return (
            f"DriftCheck({verdict}: T = {self.statistic:.4g} vs {self.threshold:.4g} (chi-square, {self.dof} dof, "
            f"false alarms {self.false_alarm:.3g}), p = {self.p_value:.3g}, {self.n} poses)"
        )


def _parameters(robot) -> tuple[np.ndarray, np.ndarray]:
    """(theta, C): the registered parameters in the covariance's order (the table's, the tool point, the scales)."""
    if robot.covariance is None:
        raise DenavitError(
            f"{robot.name}: the drift check needs the model's covariance (a robot file's [covariance], written by "
            "identify or calibrate --save), got a model without one"
        )
    t = robot.table
    parts = [np.asarray(t.params, dtype=float).ravel(), np.asarray(t.T_last_tool, dtype=float)[:3, 3]]
    if robot.reading_scale is not None:
        parts.append(np.asarray(robot.reading_scale, dtype=float))
    theta = np.concatenate(parts)
    C = np.asarray(robot.covariance, dtype=float)
    if C.shape != (len(theta), len(theta)):
        raise DenavitError(f"{robot.name}: covariance of shape {C.shape}, expected ({len(theta)}, {len(theta)})")
    return theta, C


def tool_points(robot, theta: np.ndarray, readings: np.ndarray) -> np.ndarray:
    """(N, 3) tool points (m, world) of ``robot`` with its parameters replaced by ``theta`` (the covariance's order)
    at the controller's ``readings`` (N, n)."""
    from ..compensation import unit_screws  # noqa: PLC0415 (table_sigma's parameter map, shared)
    from ..robot import joint_values  # noqa: PLC0415

    t = robot.table
    n = t.params.size
    T = np.array(t.T_last_tool)
    T[:3, 3] = theta[n : n + 3]
    if robot.reading_scale is not None:  # the scales as theta has them, the readings fixed
        q = joint_values(readings, robot.coupling, theta[n + 3 :], robot.reading_reference)
    else:
        q = robot.joint_values(readings)
    P = theta[:n].reshape(t.params.shape)
    if t.convention == "poe":
        P = unit_screws(P, t.kinds)
    return _core.fk_batch(_core.Table(t.convention, P, t.kinds, t.T_world_base, T).to_model(), q)[:, :3, 3]


def jacobian(robot, readings: np.ndarray) -> np.ndarray:
    """(3N, p) derivatives of the stacked tool points (m) with respect to the covariance's parameters, by central
    differences with a step of each parameter's own sigma (zero columns for parameters with no variance)."""
    theta, C = _parameters(robot)
    step = np.sqrt(np.maximum(np.diag(C), 0.0))
    J = np.zeros((3 * len(readings), len(theta)))
    for k in np.flatnonzero(step > 0):
        e = np.zeros_like(theta)
        e[k] = step[k]
        J[:, k] = (
            (tool_points(robot, theta + e, readings) - tool_points(robot, theta - e, readings)) / (2 * e[k])
        ).ravel()
    return J


def residual_covariance(robot, readings: np.ndarray, noise: float) -> np.ndarray:
    """(3N, 3N) ``S = J C J^T + noise^2 I`` of the stacked residuals under "no change" (module docstring)."""
    J = jacobian(robot, readings)
    _, C = _parameters(robot)
    return J @ C @ J.T + noise**2 * np.eye(len(J))


def test(robot, readings: np.ndarray, points: np.ndarray, *, noise: float = NOISE_M, false_alarm: float = FALSE_ALARM):
    """The chi-square test (module docstring) of measured ``points`` (N, 3) m at ``readings`` (N, n) rad / m."""
    from scipy.stats import chi2  # noqa: PLC0415

    if not 0 < false_alarm < 1:
        raise DenavitError(f"false alarm rate: expected a probability in (0, 1), got {false_alarm}")
    if not (np.isfinite(noise) and noise > 0):
        raise DenavitError(f"noise: expected the tracker's noise per coordinate, > 0 m, got {noise}")
    readings = np.atleast_2d(np.asarray(readings, dtype=float))
    points = np.atleast_2d(np.asarray(points, dtype=float))
    if points.shape != (len(readings), 3):
        raise DenavitError(f"points: expected shape ({len(readings)}, 3) (one per pose, m), got {points.shape}")
    theta, _ = _parameters(robot)
    r = points - tool_points(robot, theta, readings)
    S = residual_covariance(robot, readings, noise)
    L = np.linalg.cholesky(S)
    w = np.linalg.solve(L, r.ravel())
    dof = r.size
    stat = float(w @ w)
    pred = np.sqrt(np.maximum(np.einsum("ii->i", S).reshape(-1, 3).sum(axis=1) - 3 * noise**2, 0.0))
    return DriftCheck(
        stat,
        float(chi2.ppf(1 - false_alarm, dof)),
        dof,
        float(chi2.sf(stat, dof)),
        false_alarm,
        float(noise),
        np.linalg.norm(r, axis=1),
        pred,
    )


def drift_check(
    robot,
    data,
    *,
    noise: float = NOISE_M,
    false_alarm: float = FALSE_ALARM,
    length: str | None = None,
    angle: str | None = None,
    target: int | None = None,
) -> DriftCheck:
    """The drift check of ``robot`` (a Robot with its covariance, or a robot file) on ``data``: a measurement file
    (``q1..qn,x,y,z``, units declared, or ``length`` / ``angle``), or :class:`~denavit.calibration.Measurements`;
    ``target``: one target of several per pose (0-based)."""
    from ..api import _measurements, _robot  # noqa: PLC0415

    robot = _robot(robot)
    meas = _measurements(
        data, robot, points=None, poses=None, format="auto", length=length, angle=angle, columns=None, target=target
    )
    if getattr(meas, "points", None) is None:
        raise DenavitError(f"{getattr(meas, 'source', 'data')}: expected measured tool points (one target per pose)")
    return test(robot, meas.q, meas.points, noise=noise, false_alarm=false_alarm)


def noncentrality(robot, readings: np.ndarray, delta: np.ndarray, noise: float = NOISE_M) -> float:
    """``lambda = delta^T S^-1 delta`` of a change ``delta`` (N, 3) m of the tool points at ``readings``."""
    S = residual_covariance(robot, np.atleast_2d(readings), noise)
    d = np.asarray(delta, dtype=float).ravel()
    return float(d @ np.linalg.solve(S, d))


def power(lam: float, dof: int, false_alarm: float = FALSE_ALARM) -> float:
    """The probability that the check declares a change of noncentrality ``lam`` (noncentral chi-square)."""
    from scipy.stats import chi2, ncx2  # noqa: PLC0415

    return float(ncx2.sf(chi2.ppf(1 - false_alarm, dof), dof, lam))


def offset_changes(robot, readings: np.ndarray, offset: float) -> np.ndarray:
    """(n, N, 3) the tool points' change (m) when each joint's offset changes by ``offset`` (rad / m), to first order:
    the position rows of the tool Jacobian (``local_world_aligned``) times ``offset``."""
    m = robot.model()
    q = robot.joint_values(readings) if robot.has_reading_model else np.atleast_2d(readings)
    J = np.asarray(_core.jacobian_batch(m, q, "local_world_aligned"))[:, :3, :]
    return np.moveaxis(J, 2, 0) * offset


def design(
    robot,
    count: int = 10,
    *,
    offset: float = np.radians(DESIGN_OFFSET_DEG),
    noise: float = NOISE_M,
    candidates: int = 200,
) -> np.ndarray:
    """(count, n) the check's joint readings (rad / m) among ``candidates`` configurations within the limits
    (:func:`denavit.calibration.parametrization.configurations`), chosen greedily to maximise the smallest
    noncentrality over a change ``offset`` of any one joint's offset."""
    from ..calibration.parametrization import configurations  # noqa: PLC0415

    if count < 1:
        raise DenavitError(f"check poses: expected at least 1, got {count}")
    Q = configurations(robot, candidates)
    D = offset_changes(robot, Q, offset)  # (n, M, 3)
    J = jacobian(robot, Q).reshape(len(Q), 3, -1)
    _, C = _parameters(robot)
    chosen: list[int] = []
    for _ in range(count):
        best, best_k = -1.0, -1
        for k in range(len(Q)):
            if k in chosen:
                continue
            idx = [*chosen, k]
            Jk = J[idx].reshape(3 * len(idx), -1)
            S = Jk @ C @ Jk.T + noise**2 * np.eye(3 * len(idx))
            Dk = D[:, idx, :].reshape(D.shape[0], -1)
            lam = np.einsum("ji,ji->j", Dk, np.linalg.solve(S, Dk.T).T).min()
            if lam > best:
                best, best_k = lam, k
        chosen.append(best_k)
    return Q[chosen]
