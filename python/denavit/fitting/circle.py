"""Circle fits of a revolute joint's sweep: the plane and algebraic circle of Hayat et al. eqs. (1)-(9) (Kasa),
the "hyper" circle of Al-Sharadqah & Chernov (2009) and the orthogonal-distance (geometric) circle.

References: see :mod:`denavit.fitting` ([H]_, [AC]_, [S]_, [C]_).
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import DegenerateError, NotConvergedError
from ..geometry import perpendicular_basis
from .checks import check_loss, check_points, check_positive, prefix
from .result import AxisFit, axis_sigmas, check_sigma
from .robust import CHI_4SIGMA, cov_from_jacobian, flag_outliers, irls, rms_spread, robust_sigma, tall_svd

#: sigma_2 / sigma_1 of the centred points below this means "collinear" for a circle fit.
COLLINEAR_TOL = 1e-9


def unit_from_params(n0, t1, t2, a, b):
    """n = (n0 + a t1 + b t2)/|.| and its Jacobian G = dn/d(a, b), shape (3, 2)."""
    u = n0 + a * t1 + b * t2
    nu = np.linalg.norm(u)
    n = u / nu
    proj = np.eye(3) - np.outer(n, n)
    return n, proj @ np.column_stack([t1, t2]) / nu


def _plane(p: np.ndarray, what: str, where: str, length: float = 1.0):
    """[H]_ eqs. (1)-(4): centroid, SVD of the centred points, in-plane coordinates.

    ``length`` is the metres per unit of ``p`` (the fits pass normalised coordinates), for messages.
    Returns the centroid (3,), the right-handed basis V (3, 3) (columns v1, v2 in the plane, v3 = v1 x v2 the
    normal), the singular values (3,) and the in-plane coordinates (m, 2) of the points about the centroid.
    """
    centroid = p.mean(axis=0)  # eq. (1)
    nmat = p - centroid  # eq. (2)
    s, vt = tall_svd(nmat) if len(nmat) >= 3 else np.linalg.svd(nmat, full_matrices=False)[1:]  # eq. (3)
    if s[1] <= COLLINEAR_TOL * s[0]:
        spread = s / math.sqrt(len(p)) * length * 1e3  # RMS extent along each principal direction, mm
        raise DegenerateError(
            f"{prefix(where)}{what} needs points spanning a plane, got collinear points (RMS spread about their"
            f" centroid {spread[0]:.3g} mm along the line, {spread[1]:.3g} and {spread[2]:.3g} mm across it:"
            f" sigma2/sigma1 = {s[1] / s[0]:.1e} <= {COLLINEAR_TOL:g}); if the joint is prismatic, declare it so (a"
            " line fit)"
        )
    v = vt.T.copy()
    v[:, 2] = np.cross(v[:, 0], v[:, 1])  # right-handed; v3 is the normal (eq. 4's third row)
    xy = nmat @ v[:, :2]  # eq. (4): R = V^T N^T, first two rows
    return centroid, v, s, xy


def in_plane_angles(p, centre, n):
    """Angles (m,) rad of the points about the axis (``centre``, unit ``n``), counter-clockwise about ``n``."""
    t1, t2 = perpendicular_basis(n)
    d = p - centre
    return np.arctan2(d @ t2, d @ t1)  # counter-clockwise about n


def arc_span(phi: np.ndarray) -> float:
    """Angular span covered by angles phi (rad): 2 pi minus the largest gap between neighbours."""
    s = np.sort(np.mod(phi, 2 * np.pi))
    gaps = np.diff(np.concatenate([s, [s[0] + 2 * np.pi]]))
    return float(2 * np.pi - gaps.max())


def net_turn(phi: np.ndarray) -> float:
    """Net signed angle (rad) turned by the sequence of angles phi (each step taken in (-pi, pi])."""
    return float(np.sum(np.angle(np.exp(1j * np.diff(phi)))))


def _circle_parts(p, centre, n, r):
    d = (p.T - centre[:, None]).T  # (the per-point sums over the coordinates of the (3, m) view: whole rows for numpy)
    h = d @ n
    w = (d.T - n[:, None] * h).T
    rho = np.sqrt(w[:, 0] ** 2 + w[:, 1] ** 2 + w[:, 2] ** 2)
    return d, h, w, rho, rho - r


def circle_misfit(p, centre, n, r):
    """(signed orthogonal distance (m,) of each point to the circle, out-of-plane offsets h (m,), radial misfits (m,)).

    The distance is ``sign(rho - r) * sqrt(h^2 + (rho - r)^2)`` (positive outside), as :attr:`AxisFit.residuals`.
    """
    _, h, _, _, g = _circle_parts(p, centre, n, r)
    return np.where(g >= 0, 1.0, -1.0) * np.hypot(h, g), h, g


def _circle_jacobian(p, centre, n, r, g):
    """Jacobian of the residuals [h (m), rho - r (m)] w.r.t. [centre (3), a, b, r].

    h = (p - c).n, rho = |(I - n n^T)(p - c)|; ``g`` (3, 2) = dn/d(a, b). Rows: dh = [-n, d^T g, 0],
    d(rho - r) = [-w^, -h w^T g, -1] with w^ the unit radial vector.
    """
    d, h, w, rho, _ = _circle_parts(p, centre, n, r)
    what = w / np.maximum(rho, 1e-300)[:, None]
    m = p.shape[0]
    jh = np.hstack([np.broadcast_to(-n, (m, 3)), d @ g, np.zeros((m, 1))])
    jg = np.hstack([-what, -h[:, None] * (what @ g), -np.ones((m, 1))])
    return np.vstack([jh, jg])


def _tracker_whitening(shape, p, centre, n, r):
    """Per point the lower-triangular inverse ``(l11, l21, l22)`` (3 arrays (m,)) of the Cholesky factor of the
    covariance of its residuals [h, rho - r] (the out-of-plane and radial directions n and e_k), from the tracker's
    covariance shape ``shape`` = (u (3, m) lines of sight, variances along and across them (m,), over their mean):
    ``x^T S y = b x.y + (a - b)(x.u)(y.u)``. The tangential component is not a residual (orthogonal distance)."""
    u, a, b = shape
    _, _, w, rho, _ = _circle_parts(p, centre, n, r)
    e = w / np.maximum(rho, 1e-300)[:, None]
    nu, eu = n @ u, np.einsum("mi,im->m", e, u)
    mnn, mee, mne = b + (a - b) * nu**2, b + (a - b) * eu**2, (a - b) * nu * eu
    l11 = np.sqrt(mnn)
    l21 = mne / l11
    l22 = np.sqrt(np.maximum(mee - l21**2, 1e-300))
    return 1 / l11, -l21 / (l11 * l22), 1 / l22


def _whiten(wt, h, g):
    """[h, g] (two stacked blocks of m rows, residuals or Jacobian rows) whitened by :func:`_tracker_whitening`."""
    i11, i21, i22 = wt
    if np.ndim(h) == 2:
        i11, i21, i22 = i11[:, None], i21[:, None], i22[:, None]
    return np.concatenate([i11 * h, i21 * h + i22 * g])


def _circle_result(
    p, centre, n, r, method, weights, noise_sigma, where, outliers, shape=None, covariance: bool = True
) -> AxisFit:
    """Assemble an AxisFit for a circle (centre, unit normal n, radius r), with orientation and covariance.

    The normal is oriented so that the points, in their given order, turn counter-clockwise about it (net signed
    angle > 0; each step taken in (-pi, pi]). ``covariance`` False: the circle, its orientation, misfits and arc
    alone (the covariance and sigmas nan, no outliers flagged: a start value, :func:`hyper_start`).
    """
    phi = in_plane_angles(p, centre, n)
    if net_turn(phi) < 0:
        n = -n
        phi = -phi
    e, h, g = circle_misfit(p, centre, n, r)
    if not covariance:
        return AxisFit(
            point=centre,
            direction=n,
            radius=float(r),
            residuals=e,
            rms=float(np.sqrt(np.mean(e**2))),
            cov=np.full((6, 6), math.nan),
            sigma_point_perp=math.nan,
            sigma_direction=math.nan,
            method=method,
            outliers=np.zeros(len(p), dtype=bool),
            n_points=p.shape[0],
            arc=arc_span(phi),
        )
    t1, t2 = perpendicular_basis(n)
    jac = _circle_jacobian(p, centre, n, r, np.column_stack([t1, t2]))
    res = np.concatenate([h, g])
    if shape is not None:  # the tracker's noise model: residuals and Jacobian rows whitened (the shape's mean scale)
        wt = _tracker_whitening(shape, p, centre, n, r)
        m = len(h)
        jac, res = _whiten(wt, jac[:m], jac[m:]), _whiten(wt, h, g)
    cov_t = cov_from_jacobian(
        jac, res, np.concatenate([weights, weights]), 6, noise_sigma, f"{method} circle fit", where
    )
    tmat = np.zeros((6, 6))
    tmat[:3, :3] = np.eye(3)
    tmat[3:, 3:5] = np.column_stack([t1, t2])
    cov6 = tmat @ cov_t @ tmat.T
    sp, sd = axis_sigmas(cov6, n)
    return AxisFit(
        point=centre,
        direction=n,
        radius=float(r),
        residuals=e,
        rms=float(np.sqrt(np.mean(e**2))),
        cov=cov6,
        sigma_point_perp=sp,
        sigma_direction=sd,
        method=method,
        outliers=outliers,
        n_points=p.shape[0],
        arc=arc_span(phi),
    )


def _kasa_2d(xy):
    """[H]_ eqs. (5)-(9) in the plane: returns (c1, c2, r)."""
    x, y = xy[:, 0], xy[:, 1]
    a = np.column_stack([2 * x, 2 * y, np.ones_like(x)])  # eq. (6)/(7), rows [2x', 2y', 1] (the paper prints 2x' twice)
    b = x**2 + y**2
    (c1, c2, k3), *_ = np.linalg.lstsq(a, b, rcond=None)  # eq. (8), pseudoinverse
    # eq. (9) as printed reads sqrt(c1^2 + c2^2 - k3); with k3 = r^2 - c1^2 - c2^2 (eq. 5) it is + k3.
    r2 = c1**2 + c2**2 + k3
    return c1, c2, math.sqrt(max(r2, 0.0))


def _hyper_2d(xy, what, where):
    """Al-Sharadqah & Chernov (2009) hyper fit (HyperSVD) of 2-D points: returns (c1, c2, r)."""
    mean = xy.mean(axis=0)
    x, y = (xy - mean).T
    scale = math.sqrt(np.mean(x**2 + y**2))
    x, y = x / scale, y / scale
    z = x**2 + y**2
    zxy1 = np.column_stack([z, x, y, np.ones_like(x)])
    s, vt = (
        tall_svd(zxy1) if len(zxy1) >= 4 else np.linalg.svd(zxy1)[1:]
    )  # (m, 4): never the (m, m) factor (but 4 rows of vt)
    if len(s) < 4 or s[3] < 1e-12 * s[0]:  # singular case: the points lie exactly on a circle (always for m = 3)
        coef = vt[3]
    else:
        rbar = zxy1.mean(axis=0)
        nmat = np.array(
            [
                [8 * rbar[0], 4 * rbar[1], 4 * rbar[2], 2.0],
                [4 * rbar[1], 1.0, 0.0, 0.0],
                [4 * rbar[2], 0.0, 1.0, 0.0],
                [2.0, 0.0, 0.0, 0.0],
            ]
        )
        w = vt.T @ np.diag(s) @ vt
        ymat = w @ np.linalg.solve(nmat, w)
        _, evecs = np.linalg.eigh((ymat + ymat.T) / 2)  # ascending eigenvalues
        coef = np.linalg.solve(w, evecs[:, 1])  # smallest positive eigenvalue (N has one negative eigenvalue)
    a0, a1, a2, a3 = coef
    if abs(a0) <= 1e-12 * np.max(np.abs(coef)):
        raise DegenerateError(
            f"{prefix(where)}{what}: the points lie on a straight line (infinite radius); expected an arc"
        )
    c1, c2 = -a1 / (2 * a0), -a2 / (2 * a0)
    r = math.sqrt(max(a1 * a1 + a2 * a2 - 4 * a0 * a3, 0.0)) / (2 * abs(a0))
    return c1 * scale + mean[0], c2 * scale + mean[1], r * scale


def plane_circle(p, algo, what, where, length: float = 1.0):
    """(centre (3,), unit normal (3,), radius) of the SVD plane ([H]_ eqs. 1-4) and the ``algo`` ("kasa" or "hyper")
    circle in it; ``length`` (m per unit of ``p``) for messages."""
    centroid, v, _, xy = _plane(p, what, where, length)
    c1, c2, r = _kasa_2d(xy) if algo == "kasa" else _hyper_2d(xy, what, where)
    return centroid + c1 * v[:, 0] + c2 * v[:, 1], v[:, 2].copy(), r


def robust_circle(p, what, where, length: float = 1.0):
    """(centre, unit normal, radius, inliers (m,) bool) of a trimmed hyper circle: the hyper circle of the points
    within ``CHI_4SIGMA[2]`` robust sigmas of the previous one, repeated until that set settles (concentration
    steps, as least trimmed squares; at most 20), started from the best (smallest median misfit) of the hyper
    circles of all points, of the even and of the odd rows: one blunder as large as the arc moves the plain hyper
    circle so far that neither the robust reweighting nor the outlier flags can recover, and one of the halves
    does not hold it.
    """
    m = len(p)
    floor = 1e-12 * rms_spread(p)
    best = None
    for rows in (slice(None), slice(0, None, 2), slice(1, None, 2)):
        if len(p[rows]) < 3:
            continue
        try:
            cand = plane_circle(p[rows], "hyper", what, where, length)
        except DegenerateError:
            if best is None and rows == slice(None):
                raise
            continue
        score = float(np.median(np.abs(circle_misfit(p, *cand)[0])))
        if best is None or score < best[0]:
            best = (score, cand)
    c, n, r = best[1]
    inl = np.ones(m, dtype=bool)
    for _ in range(20):
        e = circle_misfit(p, c, n, r)[0]
        new = np.abs(e) <= CHI_4SIGMA[2] * max(robust_sigma(e, 2), floor)
        if new.sum() < max(3, m // 2) or (new == inl).all():
            break
        inl = new
        c, n, r = plane_circle(p[inl], "hyper", what, where, length)
    return c, n, r, inl


def fit_circle_kasa(points, *, max_sigma_point=None, noise_sigma=None, where: str = "") -> AxisFit:
    """Fit a 3-D circle by the method of Hayat et al. [H]_, section II.C, eqs. (1)-(9), exactly.

    Centroid (eq. 1), SVD of the centred points (eqs. 2-3), the normal is the third right-singular vector, the
    points are projected onto the first two (eq. 4), and the algebraic (Kasa) circle ``2 x' c1 + 2 y' c2 + k3 =
    x'^2 + y'^2`` is solved by the pseudoinverse (eqs. 5-8), ``r = sqrt(c1^2 + c2^2 + k3)`` (eq. 9). Two typos of
    the paper are corrected: eq. (6) prints the row ``[2x', 2x', 1]`` (intended ``[2x', 2y', 1]``) and eq. (9)
    prints ``- k3`` (with eq. 5's ``k3 = r^2 - c1^2 - c2^2`` it is ``+ k3``).

    The Kasa fit is biased towards small radii on short arcs ([C]_ ch. 5); prefer :func:`fit_circle_geometric` or,
    with joint readings, :func:`fit_axis_with_readings`.

    Parameters
    ----------
    points : array_like, shape (m, 3), metres, frame ``world``
        The swept point, in time order (m >= 3, not collinear).
    max_sigma_point : float, optional, metres
        Raise :class:`DegenerateError` if the predicted ``sigma_point_perp`` exceeds it.
    noise_sigma : float, optional, metres
        Known 1-sigma measurement noise per coordinate; used for the covariance instead of the residuals.
    where : str
        Prefix for error messages (e.g. ``"j3.csv, joint 3"``).

    Returns
    -------
    AxisFit
        ``method="kasa"``; ``direction`` oriented so that the points, in order, turn counter-clockwise about it;
        ``cov`` is that of the orthogonal-distance problem evaluated at the Kasa estimate.
    """
    check_positive("max_sigma_point", max_sigma_point, where)
    check_positive("noise_sigma", noise_sigma, where)
    p = check_points(points, 3, "circle fit", where)
    centre, n, r = plane_circle(p, "kasa", "circle fit", where)
    fit = _circle_result(
        p, centre, n, r, "kasa", np.ones(len(p)), noise_sigma, where, ~robust_circle(p, "circle fit", where)[3]
    )
    return check_sigma(fit, max_sigma_point, where)


def fit_circle_hyper(points, *, max_sigma_point=None, noise_sigma=None, where: str = "") -> AxisFit:
    """Fit a 3-D circle: SVD plane ([H]_ eqs. 1-4) + Al-Sharadqah & Chernov's "hyper" algebraic circle [AC]_.

    The hyper fit minimises the algebraic distance ``A z + B x + C y + D`` (``z = x^2 + y^2``) under the
    constraint ``A^T N A = 1`` with ``N`` chosen to cancel the essential (second-order) bias; it is solved as in
    Chernov's HyperSVD (smallest positive generalised eigenvalue, exact-circle case handled by the SVD). It has no
    essential bias on short arcs, unlike the Kasa fit, and is the start value of the iterative fits.

    Parameters
    ----------
    points : array_like, shape (m, 3), metres, frame ``world``
        The swept point, in time order (m >= 3, not collinear).
    max_sigma_point : float, optional, metres
        Raise :class:`DegenerateError` if the predicted ``sigma_point_perp`` exceeds it.
    noise_sigma : float, optional, metres
        Known 1-sigma measurement noise per coordinate; used for the covariance instead of the residuals.
    where : str
        Prefix for error messages.

    Returns
    -------
    AxisFit
        ``method="hyper"``; orientation and covariance as for :func:`fit_circle_kasa`.
    """
    check_positive("max_sigma_point", max_sigma_point, where)
    check_positive("noise_sigma", noise_sigma, where)
    p = check_points(points, 3, "circle fit", where)
    centre, n, r = plane_circle(p, "hyper", "circle fit", where)
    fit = _circle_result(
        p, centre, n, r, "hyper", np.ones(len(p)), noise_sigma, where, ~robust_circle(p, "circle fit", where)[3]
    )
    return check_sigma(fit, max_sigma_point, where)


def hyper_start(p, where: str = "") -> AxisFit:
    """:func:`fit_circle_hyper`'s circle (centre, normal oriented by the point order, radius, misfits, arc) without
    its covariance and outlier flags (nan, none): the start of a fit that makes its own (the joint fit's)."""
    centre, n, r = plane_circle(p, "hyper", "circle fit", where)
    return _circle_result(p, centre, n, r, "hyper", None, None, where, None, covariance=False)


def least_squares_lm(fun, jac, x0, what, where):
    """The solution of ``scipy.optimize.least_squares`` (Levenberg-Marquardt, tolerances 1e-12) from ``x0``, or a
    :class:`NotConvergedError` naming ``what``."""
    from scipy import optimize  # noqa: PLC0415 (scipy is loaded when a fit first needs it)

    res = optimize.least_squares(fun, x0, jac=jac, method="lm", xtol=1e-12, ftol=1e-12, gtol=1e-12, max_nfev=400)
    if res.status <= 0:
        raise NotConvergedError(
            f"{prefix(where)}{what}: least squares stopped without converging ({res.message}; {res.nfev} evaluations)"
        )
    return res.x


def fit_circle_geometric(
    points, *, loss: str = "linear", f_scale=None, max_sigma_point=None, noise_sigma=None, tracker=None, where: str = ""
) -> AxisFit:
    """Orthogonal-distance 3-D circle fit ([S]_; [C]_ ch. 4), started from the hyper fit.

    Minimises ``sum_k h_k^2 + (rho_k - r)^2`` over the centre (3), the normal (2 parameters: ``n = (n0 + a t1 +
    b t2)/|.|``) and the radius, with ``h_k`` the out-of-plane offset and ``rho_k`` the distance of point ``k``
    from the axis, by ``scipy.optimize.least_squares`` (Levenberg-Marquardt, analytic Jacobian). This is the
    maximum-likelihood circle for isotropic Gaussian noise. Robust losses are applied per point to the distance
    ``sqrt(h^2 + (rho - r)^2)`` by iteratively reweighted least squares (weights ``rho'((d / f_scale)^2)`` of
    scipy's loss functions).

    Parameters
    ----------
    points : array_like, shape (m, 3), metres, frame ``world``
        The swept point, in time order (m >= 3, not collinear).
    loss : {"linear", "soft_l1", "huber"}
        Per-point loss.
    f_scale : float, optional, metres
        Soft inlier threshold of the robust loss; default 3 robust sigmas of the current fit's distances
        (re-estimated at each reweighting step).
    max_sigma_point : float, optional, metres
        Raise :class:`DegenerateError` if the predicted ``sigma_point_perp`` exceeds it.
    noise_sigma : float, optional, metres
        Known 1-sigma measurement noise per coordinate; used for the covariance instead of the residuals.
    tracker : :class:`~denavit.fitting.joint.TrackerNoise`, optional
        The tracker's range/angle noise model: each point's residuals [h, rho - r] are whitened by their covariance
        (the point's covariance shape seen in the out-of-plane and radial directions, to first order), its scale
        estimated; the whitening follows the fit (re-evaluated until the circle holds still). Default: isotropic.
    where : str
        Prefix for error messages.

    Returns
    -------
    AxisFit
        ``method="geometric"`` (``"geometric+soft_l1"``...); ``direction`` oriented so that the points, in order,
        turn counter-clockwise about it; ``cov`` from the Jacobian at the solution, ``s^2 = SSR / (2 m - 6)``
        (robust losses: weighted, see the module's Uncertainty section).
    """
    check_loss(loss, f_scale, where)
    check_positive("max_sigma_point", max_sigma_point, where)
    check_positive("noise_sigma", noise_sigma, where)
    p = check_points(points, 3, "circle fit", where)
    fit = _geometric(p, loss, f_scale, noise_sigma, "circle fit", where, tracker)
    return check_sigma(fit, max_sigma_point, where)


#: With the tracker's noise model, the geometric fit re-evaluates its whitening (it follows the circle's normal and
#: radial directions) at most this many times, until the centre moves by less than 1e-9 of the spread.
WHITENING_PASSES = 5


def _geometric(p, loss, f_scale, noise_sigma, what, where, tracker=None) -> AxisFit:
    origin = p.mean(axis=0)
    length = rms_spread(p)
    pn = (p - origin) / length  # normalised coordinates: O(1) parameters
    *state, inliers = robust_circle(pn, what, where, length)
    shape = None
    if tracker is not None:
        u, a, b = tracker.shape(p.T)
        ref2 = tracker.reference_variance(p.T)
        shape = (u, a / ref2, b / ref2)

    def solve(st, w):
        c0, n0, r0 = st
        t1, t2 = perpendicular_basis(n0)
        sw = np.sqrt(np.concatenate([w, w]))
        wt = None if shape is None else _tracker_whitening(shape, pn, c0, n0, r0)
        m = len(pn)

        def unpack(x):
            n, g = unit_from_params(n0, t1, t2, x[3], x[4])
            return c0 + x[:3], n, r0 + x[5], g

        def fun(x):
            c, n, r, _ = unpack(x)
            _, h, _, _, gg = _circle_parts(pn, c, n, r)
            return (np.concatenate([h, gg]) if wt is None else _whiten(wt, h, gg)) * sw

        def jac(x):
            c, n, r, g = unpack(x)
            J = _circle_jacobian(pn, c, n, r, g)
            return (J if wt is None else _whiten(wt, J[:m], J[m:])) * sw[:, None]

        c, n, r, _ = unpack(least_squares_lm(fun, jac, np.zeros(6), f"geometric {what}", where))
        for _ in range(WHITENING_PASSES if wt is not None else 0):  # the whitening at the fitted circle's directions
            wt = _tracker_whitening(shape, pn, c, n, r)
            c0, n0, r0 = c, n, r
            t1, t2 = perpendicular_basis(n0)
            c, n, r, _ = unpack(least_squares_lm(fun, jac, np.zeros(6), f"geometric {what}", where))
            if np.linalg.norm(c - c0) < 1e-9:
                break
        return c, n, r

    def misfit(st):
        return circle_misfit(pn, *st)[0]

    w0 = (
        np.ones(len(pn)) if loss == "linear" else inliers.astype(float) + 1e-6 * ~inliers
    )  # robust: start from the inliers
    state = solve(tuple(state), w0)
    state, w = irls(
        solve, misfit, state, loss, f_scale if f_scale is None else f_scale / length, 2, f"geometric {what}", where
    )
    c, n, r = state
    method = "geometric" if loss == "linear" else f"geometric+{loss}"
    flags = ~inliers if loss == "linear" else flag_outliers(misfit(state), 2, 1.0)
    return _circle_result(p, origin + length * c, n, r * length, method, w, noise_sigma, where, flags, shape)
