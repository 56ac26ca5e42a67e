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
from ..geometry import axis_angle_matrices, perpendicular_basis
from .robust import loss_weight, misfit_variance, robust_sigma

#: A locked reading whose correlation with the swept joint's reading exceeds this (and which moves) is coupled.
COUPLED_CORRELATION = 0.99


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
        off = off if abs(off) > 3 * se / math.sqrt(m) else 0.0
        slope = slope if m > 2 and abs(slope) > 3 * se / math.sqrt(t @ t) else 0.0
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


def _skews(v: np.ndarray) -> np.ndarray:
    """Cross-product matrices (m, 3, 3) of vectors (m, 3)."""
    out = np.zeros((len(v), 3, 3))
    out[:, 0, 1], out[:, 0, 2], out[:, 1, 2] = -v[:, 2], v[:, 1], -v[:, 0]
    out[:, 1, 0], out[:, 2, 0], out[:, 2, 1] = v[:, 2], -v[:, 1], v[:, 0]
    return out


def _chain(cs, ns, kinds, p, dq, active, jac: bool):
    """Predicted points (m, 3), and with ``jac`` the Jacobian blocks and the motion of the swept joint.

    Returns ``pred``, ``blocks`` {joint: (m, 3, 4) d pred / d [a, b, s, t]} (direction in its tangent basis,
    point across the axis), ``jp`` (m, 3, 3) d pred / d p, and ``dpdq`` {joint: (m, 3)} d pred / d q_joint.
    """
    m = dq.shape[0]
    y = np.broadcast_to(p, (m, 3)).copy()
    before, rots = {}, {}
    for i in reversed(active):
        before[i] = y
        if kinds[i] == "prismatic":
            y = y + dq[:, i, None] * ns[i]
        else:
            rots[i] = axis_angle_matrices(ns[i], dq[:, i])
            y = cs[i] + np.einsum("mij,mj->mi", rots[i], y - cs[i])
    if not jac:
        return y, None, None, None
    blocks, dpdq = {}, {}
    lin = None  # linear part of g_1 ... g_(i-1), (m, 3, 3); None is the identity
    for i in active:
        B = np.column_stack(perpendicular_basis(ns[i]))
        if kinds[i] == "prismatic":
            dn = dq[:, i, None, None] * B[None]
            local = np.concatenate([dn, np.zeros((m, 3, 2))], axis=2)
            move = np.broadcast_to(ns[i], (m, 3))
        else:
            R, v, d = rots[i], before[i] - cs[i], dq[:, i]
            s, co = np.sin(d)[:, None, None], (1 - np.cos(d))[:, None, None]
            dRv = -s * _skews(v) + co * (np.einsum("mi,i->m", v, ns[i])[:, None, None] * np.eye(3) + np.einsum("i,mj->mij", ns[i], v))
            local = np.concatenate([dRv @ B, (np.eye(3) - R) @ B], axis=2)
            move = np.cross(ns[i], np.einsum("mij,mj->mi", R, v))
        if lin is None:
            blocks[i], dpdq[i] = local, move
        else:
            blocks[i], dpdq[i] = lin @ local, np.einsum("mij,mj->mi", lin, move)
        lin_i = np.eye(3) if kinds[i] == "prismatic" else rots[i]
        lin = lin_i if lin is None else lin @ lin_i
    jp = np.broadcast_to(np.eye(3), (m, 3, 3)) if lin is None else lin
    return y, blocks, jp, dpdq


def fit_sweeps(sweeps, dqs: list, starts: list, p0: np.ndarray, *, loss: str = "linear", per_sweep_home: bool = False,
               noise_sigma=None, where: str = ""):
    """The joint fit of all sweeps (module docstring). ``dqs`` per sweep (m, n) joint motions from home
    (:func:`locked_motion`), ``starts`` per joint (point, direction) start lines, ``p0`` the start home point.

    Returns a dict: ``points`` (n, 3) feet of the home point on each axis, ``directions`` (n, 3), ``home``
    (S, 3) home point per sweep (all equal without ``per_sweep_home``), ``cov`` of [c_1, n_1, ..., c_n, n_n,
    p_1 (, p_2, ...)] (the axis points at those feet), ``misfit`` per sweep (m,) 3-D distances, ``weights`` per
    sweep (m,) robust weights, ``whitened`` per sweep (m,) misfits in point-noise units, ``sigma`` the point
    noise, ``reading_sigma`` per sweep, ``ss`` the whitened sum of squares and ``n_params``.
    """
    kinds = sweeps.kinds
    n, S = sweeps.n_joints, len(sweeps.sweeps)
    cs = [np.array(c, dtype=float) for c, _ in starts]
    ns = [np.array(d, dtype=float) / np.linalg.norm(d) for _, d in starts]
    homes = np.tile(np.asarray(p0, dtype=float), (S if per_sweep_home else 1, 1))
    npar = 4 * n + 3 * len(homes)
    active = [[i for i in range(n) if np.any(dq[:, i] != 0)] for dq in dqs]
    size = max(float(np.sqrt(np.mean(np.sum((s.points - s.points.mean(axis=0)) ** 2, axis=1)))) for s in sweeps.sweeps)
    floor = 1e-12 * size
    gam = np.ones(S)
    ws = [np.ones(len(s.points)) for s in sweeps.sweeps]

    def home_of(k):
        return homes[k] if per_sweep_home else homes[0]

    def evaluate(cs, ns, homes_, jac):
        out = []
        for k, (s, dq) in enumerate(zip(sweeps.sweeps, dqs, strict=True)):
            pred, blocks, jp, dpdq = _chain(cs, ns, kinds, homes_[k] if per_sweep_home else homes_[0], dq, active[k], jac)
            out.append((pred - s.points, blocks, jp, dpdq))
        return out

    def tangent(k, dpdq):
        j = sweeps.sweeps[k].joint - 1
        mv = dpdq[j]
        lever = np.linalg.norm(mv, axis=1)
        return mv / np.maximum(lever, 1e-300)[:, None], lever

    def whitened(r, t, g):
        rt = np.einsum("mi,mi->m", r, t)
        return r - (1 - g) * rt[:, None] * t, rt

    def normal_eq(ev):
        A = np.zeros((npar, npar))
        A2 = np.zeros((npar, npar))
        b = np.zeros(npar)
        ss = 0.0
        parts = []
        for k, (r, blocks, jp, dpdq) in enumerate(ev):
            t, lever = tangent(k, dpdq)
            cols = [(4 * i, blocks[i]) for i in active[k]] + [(4 * n + 3 * (k if per_sweep_home else 0), jp)]
            idx = np.concatenate([np.arange(o, o + blk.shape[2]) for o, blk in cols])
            J = np.concatenate([blk for _, blk in cols], axis=2)
            jt = np.einsum("mi,mik->mk", t, J)
            Jw = J - (1 - gam[k]) * t[:, :, None] * jt[:, None, :]
            rw, rt = whitened(r, t, gam[k])
            w = ws[k]
            Jf = Jw.reshape(-1, len(idx)) * np.repeat(np.sqrt(w), 3)[:, None]
            A[np.ix_(idx, idx)] += Jf.T @ Jf
            Jf2 = Jw.reshape(-1, len(idx)) * np.repeat(w, 3)[:, None]
            A2[np.ix_(idx, idx)] += Jf2.T @ Jf2
            b[idx] += Jf.T @ (rw.reshape(-1) * np.repeat(np.sqrt(w), 3))
            ss += float(np.sum(w * np.sum(rw**2, axis=1)))
            parts.append((idx, gam[k] * jt * np.sqrt(w)[:, None], rt, lever, rw))
        return A, A2, b, ss, parts

    def step(x_cs, x_ns, x_h, delta):
        new_cs, new_ns = [], []
        for i in range(n):
            B = np.column_stack(perpendicular_basis(x_ns[i]))
            nv = x_ns[i] + B @ delta[4 * i : 4 * i + 2]
            new_ns.append(nv / np.linalg.norm(nv))
            new_cs.append(x_cs[i] + (B @ delta[4 * i + 2 : 4 * i + 4] if kinds[i] == "revolute" else 0.0))
        return new_cs, new_ns, x_h + delta[4 * n :].reshape(-1, 3)

    def cost(ev):
        return sum(float(np.sum(ws[k] * np.sum(whitened(r, tangent(k, dpdq)[0], gam[k])[0] ** 2, axis=1))) for k, (r, _, _, dpdq) in enumerate(ev))

    ev = evaluate(cs, ns, homes, True)
    lam = 1e-6
    sigma2 = None
    for it in range(300):
        A, A2, b, ss, parts = normal_eq(ev)
        D = np.diag(A).copy()
        D[D <= 0] = 1.0
        # variance components: pooled point noise across the motion, each sweep's misfit along it
        A_inv = _pinv_sym(A)
        lev_t = [float(np.einsum("mk,kl,ml->", jt, A_inv[np.ix_(idx, idx)], jt)) for idx, jt, _, _, _ in parts]
        # (robust losses: the weighted residuals w r, bounded for outliers, over the weighted counts sum(w^2))
        ss_t = [float(np.sum(ws[k] ** 2 * rt**2)) for k, (_, _, rt, _, _) in enumerate(parts)]
        ss_o = sum(float(np.sum(ws[k] ** 2 * (np.sum(ev[k][0] ** 2, axis=1) - parts[k][2] ** 2))) for k in range(S))
        m_w = [float(np.sum(w**2)) for w in ws]
        red_o = 2 * sum(m_w) - (float(np.trace(A_inv @ A)) - sum(lev_t))
        sigma2 = max(ss_o / red_o if red_o > 0 else 0.0, (noise_sigma or 0.0) ** 2, floor**2)
        tau2 = [st / max(mw - lt, 1.0) for st, lt, mw in zip(ss_t, lev_t, m_w, strict=True)]
        new_gam = np.array([1.0 if not t2 > sigma2 else max(math.sqrt(sigma2 / t2), 1e-9) for t2 in tau2])
        # robust weights on the whitened misfits (in point-noise units), scale 3 robust sigmas
        new_ws = ws
        if loss != "linear":
            e = [np.linalg.norm(p[4], axis=1) for p in parts]
            f = 3.0 * max(robust_sigma(np.concatenate(e), 3), floor)
            new_ws = [loss_weight(loss, (ek / f) ** 2) for ek in e]
        changed = np.max(np.abs(new_gam - gam) / gam) > 1e-6 or any(np.max(np.abs(a - c)) > 1e-9 for a, c in zip(new_ws, ws, strict=True))
        if changed:
            gam, ws = new_gam, new_ws
            ev = evaluate(cs, ns, homes, True)
            continue
        delta = -_pinv_sym(A + lam * np.diag(D)) @ b
        small = np.max(np.abs(delta)) <= 1e-13 * max(size, 1e-300) + 1e-300
        tcs, tns, th = step(cs, ns, homes, delta)
        tev = evaluate(tcs, tns, th, True)
        if cost(tev) <= ss:
            cs, ns, homes, ev = tcs, tns, th, tev
            lam = max(lam / 10, 1e-12)
        else:
            lam *= 10
        if small or (lam > 1e8):
            break
    else:
        raise NotConvergedError(f"{where}: global fit: no convergence in 300 steps (expected the steps to settle to 1e-13 of the size)")
    A, A2, b, ss, parts = normal_eq(ev)
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
    M[6 * n :, 4 * n :] = np.eye(3 * len(homes))
    cov = M @ cov_x @ M.T
    sigma = math.sqrt(sigma2)
    reading_sigma = [math.sqrt(max(sigma2 / g**2 - sigma2, 0.0)) / max(float(np.mean(p[3])), 1e-300) for g, p in zip(gam, parts, strict=True)]
    return {
        "points": np.array(feet), "directions": np.array(ns), "home": np.array([home_of(k) for k in range(S)]), "cov": cov,
        "misfit": [np.linalg.norm(e[0], axis=1) for e in ev], "weights": ws, "whitened": [np.linalg.norm(p[4], axis=1) / sigma for p in parts],
        "sigma": sigma, "reading_sigma": reading_sigma, "ss": ss / sigma2, "n_params": npar, "gamma": gam,
    }
