"""One fit of all sweeps with their joint readings (the ``global`` fit of :func:`denavit.identification.identify`).

Every axis at the home configuration is a line ``(c_i, n_i)``; the tool point at home is ``p`` (one for all
sweeps, or one per sweep: a home that drifts between sweeps). A point of a sweep is the home point carried by
every joint's motion from home, in chain order (the product of exponentials at home)::

    p_k = g_1(g_2(... g_n(p))),   g_i(y) = c_i + R(n_i, dq_ik)(y - c_i)  (revolute),  y + dq_ik n_i  (prismatic)

with ``dq_ik`` the reading of joint ``i`` minus its home value: the swept joint's readings, and the locked
joints' recorded readings smoothed over the sweep (a straight line in time: a locked joint that sits a little
off home, or creeps, is followed; white reading noise is averaged out), unless a locked reading moves in
lock-step with the swept joint (a coupling of the controller's readings, then taken as locked at home).

Several targets per pose (2-4 SMRs on one nest, :attr:`denavit.sweeps.Sweep.targets`): every target ``t`` has its
own home point ``p + o_t`` on the last body (``o_1 = 0``; with a home per sweep the drift ``p_s`` moves them all),
carried by the same joint motion, so every axis is fitted once from all targets. 6-DoF poses
(:attr:`~denavit.sweeps.Sweep.rotations`): the measured orientation is the home orientation ``R_0`` carried by the
rotations of the same chain, ``R_k = R(n_1, dq_1k) ... R(n_n, dq_nk) R_0``; its residual (the rotation vector of
``R_pred R_meas^T``, rad) is weighted by ``sigma / sigma_rot``, ``sigma_rot`` the orientation noise (declared, or a
variance component estimated from the residuals across the swept axis). A pose is then one residual vector of
``3 k (+ 3)`` components, whose reading error moves every component along one direction (the tangent below).

Errors: the points carry isotropic noise ``sigma`` (or a tracker's range/angle noise, below); the swept joint's readings carry white errors, so along the
motion a point's misfit has the variance ``tau_s^2 = sigma^2 + (lever sigma_q)^2`` (effective variance, as the
readings fit of :mod:`denavit.fitting.readings`). ``sigma`` (pooled across the motion) and each sweep's
``tau_s`` are variance components estimated over their redundancies, together with the Gauss-Newton /
Levenberg-Marquardt steps (normal equations accumulated sweep by sweep: memory and time linear in the points).
Each step costs one pass over the points (its robust weights from that pass's own misfits). The fit stops, once
the variance components and the robust scale hold still, at a step of at most ``STEP_TOL`` of its own sigmas
(its Mahalanobis length under the covariance), or when the cost changes by no more than its round-off (about
eps times the largest coordinate times the root of the cost): a rule free of the number of points, whereas a
relative cost decrease of 1e-14 is near the round-off of a million-point cost and had cost extra passes.

A laser tracker's noise is not isotropic: the distance (ADM / interferometer) is precise, the two angles less so, so
across the line of sight the noise grows with the range. With a tracker model (``tracker``, :class:`TrackerNoise`:
the tracker's position, ``sigma_range`` and ``sigma_angle``) a point's covariance is
``sigma^2 A_k``, ``A_k = (sigma_range^2 u u^T + (sigma_angle rho_k)^2 (I - u u^T)) / ref^2`` (``u`` the unit line of
sight from the tracker to the measured point, ``rho_k`` its range, ``ref^2`` the mean of the declared per-coordinate
variance over all points: ``sigma`` stays the point noise in metres, RMS per coordinate, and the variance component
that scales the declared shape). Each target's residual, Jacobian rows and motion ``d p / d q`` are whitened by
``A_k^(-1/2) = a^(-1/2) u u^T + b^(-1/2) (I - u u^T)``; the effective covariance ``sigma^2 A_k + (lever sigma_q)^2 t
t^T`` is then ``sigma^2 I + (lever sigma_q)^2 v v^T``, ``v = A_k^(-1/2) t``, and the reading error's whitening applies
along the unit ``v``, with a factor per pose, ``gamma_k = sigma / sqrt(sigma^2 + (|v| lever sigma_q)^2)`` (the
whitened lever changes along the arc as the motion turns against the line of sight); each sweep's variance
component is its ``gamma`` at a reference lever (the RMS of its poses' at the start). Without it (the default) the
points are isotropic and nothing of this runs.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import DenavitError, NotConvergedError
from ..geometry import axis_angle_matrices, matrix_rotvec, perpendicular_basis, skew
from .robust import loss_dweight, loss_weight, misfit_variance, robust_sigma

#: A locked reading whose correlation with the swept joint's reading exceeds this (and which moves) is coupled.
COUPLED_CORRELATION = 0.99
#: Points of a sweep per step of the joint fit's normal equations (their Jacobian rows, a few MB, are not kept).
CHUNK = 8192
#: The joint fit stops at a step of at most this many of its own sigmas (Mahalanobis length under the covariance),
#: once the variance components and the robust scale move by less than GAMMA_TOL and SCALE_TOL (relative).
STEP_TOL = 1e-3
GAMMA_TOL = 1e-3
SCALE_TOL = 1e-4
#: Round-off of a misfit, in units of eps times the largest coordinate (the chain of rotations of the home point).
COST_ROUNDOFF = 16.0


@dataclass(frozen=True)
class TrackerNoise:
    """A laser tracker's point noise, the range/angle model: the distance (ADM / interferometer) to a point has the
    noise ``sigma_range`` (m, 1 sigma) along the line of sight ``u`` from the tracker at ``position`` (m, in the data's
    frame; default the origin: a tracker's export is in its own frame), each of the two angles ``sigma_angle`` (rad),
    so across the line of sight the noise is ``sigma_angle`` times the range ``rho``::

        Sigma_k = sigma_range^2 u u^T + (sigma_angle rho_k)^2 (I - u u^T)

    (typical: 5 um and 0.5-1 arcsec, i.e. 7-15 um across at 2-3 m; cf. the makers' MPE of the form 15 um + 6 um/m,
    ASME B89.4.19). The joint fit takes the shape of these covariances from the declared values, and their scale
    from the data (:func:`fit_sweeps`)."""

    sigma_range: float
    sigma_angle: float
    position: tuple = (0.0, 0.0, 0.0)

    def __post_init__(self) -> None:
        for name, unit in (("sigma_range", "m"), ("sigma_angle", "rad")):
            v = getattr(self, name)
            try:
                ok = math.isfinite(float(v)) and float(v) > 0
            except (TypeError, ValueError):
                ok = False
            if not ok:
                raise DenavitError(f"tracker noise: {name} must be a finite value > 0 in {unit}, got {v!r}")
            object.__setattr__(self, name, float(v))
        try:
            pos = np.asarray(self.position, dtype=float)
        except (TypeError, ValueError):
            pos = None
        if pos is None or pos.shape != (3,) or not np.all(np.isfinite(pos)):
            raise DenavitError(f"tracker noise: position must be 3 finite values (x, y, z in m), got {self.position!r}")
        object.__setattr__(self, "position", tuple(float(v) for v in pos))

    def shape(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The points x (3, m): their lines of sight u (3, m), and the variances along (m,) and across them (m,), m^2."""
        d = x - np.asarray(self.position)[:, None]
        rho = np.linalg.norm(d, axis=0)
        return d / np.maximum(rho, 1e-300), np.full(rho.shape, self.sigma_range**2), (self.sigma_angle * rho) ** 2

    def reference_variance(self, x: np.ndarray) -> float:
        """The mean declared variance per coordinate (m^2) over the points x (3, m): the scale the fits whiten to."""
        _, a, b = self.shape(x)
        return float(np.mean((a + 2 * b) / 3))

    def whitening(self, points: np.ndarray) -> tuple[np.ndarray, float]:
        """Per point (N, 3) the matrix ``W_k = ref Sigma_k^(-1/2)`` (N, 3, 3) and ``ref`` (m): the root of
        :meth:`reference_variance`, so that ``W_k r_k`` has the covariance ``ref^2 I`` and stays in metres
        (calibrate's weighting of its points; the joint fit's :func:`_whitener` as matrices)."""
        x = np.asarray(points, dtype=float).T
        ref2 = self.reference_variance(x)
        u, ia, ib = _whitener(self, ref2, x)
        return ib[:, None, None] * np.eye(3) + ((ia - ib)[:, None, None] * np.einsum("in,jn->nij", u, u)), math.sqrt(
            ref2
        )


def as_tracker_noise(value) -> TrackerNoise | None:
    """``value`` as a :class:`TrackerNoise`: one already, None, or (sigma_range m, sigma_angle rad[, position m])."""
    if value is None or isinstance(value, TrackerNoise):
        return value
    try:
        items = None if isinstance(value, (str, bytes)) else list(value)
    except TypeError:
        items = None
    if items is None or len(items) not in (2, 3):
        raise DenavitError(
            f"tracker noise: expected a TrackerNoise or (sigma_range m, sigma_angle rad[, position (x, y, z) m]), got {value!r}"
        )
    return TrackerNoise(*items)


def _whitener(tracker: TrackerNoise, ref2: float, x: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The whitening Sigma_k^(-1/2) of the points x (3, m) (their covariance shapes over ``ref2``, m^2): (u, the
    factors along u and across it), applied by :func:`_whiten`."""
    u, va, vb = tracker.shape(x)
    return u, np.sqrt(ref2 / va), np.sqrt(ref2 / vb)


def _whiten(w: tuple, x: np.ndarray) -> np.ndarray:
    """x (..., 3, m) whitened per point by ``w`` (:func:`_whitener`): ib x + (ia - ib) u (u . x)."""
    u, ia, ib = w
    return x * ib + u * ((ia - ib) * np.einsum("im,...im->...m", u, x))[..., None, :]


def locked_motion(q: np.ndarray, joint: int, home: np.ndarray, tol: np.ndarray):
    """Per-point joint motion from home (m, n) used by the fit, and the locked joints coupled to the swept one.

    The swept joint (0-based ``joint``) moves by its readings; a locked joint by the straight-line (time) fit of
    its readings, minus home; a locked reading that moves (range beyond ``tol``) in lock-step with the swept
    joint (correlation above ``COUPLED_CORRELATION``) is a coupling of the readings: taken as locked at home
    and returned in ``coupled`` as (joint, slope of its reading against the swept one).
    """
    m, n = q.shape
    dq = np.zeros((m, n))
    dq[:, joint] = q[:, joint] - home[joint]
    t = np.arange(m, dtype=float) - (m - 1) / 2
    coupled = []
    sw = q[:, joint] - q[:, joint].mean()
    for i in range(n):
        if i == joint:
            continue
        qi = q[:, i]
        if np.ptp(qi) > tol[i] and np.std(sw) > 0 and np.std(qi) > 0:
            r = float(np.corrcoef(qi, sw)[0, 1])
            if abs(r) > COUPLED_CORRELATION:
                coupled.append((i, float(np.polyfit(sw, qi, 1)[0])))
                continue
        # offset and creep from home, each kept only where it exceeds three of its standard errors (else noise)
        off = qi.mean() - home[i]
        slope = float(t @ (qi - qi.mean()) / (t @ t)) if m > 2 else 0.0
        rest = qi - qi.mean() - slope * t
        se = math.sqrt(float(rest @ rest) / (m - 2)) if m > 2 else 0.0
        off = off if abs(off) > max(3 * se / math.sqrt(m), 1e-12) else 0.0  # (1e-12 rad / m: round-off)
        slope = slope if m > 2 and abs(slope) * m > max(3 * se * m / math.sqrt(t @ t), 1e-12) else 0.0
        dq[:, i] = off + slope * t
    return dq, coupled


def _pinv_sym(a: np.ndarray) -> np.ndarray:
    """Inverse of a symmetric positive semi-definite matrix on its non-zero rows (parameters the data does not
    touch, e.g. the point of a prismatic axis, get zero); ``np.linalg.inv``, which stays fast on a loaded
    machine where the threaded eigen/SVD solvers crawl."""
    d = np.diag(a)
    keep = d > 1e-300
    out = np.zeros_like(a)
    out[np.ix_(keep, keep)] = np.linalg.inv(a[np.ix_(keep, keep)])
    return (out + out.T) / 2


def _trig(d: np.ndarray) -> tuple:
    """(cos, sin, 1 - cos) of the angles d (m,)."""
    co = np.cos(d)
    return co, np.sin(d), 1 - co


def _turn(n: np.ndarray, d: np.ndarray, trig: tuple | None = None) -> tuple:
    """A revolute joint's rotations R(n, d_k) for the angles d (m,): (n, K with K x = n x x, cos, sin, 1 - cos),
    for :func:`_rotate`; ``trig`` the angles' :func:`_trig` when known."""
    return (n, skew(n), *(_trig(d) if trig is None else trig))


def _rotate(turn: tuple, x: np.ndarray) -> np.ndarray:
    """R(n, d_k) x_k (Rodrigues) for vectors x (..., 3, m), or x (..., 3, 1) the same for every point; ``turn``
    from :func:`_turn`. Stacks of vectors (the leading axes) turn at once; components first, points last (the
    per-point factors then broadcast along whole rows: an (m, 3) layout had numpy loop over rows of three)."""
    n, K, co, sn, omc = turn
    return x * co + (K @ x) * sn + n[:, None] * ((n @ x) * omc)[..., None, :]


def _carried(turns: dict, active: list, i: int, x: np.ndarray) -> np.ndarray:
    """x (k, 3, m or 1) carried by the linear parts of g_1 ... g_(i-1) (the active revolute joints before i)."""
    for a in reversed(active):
        if a < i and a in turns:
            x = _rotate(turns[a], x)
    return x


def _chain(
    cs, ns, kinds, p, dq, active, jac: bool, moving: int | None = None, trig: dict | None = None, basis: bool = False
):
    """Predicted points (3, m), and with ``jac`` the Jacobian blocks and the motion of the swept joint.

    Returns ``pred``, ``blocks`` {joint: (4, 3, m) d pred / d [a, b, s, t]} (direction in its tangent basis,
    point across the axis), ``jp`` (3, 3, m) d pred / d p, and ``dpdq`` {joint: (3, m)} d pred / d q_joint (the
    parameter first, then the components, the points last, as in a chunk's Jacobian). Without ``jac`` but with
    ``moving`` (a joint), ``dpdq`` of that joint alone (the misfit's tangent), no blocks. Rotations act on
    vectors (Rodrigues), a vector the same for every point (the home point before the first joint turns it) as
    one column, so the cost is linear in the points and small per point. ``trig`` {joint: :func:`_trig` of its
    motion dq[:, joint]} when known (the fit keeps them between passes).

    ``basis`` (with ``jac``, when one revolute joint moves, :func:`_basis_chain`): the blocks (with d pred / d q
    fifth) and ``jp`` as their coefficients on (1, cos, sin) of that joint's motion, (..., 3) in place of (..., m);
    ``dpdq`` per point.
    """
    if jac and basis and _one_turn(kinds, active):
        return _basis_chain(cs, ns, p, dq, active[0], trig.get(active[0]) if trig else None)
    m = dq.shape[0]
    turns = {i: _turn(ns[i], dq[:, i], trig.get(i) if trig else None) for i in active if kinds[i] == "revolute"}
    y = np.asarray(p, dtype=float)[:, None]
    before, turned = {}, {}
    for i in reversed(active):
        before[i] = y
        if kinds[i] == "prismatic":
            y = y + ns[i][:, None] * dq[:, i]
        else:
            turned[i] = _rotate(turns[i], y - cs[i][:, None])
            y = cs[i][:, None] + turned[i]
    y = np.broadcast_to(y, (3, m))
    if not jac and moving is None:
        return y, None, None, None

    def move(i):
        """d pred / d q_i before the joints ahead of i carry it: n (prismatic), n x R (y - c) (revolute)."""
        return ns[i][None, :, None] if kinds[i] == "prismatic" else (turns[i][1] @ turned[i])[None]

    if not jac:
        return y, None, None, {moving: np.broadcast_to(_carried(turns, active, moving, move(moving))[0], (3, m))}
    blocks, dpdq = {}, {}
    for i in active:
        B = [b[:, None] for b in perpendicular_basis(ns[i])]
        n = ns[i][:, None]
        if kinds[i] == "prismatic":
            cols = [b * dq[:, i] for b in B] + [np.zeros((3, m)), np.zeros((3, m)), move(i)[0]]
        else:
            _, K, co, sn, omc = turns[i]
            v = before[i] - cs[i][:, None]
            nv = ns[i] @ v
            # d(R v)/dn b = -sin (v x b) + (1 - cos)((n.v) b + n (v.b)); (I - R) b, b across n: R b = b cos + (n x b) sin
            cols = [sn * (skew(b[:, 0]) @ v) + omc * (b * nv + n * (b[:, 0] @ v)) for b in B]
            cols += [b - (b * co + (K @ b) * sn) for b in B]
            cols.append(move(i)[0])
        X = _carried(turns, active, i, np.stack([np.broadcast_to(c, (3, m)) for c in cols]))
        blocks[i], dpdq[i] = X[:4], X[4]
    jp = np.broadcast_to(_carried(turns, active, len(kinds), np.eye(3)[:, :, None]), (3, 3, m))
    return y, blocks, jp, dpdq


def _one_turn(kinds, active) -> bool:
    """Whether one revolute joint alone moves (the locked joints at home): the Jacobian is then linear in the
    cosine and sine of its motion (:func:`_basis_chain`)."""
    return len(active) == 1 and kinds[active[0]] == "revolute"


def _basis_chain(cs, ns, p, dq, i: int, trig: tuple | None = None):
    """:func:`_chain` with ``jac`` when joint ``i`` alone moves, revolute: ``pred`` (3, m), the Jacobian blocks
    {i: (5, 3, 3)} (the four parameters' columns, then d pred / d q_i) and ``jp`` (3, 3, 3) as their coefficients on
    (1, cos dq_k, sin dq_k) (the last axis), and ``dpdq`` {i: (3, m)} per point. A rotation R(n, d) x = n (n.x) +
    (x - n (n.x)) cos d + (n x x) sin d, so every column of the Jacobian is three fixed vectors combined by the
    point's cosine and sine: the normal equations
    take the points' weighted moments of (1, cos, sin) (:class:`_Basis`) instead of a (parameters, 3) Jacobian per
    point (the same sums, in another order)."""
    n, c = ns[i], cs[i]
    K, (co, sn, omc) = skew(n), (_trig(dq[:, i]) if trig is None else trig)
    v = np.asarray(p, dtype=float) - c
    turned = _rotate((n, K, co, sn, omc), v[:, None])
    y = c[:, None] + turned
    key = (n.tobytes(), v.tobytes())
    last = _BASIS_LAST[0]  # (one reference read: threads each keep the pair they read or made)
    if last is None or last[0] != key:  # the coefficients hold for every chunk of a sweep in a pass
        last = _BASIS_LAST[0] = (key, _basis_coefficients(n, K, v))
    cols, jp = last[1]
    return y, {i: cols}, jp, {i: K @ turned}


#: (the axis direction and the home point's lever of the last :func:`_basis_chain`, their coefficients), read-only
_BASIS_LAST: list = [None]


def _basis_coefficients(n: np.ndarray, K: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:func:`_basis_chain`'s coefficients of the columns (5, 3, 3) and of ``jp`` (3, 3, 3) for the axis direction
    ``n`` (K = skew(n)) and the home point's lever ``v`` (from a point of the axis)."""
    nv = float(n @ v)
    cols = []
    for b in perpendicular_basis(n):
        q = b * nv + n * float(b @ v)  # the direction's column: sin (b x v) + (1 - cos) q
        cols.append(np.stack([q, -q, skew(b) @ v], axis=-1))
    for b in perpendicular_basis(n):  # the point's: b - R b
        cols.append(np.stack([b, -b, -(K @ b)], axis=-1))
    Kv = K @ v
    cols.append(np.stack([np.zeros(3), Kv, K @ Kv], axis=-1))  # the motion's: n x R v = (n x v) cos + n x (n x v) sin
    nn = np.outer(n, n)
    jp = np.stack([nn, np.eye(3) - nn, K], axis=-1).transpose(1, 0, 2)  # [l, :, a]: R e_l
    return np.array(cols), jp


class _Basis:
    """A chunk's Jacobian (parameters, 3, m) as ``F`` (b, m), the points' basis functions (1, cos, sin of the moving
    joint's motion, and with ``scaled`` those times the reading's motion ``F[3]`` for a scale's column, the last), and
    ``C`` (b, parameters, 3) their coefficients: J[:, :, k] = sum_a F[a, k] C[a] (:func:`_basis_chain`)."""

    __slots__ = ("F", "C", "Cf", "scaled")

    def __init__(self, F: np.ndarray, C: np.ndarray, scaled: bool = False):
        self.F, self.C, self.scaled = F, C, scaled
        # (parameters, 3 basis functions x 3 components); a scale's column on (1, cos, sin), times the reading after
        Cf = C[:3].copy()
        if scaled:
            Cf[:, -1] = C[3:, -1]
        self.Cf = np.ascontiguousarray(Cf.transpose(1, 0, 2)).reshape(C.shape[1], -1)

    def dot(self, x: np.ndarray) -> np.ndarray:
        """sum_i J[p, i, k] x[i, k] (parameters, m) for x (3, m)."""
        out = self.Cf @ (self.F[:3, None, :] * x[None]).reshape(-1, x.shape[1])
        if self.scaled:
            out[-1] *= self.F[3]
        return out

    def gram(self, w: np.ndarray) -> np.ndarray:
        """sum_k w_k J_k^T J_k (parameters, parameters)."""
        M = (self.F * w) @ self.F.T
        return np.einsum("ab,api,bqi->pq", M, self.C, self.C)

    def rdot(self, e: np.ndarray) -> np.ndarray:
        """sum_k J_k^T e_k (parameters,) for e (3, m)."""
        return np.einsum("api,ai->p", self.C, self.F @ e.T)


def _chain_rotation(ns, kinds, R0, dq, active, jac: bool, moving: int | None = None, trig: dict | None = None):
    """Predicted orientations ``R(n_1, dq_1) ... R(n_n, dq_n) R0`` (m, 3, 3), and with ``jac`` the Jacobian blocks
    of the orientation residual (a small rotation in ``world``): {joint: (4, 3, m) d r / d [a, b, s, t]} (the
    point across the axis does not turn anything: zeros), ``jr`` (3, 3, m) d r / d the rotation of ``R0`` (a
    rotation vector in ``world``), and {joint: (3, m)} d r / d q_joint (the joint's axis carried by the joints
    before it). Without ``jac`` but with ``moving``, that joint's d r / d q alone.

    Turning n by dq b (b across n) turns R(n, dq) by ``J_l(dq n) dq b = sin(dq) b + (1 - cos(dq)) n x b`` (the left
    Jacobian of SO(3)), then carried by the joints before. ``trig`` as for :func:`_chain`."""
    m = dq.shape[0]
    turns = {i: _turn(ns[i], dq[:, i], trig.get(i) if trig else None) for i in active if kinds[i] == "revolute"}
    # the columns of R0 (column, component, 1), turned by every joint; then (m, row, column)
    Y = np.transpose(
        np.broadcast_to(_carried(turns, active, len(kinds), np.asarray(R0, dtype=float).T[:, :, None]), (3, 3, m)),
        (2, 1, 0),
    )
    if not jac and moving is None:
        return Y, None, None, None

    def turn(i):
        return (
            np.zeros((3, m))
            if kinds[i] == "prismatic"
            else np.broadcast_to(_carried(turns, active, i, ns[i][None, :, None])[0], (3, m))
        )

    if not jac:
        return Y, None, None, {moving: turn(moving)}
    blocks, dpdq = {}, {}
    for i in active:
        if kinds[i] == "prismatic":
            blocks[i] = np.zeros((4, 3, m))
        else:
            _, K, co, sn, omc = turns[i]
            cols = _carried(
                turns,
                active,
                i,
                np.stack([b[:, None] * sn + (K @ b)[:, None] * omc for b in perpendicular_basis(ns[i])]),
            )
            blocks[i] = np.concatenate([cols, np.zeros((2, 3, m))])
        dpdq[i] = turn(i)
    jr = np.broadcast_to(_carried(turns, active, len(kinds), np.eye(3)[:, :, None]), (3, 3, m))
    return Y, blocks, jr, dpdq


def _chordal_mean(R: np.ndarray) -> np.ndarray:
    """The rotation closest (Frobenius) to the mean of rotations R (m, 3, 3) (the chordal L2 mean)."""
    u, _, vt = np.linalg.svd(np.mean(R, axis=0))
    return u @ np.diag([1.0, 1.0, np.sign(np.linalg.det(u @ vt))]) @ vt


def start_homes(sweeps, starts) -> tuple[np.ndarray, np.ndarray | None]:
    """Start values of the joint fit: each target's point at home (k, 3) and the probe's orientation at home (3, 3)
    (None without 6-DoF poses): every measured point (orientation) turned back to home about its sweep's start axis
    by the swept joint's readings, averaged (orientations by their chordal mean)."""
    K = sweeps.n_targets
    est = [[] for _ in range(K)]
    rots = []
    for s, (c, nv) in zip(sweeps.sweeps, starts, strict=True):
        j = s.joint - 1
        d = sweeps.home[j] - s.q[:, j]
        pts = [s.points] if s.targets is None else [s.targets[:, t] for t in range(K)]
        if sweeps.kinds[j] == "prismatic":
            for t, p in enumerate(pts):
                est[t].append(p + np.outer(d, nv))
            if s.rotations is not None:
                rots.append(s.rotations)
        else:
            turn = _turn(np.asarray(nv, dtype=float), d)
            for t, p in enumerate(pts):
                est[t].append(c + _rotate(turn, p.T - c[:, None]).T)
            if s.rotations is not None:
                rots.append(axis_angle_matrices(nv, d) @ s.rotations)
    homes = np.array([np.mean(np.vstack(e), axis=0) for e in est])
    return homes, (_chordal_mean(np.vstack(rots)) if rots else None)


def fit_sweeps(
    sweeps,
    dqs: list,
    starts: list,
    p0: np.ndarray,
    *,
    loss: str = "linear",
    per_sweep_home: bool = False,
    scales=False,
    scale_prior=None,
    noise_sigma=None,
    gamma=None,
    offsets0=None,
    rotation0=None,
    rotation_sigma=None,
    tracker=None,
    where: str = "",
):
    """The joint fit of all sweeps (module docstring). ``dqs`` per sweep (m, n) joint motions from home
    (:func:`locked_motion`), ``starts`` per joint (point, direction) start lines, ``p0`` the start home point (of
    the first target); with several targets ``offsets0`` (k - 1, 3) the start offsets of the other targets' home
    points from it, with 6-DoF poses ``rotation0`` (3, 3) the start orientation at home (both by default from
    :func:`start_homes`) and ``rotation_sigma`` (rad) the declared orientation noise (default: estimated).

    ``scales``: False (none), True (every swept joint's reading scale error is a parameter) or the joints
    (0-based) whose scale is one. ``scale_prior``: None, or ``(tau, sigma)``: every fitted scale is drawn from a
    zero-mean normal population of standard deviation ``tau`` (a pseudo-observation ``s_j / tau`` weighted against the
    points as ``(sigma / tau)^2``, ``sigma`` the point noise of the caller's simpler fit), so the fit is the posterior
    mode and its covariance the posterior's (:func:`denavit.identification.choice._reading_scales`). ``tracker`` a
    :class:`TrackerNoise` (or (sigma_range m, sigma_angle rad[, position m])): the points' covariances take its
    range/angle shape (module docstring); None: isotropic.

    Returns a dict: ``points`` (n, 3) feet of the home point on each axis, ``directions`` (n, 3), ``home``
    (S, 3) home point per sweep (all equal without ``per_sweep_home``), ``cov`` of [c_1, n_1, ..., c_n, n_n,
    p_1 (, p_2, ...)] (the axis points at those feet; with ``scales`` marginal over the scales), ``cov_all`` the
    same followed by the offsets of the further targets and the rotation vector of the home orientation (world),
    ``offsets`` (k - 1, 3), ``rotation`` (3, 3) the orientation at home (None without poses), ``rotation_sigma`` the
    orientation noise (rad; nan without poses), ``scales`` (n,)
    each swept joint's reading scale error ``s_j`` (the joint turns by ``(1 + s_j)`` times its reading's motion;
    zeros without ``scales``) and ``scale_sigma`` (n,) their one-sigma (nan without), ``scale_cross`` (rows of
    ``cov``, n) and ``scale_cov`` (n, n) their covariance with those parameters and among themselves (zeros where not
    fitted), ``misfit`` per sweep (m,) 3-D distances (RMS over the targets of a pose), ``weights`` per sweep (m,)
    robust weights, ``whitened`` per sweep (m,) misfits in point-noise units (norms of ``components`` components),
    ``sigma`` the point
    noise, ``reading_sigma`` per sweep, ``ss`` the whitened sum of squares and ``n_params``; ``tracker_ref2`` the
    tracker model's reference variance (m^2: ``sigma / sqrt(tracker_ref2)`` is the point noise over the declared; nan
    without a model).
    """
    kinds = sweeps.kinds
    n, S = sweeps.n_joints, len(sweeps.sweeps)
    K = sweeps.n_targets
    rot = sweeps.has_rotations
    cs = [np.array(c, dtype=float) for c, _ in starts]
    ns = [np.array(d, dtype=float) / np.linalg.norm(d) for _, d in starts]
    if (K > 1 and offsets0 is None) or (rot and rotation0 is None):
        h0, r0 = start_homes(sweeps, starts)
        offsets0 = h0[1:] - h0[0] if offsets0 is None else offsets0
        rotation0 = r0 if rotation0 is None else rotation0
    homes = np.tile(np.asarray(p0, dtype=float), (S if per_sweep_home else 1, 1))
    offs = np.zeros((0, 3)) if K == 1 else np.array(offsets0, dtype=float).reshape(K - 1, 3)
    R0 = np.array(rotation0, dtype=float) if rot else None
    # the joints whose reading scale is fitted: every swept joint (scales True), or those given (0-based)
    all_swept = sorted({s.joint - 1 for s in sweeps.sweeps})
    swept = (
        (all_swept if scales is True else sorted({int(j) for j in scales} & set(all_swept)))
        if scales is not False and scales is not None
        else []
    )
    sc = np.zeros(n)
    H = len(homes)
    i_off = 4 * n + 3 * H  # the first offset's index, then the home rotation's, then the scales'
    i_rot = i_off + 3 * (K - 1)
    i_sc = i_rot + (3 if rot else 0)
    npar = i_sc + len(swept)
    prior_w = 0.0 if scale_prior is None or not swept else (scale_prior[1] / scale_prior[0]) ** 2
    i_prior = np.arange(i_sc, npar)
    D = 3 * K + (3 if rot else 0)  # residual components per pose
    active = [[i for i in range(n) if np.any(dq[:, i] != 0)] for dq in dqs]
    size = max(float(np.sqrt(np.mean(np.sum((s.points - s.points.mean(axis=0)) ** 2, axis=1)))) for s in sweeps.sweeps)
    floor = 1e-12 * size
    gam = np.ones(S) if gamma is None else np.array(gamma, dtype=float)
    ws = [np.ones(len(s.points)) for s in sweeps.sweeps]

    def home_of(k):
        return homes[k] if per_sweep_home else homes[0]

    def measured(s, rows, t):
        return (s.points[rows] if s.targets is None else s.targets[rows, t]).T

    tracker = as_tracker_noise(tracker)
    ref2 = lref = None
    wmax = 1.0
    if tracker is not None:
        # the points' covariance shapes over their mean variance per coordinate (every point of every target): the
        # fit's sigma stays the point noise in metres (RMS per coordinate), its scale a variance component
        shapes = [tracker.shape(measured(s, slice(None), t)) for s in sweeps.sweeps for t in range(K)]
        ref2 = float(np.mean(np.concatenate([(va + 2 * vb) / 3 for _, va, vb in shapes])))
        wmax = math.sqrt(ref2 / min(float(np.min(np.minimum(va, vb))) for _, va, vb in shapes))

    trig = {}  # (sweep, first row of a chunk): (the scales of its active joints, {joint: _trig of its motion}, the motion)
    simple = (
        tracker is None and not rot and K == 1
    )  # a pose one point, isotropic: the Jacobian of one turning joint by moments

    def chunks(k, cs, ns, homes_, offs_, R_, sc_, wr, jac):
        """(rows, misfits r (D, m), d r / d q of the swept joint (D, m), Jacobian (local parameters, D, m) or None,
        None or with a tracker model the 3-D misfits (m,) (RMS over the targets)) of sweep k, CHUNK poses at a time
        (the joints turning by (1 + s) times their readings' motion); the orientation rows weighted by ``wr``, with a
        tracker model each target's rows whitened by its point's Sigma_k^(-1/2). Components first, points last
        (:func:`_rotate`)."""
        s, dq = sweeps.sweeps[k], dqs[k]
        j = s.joint - 1
        h = homes_[k] if per_sweep_home else homes_[0]
        npl = len(local(k))
        for a in range(0, len(dq), CHUNK):
            rows = slice(a, a + CHUNK)
            # the chunk's joint motions and their cosines and sines, kept while the reading scales they were made with hold
            key = tuple(float(sc_[i]) for i in active[k])
            if trig.get((k, a), (None,))[0] != key:
                dqc = dq[rows] * (1 + sc_)
                trig[(k, a)] = (key, {i: _trig(dqc[:, i]) for i in active[k] if kinds[i] == "revolute"}, dqc)
            _, tc, dqc = trig[(k, a)]
            mc = len(dqc)
            rs, mvs, Js = [], [], []
            dist = None if tracker is None else np.zeros(mc)
            for t in range(K):
                pred, blocks, jp, dpdq = _chain(
                    cs, ns, kinds, h + (offs_[t - 1] if t else 0.0), dqc, active[k], jac, j, trig=tc, basis=simple
                )
                r_t, mv_t = pred - measured(s, rows, t), dpdq[j]
                if (
                    jac and simple and _one_turn(kinds, active[k])
                ):  # the Jacobian on the points' (1, cos, sin) (:class:`_Basis`)
                    co, sn = tc[j][0], tc[j][1]
                    C = np.zeros((6 if j in swept else 3, npl, 3))
                    C[:3, :7] = np.concatenate([blocks[j][:4], jp]).transpose(2, 0, 1)
                    F = [np.ones(mc), co, sn]
                    if j in swept:  # the scale's column: d pred / d q times the reading's motion
                        C[3:, 7] = blocks[j][4].T
                        F += [dq[rows, j], dq[rows, j] * co, dq[rows, j] * sn]
                    Js.append(_Basis(np.array(F), C, j in swept))
                    rs.append(r_t)
                    mvs.append(mv_t)
                    continue
                if tracker is not None:
                    w_t = _whitener(tracker, ref2, measured(s, rows, t))
                    dist += np.sum(r_t**2, axis=0) / K
                    r_t, mv_t = _whiten(w_t, r_t), _whiten(w_t, mv_t)
                rs.append(r_t)
                mvs.append(mv_t)
                if jac:
                    jo = np.zeros((3 * (K - 1), 3, mc))
                    if t:
                        jo[3 * (t - 1) : 3 * t] = jp
                    J_t = np.concatenate(
                        [blocks[i] for i in active[k]]
                        + [jp, jo]
                        + ([np.zeros((3, 3, mc))] if rot else [])
                        + ([(dpdq[j] * dq[rows, j])[None]] if j in swept else [])
                    )
                    Js.append(J_t if tracker is None else _whiten(w_t, J_t))
            if rot:
                Rp, blocks, jr, dpdq = _chain_rotation(ns, kinds, R_, dqc, active[k], jac, j, trig=tc)
                rs.append(wr * matrix_rotvec(Rp @ np.swapaxes(s.rotations[rows], 1, 2)).T)
                mvs.append(wr * dpdq[j])
                if jac:
                    Js.append(
                        wr
                        * np.concatenate(
                            [blocks[i] for i in active[k]]
                            + [np.zeros((3 + 3 * (K - 1), 3, mc)), jr]
                            + ([(dpdq[j] * dq[rows, j])[None]] if j in swept else [])
                        )
                    )
            one = len(rs) == 1
            yield (
                rows,
                rs[0] if one else np.concatenate(rs),
                mvs[0] if one else np.concatenate(mvs),
                (Js[0] if one else np.concatenate(Js, axis=1)) if jac else None,
                None if dist is None else np.sqrt(dist),
            )

    def tangent(mv):
        lever = np.linalg.norm(mv, axis=0)
        return mv / np.maximum(lever, 1e-300), lever

    def whitened(r, t, g):
        rt = np.einsum("im,im->m", r, t)
        return r - (1 - g) * rt * t, rt

    def g_of(k, lever):
        """The whitening factor along the tangent: the sweep's gamma (its poses' levers are alike), or with a tracker
        model one per pose (m,): the sweep's reading variance, gamma at its reference lever ``lref``, at each pose's
        whitened lever |Sigma_k^(-1/2) d p / d q| (the line of sight turns against the motion along the arc)."""
        if lref is None:
            return gam[k]
        return 1 / np.sqrt(1 + (1 / gam[k] ** 2 - 1) * (lever / lref[k]) ** 2)

    def local(k):
        j = sweeps.sweeps[k].joint - 1
        h0 = 4 * n + 3 * (k if per_sweep_home else 0)
        return np.concatenate(
            [np.arange(4 * i, 4 * i + 4) for i in active[k]]
            + [np.arange(h0, h0 + 3), np.arange(i_off, i_sc)]
            + ([[i_sc + swept.index(j)]] if j in swept else [])
        ).astype(int)

    def normal_eq(cs, ns, homes_, offs_, R_, sc_, wr, f=None, bread=False):
        """Normal matrix, its robust sandwich part (with ``bread``, the final pass; else the normal matrix again),
        gradient, whitened cost, and per sweep (indices, Gram matrix of the weighted tangential rows, tangential
        residuals, levers, whitened residuals and misfits (D, m), Gram matrix of the orientation rows across the
        swept axis, their squares), accumulated sweep by sweep and CHUNK poses at a
        time (memory linear in the points, small per point). Whitening scales the
        component along the tangent t by gamma: J_w^T J_w = J^T J - (1 - gamma^2) (t^T J)^T (t^T J), J_w^T r_w
        likewise. With the robust scale ``f`` the robust weights ``ws`` are those of this point's whitened misfits
        (z = |r_w|^2 / f^2; iteratively reweighted least squares, one pass per step); without it they stay. With
        ``bread``, also the M-estimator's bread term (Huber 1981 sec. 7.6): 2 w'(z) / f^2 (J_w^T r_w)(J_w^T r_w)^T
        per point, added to J_w^T W J_w; without it the sigmas of a robust fit on clean data came out 7 % small."""
        A = np.zeros((npar, npar))
        A2 = np.zeros((npar, npar)) if bread else None
        b = np.zeros(npar)
        ss = 0.0
        Bd = np.zeros((npar, npar)) if bread else None
        parts = []
        for k in range(S):
            idx = local(k)
            Gt = np.zeros((len(idx), len(idx)))
            Gr = np.zeros((len(idx), len(idx))) if rot else None
            m = len(dqs[k])
            rt_k, lever_k, rw_k, r_k, rr_k = np.empty(m), np.empty(m), np.empty((D, m)), np.empty((D, m)), np.zeros(m)
            dist_k = None if tracker is None else np.empty(m)
            for rows, r, mv, J, dist in chunks(k, cs, ns, homes_, offs_, R_, sc_, wr, True):
                t, lever = tangent(mv)
                g = g_of(k, lever)
                g2 = 1 - g**2
                moments = isinstance(J, _Basis)
                jt = J.dot(t) if moments else np.einsum("im,pim->pm", t, J)
                rw, rt = whitened(r, t, g)
                if f is not None:
                    ws[k][rows] = loss_weight(loss, np.sum(rw**2, axis=0) / f**2)
                w = ws[k][rows]
                Jf = None if moments else J.reshape(len(idx), -1)
                if np.ndim(g):  # per pose (a tracker model)
                    A_t, G_t = (jt * (w * g2)) @ jt.T, (jt * (w * g**2)) @ jt.T
                else:
                    tt = (jt * w) @ jt.T
                    A_t, G_t = g2 * tt, g**2 * tt
                A[np.ix_(idx, idx)] += (J.gram(w) if moments else (J * w).reshape(len(idx), -1) @ Jf.T) - A_t
                if A2 is not None:
                    A2[np.ix_(idx, idx)] += (
                        J.gram(w**2) if moments else (J * w**2).reshape(len(idx), -1) @ Jf.T
                    ) - g2 * (jt * w**2) @ jt.T
                e = w * (r - g2 * rt * t)
                b[idx] += J.rdot(e) if moments else Jf @ e.reshape(-1)
                ss += float(np.sum(w * np.sum(rw**2, axis=0)))
                Gt += G_t
                if rot:  # the orientation rows across the swept axis (its reading error turns the probe about it)
                    e = mv[-3:] / np.maximum(np.linalg.norm(mv[-3:], axis=0), 1e-300)
                    ro, Jo = r[-3:], J[:, -3:]
                    ro = ro - np.einsum("im,im->m", ro, e) * e
                    Jo = Jo - e * np.einsum("im,pim->pm", e, Jo)[:, None, :]
                    Gr += np.einsum("pim,qim->pq", Jo * w, Jo)
                    rr_k[rows] = np.sum(ro**2, axis=0)
                if bread:
                    gw = (J.dot(rw) if moments else np.einsum("im,pim->pm", rw, J)) - (
                        1 - g
                    ) * g * rt * jt  # J_w^T r_w per point
                    c = 2 * loss_dweight(loss, np.sum(rw**2, axis=0) / f**2) / f**2
                    Bd[np.ix_(idx, idx)] += (gw * c) @ gw.T
                rt_k[rows], lever_k[rows], rw_k[:, rows], r_k[:, rows] = rt, lever, rw, r
                if dist_k is not None:
                    dist_k[rows] = dist
            parts.append((idx, Gt, rt_k, lever_k, rw_k, r_k, Gr, rr_k, dist_k))
        if prior_w:  # the scales' prior: the pseudo-observations s_j / tau, at the points' weight
            for M_ in (A, A2) if A2 is not None else (A,):
                M_[i_prior, i_prior] += prior_w
            b[i_prior] += prior_w * sc_[swept]
            ss += prior_w * float(np.sum(sc_[swept] ** 2))
        if bread:
            return A + Bd, A2, b, ss, parts
        return A, A, b, ss, parts

    def step(x_cs, x_ns, x_h, x_o, x_R, x_sc, delta):
        new_cs, new_ns = [], []
        for i in range(n):
            B = np.column_stack(perpendicular_basis(x_ns[i]))
            nv = x_ns[i] + B @ delta[4 * i : 4 * i + 2]
            new_ns.append(nv / np.linalg.norm(nv))
            new_cs.append(x_cs[i] + (B @ delta[4 * i + 2 : 4 * i + 4] if kinds[i] == "revolute" else 0.0))
        new_sc = x_sc.copy()
        new_sc[swept] += delta[i_sc:]
        new_R = (
            axis_angle_matrices(
                delta[i_rot:i_sc] / max(np.linalg.norm(delta[i_rot:i_sc]), 1e-300), [np.linalg.norm(delta[i_rot:i_sc])]
            )[0]
            @ x_R
            if rot
            else None
        )
        return (
            new_cs,
            new_ns,
            x_h + delta[4 * n : i_off].reshape(-1, 3),
            x_o + delta[i_off:i_rot].reshape(-1, 3),
            new_R,
            new_sc,
        )

    def cost(cs, ns, homes_, offs_, R_, sc_, wr):
        """The whitened cost at a trial point: misfits and tangents only, no Jacobian blocks."""
        total = 0.0
        for k in range(S):
            for rows, r, mv, _, _ in chunks(k, cs, ns, homes_, offs_, R_, sc_, wr, False):
                t, lever = tangent(mv)
                total += float(np.sum(ws[k][rows] * np.sum(whitened(r, t, g_of(k, lever))[0] ** 2, axis=0)))
        return total + prior_w * float(np.sum(sc_[swept] ** 2))

    # Levenberg-Marquardt steps on the whitened, robustly weighted cost, one pass over the points per step; the
    # variance components (gamma, the orientation weight) and the robust scale (f) of each pass are those of the
    # pass before (a fixed point of all of them). Stopping is scale-free: a step of at most STEP_TOL of its own sigmas
    # (Mahalanobis length under the covariance sigma^2 A^-1), or a cost that changes within its round-off, once the
    # variance components and f hold still.
    wr = 0.0
    srot = math.nan
    if rot:  # the orientation weight sigma / sigma_rot, first from the start residuals
        pr, rr = [], []
        for k in range(S):
            for _, r, _, _, _ in chunks(k, cs, ns, homes, offs, R0, sc, 1.0, False):
                pr.append(np.sum(r[:-3] ** 2, axis=0) / (3 * K))
                rr.append(np.sum(r[-3:] ** 2, axis=0) / 3)
        srot = (
            float(rotation_sigma)
            if rotation_sigma is not None
            else max(math.sqrt(np.median(np.concatenate(rr))), 1e-12)
        )
        wr = max(math.sqrt(np.median(np.concatenate(pr))), noise_sigma or 0.0, floor) / srot
    lam = 1e-6
    sigma2 = f = f_next = None
    eps_cost = COST_ROUNDOFF * np.finfo(float).eps * max(float(np.max(np.abs(s.points))) for s in sweeps.sweeps) * wmax
    if tracker is not None:  # each sweep's reference lever: the RMS of its poses' whitened levers at the start
        lref = np.array(
            [
                math.sqrt(
                    np.mean(
                        np.concatenate(
                            [
                                tangent(mv)[1] ** 2
                                for _, _, mv, _, _ in chunks(k, cs, ns, homes, offs, R0, sc, wr, False)
                            ]
                        )
                    )
                )
                for k in range(S)
            ]
        )
    fresh = True
    first = 0
    if gamma is not None and not rot and loss != "linear":
        # the variance components are given: the first pass would only give the first robust scale (its normal
        # equations, on weights of one, make way for those of that scale), from the start's whitened misfits alone
        norms = [
            np.linalg.norm(whitened(r, tangent(mv)[0], g_of(k, tangent(mv)[1]))[0], axis=0)
            for k in range(S)
            for _, r, mv, _, _ in chunks(k, cs, ns, homes, offs, R0, sc, wr, False)
        ]
        f, first = 3.0 * math.sqrt(D / 3) * max(robust_sigma(np.concatenate(norms), D), floor), 1
    for it in range(first, 300):
        if fresh:
            A, A2, b, ss, parts = normal_eq(cs, ns, homes, offs, R0, sc, wr, f)
            D_ = np.diag(A).copy()
            D_[D_ <= 0] = 1.0
            # variance components: pooled point noise across the motion, each sweep's misfit along it
            A_inv = _pinv_sym(A)
            lev_t = [float(np.sum(A_inv[np.ix_(p[0], p[0])] * p[1])) for p in parts]
            # (robust losses: the weighted residuals w r, bounded for outliers, over the weighted counts sum(w^2))
            ss_t = [float(np.sum(ws[k] ** 2 * p[2] ** 2)) for k, p in enumerate(parts)]
            ss_o = sum(
                float(np.sum(ws[k] ** 2 * (np.sum(parts[k][5] ** 2, axis=0) - parts[k][2] ** 2))) for k in range(S)
            )
            m_w = [float(np.sum(w**2)) for w in ws]
            red_o = (D - 1) * sum(m_w) - (float(np.trace(A_inv @ A)) - sum(lev_t))
            sigma2 = max(ss_o / red_o if red_o > 0 else 0.0, (noise_sigma or 0.0) ** 2, floor**2)
            tau2 = [st / max(mw - lt, 1.0) for st, lt, mw in zip(ss_t, lev_t, m_w, strict=True)]
            if (
                lref is not None
            ):  # per pose sigma^2 + (lever sigma_q)^2: the reading variance over the mean lever^2, at lref
                tau2 = [
                    sigma2
                    + lref[k] ** 2 * (t2 - sigma2) / max(float(np.sum(ws[k] ** 2 * parts[k][3] ** 2)) / m_w[k], 1e-300)
                    for k, t2 in enumerate(tau2)
                ]
            new_gam = (
                gam
                if gamma is not None
                else np.array([1.0 if not t2 > sigma2 else max(math.sqrt(sigma2 / t2), 1e-9) for t2 in tau2])
            )
            new_wr = wr
            if rot:  # the orientation noise across the swept axis, over its redundancy (2 per pose less its leverage)
                ss_r = sum(float(np.sum(ws[k] ** 2 * p[7])) for k, p in enumerate(parts)) / wr**2
                red_r = 2 * sum(m_w) - sum(float(np.sum(A_inv[np.ix_(p[0], p[0])] * p[6])) for p in parts)
                if rotation_sigma is None:
                    srot = max(math.sqrt(ss_r / red_r) if red_r > 0 else srot, 1e-12)
                new_wr = math.sqrt(sigma2) / srot
            # the robust scale of the next pass's weights: 3 robust sigmas of the whitened misfits (point-noise units;
            # times sqrt(D / 3): a pose of D components has the norm of one point's 3 at the same per-component noise)
            if loss != "linear":
                f_next = (
                    3.0
                    * math.sqrt(D / 3)
                    * max(robust_sigma(np.concatenate([np.linalg.norm(p[4], axis=0) for p in parts]), D), floor)
                )
            # how far the variance components and f moved at this pass, in units of their tolerances (after 100
            # passes they are frozen)
            dg = float(np.max(np.abs(new_gam - gam) / gam))
            if rot:
                dg = max(dg, abs(new_wr - wr) / wr)
            df = 0.0 if f_next is None else math.inf if f is None else abs(f_next - f) / f
            moved = max(dg / GAMMA_TOL, df / SCALE_TOL) if it < 100 else 0.0
            gross = it < 100 and max(dg, df) > 0.1
            fresh = False
        if gross:  # a large change (the first robust weights, a first gamma): no step on the old ones
            gam, wr, f, fresh = new_gam, new_wr, f_next, True
            continue
        delta = -_pinv_sym(A + lam * np.diag(D_)) @ b
        m2 = float(delta @ A @ delta) / sigma2  # (the step's length in its own sigmas)^2
        tiny = m2 <= STEP_TOL**2 or np.max(np.abs(delta)) <= 1e-13 * max(size, 1e-300)
        trial = step(cs, ns, homes, offs, R0, sc, delta)
        new_cost = cost(*trial, wr)
        level = eps_cost * math.sqrt(ss) + 64 * np.finfo(float).eps * ss  # round-off of a cost difference
        accepted = new_cost <= ss or (tiny and new_cost <= ss + level)
        if accepted:
            cs, ns, homes, offs, R0, sc = trial
            lam = max(lam / 10, 1e-12)
        else:
            lam *= 10
        # nothing left to gain beyond round-off: a tiny step, or a cost that neither fell nor was predicted to beyond it
        settled = tiny or (new_cost - ss <= level and m2 * sigma2 <= level)
        if (settled and moved <= 1) or lam > 1e8:
            break
        if accepted or settled:
            gam, f, fresh = new_gam, f_next, True
    else:
        raise NotConvergedError(
            f"{where}: global fit: no convergence in 300 steps (expected a step below {STEP_TOL:g} of its sigmas)"
        )
    f_final = f
    A, A2, b, ss, parts = normal_eq(cs, ns, homes, offs, R0, sc, wr, f_final, bread=loss != "linear")
    psi2 = sum(float(np.sum(w**2 * np.sum(p[4] ** 2, axis=0))) for w, p in zip(ws, parts, strict=True))
    dof = D * sum(float(np.sum(w**2)) for w in ws) - npar
    s2 = misfit_variance(np.sqrt(psi2) * np.ones(1), dof, math.sqrt(sigma2))
    A_inv = _pinv_sym(A)
    cov_x = s2 * A_inv @ A2 @ A_inv
    # map the local parameters to [c_j (the foot of the home point), n_j], the home points, offsets and rotation
    ph = homes.mean(axis=0)
    feet = []
    n_out = 6 * n + 3 * H
    M = np.zeros((n_out + (i_sc - i_off), npar))
    for j in range(n):
        B = np.column_stack(perpendicular_basis(ns[j]))
        h = float((ph - cs[j]) @ ns[j])
        feet.append(cs[j] + ns[j] * h)
        M[6 * j : 6 * j + 3, 4 * j : 4 * j + 2] = h * B
        if kinds[j] == "revolute":
            M[6 * j : 6 * j + 3, 4 * j + 2 : 4 * j + 4] = B
        M[6 * j + 3 : 6 * j + 6, 4 * j : 4 * j + 2] = B
    M[6 * n : n_out, 4 * n : i_off] = np.eye(3 * H)
    M[n_out:, i_off:i_sc] = np.eye(i_sc - i_off)
    cov_all = M @ cov_x @ M.T
    scale_sigma = np.full(n, math.nan)
    scale_sigma[swept] = np.sqrt(np.clip(np.diag(cov_x)[i_sc:], 0, None))
    # the scales' covariance with [c_j, n_j, ..., p] and among themselves (n columns, zero where not fitted)
    Ms = np.zeros((n, npar))
    Ms[swept, i_sc + np.arange(len(swept))] = 1.0
    scale_cross, scale_cov = (M @ cov_x @ Ms.T)[:n_out], Ms @ cov_x @ Ms.T
    sigma = math.sqrt(sigma2)
    levers = [float(np.mean(p[3])) for p in parts] if lref is None else lref
    reading_sigma = [
        math.sqrt(max(sigma2 / g**2 - sigma2, 0.0)) / max(lv, 1e-300) for g, lv in zip(gam, levers, strict=True)
    ]
    misfit = [np.sqrt(np.sum(p[5][: 3 * K] ** 2, axis=0) / K) if p[8] is None else p[8] for p in parts]
    return {
        "points": np.array(feet),
        "directions": np.array(ns),
        "home": np.array([home_of(k) for k in range(S)]),
        "cov": cov_all[:n_out, :n_out],
        "cov_all": cov_all,
        "offsets": offs,
        "rotation": R0,
        "rotation_sigma": srot if rot else math.nan,
        "components": D,
        "n_homes": H,
        "misfit": misfit,
        "weights": ws,
        "whitened": [np.linalg.norm(p[4], axis=0) / sigma for p in parts],
        "sigma": sigma,
        "reading_sigma": reading_sigma,
        "ss": ss / sigma2,
        "ss_m": ss,
        "n_params": npar,
        "gamma": gam,
        "scales": sc,
        "scale_sigma": scale_sigma,
        "scale_cross": scale_cross,
        "scale_cov": scale_cov,
        "tracker_ref2": math.nan if ref2 is None else ref2,
    }
