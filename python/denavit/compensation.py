"""Compensation: put an identified model to work on a robot whose controller keeps its nominal model.

For each target tool pose ``T`` (robot base frame), :func:`compensate` finds the joint values ``q`` that
reach it on the identified model, solved from the nominal solution's branch, and the pose
``T' = FK_nominal(q)`` to send to the controller: its nominal inverse kinematics turns ``T'`` into ``q``,
and the robot reaches ``T`` (RoboDK calls this "filtering" a program). The solves run in the Rust core
(``denavit._core.compensate``), without the GIL, on every core.

:func:`predicted_sigma` gives the predicted tool-position error (1 sigma, 3-D RMS) of an identified model
at given configurations from the covariance of an identification or calibration result;
:func:`accuracy_map` compares, over the workspace or a program, the error of the nominal model (how far the
robot is from where the nominal model says) with that prediction.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import _core
from .errors import DenavitError


@dataclass(frozen=True)
class Compensation:
    """The compensation of N targets (SI: m, rad). Per target:

    ``targets`` (N, 4, 4) as given; ``commands`` (N, 4, 4) ``T' = FK_nominal(q)``, the poses to send;
    ``q`` (N, n) the identified model's joint values; ``q_nominal`` (N, n) the nominal ones;
    ``reached``, ``branch_changed``, ``path_jump`` flags (never silently kept: a row with a flag is not a
    valid command); ``residual`` (N,) position residual of the identified solve (m); ``before`` (N,) the
    position error the robot makes without compensation (m); ``predicted_after`` (N,) the predicted
    position error after it (1 sigma, m) when a result with a covariance was given, else None.
    """

    targets: np.ndarray
    commands: np.ndarray
    q: np.ndarray
    q_nominal: np.ndarray
    reached: np.ndarray
    branch_changed: np.ndarray
    path_jump: np.ndarray
    residual: np.ndarray
    residual_rotation: np.ndarray
    before: np.ndarray
    before_rotation: np.ndarray
    predicted_after: np.ndarray | None = None

    @property
    def ok(self) -> np.ndarray:
        """(N,) rows whose command can be sent: reached, on the nominal branch, no path jump."""
        return self.reached & ~self.branch_changed & ~self.path_jump

    def __len__(self) -> int:
        return len(self.targets)

    def __repr__(self) -> str:
        flagged = int((~self.ok).sum())
        before = float(np.sqrt(np.mean(self.before**2))) if len(self) else float("nan")
        return f"Compensation({len(self)} targets, {flagged} flagged, error before {before * 1e3:.4g} mm RMS)"


def _model(m, what: str) -> _core.Model:
    if isinstance(m, _core.Model):
        return m
    if hasattr(m, "model") and callable(m.model):
        return m.model()
    if isinstance(m, str) or hasattr(m, "__fspath__"):
        from .robot import load  # noqa: PLC0415

        return load(m).model()
    raise DenavitError(f"{what}: expected a Model, a Robot, a result with .model(), a built-in name or a robot file, got {type(m).__name__}")


def compensate(nominal, identified, targets, *, q_nominal=None, q0=None, path: bool = False, result=None, branch_tol: float = 0.1, **ik_options) -> Compensation:
    """Compensate ``targets`` for a controller that keeps ``nominal`` while the robot is ``identified``.

    Parameters
    ----------
    nominal, identified : Model, Robot, Identification, Calibration, built-in name or robot file
        The controller's model and the robot's identified model (same joints; both in the robot base frame).
    targets : array-like, shape (N, 4, 4)
        Target tool poses ``T_world_tool`` (m).
    q_nominal : array-like, shape (N, n), optional
        The program's nominal joint values (rad / m), when it was written as joint rows; else the targets are
        solved on the nominal model from ``q0`` (shape (n,), default zeros).
    path : bool
        The targets form a path: nominal solutions are warm-started along it and jumps are flagged.
    result : Identification or Calibration, optional
        Gives ``predicted_after`` (:func:`predicted_sigma` at the compensated joint values).
    branch_tol : float
        Largest joint change (rad / m) from the nominal solution that keeps its branch.
    ik_options
        Options of the IK solves (``method``, ``tol_position``, ``tol_rotation``, ``restarts``, ...).
    """
    nom, ide = _model(nominal, "nominal"), _model(identified, "identified")
    T = np.asarray(targets, dtype=float)
    if T.ndim == 2:
        T = T[None]
    r = _core.compensate(nom, ide, T, q_nominal, q0, path=path, branch_tol=branch_tol, **ik_options)
    q = r.q
    predicted = predicted_sigma(result, q) if result is not None else None
    return Compensation(T, r.commands, q, r.q_nominal, r.reached, r.branch_changed, r.path_jump, r.position_error, r.rotation_error,
                        r.before_position, r.before_rotation, predicted)


def predicted_sigma(result, q) -> np.ndarray:
    """(N,) predicted tool-position error (1 sigma, 3-D RMS: ``sqrt(trace(J C J^T))``, m) of the model that
    ``result`` identified, at configurations ``q`` (N, n), from its covariance ``C``.

    result : a calibration (:class:`denavit.calibration.Calibration`: the analytic identification Jacobian of
        its chain over the estimated parameters, base registration excluded since targets live in the robot
        base frame) or an identification (:class:`denavit.identify.Identification`: the covariance of the
        axis lines and the tool point, propagated to the tool by central differences through the exact ED-H
        model of the axes).
    """
    q = np.atleast_2d(np.asarray(q, dtype=float))
    if hasattr(result, "parametrization") and hasattr(result, "covariance"):
        pz = result.parametrization
        free = [pz.index(n) for n in result.free_names]
        keep = list(range(len(free)))
        _, J = pz.evaluate(result.values, q, True)
        Jp = J[:, :3, :][:, :, [free[k] for k in keep]]
        C = np.asarray(result.covariance)[np.ix_(keep, keep)]
        return np.sqrt(np.maximum(np.einsum("nij,jk,nik->n", Jp, C, Jp), 0.0))
    if hasattr(result, "axis_cov") and hasattr(result, "axes"):
        return _axes_sigma(result, q)
    raise DenavitError(f"result: expected an identification or a calibration result with a covariance, got {type(result).__name__}")


def table_sigma(robot, q) -> np.ndarray:
    """(N,) predicted tool-position error (1 sigma, 3-D RMS, m) at configurations ``q`` (N, n) of a robot whose
    ``covariance`` (of its table's parameters and tool translation, e.g. read from a robot file's
    ``[covariance]``) is known: ``sqrt(trace(J C J^T))``, ``J`` by central differences of the forward kinematics."""
    C = np.asarray(robot.covariance, dtype=float)
    t = robot.table
    theta0 = np.concatenate([np.asarray(t.params).ravel(), np.asarray(t.T_last_tool)[:3, 3]])
    if C.shape != (len(theta0), len(theta0)):
        raise DenavitError(f"{robot.name}: covariance of shape {C.shape}, expected ({len(theta0)}, {len(theta0)}) (the table's parameters and the tool's x, y, z)")
    q = np.atleast_2d(np.asarray(q, dtype=float))
    n = t.params.size

    def tool_points(theta):
        T = np.array(t.T_last_tool)
        T[:3, 3] = theta[n:]
        return _core.fk_batch(_core.Table(t.convention, theta[:n].reshape(t.params.shape), t.kinds, t.T_world_base, T).to_model(), q)[:, :3, 3]

    scale = np.sqrt(np.maximum(np.diag(C), 0.0))
    J = np.zeros((len(q), 3, len(theta0)))
    for k in np.flatnonzero(scale > 0):
        e = np.zeros_like(theta0)
        e[k] = scale[k]
        J[:, :, k] = (tool_points(theta0 + e) - tool_points(theta0 - e)) / (2 * scale[k])
    return np.sqrt(np.maximum(np.einsum("nij,jk,nik->n", J, C, J), 0.0))


def _axes_sigma(ident, q: np.ndarray) -> np.ndarray:
    ax = ident.axes
    n = ax.nq
    C = np.asarray(ident.axis_cov)
    theta0 = np.concatenate([np.concatenate([ax.points[i], ax.directions[i]]) for i in range(n)] + [ident.tool_point])

    def tool_points(theta):
        P = theta[: 6 * n].reshape(n, 6)
        T_tool = np.array(ax.T_world_tool)
        T_tool[:3, 3] = theta[6 * n:]
        a = _core.JointAxes(P[:, :3], P[:, 3:], kinds=list(ax.kinds), q_ref=ax.q_ref, T_world_base=ax.T_world_base, T_world_tool=T_tool, lower=ax.lower, upper=ax.upper)
        return _core.fk_batch(_core.extract(a, "edh", fidelity=False).table.to_model(), q)[:, :3, 3]

    scale = np.sqrt(np.maximum(np.diag(C), 0.0))
    J = np.zeros((len(q), 3, len(theta0)))
    for k in np.flatnonzero(scale > 0):
        h = scale[k]
        e = np.zeros_like(theta0)
        e[k] = h
        J[:, :, k] = (tool_points(theta0 + e) - tool_points(theta0 - e)) / (2 * h)
    return np.sqrt(np.maximum(np.einsum("nij,jk,nik->n", J, C, J), 0.0))


@dataclass(frozen=True)
class AccuracyMap:
    """The accuracy of the nominal and of the identified model at configurations ``q`` (N, n):
    ``nominal`` (N,) the position error of the nominal model (|p_identified - p_nominal|, m: what the robot
    misses when commanded with the nominal model), ``identified`` (N,) the predicted 1-sigma position error
    of the identified model (m), ``points`` (N, 3) the tool positions (m)."""

    q: np.ndarray
    points: np.ndarray
    nominal: np.ndarray
    identified: np.ndarray

    def __repr__(self) -> str:
        s = self.summary()
        return (f"AccuracyMap({s['configurations']} configurations: nominal model error rms {s['nominal']['rms'] * 1e3:.4g} mm (max {s['nominal']['max'] * 1e3:.4g}), "
                f"identified 1 sigma rms {s['identified']['rms'] * 1e3:.4g} mm (max {s['identified']['max'] * 1e3:.4g}))")

    def summary(self) -> dict:
        """RMS, median, 95th percentile and maximum of both, in metres."""
        def stats(v):
            return {"rms": float(np.sqrt(np.mean(v**2))), "median": float(np.median(v)), "p95": float(np.percentile(v, 95)), "max": float(v.max())}

        return {"nominal": stats(self.nominal), "identified": stats(self.identified), "configurations": len(self.q)}


def accuracy_map(nominal, identified, result, q=None, *, count: int = 1000) -> AccuracyMap:
    """:class:`AccuracyMap` over ``q`` (N, n; a program's joint values) or, by default, ``count``
    quasi-random configurations within the nominal's joint limits (a Halton sequence)."""
    nom, ide = _model(nominal, "nominal"), _model(identified, "identified")
    if q is None:
        from scipy.stats import qmc  # noqa: PLC0415

        lo, hi = np.asarray(nom.lower, dtype=float), np.asarray(nom.upper, dtype=float)
        rev = np.array([k == "revolute" for k in nom.kinds])
        lo, hi = np.where(rev, np.maximum(lo, -np.pi), lo), np.where(rev, np.minimum(hi, np.pi), hi)
        q = qmc.scale(qmc.Halton(d=nom.nq, scramble=False).random(count + 1)[1:], lo, hi)
    q = np.atleast_2d(np.asarray(q, dtype=float))
    p_nom = _core.fk_batch(nom, q)[:, :3, 3]
    p_id = _core.fk_batch(ide, q)[:, :3, 3]
    return AccuracyMap(q, p_id, np.linalg.norm(p_id - p_nom, axis=1), predicted_sigma(result, q))


def identification_accuracy(result, *, count: int = 1000) -> AccuracyMap | None:
    """The :class:`AccuracyMap` of an identification against its nominal (None without one): the nominal
    model placed as the identification placed it (its base) with the measured tool point attached so that both
    agree at the home configuration, the identified model's exact ED-H geometry, the prediction from the axes'
    covariance."""
    if result.nominal is None:
        return None
    ident = result.model(convention="edh")
    home = np.asarray(result.sweeps.home, dtype=float)
    flange = result.nominal.model().with_tool(np.eye(4))
    tool = np.linalg.inv(_core.fk(flange, home)) @ _core.fk(ident, home)
    nominal = flange.with_tool(tool)
    return accuracy_map(nominal, ident, result, count=count)
