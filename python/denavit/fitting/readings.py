"""The fit of a revolute axis that uses the recorded joint readings: the points are rotations of one rigid point
about the axis by the readings (after the circle-point method of Hayat et al., section II.C)."""

from __future__ import annotations

import math

import numpy as np

from ..errors import DenavitError
from ..geometry import axis_angle_matrices, perpendicular_basis, skew
from .checks import check_loss, check_points, check_positive, check_q, prefix
from .circle import (
    arc_span,
    circle_misfit,
    in_plane_angles,
    least_squares_lm,
    plane_circle,
    unit_from_params,
)
from .result import AxisFit, axis_sigmas, check_sigma
from .robust import cov_from_jacobian, flag_outliers, irls, rms_spread, robust_sigma

#: The readings fit raises if its robust misfit sigma exceeds this many times that of a free circle.
READINGS_MISMATCH = 10.0


def fit_axis_with_readings(
    points, q, *, loss: str = "linear", f_scale=None, max_sigma_point=None, noise_sigma=None, where: str = ""
) -> AxisFit:
    """Fit a revolute axis using the joint readings: the points are rotations of one rigid point.

    Model (after the circle-point method of [H]_ section II.C, with the recorded angles added)::

        p_k = c + R(n, q_k - q_ref) (p0 - c),    R = Rodrigues rotation (right-hand rule)

    with unknowns the axis direction ``n`` (2 parameters, ``n = (n0 + a t1 + b t2)/|.|``), the axis point ``c``
    (2 parameters, in the plane through a reference point perpendicular to ``n0``) and the rigid point ``p0`` at
    ``q_ref = mean(q)`` (3 parameters): 7 unknowns, ``3 m`` residuals, solved by ``scipy.optimize.least_squares``
    (Levenberg-Marquardt, analytic Jacobian) from the hyper circle. Only differences of ``q`` matter (no per-sweep
    offset is estimated). Because the angles fix the arc length, the radius -- hence the axis position -- is far
    better determined than by a circle fit on short arcs.

    Parameters
    ----------
    points : array_like, shape (m, 3), metres, frame ``world``
        The swept point (m >= 3, not collinear), any order.
    q : array_like, shape (m,), radians
        The joint reading at each point.
    loss : {"linear", "soft_l1", "huber"}
        Per-point loss on the 3-D misfit ``|p_k - model_k|`` (iteratively reweighted least squares).
    f_scale, max_sigma_point, noise_sigma, where
        As for :func:`~denavit.fitting.circle.fit_circle_geometric` (``f_scale``'s default: 3 robust sigmas of
        the current fit's 3-D misfits).

    Returns
    -------
    AxisFit
        ``method="readings"``; ``point`` is the circle centre (the foot of ``p0`` on the axis), ``radius`` the
        distance of ``p0`` from the axis, ``direction`` such that increasing ``q`` turns counter-clockwise about
        it; ``residuals`` are distances to that circle, ``outliers`` are judged on the 3-D misfit;
        ``cov`` from the Jacobian at the solution, ``s^2 = SSR / (3 m - 7)`` (robust losses: weighted, see the
        module's Uncertainty section).

    Raises
    ------
    DenavitError
        If the points do not move like rotations by ``q`` (e.g. ``q`` in degrees, out of order, or a wrong joint
        scale): checked at the start (rotated back by ``q`` the points must gather, within a quarter of the radius)
        and at the solution for m >= 6 (robust misfit sigma at most ``READINGS_MISMATCH`` times that of the hyper
        circle).
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


def _readings(p, q, loss, f_scale, noise_sigma, where) -> AxisFit:
    what = "readings fit"
    m = p.shape[0]
    origin = p.mean(axis=0)
    length = rms_spread(p)
    pn = (p - origin) / length
    delta = q - q.mean()

    # start: hyper circle; the normal's sign and p0 from rotating the points back by the readings
    c0, n0, r0 = plane_circle(pn, "hyper", what, where, length)
    best = None
    for sgn in (1.0, -1.0):
        back = c0 + np.einsum("kij,kj->ki", axis_angle_matrices(sgn * n0, -delta), pn - c0)
        spread = math.sqrt(np.mean(np.sum((back - back.mean(axis=0)) ** 2, axis=1)))
        if best is None or spread < best[0]:
            best = (spread, sgn * n0, back.mean(axis=0))
    spread, n0, p00 = best
    if spread > 0.25 * r0:
        raise DenavitError(
            f"{prefix(where)}{what}: the points do not move as rotations by the readings q about one axis "
            f"(rotated back by q they scatter by {spread * length * 1e3:.3g} mm RMS on a circle of radius "
            f"{r0 * length * 1e3:.3g} mm; expected a small fraction of the radius): are q in radians and "
            "paired with the points in the same order?"
        )

    def solve(st, w):
        cr, nr, pr = st
        t1, t2 = perpendicular_basis(nr)
        tt = np.column_stack([t1, t2])
        sw = np.repeat(np.sqrt(w), 3)

        def unpack(x):
            n, g = unit_from_params(nr, t1, t2, x[0], x[1])
            return cr + tt @ x[2:4], n, pr + x[4:7], g

        def fun(x):
            c, n, p0, _ = unpack(x)
            pred, _ = _readings_model(c, n, p0, delta)
            return (pred - pn).ravel() * sw

        def jac(x):
            c, n, p0, g = unpack(x)
            return _readings_jacobian(c, n, p0, delta, g, tt) * sw[:, None]

        c, n, p0, _ = unpack(least_squares_lm(fun, jac, np.zeros(7), what, where))
        return c, n, p0

    def misfit(st):
        return np.linalg.norm(_readings_model(*st, delta)[0] - pn, axis=1)

    state = solve((c0, n0, p00), np.ones(m))
    state, w = irls(solve, misfit, state, loss, f_scale, 3, what, where)

    # model check: with the readings, the point must be explained about as well as by a free circle
    sig_read = robust_sigma(misfit(state), 3)
    sig_circ = robust_sigma(circle_misfit(pn, c0, n0, r0)[0], 2)
    if m >= 6 and sig_read > READINGS_MISMATCH * sig_circ + 1e-9:  # a circle through < 6 points leaves too few dof
        raise DenavitError(
            f"{prefix(where)}{what}: the joint readings q do not explain the point motion: robust misfit "
            f"{sig_read * length * 1e3:.3g} mm per coordinate with the readings vs {sig_circ * length * 1e3:.3g} mm "
            f"for a free circle (expected at most {READINGS_MISMATCH:g}x): are q in radians, paired with the points "
            "in the same order, and is the joint's scale right? (method='geometric' ignores q)"
        )

    # back to metres; covariance re-linearised at the solution (a = b = u = v = 0)
    c, n, p0 = state
    c, p0 = origin + length * c, origin + length * p0
    t1, t2 = perpendicular_basis(n)
    tt = np.column_stack([t1, t2])
    pred, _ = _readings_model(c, n, p0, delta)
    resid = pred - p
    jac = _readings_jacobian(c, n, p0, delta, tt, tt)
    cov_t = cov_from_jacobian(jac, resid.ravel(), np.repeat(w, 3), 7, noise_sigma, what, where)
    v = p0 - c
    hv = v @ n
    centre = c + hv * n
    radius = float(np.linalg.norm(v - hv * n))
    dcentre = np.hstack([(hv * np.eye(3) + np.outer(n, v)) @ tt, tt, np.outer(n, n)])  # d centre / d [a b u v p0]
    tmat = np.vstack([dcentre, np.hstack([tt, np.zeros((3, 5))])])
    cov6 = tmat @ cov_t @ tmat.T
    sp, sd = axis_sigmas(cov6, n)
    e, _, _ = circle_misfit(p, centre, n, radius)
    mis = np.linalg.norm(resid, axis=1)
    return AxisFit(
        point=centre, direction=n, radius=radius, residuals=e, rms=float(np.sqrt(np.mean(e**2))), cov=cov6,
        sigma_point_perp=sp, sigma_direction=sd, method="readings" if loss == "linear" else f"readings+{loss}",
        outliers=flag_outliers(mis, 3, length), n_points=m, arc=arc_span(in_plane_angles(p, centre, n)),
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
