"""One fit of all sweeps with their joint readings (the ``global`` fit of :func:`denavit.identify.identify`).

Every axis at the home configuration is a line ``(c_i, n_i)``; the tool point at home is ``p`` (one for all
sweeps, or one per sweep: a home that drifts between sweeps). A point of a sweep is the home point carried by
every joint's motion from home, in chain order (the product of exponentials at home)::

    p_k = g_1(g_2(... g_n(p))),   g_i(y) = c_i + R(n_i, dq_ik)(y - c_i)  (revolute),  y + dq_ik n_i  (prismatic)

with ``dq_ik`` the reading of joint ``i`` minus its home value: the swept joint's readings, and the locked
joints' recorded readings smoothed over the sweep (a straight line in time: a locked joint that sits a little
off home, or creeps, is followed; white reading noise is averaged out), unless a locked reading moves in
lock-step with the swept joint (a coupling of the controller's readings, then taken as locked at home).

Errors: the points carry isotropic noise ``sigma``; the swept joint's readings carry white errors, so along the
motion a point's misfit has the variance ``tau_s^2 = sigma^2 + (lever sigma_q)^2`` (effective variance, as the
readings fit of :mod:`denavit.fitting.readings`). ``sigma`` (pooled across the motion) and each sweep's
``tau_s`` are variance components estimated over their redundancies, together with the Gauss-Newton /
Levenberg-Marquardt steps (normal equations accumulated sweep by sweep: memory and time linear in the points).
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import NotConvergedError
from ..geometry import perpendicular_basis
from .robust import loss_dweight, loss_weight, misfit_variance, robust_sigma

#: A locked reading whose correlation with the swept joint's reading exceeds this (and which moves) is coupled.
COUPLED_CORRELATION = 0.99
#: Points of a sweep per step of the joint fit's normal equations (their Jacobian rows, a few MB, are not kept).
CHUNK = 8192


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


def _cross(n: np.ndarray, x: np.ndarray) -> np.ndarray:
    """n x x_k for one vector n (3,) and vectors x (m, 3)."""
    return np.column_stack([n[1] * x[:, 2] - n[2] * x[:, 1], n[2] * x[:, 0] - n[0] * x[:, 2], n[0] * x[:, 1] - n[1] * x[:, 0]])


def _crosses(v: np.ndarray, b: np.ndarray) -> np.ndarray:
    """v_k x b for vectors v (m, 3) and one vector b (3,)."""
    return -_cross(b, v)


def _rotate(n, cs, sn, x):
    """R(n, d_k) x_k (Rodrigues) for vectors x (m, 3), with cs, sn (m, 1) the cosines and sines of the angles."""
    return x * cs + _cross(n, x) * sn + np.outer(x @ n, n) * (1 - cs)


def _chain(cs, ns, kinds, p, dq, active, jac: bool, moving: int | None = None):
    """Predicted points (m, 3), and with ``jac`` the Jacobian blocks and the motion of the swept joint.

    Returns ``pred``, ``blocks`` {joint: (m, 3, 4) d pred / d [a, b, s, t]} (direction in its tangent basis,
    point across the axis), ``jp`` (m, 3, 3) d pred / d p, and ``dpdq`` {joint: (m, 3)} d pred / d q_joint.
    Without ``jac`` but with ``moving`` (a joint), ``dpdq`` of that joint alone (the misfit's tangent), no blocks.
    Rotations act on vectors (Rodrigues), so the cost is linear in the points and small per point.
    """
    m = dq.shape[0]
    y = np.broadcast_to(p, (m, 3)).copy()
    before, trig = {}, {}
    for i in reversed(active):
        before[i] = y
        if kinds[i] == "prismatic":
            y = y + dq[:, i, None] * ns[i]
        else:
            trig[i] = (np.cos(dq[:, i])[:, None], np.sin(dq[:, i])[:, None])
            y = cs[i] + _rotate(ns[i], *trig[i], y - cs[i])
    if not jac and moving is None:
        return y, None, None, None

    def outer(i, x):
        """x (m, 3) carried by the linear parts of g_1 ... g_(i-1) (the joints before i)."""
        for k in reversed([a for a in active if a < i]):
            if kinds[k] == "revolute":
                x = _rotate(ns[k], *trig[k], x)
        return x

    blocks, dpdq = {}, {}
    if not jac:
        i = moving
        move = ns[i] if kinds[i] == "prismatic" else _cross(ns[i], _rotate(ns[i], *trig[i], before[i] - cs[i]))
        return y, None, None, {i: outer(i, np.broadcast_to(move, (m, 3)))}
    for i in active:
        B = np.column_stack(perpendicular_basis(ns[i]))
        cols = []
        if kinds[i] == "prismatic":
            for c in range(2):
                cols.append(dq[:, i, None] * B[:, c])
            cols += [np.zeros((m, 3)), np.zeros((m, 3))]
            move = np.broadcast_to(ns[i], (m, 3))
        else:
            co, sn = trig[i]
            v = before[i] - cs[i]
            nv = (v @ ns[i])[:, None]
            for c in range(2):  # d(R v)/dn b = -sin (v x b) + (1 - cos)((n.v) b + n (v.b))
                b = B[:, c]
                cols.append(-sn * _crosses(v, b) + (1 - co) * (nv * b + np.outer(v @ b, ns[i])))
            for c in range(2):  # (I - R) b, b across n: R b = b cos + (n x b) sin
                b = B[:, c]
                cols.append(b - (b * co + np.cross(ns[i], b) * sn))
            move = _cross(ns[i], _rotate(ns[i], co, sn, v))
        blocks[i] = np.stack([outer(i, c) for c in cols], axis=2)
        dpdq[i] = outer(i, np.array(move))
    jp = np.stack([outer(len(kinds), np.broadcast_to(e, (m, 3))) for e in np.eye(3)], axis=2)
    return y, blocks, jp, dpdq


def fit_sweeps(sweeps, dqs: list, starts: list, p0: np.ndarray, *, loss: str = "linear", per_sweep_home: bool = False,
               scales=False, noise_sigma=None, gamma=None, where: str = ""):
    """The joint fit of all sweeps (module docstring). ``dqs`` per sweep (m, n) joint motions from home
    (:func:`locked_motion`), ``starts`` per joint (point, direction) start lines, ``p0`` the start home point.

    ``scales``: False (none), True (every swept joint's reading scale error is a parameter) or the joints
    (0-based) whose scale is one (:func:`denavit.identify._choose` selects them joint by joint).

    Returns a dict: ``points`` (n, 3) feet of the home point on each axis, ``directions`` (n, 3), ``home``
    (S, 3) home point per sweep (all equal without ``per_sweep_home``), ``cov`` of [c_1, n_1, ..., c_n, n_n,
    p_1 (, p_2, ...)] (the axis points at those feet; with ``scales`` marginal over the scales), ``scales`` (n,)
    each swept joint's reading scale error ``s_j`` (the joint turns by ``(1 + s_j)`` times its reading's motion;
    zeros without ``scales``) and ``scale_sigma`` (n,) their one-sigma (nan without), ``scale_cross`` (rows of
    ``cov``, n) and ``scale_cov`` (n, n) their covariance with those parameters and among themselves (zeros where not
    fitted), ``misfit`` per sweep (m,) 3-D distances, ``weights`` per
    sweep (m,) robust weights, ``whitened`` per sweep (m,) misfits in point-noise units, ``sigma`` the point
    noise, ``reading_sigma`` per sweep, ``ss`` the whitened sum of squares and ``n_params``.
    """
    kinds = sweeps.kinds
    n, S = sweeps.n_joints, len(sweeps.sweeps)
    cs = [np.array(c, dtype=float) for c, _ in starts]
    ns = [np.array(d, dtype=float) / np.linalg.norm(d) for _, d in starts]
    homes = np.tile(np.asarray(p0, dtype=float), (S if per_sweep_home else 1, 1))
    # the joints whose reading scale is fitted: every swept joint (scales True), or those given (0-based)
    all_swept = sorted({s.joint - 1 for s in sweeps.sweeps})
    swept = (all_swept if scales is True else sorted({int(j) for j in scales} & set(all_swept))) if scales is not False and scales is not None else []
    sc = np.zeros(n)
    n_h = 4 * n + 3 * len(homes)  # the first scale's index
    npar = n_h + len(swept)
    active = [[i for i in range(n) if np.any(dq[:, i] != 0)] for dq in dqs]
    size = max(float(np.sqrt(np.mean(np.sum((s.points - s.points.mean(axis=0)) ** 2, axis=1)))) for s in sweeps.sweeps)
    floor = 1e-12 * size
    gam = np.ones(S) if gamma is None else np.array(gamma, dtype=float)
    ws = [np.ones(len(s.points)) for s in sweeps.sweeps]

    def home_of(k):
        return homes[k] if per_sweep_home else homes[0]

    def chunks(k, cs, ns, homes_, sc_, jac):
        """(rows, misfits r, d pred / d q of the swept joint, blocks, jp) of sweep k, CHUNK points at a time (the
        joints turning by (1 + s) times their readings' motion)."""
        s, dq = sweeps.sweeps[k], dqs[k]
        j = s.joint - 1
        for a in range(0, len(dq), CHUNK):
            rows = slice(a, a + CHUNK)
            pred, blocks, jp, dpdq = _chain(cs, ns, kinds, homes_[k] if per_sweep_home else homes_[0], dq[rows] * (1 + sc_), active[k], jac, j)
            yield rows, pred - s.points[rows], dpdq[j], blocks, jp

    def tangent(mv):
        lever = np.linalg.norm(mv, axis=1)
        return mv / np.maximum(lever, 1e-300)[:, None], lever

    def whitened(r, t, g):
        rt = np.einsum("mi,mi->m", r, t)
        return r - (1 - g) * rt[:, None] * t, rt

    def normal_eq(cs, ns, homes_, sc_, bread=None):
        """Normal matrix, its robust sandwich part, gradient, whitened cost, and per sweep (indices, Gram matrix of
        the weighted tangential rows, tangential residuals, levers, whitened residuals, misfits), accumulated sweep
        by sweep and CHUNK points at a time (memory linear in the points, small per point). Whitening scales the
        component along the tangent t by gamma: J_w^T J_w = J^T J - (1 - gamma^2) (t^T J)^T (t^T J), J_w^T r_w
        likewise. With ``bread`` (the robust scale f), also the M-estimator's bread term (Huber 1981 sec. 7.6):
        2 w'(z) / f^2 (J_w^T r_w)(J_w^T r_w)^T per point (z = |r_w|^2 / f^2), added to J_w^T W J_w; without it
        the sigmas of a robust fit on clean data came out 7 % small."""
        A = np.zeros((npar, npar))
        A2 = np.zeros((npar, npar)) if loss != "linear" else None
        b = np.zeros(npar)
        ss = 0.0
        Bd = np.zeros((npar, npar)) if bread else None
        parts = []
        for k in range(S):
            g2 = 1 - gam[k] ** 2
            j = sweeps.sweeps[k].joint - 1
            h0 = 4 * n + 3 * (k if per_sweep_home else 0)
            fit_s = j in swept  # (this sweep's joint has a scale parameter)
            idx = np.concatenate([np.arange(4 * i, 4 * i + 4) for i in active[k]] + [np.arange(h0, h0 + 3)] + ([[n_h + swept.index(j)]] if fit_s else []))
            Gt = np.zeros((len(idx), len(idx)))
            m = len(dqs[k])
            rt_k, lever_k, rw_k, r_k = np.empty(m), np.empty(m), np.empty((m, 3)), np.empty((m, 3))
            for rows, r, mv, blocks, jp in chunks(k, cs, ns, homes_, sc_, True):
                t, lever = tangent(mv)
                # (with scales: d pred / d s_j = d pred / d q_j times the reading's motion)
                J = np.concatenate([blocks[i] for i in active[k]] + [jp] + ([(mv * dqs[k][rows, j, None])[:, :, None]] if fit_s else []), axis=2)
                jt = np.einsum("mi,mik->mk", t, J)
                rt = np.einsum("mi,mi->m", r, t)
                w = ws[k][rows]
                Jf = J.reshape(-1, len(idx))
                w3 = np.repeat(w, 3)
                A[np.ix_(idx, idx)] += (Jf * w3[:, None]).T @ Jf - g2 * (jt * w[:, None]).T @ jt
                if A2 is not None:
                    A2[np.ix_(idx, idx)] += (Jf * (w3**2)[:, None]).T @ Jf - g2 * (jt * (w**2)[:, None]).T @ jt
                b[idx] += Jf.T @ (w3 * (r - g2 * rt[:, None] * t).reshape(-1))
                rw = r - (1 - gam[k]) * rt[:, None] * t
                ss += float(np.sum(w * np.sum(rw**2, axis=1)))
                Gt += gam[k] ** 2 * (jt * w[:, None]).T @ jt
                if bread:
                    gw = np.einsum("mi,mik->mk", rw, J) - ((1 - gam[k]) * gam[k] * rt)[:, None] * jt  # J_w^T r_w per point
                    c = 2 * loss_dweight(loss, np.sum(rw**2, axis=1) / bread**2) / bread**2
                    Bd[np.ix_(idx, idx)] += (gw * c[:, None]).T @ gw
                rt_k[rows], lever_k[rows], rw_k[rows], r_k[rows] = rt, lever, rw, r
            parts.append((idx, Gt, rt_k, lever_k, rw_k, r_k))
        if bread:
            return A + Bd, A2, b, ss, parts
        return A, (A if A2 is None else A2), b, ss, parts

    def step(x_cs, x_ns, x_h, x_sc, delta):
        new_cs, new_ns = [], []
        for i in range(n):
            B = np.column_stack(perpendicular_basis(x_ns[i]))
            nv = x_ns[i] + B @ delta[4 * i : 4 * i + 2]
            new_ns.append(nv / np.linalg.norm(nv))
            new_cs.append(x_cs[i] + (B @ delta[4 * i + 2 : 4 * i + 4] if kinds[i] == "revolute" else 0.0))
        new_sc = x_sc.copy()
        new_sc[swept] += delta[n_h:]
        return new_cs, new_ns, x_h + delta[4 * n : n_h].reshape(-1, 3), new_sc

    def cost(cs, ns, homes_, sc_):
        """The whitened cost at a trial point: misfits and tangents only, no Jacobian blocks."""
        total = 0.0
        for k in range(S):
            for rows, r, mv, _, _ in chunks(k, cs, ns, homes_, sc_, False):
                total += float(np.sum(ws[k][rows] * np.sum(whitened(r, tangent(mv)[0], gam[k])[0] ** 2, axis=1)))
        return total

    lam = 1e-6
    sigma2 = None
    for it in range(300):
        A, A2, b, ss, parts = normal_eq(cs, ns, homes, sc)
        D = np.diag(A).copy()
        D[D <= 0] = 1.0
        # variance components: pooled point noise across the motion, each sweep's misfit along it
        A_inv = _pinv_sym(A)
        lev_t = [float(np.sum(A_inv[np.ix_(idx, idx)] * Gt)) for idx, Gt, _, _, _, _ in parts]
        # (robust losses: the weighted residuals w r, bounded for outliers, over the weighted counts sum(w^2))
        ss_t = [float(np.sum(ws[k] ** 2 * rt**2)) for k, (_, _, rt, _, _, _) in enumerate(parts)]
        ss_o = sum(float(np.sum(ws[k] ** 2 * (np.sum(parts[k][5] ** 2, axis=1) - parts[k][2] ** 2))) for k in range(S))
        m_w = [float(np.sum(w**2)) for w in ws]
        red_o = 2 * sum(m_w) - (float(np.trace(A_inv @ A)) - sum(lev_t))
        sigma2 = max(ss_o / red_o if red_o > 0 else 0.0, (noise_sigma or 0.0) ** 2, floor**2)
        tau2 = [st / max(mw - lt, 1.0) for st, lt, mw in zip(ss_t, lev_t, m_w, strict=True)]
        new_gam = gam if gamma is not None else np.array([1.0 if not t2 > sigma2 else max(math.sqrt(sigma2 / t2), 1e-9) for t2 in tau2])
        # robust weights on the whitened misfits (in point-noise units), scale 3 robust sigmas
        new_ws = ws
        if loss != "linear":
            e = [np.linalg.norm(p[4], axis=1) for p in parts]
            f = 3.0 * max(robust_sigma(np.concatenate(e), 3), floor)
            new_ws = [loss_weight(loss, (ek / f) ** 2) for ek in e]
            f_final = f
        # (the weights need 0.1 % / 1e-6; after 100 steps they are frozen, so that the steps settle)
        changed = it < 100 and (np.max(np.abs(new_gam - gam) / gam) > 1e-3 or any(np.max(np.abs(a - c)) > 1e-6 for a, c in zip(new_ws, ws, strict=True)))
        if changed:
            gam, ws = new_gam, new_ws
            continue
        delta = -_pinv_sym(A + lam * np.diag(D)) @ b
        small = np.max(np.abs(delta)) <= 1e-13 * max(size, 1e-300) + 1e-300
        tcs, tns, th, tsc = step(cs, ns, homes, sc, delta)
        new_cost = cost(tcs, tns, th, tsc)
        if new_cost <= ss:
            cs, ns, homes, sc = tcs, tns, th, tsc
            lam = max(lam / 10, 1e-12)
            small = small or (not changed and ss - new_cost <= 1e-14 * ss)
        else:
            lam *= 10
        if small or (lam > 1e8):
            break
    else:
        raise NotConvergedError(f"{where}: global fit: no convergence in 300 steps (expected the steps to settle to 1e-13 of the size)")
    A, A2, b, ss, parts = normal_eq(cs, ns, homes, sc, bread=f_final if loss != "linear" else None)
    psi2 = sum(float(np.sum(w**2 * np.sum(p[4] ** 2, axis=1))) for w, p in zip(ws, parts, strict=True))
    dof = 3 * sum(float(np.sum(w**2)) for w in ws) - npar
    s2 = misfit_variance(np.sqrt(psi2) * np.ones(1), dof, math.sqrt(sigma2))
    A_inv = _pinv_sym(A)
    cov_x = s2 * A_inv @ A2 @ A_inv
    # map the local parameters to [c_j (the foot of the home point), n_j] and the home points
    ph = homes.mean(axis=0)
    feet = []
    M = np.zeros((6 * n + 3 * len(homes), npar))
    for j in range(n):
        B = np.column_stack(perpendicular_basis(ns[j]))
        h = float((ph - cs[j]) @ ns[j])
        feet.append(cs[j] + ns[j] * h)
        M[6 * j : 6 * j + 3, 4 * j : 4 * j + 2] = h * B
        if kinds[j] == "revolute":
            M[6 * j : 6 * j + 3, 4 * j + 2 : 4 * j + 4] = B
        M[6 * j + 3 : 6 * j + 6, 4 * j : 4 * j + 2] = B
    M[6 * n :, 4 * n : n_h] = np.eye(3 * len(homes))
    cov = M @ cov_x @ M.T
    scale_sigma = np.full(n, math.nan)
    scale_sigma[swept] = np.sqrt(np.clip(np.diag(cov_x)[n_h:], 0, None))
    # the scales' covariance with [c_j, n_j, ..., p] and among themselves (n columns, zero where not fitted)
    Ms = np.zeros((n, npar))
    Ms[swept, n_h + np.arange(len(swept))] = 1.0
    scale_cross, scale_cov = M @ cov_x @ Ms.T, Ms @ cov_x @ Ms.T
    sigma = math.sqrt(sigma2)
    reading_sigma = [math.sqrt(max(sigma2 / g**2 - sigma2, 0.0)) / max(float(np.mean(p[3])), 1e-300) for g, p in zip(gam, parts, strict=True)]
    return {
        "points": np.array(feet), "directions": np.array(ns), "home": np.array([home_of(k) for k in range(S)]), "cov": cov,
        "misfit": [np.linalg.norm(p[5], axis=1) for p in parts], "weights": ws, "whitened": [np.linalg.norm(p[4], axis=1) / sigma for p in parts],
        "sigma": sigma, "reading_sigma": reading_sigma, "ss": ss / sigma2, "ss_m": ss, "n_params": npar, "gamma": gam,
        "scales": sc, "scale_sigma": scale_sigma, "scale_cross": scale_cross, "scale_cov": scale_cov,
    }
