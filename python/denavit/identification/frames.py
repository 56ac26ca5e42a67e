"""Frames and tables around the fits: the tool frame, short arcs, the nominal table and origins, the ED-H
parallel tolerance, the joint axes and the parameter covariance propagated from the fit."""

from __future__ import annotations

import math

import numpy as np

from .. import _core
from ..fitting.result import flipped
from ..geometry import closest_point, matrix_rotvec, rotvec_matrix
from ..message import Angle, Length, Message
from ..robot import Robot
from ..sweeps import SweepSet
from .prepare import sweep_where

#: Where the tool frame's orientation at home comes from (:attr:`Identification.tool_orientation`).
TOOL_ORIENTATION = {
    "nominal": "the nominal's flange orientation at home (not identified: one target per pose has no orientation)",
    "poses": "the 6-DoF poses: the probe's frame at home, fitted with the axes",
    "nest": (
        "the targets' points at home against the declared nest (their positions in the tool frame): the best rotation"
        " (Kabsch)"
    ),
    "targets": (
        "the targets' points at home: x from target 1 to target 2, z across the plane of targets 1-3 (no nest declared)"
    ),
}


def _rotation_between(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The smallest rotation taking the direction of a (3,) onto that of b (3,)."""
    a, b = a / np.linalg.norm(a), b / np.linalg.norm(b)
    v = np.cross(a, b)
    return rotvec_matrix(v / max(np.linalg.norm(v), 1e-300) * math.atan2(np.linalg.norm(v), float(a @ b)))


def _tool_frame(
    sweeps: SweepSet, res: dict | None, R_nominal: np.ndarray, notes: list[str]
) -> tuple[np.ndarray, str, np.ndarray | None]:
    """The tool frame's orientation at home in world, where it came from (:data:`TOOL_ORIENTATION`), and the
    (3, p) Jacobian of its small rotation (world) with respect to the joint fit's parameters (``res["cov_all"]``),
    None when it is the nominal's. Several targets: the frame of their home points (against the declared nest,
    or of the points themselves); 6-DoF poses: the fitted orientation."""
    K = sweeps.n_targets
    if res is None or (K == 1 and res["rotation"] is None):
        return R_nominal, "nominal", None
    p = res["cov_all"].shape[0]
    if res["rotation"] is not None:
        G = np.zeros((3, p))
        G[:, p - 3 :] = np.eye(3)
        return res["rotation"], "poses", G
    n6 = 6 * sweeps.n_joints
    H = res["n_homes"]
    nest = sweeps.nest
    if nest is None and K < 3:
        notes.append(
            "tool frame: two targets per pose fix its orientation only up to a turn about the line through them; the"
            " nominal's is kept (declare the nest, the targets' positions in the tool frame, for the rest)"
        )
        return R_nominal, "nominal", None

    def frame(theta):
        homes = theta[: 3 * H].reshape(H, 3).mean(axis=0)
        P = np.vstack([homes, homes + theta[3 * H :].reshape(K - 1, 3)])
        if nest is None:
            x = (P[1] - P[0]) / np.linalg.norm(P[1] - P[0])
            z = np.cross(x, P[2] - P[0])
            z /= np.linalg.norm(z)
            return np.column_stack([x, np.cross(z, x), z])
        if K == 2:
            return _rotation_between(R_nominal @ (nest[1] - nest[0]), P[1] - P[0]) @ R_nominal
        a, b = nest - nest.mean(axis=0), P - P.mean(axis=0)
        u, _, vt = np.linalg.svd(b.T @ a)
        return u @ np.diag([1.0, 1.0, np.sign(np.linalg.det(u @ vt))]) @ vt

    theta0 = np.concatenate([res["home"][:H].ravel(), res["offsets"].ravel()])
    R = frame(theta0)
    J = np.zeros((3, len(theta0)))
    for i in range(len(theta0)):
        e = np.zeros_like(theta0)
        e[i] = 1e-7
        J[:, i] = (matrix_rotvec(frame(theta0 + e) @ R.T) - matrix_rotvec(frame(theta0 - e) @ R.T)) / 2e-7
    G = np.zeros((3, p))
    G[:, n6 : n6 + len(theta0)] = J
    how = "nest" if nest is not None else "targets"
    if how == "nest" and K == 2:
        notes.append(
            "tool frame: two targets fix its orientation up to a turn about the line through them: that turn is the"
            " nominal's"
        )
    if how == "targets":
        notes.append(
            "tool frame: no nest declared (the targets' positions in the tool frame): its orientation is the frame of"
            " the targets' points (x from target 1 to 2, z across the plane of targets 1-3)"
        )
    return R, how, G


#: An axis whose predicted position is known no better than this (1 sigma, m) gets a note naming its arc and the
#: predicted sigma (issue 16: a 1-degree arc had given FK 438 mm off with no note unless --max-sigma was given).
SHORT_ARC_SIGMA = 1e-3
#: ... when its arc is shorter than this (rad): a long arc known that poorly has other causes (noise, a unit slip).
SHORT_ARC = math.radians(20.0)


def _short_arc_notes(sweeps: SweepSet, fits: list, notes: list[str]) -> list[str]:
    """A note per sweep whose arc is shorter than :data:`SHORT_ARC` and whose axis-position sigma exceeds
    :data:`SHORT_ARC_SIGMA` (too short, or too few points, for an axis worth calibrating with); the notes are also
    returned (the plausibility error cites them)."""
    short = []
    for s, f in zip(sweeps.sweeps, fits, strict=True):
        if sweeps.kinds[s.joint - 1] == "revolute" and not f.sigma_point_perp <= SHORT_ARC_SIGMA and f.arc < SHORT_ARC:
            short.append(
                Message(
                    "{where}: the {arc:.3g} arc gives a predicted axis-position sigma of {sigma:.3g} (above"
                    " {limit:g}): sweep a longer arc or measure more points (--max-sigma makes this an error)",
                    where=sweep_where(s, sweeps.source),
                    arc=Angle(f.arc),
                    sigma=Length(f.sigma_point_perp),
                    limit=Length(SHORT_ARC_SIGMA),
                )
            )
    notes.extend(short)
    return short


def _oriented_by_nominal(sweeps: SweepSet, fits: list, nominal: Robot, notes: list[str]) -> list:
    """Without readings a sweep's direction comes from the point order; one that runs against the nominal's
    axis direction (e.g. recorded with decreasing joint values, or listed newest-first) is turned to the
    nominal's, with a note naming the joint."""
    nom = _core.axes(nominal.model(), sweeps.home).directions
    out = []
    for s, f in zip(sweeps.sweeps, fits, strict=True):
        j = s.joint - 1
        if f.direction @ np.asarray(nom[j]) < 0:
            notes.append(
                f"{sweep_where(s, sweeps.source)}: without readings the sweep runs against the nominal's axis {j + 1} "
                "(decreasing joint values, or rows newest-first?): oriented by the nominal"
            )
            f = flipped(f)
        out.append(f)
    return out


def nominal_convention_table(nominal: Robot | None, convention: str, home: np.ndarray) -> _core.Table | None:
    if nominal is None:
        return None
    if nominal.convention == convention:
        return nominal.table
    m = nominal.model()
    return _core.extract(_core.axes(m, np.zeros(m.nq)), convention).table


def origins(
    nominal_table: _core.Table | None, convention: str, home: np.ndarray, axes: _core.JointAxes | None = None
) -> np.ndarray | None:
    """ED-H frame origins: the nominal's on-body origins at home (world points, one per axis), which the core
    projects along each identified axis (Guo et al. sec. III: the origins are chosen on the body, not at the
    circle centres); None without a nominal or in other conventions. With the identified ``axes`` (at home), the
    last origin (the flange's) is at the nominal's distance along the last axis from its common normal with the axis
    before (the wrist), where the nominal's world point would put it as far off as the arm's errors before the wrist
    move the last axis along itself (1-3 mm for 0.5 mm / 0.05 deg errors, against the last link's own length error)."""
    if nominal_table is None or convention != "edh":
        return None
    o = np.array(nominal_table.frames(home))[1:, :3, 3]
    if axes is None or len(o) < 2:
        return o
    na = _core.axes(nominal_table.to_model(), home)
    Pn, Dn, P, D = na.points, na.directions, axes.points, axes.directions
    if np.linalg.norm(np.cross(Dn[-2], Dn[-1])) > 0.1:  # (a last axis parallel to the one before: no wrist point)
        s = (o[-1] - closest_point(Pn[-1], Dn[-1], Pn[-2], Dn[-2])) @ Dn[-1]
        o[-1] = closest_point(P[-1], D[-1], P[-2], D[-2]) + s * D[-1]
    return o


#: Axes with sin(angle) below this are parallel (identify's default ``parallel_tol``; also the bound of the ED-H
#: tolerance below when a table in another convention is asked of a result).
PARALLEL_TOL = 1e-3

#: ED-H with a nominal: a pair of axes the nominal has parallel takes the nominal's x when its tilt is within this
#: many of its combined direction sigmas (the common normal of a pair parallel within its noise follows the noise).
EDH_PARALLEL_SIGMAS = 3.0


def _edh_parallel_tol(fits: list, nominal: Robot | None, home: np.ndarray, parallel_tol: float) -> float:
    """The ``parallel_tol`` of an ED-H extraction against ``nominal``: ``EDH_PARALLEL_SIGMAS`` combined direction
    sigmas of the pairs the nominal has parallel (at most ``parallel_tol``; at least 1e-9, the round-off of data
    written to 10 digits), so that only a tilt the data cannot tell from zero is dropped (Guo et al.'s ED-H is
    exact for every other pair)."""
    if nominal is None:
        return parallel_tol
    z = np.asarray(_core.axes(nominal.model(), home).directions)
    sig = [
        math.hypot(fits[k].sigma_direction, fits[k + 1].sigma_direction)
        for k in range(len(z) - 1)
        if np.linalg.norm(np.cross(z[k], z[k + 1])) < 1e-9
        and np.isfinite(fits[k].sigma_direction)
        and np.isfinite(fits[k + 1].sigma_direction)
    ]
    return min(parallel_tol, max(EDH_PARALLEL_SIGMAS * max(sig, default=0.0), 1e-9))


def _axes_from(
    x: np.ndarray, sweeps: SweepSet, tool_R: np.ndarray, T_world_base: np.ndarray, lower, upper, q_ref=None
) -> _core.JointAxes:
    """The joint axes of ``x`` ([c_1, n_1, ..., tool point]) at the joint values ``q_ref`` (default the sweeps' home;
    with compliant joints the links' values there, :func:`denavit.identification.run._link_home`)."""
    n = sweeps.n_joints
    pts = np.array([x[6 * j : 6 * j + 3] for j in range(n)])
    dirs = np.array([x[6 * j + 3 : 6 * j + 6] for j in range(n)])
    T = np.eye(4)
    T[:3, :3] = tool_R
    T[:3, 3] = x[6 * n : 6 * n + 3]
    return _core.JointAxes(
        pts,
        dirs,
        kinds=sweeps.kinds,
        q_ref=sweeps.home if q_ref is None else q_ref,
        T_world_base=T_world_base,
        T_world_tool=T,
        lower=lower,
        upper=upper,
    )


def _parameter_cov(
    x: np.ndarray,
    cov: np.ndarray,
    ax: _core.JointAxes,
    sweeps: SweepSet,
    convention: str,
    opts: dict,
    p_ref: np.ndarray,
    n_rot: int = 0,
) -> np.ndarray:
    """The covariance of [the ``convention`` table's parameters (row-major, angles wrapped about ``p_ref``), the tool's
    translation (, the reading scales)] from the covariance ``cov`` of [c_1, n_1, ..., tool point (, the tool's small
    rotation in world: ``n_rot`` = 3) (, scales)] at ``x`` (the scales pass through), by central differences through
    the core's extraction with ``opts``."""
    J = _parameter_jacobian(x, len(cov), ax, sweeps, convention, opts, p_ref, n_rot)
    return J @ cov @ J.T


def _parameter_jacobian(
    x: np.ndarray,
    size: int,
    ax: _core.JointAxes,
    sweeps: SweepSet,
    convention: str,
    opts: dict,
    p_ref: np.ndarray,
    n_rot: int = 0,
    torque_home: np.ndarray | None = None,
) -> np.ndarray:
    """:func:`_parameter_cov`'s Jacobian, by [c_1, n_1, ..., tool point (, rotation) (, scales)] (``size`` of them)
    and, with ``torque_home`` (n,) N m, the joints' compliances after them: the links' values at home ``ax.q_ref``
    are the home less ``k torque_home`` (run._link_home), so a compliance turns its joint's offset in the table (an
    identification's axes are the arm's at home under its own weight)."""
    n6 = 6 * sweeps.n_joints + 3
    nk = 0 if torque_home is None else sweeps.n_joints
    tool_R, base = np.asarray(ax.T_world_tool)[:3, :3], np.asarray(ax.T_world_base)
    angle_cols = np.array(_core.Table(convention, p_ref, list(ax.kinds)).angle_columns)
    xs = np.concatenate([x, np.zeros(size - n6 + nk)])
    k_home = np.zeros(sweeps.n_joints) if torque_home is None else np.asarray(torque_home, dtype=float)

    def params_of(xv):
        R = rotvec_matrix(xv[n6 : n6 + n_rot]) @ tool_R if n_rot else tool_R
        q_ref = np.asarray(ax.q_ref) - (K_STEP * xv[size:] * k_home if nk else 0.0)
        a = _axes_from(xv[:n6], sweeps, R, base, ax.lower, ax.upper, q_ref)
        t = _core.extract(a, convention, fidelity=False, **opts).table  # the tool-error check: once, by the caller
        d = t.params - p_ref
        d[:, angle_cols] = (d[:, angle_cols] + np.pi) % (2 * np.pi) - np.pi
        return np.concatenate([(p_ref + d).ravel(), np.asarray(t.T_last_tool)[:3, 3], xv[n6 + n_rot : size]])

    J = _jacobian(xs, params_of)
    J[:, size:] /= K_STEP  # (by the compliances themselves)
    return J


#: The compliances' columns of :func:`_parameter_jacobian` step by this times its 1e-7 (rad/(N m)): a joint holding
#: 5000 N m at home turns by 5e-7 rad (the extraction's linear range).
K_STEP = 1e-3


def _jacobian(x: np.ndarray, f) -> np.ndarray:
    """The Jacobian of f(x) (a flat vector, angles wrapped) at x, by central differences."""
    y0 = f(x)
    J = np.zeros((len(y0), len(x)))
    for i in range(len(x)):
        h = 1e-7
        xp, xm = x.copy(), x.copy()
        xp[i] += h
        xm[i] -= h
        d = f(xp) - f(xm)
        J[:, i] = d / (2 * h)
    return J
