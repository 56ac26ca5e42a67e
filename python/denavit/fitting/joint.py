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

Errors: the points carry isotropic noise ``sigma`` (or a tracker's range/angle noise, below); the swept joint's
readings carry white errors, so along the
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

import numpy as np

from ..errors import NotConvergedError
from ..geometry import axis_angle_matrices, matrix_rotvec, perpendicular_basis
from .chain import _Basis, _chain, _chain_rotation, _one_turn, _rotate, _trig, _turn
from .elastic import _Compliances
from .robust import loss_dweight, loss_weight, misfit_variance, robust_sigma
from .tracker import TrackerNoise as TrackerNoise  # (the joint fit's noise model, named here too)
from .tracker import _whiten, _whitener, as_tracker_noise

#: Points of a sweep per step of the joint fit's normal equations (their Jacobian rows, a few MB, are not kept).
CHUNK = 8192
#: The joint fit stops at a step of at most this many of its own sigmas (Mahalanobis length under the covariance),
#: once the variance components and the robust scale move by less than GAMMA_TOL and SCALE_TOL (relative).
STEP_TOL = 1e-3
GAMMA_TOL = 1e-3
SCALE_TOL = 1e-4
#: Round-off of a misfit, in units of eps times the largest coordinate (the chain of rotations of the home point).
COST_ROUNDOFF = 16.0
#: Points of a sweep above which the choices around the joint fit are made on every k-th point, at most this many:
#: its start (the circles, the home point), the point noise of the dwell check, and auto's measurement model with its
#: variance components and robust weights (issue 41); the chosen model is then fitted once on all points. Up to it,
#: every step sees every point.
SUBSAMPLE = 50_000


def stride(m: int) -> int:
    """k of every k-th point of a sweep of ``m`` points that its choices see (:data:`SUBSAMPLE`): 1 up to it."""
    return -(-m // SUBSAMPLE)


def _pinv_sym(a: np.ndarray) -> np.ndarray:
    """Inverse of a symmetric positive semi-definite matrix on its non-zero rows (parameters the data does not
    touch, e.g. the point of a prismatic axis, get zero); ``np.linalg.inv``, which stays fast on a loaded
    machine where the threaded eigen/SVD solvers crawl."""
    d = np.diag(a)
    keep = d > 1e-300
    out = np.zeros_like(a)
    out[np.ix_(keep, keep)] = np.linalg.inv(a[np.ix_(keep, keep)])
    return (out + out.T) / 2


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
        rows = slice(None, None, stride(len(s.points)))  # (a start: every k-th point of a long sweep)
        j = s.joint - 1
        d = sweeps.home[j] - s.q[rows, j]
        pts = [s.points[rows]] if s.targets is None else [s.targets[rows, t] for t in range(K)]
        meas_R = None if s.rotations is None else s.rotations[rows]
        if sweeps.kinds[j] == "prismatic":
            for t, p in enumerate(pts):
                est[t].append(p + np.outer(d, nv))
            if meas_R is not None:
                rots.append(meas_R)
        else:
            turn = _turn(np.asarray(nv, dtype=float), d)
            for t, p in enumerate(pts):
                est[t].append(c + _rotate(turn, p.T - c[:, None]).T)
            if meas_R is not None:
                rots.append(axis_angle_matrices(nv, d) @ meas_R)
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
    weights0=None,
    torques=None,
    start=None,
    where: str = "",
):
    """The joint fit of all sweeps (module docstring). ``dqs`` per sweep (m, n) joint motions from home (arrays, or
    :class:`~denavit.fitting.motion.Motion` from :func:`~denavit.fitting.motion.locked_motion`), ``starts`` per joint
    (point, direction) start lines, ``p0`` the start home point (of
    the first target); with several targets ``offsets0`` (k - 1, 3) the start offsets of the other targets' home
    points from it, with 6-DoF poses ``rotation0`` (3, 3) the start orientation at home (both by default from
    :func:`start_homes`) and ``rotation_sigma`` (rad) the declared orientation noise (default: estimated).

    ``scales``: False (none), True (every swept joint's reading scale error is a parameter) or the joints
    (0-based) whose scale is one. ``scale_prior``: None, or ``(tau, sigma)``: every fitted scale is drawn from a
    zero-mean normal population of standard deviation ``tau`` (a pseudo-observation ``s_j / tau`` weighted against the
    points as ``(sigma / tau)^2``, ``sigma`` the point noise of the caller's simpler fit), so the fit is the posterior
    mode and its covariance the posterior's (:func:`denavit.identification.choice._with_scale_prior`). ``tracker`` a
    :class:`TrackerNoise` (or (sigma_range m, sigma_angle rad[, position m])): the points' covariances take its
    range/angle shape (module docstring); None: isotropic. ``weights0``: None, or (gamma per sweep, robust scale or
    None) of the same model fitted on a subsample (:func:`stride`): the variance components and the robust scale
    start there instead of at one and none, and are estimated as ever (the first pass then steps at once). ``start``:
    None, or a result of this function on the same sweeps: the home points, reading scales and compliances start at
    its values where this fit frees them (else at p0 and zeros). ``torques``: None, or per sweep (m, n) the gravity
    torques each joint holds at each pose less those it holds at home (N m; N for a prismatic joint): every joint whose
    torque changes gets a compliance ``k_i`` (rad/(N m), m/N), its link turning by ``dq_i - k_i dtau_i``
    (:mod:`denavit.calibration.compliance`'s model; the axes are those of the arm at home under its own weight),
    fitted with ``k_i >= 0`` (:meth:`~denavit.fitting.elastic._Compliances.bound_compliances`).

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
    ``sigma`` the point noise, ``reading_sigma`` per sweep, ``ss`` the whitened sum of squares and ``n_params``;
    ``robust_scale`` the robust loss's scale (m, of the whitened misfits; None with "linear"); ``tracker_ref2`` the
    tracker model's reference variance (m^2: ``sigma / sqrt(tracker_ref2)`` is the point noise over the declared; nan
    without a model); ``compliance`` (n,) the compliances (zeros where not fitted), ``compliance_sigma`` (n,) (nan where
    not fitted) and ``compliance_cov`` (n, n), ``compliance_cross`` (rows of ``cov``, then the n scales; n) their
    covariance with those (zeros where not fitted), ``compliance_held`` (n,) those held at their bound 0 (with their
    sigmas) and ``compliance_negative`` (n,) the value each held one had in the fit that held it (0 elsewhere).
    """
    fit = _JointFit(
        sweeps,
        dqs,
        starts,
        p0,
        loss=loss,
        per_sweep_home=per_sweep_home,
        scales=scales,
        scale_prior=scale_prior,
        noise_sigma=noise_sigma,
        gamma=gamma,
        offsets0=offsets0,
        rotation0=rotation0,
        rotation_sigma=rotation_sigma,
        tracker=tracker,
        weights0=weights0,
        torques=torques,
        start=start,
        where=where,
    )
    fit.solve()
    fit.bound_compliances()
    return fit.result()


class _JointFit(_Compliances):
    """One joint fit (:func:`fit_sweeps`) as named steps: the parameters' layout and start (``__init__``), a sweep's
    misfits and Jacobian CHUNK poses at a time (:meth:`chunks`), the normal equations (:meth:`normal_eq`), the
    variance components (:meth:`variance_components`), the Levenberg-Marquardt steps (:meth:`solve`) and the
    result with its covariance (:meth:`result`). The parameters are [per joint (a, b) the direction's tilt in its
    tangent basis and (s, t) the point across the axis; the home points; the further targets' offsets; the home
    orientation's rotation; the fitted scales; the fitted compliances]. ``sc`` holds the reading scales (n,), then with
    ``torques`` the compliances (n,)."""

    def __init__(
        self,
        sweeps,
        dqs,
        starts,
        p0,
        *,
        loss,
        per_sweep_home,
        scales,
        scale_prior,
        noise_sigma,
        gamma,
        offsets0,
        rotation0,
        rotation_sigma,
        tracker,
        weights0,
        torques,
        start,
        where,
    ):
        self.sweeps, self.dqs, self.loss, self.where, self.weights0 = (sweeps, dqs, loss, where, weights0)
        self.per_sweep_home, self.noise_sigma = per_sweep_home, noise_sigma
        self.gamma, self.rotation_sigma = gamma, rotation_sigma
        self.kinds = sweeps.kinds
        self.n, self.S = n, S = sweeps.n_joints, len(sweeps.sweeps)
        self.K = K = sweeps.n_targets
        self.rot = rot = sweeps.has_rotations
        self.cs = [np.array(c, dtype=float) for c, _ in starts]
        self.ns = [np.array(d, dtype=float) / np.linalg.norm(d) for _, d in starts]
        if (K > 1 and offsets0 is None) or (rot and rotation0 is None):
            h0, r0 = start_homes(sweeps, starts)
            offsets0 = h0[1:] - h0[0] if offsets0 is None else offsets0
            rotation0 = r0 if rotation0 is None else rotation0
        self.homes = np.tile(np.asarray(p0, dtype=float), (S if per_sweep_home else 1, 1))
        self.offs = np.zeros((0, 3)) if K == 1 else np.array(offsets0, dtype=float).reshape(K - 1, 3)
        self.R0 = np.array(rotation0, dtype=float) if rot else None
        # the joints whose reading scale is fitted: every swept joint (scales True), or those given (0-based)
        all_swept = sorted({s.joint - 1 for s in sweeps.sweeps})
        self.swept = swept = (
            (all_swept if scales is True else sorted({int(j) for j in scales} & set(all_swept)))
            if scales is not False and scales is not None
            else []
        )
        self.tq = torques
        tmax = np.zeros(n) if torques is None else np.max([np.max(np.abs(t), axis=0) for t in torques], axis=0)
        kj = [i for i in range(n) if tmax[i] > 1e-6 * max(tmax.max(), 1e-300)]  # (TORQUE_FLOOR's rule)
        self.held, self.negative = [], np.zeros(n)  # the compliances held at k = 0 (bound_compliances)
        self.sc = np.zeros(2 * n if torques is not None else n)
        self.H = H = len(self.homes)
        self.i_off = 4 * n + 3 * H  # the first offset's index, then the home rotation's, then the scales'
        self.i_rot = self.i_off + 3 * (K - 1)
        self.i_sc = self.i_rot + (3 if rot else 0)
        self.i_k = self.i_sc + len(swept)
        self.prior_w = 0.0 if scale_prior is None or not swept else (scale_prior[1] / scale_prior[0]) ** 2
        self.i_prior = np.arange(self.i_sc, self.i_k)
        self.D = 3 * K + (3 if rot else 0)  # residual components per pose
        self.size = max(
            float(np.sqrt(np.mean(np.sum((s.points - s.points.mean(axis=0)) ** 2, axis=1)))) for s in sweeps.sweeps
        )
        self.floor = 1e-12 * self.size
        g0 = gamma if gamma is not None else (None if weights0 is None else weights0[0])
        self.gam = np.ones(S) if g0 is None else np.array(g0, dtype=float)
        self.ws = [np.ones(len(s.points)) for s in sweeps.sweeps]
        self.tracker = tracker = as_tracker_noise(tracker)
        self.ref2 = self.lref = None
        self.wmax = 1.0
        if tracker is not None:
            # the points' covariance shapes over their mean variance per coordinate (every point of every target): the
            # fit's sigma stays the point noise in metres (RMS per coordinate), its scale a variance component
            shapes = [tracker.shape(self.measured(s, slice(None), t)) for s in sweeps.sweeps for t in range(K)]
            self.ref2 = float(np.mean(np.concatenate([(va + 2 * vb) / 3 for _, va, vb in shapes])))
            self.wmax = math.sqrt(self.ref2 / min(float(np.min(np.minimum(va, vb))) for _, va, vb in shapes))
        # (sweep, first row of a chunk): (the scales of its active joints, {joint: _trig of its motion})
        self.trig = {}
        self.free_compliances(kj)
        if start is not None:  # (a fit of the same sweeps: its home points, scales and compliances where freed here)
            self.homes = start["home"].copy() if per_sweep_home and len(start["home"]) == S else self.homes
            self.sc[swept] = start["scales"][swept]
            self.sc[[n + i for i in kj]] = start["compliance"][kj]

    def home_of(self, k):
        return self.homes[k] if self.per_sweep_home else self.homes[0]

    @staticmethod
    def measured(s, rows, t):
        return (s.points[rows] if s.targets is None else s.targets[rows, t]).T

    def chunks(self, k, cs, ns, homes_, offs_, R_, sc_, wr, jac):
        """(rows, misfits r (D, m), d r / d q of the swept joint (D, m), Jacobian (local parameters, D, m) or None,
        None or with a tracker model the 3-D misfits (m,) (RMS over the targets)) of sweep k, CHUNK poses at a time
        (the joints turning by (1 + s) times their readings' motion); the orientation rows weighted by ``wr``, with a
        tracker model each target's rows whitened by its point's Sigma_k^(-1/2). Components first, points last
        (:func:`_rotate`)."""
        s, dq = self.sweeps.sweeps[k], self.dqs[k]
        K, active, kinds, swept, trig = self.K, self.active[k], self.kinds, self.swept, self.trig
        j = s.joint - 1
        h = homes_[k] if self.per_sweep_home else homes_[0]
        npl, n = len(self.local(k)), self.n
        for a in range(0, len(dq), CHUNK):
            rows = slice(a, a + CHUNK)
            # the chunk's joint motions and their cosines and sines, kept while the reading scales they were made
            # with hold
            key = tuple(float(sc_[i]) for i in active) + tuple(sc_[n:])
            dqe = dq[rows] if self.tq is None else dq[rows] - sc_[n:] * self.tq[k][rows]  # the links' motion
            dqc = dqe * (1 + sc_[:n])
            if trig.get((k, a), (None,))[0] != key:
                trig[(k, a)] = (key, {i: _trig(dqc[:, i]) for i in active if kinds[i] == "revolute"})
            tc = trig[(k, a)][1]
            mc = len(dqc)
            rs, mvs, Js = [], [], []
            dist = None if self.tracker is None else np.zeros(mc)
            moments = jac and self.simple and _one_turn(kinds, active)
            for t in range(K):
                pred, blocks, jp, dpdq = _chain(
                    cs, ns, kinds, h + (offs_[t - 1] if t else 0.0), dqc, active, jac, j, trig=tc, basis=moments
                )
                r_t, mv_t = pred - self.measured(s, rows, t), dpdq[j]
                if moments:  # the Jacobian on the points' (1, cos, sin) (:class:`_Basis`)
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
                if self.tracker is not None:
                    w_t = _whitener(self.tracker, self.ref2, self.measured(s, rows, t))
                    dist += np.sum(r_t**2, axis=0) / K
                    r_t, mv_t = _whiten(w_t, r_t), _whiten(w_t, mv_t)
                rs.append(r_t)
                mvs.append(mv_t)
                if jac:
                    jo = np.zeros((3 * (K - 1), 3, mc))
                    if t:
                        jo[3 * (t - 1) : 3 * t] = jp
                    J_t = np.concatenate(
                        [blocks[i] for i in active]
                        + [jp, jo]
                        + ([np.zeros((3, 3, mc))] if self.rot else [])
                        + ([(dpdq[j] * dqe[:, j])[None]] if j in swept else [])
                        + self.k_columns(k, rows, sc_, dpdq)
                    )
                    Js.append(J_t if self.tracker is None else _whiten(w_t, J_t))
            if self.rot:
                Rp, blocks, jr, dpdq = _chain_rotation(ns, kinds, R_, dqc, active, jac, j, trig=tc)
                rs.append(wr * matrix_rotvec(Rp @ np.swapaxes(s.rotations[rows], 1, 2)).T)
                mvs.append(wr * dpdq[j])
                if jac:
                    Js.append(
                        wr
                        * np.concatenate(
                            [blocks[i] for i in active]
                            + [np.zeros((3 + 3 * (K - 1), 3, mc)), jr]
                            + ([(dpdq[j] * dqe[:, j])[None]] if j in swept else [])
                            + self.k_columns(k, rows, sc_, dpdq)
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

    @staticmethod
    def tangent(mv):
        lever = np.linalg.norm(mv, axis=0)
        return mv / np.maximum(lever, 1e-300), lever

    @staticmethod
    def whitened(r, t, g):
        rt = np.einsum("im,im->m", r, t)
        return r - (1 - g) * rt * t, rt

    def g_of(self, k, lever):
        """The whitening factor along the tangent: the sweep's gamma (its poses' levers are alike), or with a tracker
        model one per pose (m,): the sweep's reading variance, gamma at its reference lever ``lref``, at each pose's
        whitened lever |Sigma_k^(-1/2) d p / d q| (the line of sight turns against the motion along the arc)."""
        if self.lref is None:
            return self.gam[k]
        return 1 / np.sqrt(1 + (1 / self.gam[k] ** 2 - 1) * (lever / self.lref[k]) ** 2)

    def local(self, k):
        """The indices of the parameters sweep k touches."""
        j = self.sweeps.sweeps[k].joint - 1
        h0 = 4 * self.n + 3 * (k if self.per_sweep_home else 0)
        return np.concatenate(
            [np.arange(4 * i, 4 * i + 4) for i in self.active[k]]
            + [np.arange(h0, h0 + 3), np.arange(self.i_off, self.i_sc)]
            + ([[self.i_sc + self.swept.index(j)]] if j in self.swept else [])
            + [np.arange(self.i_k, self.npar)]
        ).astype(int)

    def normal_eq(self, cs, ns, homes_, offs_, R_, sc_, wr, f=None, bread=False):
        """Normal matrix, its robust sandwich part (with ``bread``, the final pass; else the normal matrix again),
        gradient, whitened cost, and per sweep (indices, Gram matrix of the weighted tangential rows, tangential
        residuals, levers, squared norms of the whitened residuals and of the misfits (m,), Gram matrix of the
        orientation rows across the swept axis, their squares, the 3-D misfits with a tracker model (m,) or None, the
        squared norms of the points' misfits (m,)), accumulated sweep by sweep and CHUNK poses at a time (memory
        linear in the points, a few numbers per point: no Jacobian rows kept). Whitening scales the
        component along the tangent t by gamma: J_w^T J_w = J^T J - (1 - gamma^2) (t^T J)^T (t^T J), J_w^T r_w
        likewise. With the robust scale ``f`` the robust weights ``ws`` are those of this point's whitened misfits
        (z = |r_w|^2 / f^2; iteratively reweighted least squares, one pass per step); without it they stay. With
        ``bread``, also the M-estimator's bread term (Huber 1981 sec. 7.6): 2 w'(z) / f^2 (J_w^T r_w)(J_w^T r_w)^T
        per point, added to J_w^T W J_w; without it the sigmas of a robust fit on clean data came out 7 % small."""
        npar, D, rot, loss, ws = self.npar, self.D, self.rot, self.loss, self.ws
        A = np.zeros((npar, npar))
        A2 = np.zeros((npar, npar)) if bread else None
        b = np.zeros(npar)
        ss = 0.0
        Bd = np.zeros((npar, npar)) if bread else None
        parts = []
        for k in range(self.S):
            idx = self.local(k)
            Gt = np.zeros((len(idx), len(idx)))
            Gr = np.zeros((len(idx), len(idx))) if rot else None
            m = len(self.dqs[k])
            rt_k, lever_k, rw2_k, r2_k, rr_k = (np.empty(m), np.empty(m), np.empty(m), np.empty(m), np.zeros(m))
            rp2_k = r2_k if D == 3 * self.K else np.empty(m)
            dist_k = None if self.tracker is None else np.empty(m)
            for rows, r, mv, J, dist in self.chunks(k, cs, ns, homes_, offs_, R_, sc_, wr, True):
                t, lever = self.tangent(mv)
                g = self.g_of(k, lever)
                g2 = 1 - g**2
                moments = isinstance(J, _Basis)
                jt = J.dot(t) if moments else np.einsum("im,pim->pm", t, J)
                rw, rt = self.whitened(r, t, g)
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
                rt_k[rows], lever_k[rows], rw2_k[rows], r2_k[rows] = (
                    rt,
                    lever,
                    np.sum(rw**2, axis=0),
                    np.sum(r**2, axis=0),
                )
                if rp2_k is not r2_k:
                    rp2_k[rows] = np.sum(r[: 3 * self.K] ** 2, axis=0)
                if dist_k is not None:
                    dist_k[rows] = dist
            parts.append((idx, Gt, rt_k, lever_k, rw2_k, r2_k, Gr, rr_k, dist_k, rp2_k))
        if self.prior_w:  # the scales' prior: the pseudo-observations s_j / tau, at the points' weight
            for M_ in (A, A2) if A2 is not None else (A,):
                M_[self.i_prior, self.i_prior] += self.prior_w
            b[self.i_prior] += self.prior_w * sc_[self.swept]
            ss += self.prior_w * float(np.sum(sc_[self.swept] ** 2))
        if bread:
            return A + Bd, A2, b, ss, parts
        return A, A, b, ss, parts

    def step(self, x_cs, x_ns, x_h, x_o, x_R, x_sc, delta):
        """The parameters (cs, ns, homes, offsets, rotation, scales) moved by ``delta``."""
        n, i_off, i_rot, i_sc = self.n, self.i_off, self.i_rot, self.i_sc
        new_cs, new_ns = [], []
        for i in range(n):
            B = np.column_stack(perpendicular_basis(x_ns[i]))
            nv = x_ns[i] + B @ delta[4 * i : 4 * i + 2]
            new_ns.append(nv / np.linalg.norm(nv))
            new_cs.append(x_cs[i] + (B @ delta[4 * i + 2 : 4 * i + 4] if self.kinds[i] == "revolute" else 0.0))
        new_sc = x_sc.copy()
        new_sc[self.swept] += delta[i_sc : self.i_k]
        new_sc[[n + i for i in self.kj]] += delta[self.i_k :]
        v, ang = delta[i_rot:i_sc], np.linalg.norm(delta[i_rot:i_sc])  # (the home orientation's turn)
        new_R = axis_angle_matrices(v / max(ang, 1e-300), [ang])[0] @ x_R if self.rot else None
        return (
            new_cs,
            new_ns,
            x_h + delta[4 * n : i_off].reshape(-1, 3),
            x_o + delta[i_off:i_rot].reshape(-1, 3),
            new_R,
            new_sc,
        )

    def cost(self, cs, ns, homes_, offs_, R_, sc_, wr):
        """The whitened cost at a trial point: misfits and tangents only, no Jacobian blocks."""
        total = 0.0
        for k in range(self.S):
            for rows, r, mv, _, _ in self.chunks(k, cs, ns, homes_, offs_, R_, sc_, wr, False):
                t, lever = self.tangent(mv)
                total += float(
                    np.sum(self.ws[k][rows] * np.sum(self.whitened(r, t, self.g_of(k, lever))[0] ** 2, axis=0))
                )
        return total + self.prior_w * float(np.sum(sc_[self.swept] ** 2))

    def start(self):
        """Before the first step: the orientation weight (6-DoF poses), the cost's round-off, each sweep's reference
        lever (a tracker model) and, when the variance components are given, the first robust scale."""
        S, K, D = self.S, self.K, self.D
        args = (self.cs, self.ns, self.homes, self.offs, self.R0, self.sc)
        self.wr = 0.0
        self.srot = math.nan
        if self.rot:  # the orientation weight sigma / sigma_rot, first from the start residuals
            pr, rr = [], []
            for k in range(S):
                for _, r, _, _, _ in self.chunks(k, *args, 1.0, False):
                    pr.append(np.sum(r[:-3] ** 2, axis=0) / (3 * K))
                    rr.append(np.sum(r[-3:] ** 2, axis=0) / 3)
            self.srot = (
                float(self.rotation_sigma)
                if self.rotation_sigma is not None
                else max(math.sqrt(np.median(np.concatenate(rr))), 1e-12)
            )
            self.wr = max(math.sqrt(np.median(np.concatenate(pr))), self.noise_sigma or 0.0, self.floor) / self.srot
        wr = self.wr
        self.eps_cost = (
            COST_ROUNDOFF
            * np.finfo(float).eps
            * max(float(np.max(np.abs(s.points))) for s in self.sweeps.sweeps)
            * self.wmax
        )
        if self.tracker is not None:  # each sweep's reference lever: the RMS of its poses' whitened levers at the start
            self.lref = np.array(
                [
                    math.sqrt(
                        np.mean(
                            np.concatenate(
                                [self.tangent(mv)[1] ** 2 for _, _, mv, _, _ in self.chunks(k, *args, wr, False)]
                            )
                        )
                    )
                    for k in range(S)
                ]
            )
        self.f, self.first = (None if self.weights0 is None else self.weights0[1]), 0
        if self.gamma is not None and not self.rot and self.loss != "linear":
            # the variance components are given: the first pass would only give the first robust scale (its normal
            # equations, on weights of one, make way for those of that scale), from the start's whitened misfits alone
            norms = [
                np.linalg.norm(self.whitened(r, self.tangent(mv)[0], self.g_of(k, self.tangent(mv)[1]))[0], axis=0)
                for k in range(S)
                for _, r, mv, _, _ in self.chunks(k, *args, wr, False)
            ]
            self.f, self.first = 3.0 * math.sqrt(D / 3) * max(robust_sigma(np.concatenate(norms), D), self.floor), 1

    def variance_components(self, A, parts, it):
        """From a pass's normal equations: the point noise sigma^2 (pooled across the motion), each sweep's gamma, the
        orientation weight, the robust scale of the next pass's weights, and how far they moved (in units of their
        tolerances; after 100 passes they are frozen) and whether grossly. Returns (sigma2, gam, wr, f_next, moved,
        gross)."""
        S, D, ws, gam, wr, f = self.S, self.D, self.ws, self.gam, self.wr, self.f
        # variance components: pooled point noise across the motion, each sweep's misfit along it
        A_inv = _pinv_sym(A)
        lev_t = [float(np.sum(A_inv[np.ix_(p[0], p[0])] * p[1])) for p in parts]
        # (robust losses: the weighted residuals w r, bounded for outliers, over the weighted counts sum(w^2))
        ss_t = [float(np.sum(ws[k] ** 2 * p[2] ** 2)) for k, p in enumerate(parts)]
        ss_o = sum(float(np.sum(ws[k] ** 2 * (parts[k][5] - parts[k][2] ** 2))) for k in range(S))
        m_w = [float(np.sum(w**2)) for w in ws]
        red_o = (D - 1) * sum(m_w) - (float(np.trace(A_inv @ A)) - sum(lev_t))
        sigma2 = max(ss_o / red_o if red_o > 0 else 0.0, (self.noise_sigma or 0.0) ** 2, self.floor**2)
        tau2 = [st / max(mw - lt, 1.0) for st, lt, mw in zip(ss_t, lev_t, m_w, strict=True)]
        if (
            self.lref is not None
        ):  # per pose sigma^2 + (lever sigma_q)^2: the reading variance over the mean lever^2, at lref
            tau2 = [
                sigma2
                + self.lref[k] ** 2 * (t2 - sigma2) / max(float(np.sum(ws[k] ** 2 * parts[k][3] ** 2)) / m_w[k], 1e-300)
                for k, t2 in enumerate(tau2)
            ]
        new_gam = (
            gam
            if self.gamma is not None
            else np.array([1.0 if not t2 > sigma2 else max(math.sqrt(sigma2 / t2), 1e-9) for t2 in tau2])
        )
        new_wr = wr
        if self.rot:  # the orientation noise across the swept axis, over its redundancy (2 per pose less its leverage)
            ss_r = sum(float(np.sum(ws[k] ** 2 * p[7])) for k, p in enumerate(parts)) / wr**2
            red_r = 2 * sum(m_w) - sum(float(np.sum(A_inv[np.ix_(p[0], p[0])] * p[6])) for p in parts)
            if self.rotation_sigma is None:
                self.srot = max(math.sqrt(ss_r / red_r) if red_r > 0 else self.srot, 1e-12)
            new_wr = math.sqrt(sigma2) / self.srot
        # the robust scale of the next pass's weights: 3 robust sigmas of the whitened misfits (point-noise units;
        # times sqrt(D / 3): a pose of D components has the norm of one point's 3 at the same per-component noise)
        f_next = self.f_next
        if self.loss != "linear":
            f_next = (
                3.0
                * math.sqrt(D / 3)
                * max(robust_sigma(np.concatenate([np.sqrt(p[4]) for p in parts]), D), self.floor)
            )
        # how far the variance components and f moved at this pass, in units of their tolerances (after 100
        # passes they are frozen)
        dg = float(np.max(np.abs(new_gam - gam) / gam))
        if self.rot:
            dg = max(dg, abs(new_wr - wr) / wr)
        df = 0.0 if f_next is None else math.inf if f is None else abs(f_next - f) / f
        if it >= 100:  # frozen: the fit settles on the weights it has (a slow fixed point had crept on to pass 300)
            return sigma2, gam, wr, f, 0.0, False
        return sigma2, new_gam, new_wr, f_next, max(dg / GAMMA_TOL, df / SCALE_TOL), max(dg, df) > 0.1

    def solve(self):
        """Levenberg-Marquardt steps on the whitened, robustly weighted cost, one pass over the points per step; the
        variance components (gamma, the orientation weight) and the robust scale (f) of each pass are those of the
        pass before (a fixed point of all of them). Stopping is scale-free: a step of at most STEP_TOL of its own
        sigmas (Mahalanobis length under the covariance sigma^2 A^-1), or a cost that changes within its round-off,
        once the variance components and f hold still."""
        self.start()
        self.f_next = None
        x = (self.cs, self.ns, self.homes, self.offs, self.R0, self.sc)
        lam = 1e-6
        fresh = True
        for it in range(self.first, 300):
            if fresh:
                parts = None  # (the last pass's per-point parts go before the next pass makes its own)
                A, _, b, ss, parts = self.normal_eq(*x, self.wr, self.f)
                D_ = np.diag(A).copy()
                D_[D_ <= 0] = 1.0
                sigma2, new_gam, new_wr, self.f_next, moved, gross = self.variance_components(A, parts, it)
                fresh = False
            if gross:  # a large change (the first robust weights, a first gamma): no step on the old ones
                self.gam, self.wr, self.f, fresh = new_gam, new_wr, self.f_next, True
                continue
            delta = -_pinv_sym(A + lam * np.diag(D_)) @ b
            m2 = float(delta @ A @ delta) / sigma2  # (the step's length in its own sigmas)^2
            tiny = m2 <= STEP_TOL**2 or np.max(np.abs(delta)) <= 1e-13 * max(self.size, 1e-300)
            trial = self.step(*x, delta)
            new_cost = self.cost(*trial, self.wr)
            level = self.eps_cost * math.sqrt(ss) + 64 * np.finfo(float).eps * ss  # round-off of a cost difference
            accepted = new_cost <= ss or (tiny and new_cost <= ss + level)
            if accepted:
                x = trial
                lam = max(lam / 10, 1e-12)
            else:
                lam *= 10
            # nothing left to gain beyond round-off: a tiny step, or a cost that neither fell nor was predicted to
            # beyond it
            settled = tiny or (new_cost - ss <= level and m2 * sigma2 <= level)
            if (settled and moved <= 1) or lam > 1e8:
                break
            if accepted or settled:
                self.gam, self.wr, self.f, fresh = new_gam, new_wr, self.f_next, True
        else:
            raise NotConvergedError(
                f"{self.where}: global fit: no convergence in 300 steps "
                f"(expected a step below {STEP_TOL:g} of its sigmas)"
            )
        self.cs, self.ns, self.homes, self.offs, self.R0, self.sc = x
        self.sigma2 = sigma2

    def result(self) -> dict:
        """The fit's result (:func:`fit_sweeps`): a last pass with the final weights gives the sandwich covariance,
        mapped to [c_j (the foot of the home point), n_j], the home points, offsets and rotation, and the scales."""
        n, S, K, H, npar = self.n, self.S, self.K, self.H, self.npar
        i_off, i_sc, swept, ws, sigma2 = self.i_off, self.i_sc, self.swept, self.ws, self.sigma2
        cs, ns, homes, gam, lref = self.cs, self.ns, self.homes, self.gam, self.lref
        A, A2, b, ss, parts = self.normal_eq(
            cs, ns, homes, self.offs, self.R0, self.sc, self.wr, self.f, bread=self.loss != "linear"
        )
        psi2 = sum(float(np.sum(w**2 * p[4])) for w, p in zip(ws, parts, strict=True))
        dof = self.D * sum(float(np.sum(w**2)) for w in ws) - (npar - len(self.held))
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
            if self.kinds[j] == "revolute":
                M[6 * j : 6 * j + 3, 4 * j + 2 : 4 * j + 4] = B
            M[6 * j + 3 : 6 * j + 6, 4 * j : 4 * j + 2] = B
        M[6 * n : n_out, 4 * n : i_off] = np.eye(3 * H)
        M[n_out:, i_off:i_sc] = np.eye(i_sc - i_off)
        cov_all = M @ cov_x @ M.T
        scale_sigma = np.full(n, math.nan)
        scale_sigma[swept] = np.sqrt(np.clip(np.diag(cov_x)[i_sc : self.i_k], 0, None))
        # the scales' covariance with [c_j, n_j, ..., p] and among themselves (n columns, zero where not fitted)
        Ms = np.zeros((n, npar))
        Ms[swept, i_sc + np.arange(len(swept))] = 1.0
        scale_cross, scale_cov = (M @ cov_x @ Ms.T)[:n_out], Ms @ cov_x @ Ms.T
        Mk = np.zeros((n, npar))  # the compliances' (zero where not fitted)
        Mk[self.kj, self.i_k + np.arange(len(self.kj))] = 1.0
        k_cov = Mk @ cov_x @ Mk.T
        k_cross = np.vstack([(M @ cov_x @ Mk.T)[:n_out], Ms @ cov_x @ Mk.T])  # (rows of cov, then the scales)
        k_sigma = np.full(n, math.nan)
        k_sigma[self.kj] = np.sqrt(np.clip(np.diag(k_cov)[self.kj], 0, None))
        sigma = math.sqrt(sigma2)
        levers = [float(np.mean(p[3])) for p in parts] if lref is None else lref
        reading_sigma = [
            math.sqrt(max(sigma2 / g**2 - sigma2, 0.0)) / max(lv, 1e-300) for g, lv in zip(gam, levers, strict=True)
        ]
        misfit = [np.sqrt(p[9] / K) if p[8] is None else p[8] for p in parts]
        return {
            "points": np.array(feet),
            "directions": np.array(ns),
            "home": np.array([self.home_of(k) for k in range(S)]),
            "cov": cov_all[:n_out, :n_out],
            "cov_all": cov_all,
            "offsets": self.offs,
            "rotation": self.R0,
            "rotation_sigma": self.srot if self.rot else math.nan,
            "components": self.D,
            "n_homes": H,
            "misfit": misfit,
            "weights": ws,
            "whitened": [np.sqrt(p[4]) / sigma for p in parts],
            "sigma": sigma,
            "reading_sigma": reading_sigma,
            "ss": ss / sigma2,
            "ss_m": ss,
            "n_params": npar - len(self.held),  # (the free ones: a compliance held at 0 is no parameter of the fit)
            "gamma": gam,
            "robust_scale": self.f,
            "scales": self.sc[:n],
            "scale_sigma": scale_sigma,
            "scale_cross": scale_cross,
            "scale_cov": scale_cov,
            "tracker_ref2": math.nan if self.ref2 is None else self.ref2,
            "compliance": self.sc[n:] if self.tq is not None else np.zeros(n),
            "compliance_sigma": k_sigma,
            "compliance_cov": k_cov,
            "compliance_cross": k_cross,
            "compliance_held": np.isin(np.arange(n), self.held),
            "compliance_negative": self.negative,
        }
