"""The fit of a revolute axis that uses the recorded joint readings: the points are rotations of one rigid point
about the axis by the readings (after the circle-point method of Hayat et al., section II.C)."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from ..errors import DenavitError
from ..geometry import axis_angle_matrices, perpendicular_basis, skew
from .checks import check_loss, check_points, check_positive, check_q, prefix
from .circle import (
    arc_span,
    circle_misfit,
    in_plane_angles,
    least_squares_lm,
    net_turn,
    robust_circle,
    unit_from_params,
)
from .result import AxisFit, axis_sigmas, check_sigma, flipped
from .robust import CHI_MEDIAN, cov_from_jacobian, flag_outliers, irls, rms_spread, robust_sigma

#: Below this ratio of the point noise to the tangential misfit (point noise and reading noise together) the
#: readings are worth nothing to the fit: the result is the geometric circle, oriented by the readings.
READINGS_WORTHLESS = 1e-3


def fit_axis_with_readings(
    points, q, *, loss: str = "linear", f_scale=None, max_sigma_point=None, noise_sigma=None, where: str = ""
) -> AxisFit:
    """Fit a revolute axis using the joint readings, weighted by what the readings are worth.

    Model (after the circle-point method of [H]_ section II.C, with the recorded angles added)::

        p_k = c + R(n, q_k + e_k - q_ref) (p0 - c) + eps_k,    R = Rodrigues rotation (right-hand rule)

    with unknowns the axis direction ``n`` (2 parameters, ``n = (n0 + a t1 + b t2)/|.|``), the axis point ``c``
    (2 parameters, in the plane through a reference point perpendicular to ``n0``) and the rigid point ``p0`` at
    ``q_ref = mean(q)`` (3 parameters): 7 unknowns, ``3 m`` residuals. The point noise ``eps_k`` has ``sigma``
    per coordinate, the reading error ``e_k`` (white; a joint's scale error shows up in it too) ``sigma_q``: to
    first order a point's misfit has the covariance ``sigma^2 I + (r sigma_q)^2 t t^T`` (``t`` the unit tangent
    of the circle, ``r`` the radius; the "effective variance" errors-in-variables model). Both variances are
    estimated: ``sigma`` from the free (hyper) circle's misfit, which does not depend on the readings (a declared
    ``noise_sigma`` is its floor), ``tau^2 = sigma^2 + (r sigma_q)^2`` from the misfit along the tangent over its
    redundancy (a variance-component step), iterated with the weights ``1/sigma``, ``1/tau`` to a fixed point. With
    exact readings ``tau = sigma`` and
    this is the plain readings fit, which fixes the radius -- hence the axis position -- far better than a circle
    on short arcs; as the readings get worse their weight goes to zero and the fit becomes the geometric circle
    (below ``READINGS_WORTHLESS`` it is the geometric circle). The readings are never refused.

    Parameters
    ----------
    points : array_like, shape (m, 3), metres, frame ``world``
        The swept point (m >= 3, not collinear), any order.
    q : array_like, shape (m,), radians
        The joint reading at each point.
    loss : {"linear", "soft_l1", "huber"}
        Per-point loss on the weighted 3-D misfit (iteratively reweighted least squares).
    f_scale, max_sigma_point, noise_sigma, where
        As for :func:`~denavit.fitting.circle.fit_circle_geometric` (``f_scale``'s default: 3 robust sigmas of
        the current fit's weighted misfits, in metres of point noise).

    Returns
    -------
    AxisFit
        ``method="readings"``; ``point`` is the circle centre (the foot of ``p0`` on the axis), ``radius`` the
        distance of ``p0`` from the axis, ``direction`` such that increasing ``q`` turns counter-clockwise about
        it; ``residuals`` are distances to that circle, ``outliers`` are judged on the weighted 3-D misfit;
        ``reading_sigma`` the estimated reading error ``sigma_q`` (rad) and ``noise`` the point noise ``sigma``;
        ``cov`` from the weighted Jacobian at the solution (see the module's Uncertainty section).

    Raises
    ------
    DenavitError
        If the points do not move like rotations by ``q`` at all (e.g. ``q`` in degrees): rotated back by ``q``
        the points must gather, within a quarter of the radius.
    """
    check_loss(loss, f_scale, where)
    check_positive("max_sigma_point", max_sigma_point, where)
    check_positive("noise_sigma", noise_sigma, where)
    p = check_points(points, 3, "readings fit", where)
    qa = check_q(q, p.shape[0], where)
    fit = _readings(p, qa, loss, f_scale, noise_sigma, where)
    return check_sigma(fit, max_sigma_point, where)


def _readings_model(c, n, p0, delta):
    rot = axis_angle_matrices(n, delta)
    return c + (rot @ (p0 - c)), rot


def _tangents(c, n, pred):
    """Unit tangents (m, 3) of the circle about (c, n) at the predicted points (the direction a reading error moves
    them)."""
    t = np.cross(n, pred - c)
    return t / np.maximum(np.linalg.norm(t, axis=1), 1e-300)[:, None]


def whiten(r, jac, t, gamma):
    """Residuals (m, 3) and Jacobian (m, 3, k) with the tangential component scaled by ``gamma`` (= sigma / tau)."""
    rt = np.einsum("mi,mi->m", r, t)
    r_w = r - (1.0 - gamma) * rt[:, None] * t
    if jac is None:
        return r_w, None
    jt = np.einsum("mi,mik->mk", t, jac)
    return r_w, jac - (1.0 - gamma) * t[:, :, None] * jt[:, None, :]


def tangential_variance(r, jac, t, w, gamma):
    """Forstner's variance-component step for the misfit along the tangents: its weighted sum of squares over its
    redundancy (count minus the trace of its share of the hat matrix).

    ``r`` (m, 3) and ``jac`` (m, 3, k) unweighted residuals and Jacobian, ``t`` (m, 3) unit tangents, ``w`` (m,)
    robust weights, ``gamma`` the current tangential weight (the weights are 1 across the tangent, ``gamma``
    along it). Returns ``tau^2`` (the units of ``r`` squared): ``sum((w r_t)^2) / (sum(w^2) - leverage)``, as
    :func:`~denavit.fitting.robust.weighted_cov` (a down-weighted blunder does not inflate it).
    """
    _, jw = whiten(r, jac, t, gamma)
    jw = jw * np.sqrt(w)[:, None, None]
    a_inv = np.linalg.inv(np.einsum("mik,mil->kl", jw, jw))
    jt = np.einsum("mi,mik->mk", t, jw)  # tangential rows (weighted by gamma)
    lev_t = float(np.einsum("mk,kl,ml->", jt, a_inv, jt))
    rt = np.einsum("mi,mi->m", r, t)
    red = float(np.sum(w**2)) - lev_t  # robust losses: the weighted residuals w r over the weighted count
    return float(np.sum((w * rt) ** 2)) / red if red > 0 else math.nan


def _readings(p, q, loss, f_scale, noise_sigma, where) -> AxisFit:
    what = "readings fit"
    m = p.shape[0]
    origin = p.mean(axis=0)
    length = rms_spread(p)
    pn = (p - origin) / length
    delta = q - q.mean()
    declared = None if noise_sigma is None else noise_sigma / length

    # start: hyper circle; the normal's sign and p0 from rotating the points back by the readings
    # (trimmed, so that one blunder does not spoil the start; the spread is a median, for the same reason)
    c0, n0, r0, inliers = robust_circle(pn, what, where, length)
    best = None
    for sgn in (1.0, -1.0):
        back = c0 + np.einsum("kij,kj->ki", axis_angle_matrices(sgn * n0, -delta), pn - c0)
        mid = np.median(back[inliers], axis=0)
        spread = float(np.median(np.linalg.norm(back - mid, axis=1))) / CHI_MEDIAN[3] * math.sqrt(3)
        if best is None or spread < best[0]:
            best = (spread, sgn * n0, mid)
    spread, n0, p00 = best
    if spread > 0.25 * r0:
        raise DenavitError(
            f"{prefix(where)}{what}: the points do not move as rotations by the readings q about one axis "
            f"(rotated back by q they scatter by {spread * length * 1e3:.3g} mm (robust RMS) on a circle of radius "
            f"{r0 * length * 1e3:.3g} mm; expected a small fraction of the radius): are q in radians and "
            "paired with the points in the same order?"
        )

    gamma = 1.0

    def solve(st, w):
        cr, nr, pr = st
        t1, t2 = perpendicular_basis(nr)
        tt = np.column_stack([t1, t2])
        tan = _tangents(cr, nr, _readings_model(cr, nr, pr, delta)[0])  # fixed during one solve
        sw = np.sqrt(w)[:, None]

        def unpack(x):
            n, g = unit_from_params(nr, t1, t2, x[0], x[1])
            return cr + tt @ x[2:4], n, pr + x[4:7], g

        def fun(x):
            c, n, p0, _ = unpack(x)
            pred, _ = _readings_model(c, n, p0, delta)
            return (whiten(pred - pn, None, tan, gamma)[0] * sw).ravel()

        def jac(x):
            c, n, p0, g = unpack(x)
            j = _readings_jacobian(c, n, p0, delta, g, tt).reshape(m, 3, 7)
            return (whiten(np.zeros((m, 3)), j, tan, gamma)[1] * sw[:, :, None]).reshape(-1, 7)

        c, n, p0, _ = unpack(least_squares_lm(fun, jac, np.zeros(7), what, where))
        return c, n, p0

    def parts(st):
        c, n, p0 = st
        t1, t2 = perpendicular_basis(n)
        tt = np.column_stack([t1, t2])
        pred, _ = _readings_model(c, n, p0, delta)
        return pred - pn, _readings_jacobian(c, n, p0, delta, tt, tt).reshape(m, 3, 7), _tangents(c, n, pred)

    def misfit(st):
        r, _, tan = parts(st)
        return np.linalg.norm(whiten(r, None, tan, gamma)[0], axis=1)

    # the point noise from the free (hyper) circle, independent of the readings (robust losses: robust sigma)
    e0 = circle_misfit(pn, c0, n0, r0)[0]
    s2 = float(e0 @ e0) / (2 * m - 6) if loss == "linear" and m > 3 and inliers.all() else robust_sigma(e0, 2) ** 2
    if declared is not None:  # a declared point noise is a floor (misfit beyond it is not hidden)
        s2 = max(declared**2, s2)
    state = solve((c0, n0, p00), np.ones(m) if loss == "linear" else inliers + 1e-6 * ~inliers)
    w = np.ones(m)
    t2 = s2
    for _ in range(50):  # the tangential misfit (point noise and reading error) and the weights to a fixed point
        state, w = irls(solve, misfit, state, loss, f_scale if f_scale is None else f_scale / length, 3, what, where)
        r, j, tan = parts(state)
        t2 = tangential_variance(r, j, tan, w, gamma)
        new = 1.0 if not t2 > s2 else max(math.sqrt(s2 / t2), 1e-12)
        if abs(new - gamma) <= 1e-4 * gamma:
            gamma = new
            break
        gamma = new
        if gamma < READINGS_WORTHLESS:
            break
        state = solve(state, w)

    c, n, p0 = state
    radius_n = float(np.linalg.norm((p0 - c) - ((p0 - c) @ n) * n))
    sigma_q = math.sqrt(max(t2 - s2, 0.0)) / radius_n if radius_n > 0 else math.nan
    method = "readings" if loss == "linear" else f"readings+{loss}"
    if gamma < READINGS_WORTHLESS:  # the readings are worth nothing: the geometric circle, oriented by them
        from .circle import fit_circle_geometric  # noqa: PLC0415

        fit = fit_circle_geometric(p, loss=loss, f_scale=f_scale, noise_sigma=noise_sigma, where=where)
        fit = replace(fit, reading_sigma=sigma_q, method=method)
        phi = in_plane_angles(p, fit.point, fit.direction)
        return flipped(fit) if net_turn(phi[np.argsort(q, kind="stable")]) < 0 else fit

    # back to metres; covariance re-linearised at the solution (a = b = u = v = 0)
    c, p0 = origin + length * c, origin + length * p0
    t1, t2v = perpendicular_basis(n)
    tt = np.column_stack([t1, t2v])
    pred, _ = _readings_model(c, n, p0, delta)
    resid = pred - p
    jac = _readings_jacobian(c, n, p0, delta, tt, tt).reshape(m, 3, 7)
    tan = _tangents(c, n, pred)
    rw, jw = whiten(resid, jac, tan, gamma)
    cov_t = cov_from_jacobian(jw.reshape(-1, 7), rw.ravel(), np.repeat(w, 3), 7, noise_sigma, what, where)
    v = p0 - c
    hv = v @ n
    centre = c + hv * n
    radius = float(np.linalg.norm(v - hv * n))
    dcentre = np.hstack([(hv * np.eye(3) + np.outer(n, v)) @ tt, tt, np.outer(n, n)])  # d centre / d [a b u v p0]
    tmat = np.vstack([dcentre, np.hstack([tt, np.zeros((3, 5))])])
    cov6 = tmat @ cov_t @ tmat.T
    sp, sd = axis_sigmas(cov6, n)
    e, _, _ = circle_misfit(p, centre, n, radius)
    mis = np.linalg.norm(rw, axis=1)
    return AxisFit(
        point=centre,
        direction=n,
        radius=radius,
        residuals=e,
        rms=float(np.sqrt(np.mean(e**2))),
        cov=cov6,
        sigma_point_perp=sp,
        sigma_direction=sd,
        method=method,
        outliers=~inliers if loss == "linear" else flag_outliers(mis, 3, length),
        n_points=m,
        arc=arc_span(in_plane_angles(p, centre, n)),
        reading_sigma=sigma_q,
        noise=math.sqrt(s2) * length,
    )


def _readings_jacobian(c, n, p0, delta, g, tt):
    """d(model_k)/d[a, b, u, v, p0] for the readings model, shape (3 m, 7).

    d(R v)/dn = -sin [v]x + (1 - cos)((n.v) I + n v^T); d/dc = (I - R); d/dp0 = R.
    """
    v = p0 - c
    rot = axis_angle_matrices(n, delta)
    s, co = np.sin(delta), 1 - np.cos(delta)
    dn = -s[:, None, None] * skew(v) + co[:, None, None] * ((v @ n) * np.eye(3) + np.outer(n, v))
    j = np.concatenate([dn @ g, (np.eye(3) - rot) @ tt, rot], axis=2)
    return j.reshape(-1, 7)
