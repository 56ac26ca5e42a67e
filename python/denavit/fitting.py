"""Joint-axis identification from measured joint sweeps (circle-point method) and oriented bounding boxes.

A revolute joint is swept while all other joints are locked; a point fixed to the moving link then traces a
circular arc whose centre lies on the joint axis and whose plane is perpendicular to it. A prismatic joint
moves the point along a straight line parallel to its axis. This module fits those circles and lines.

Frames and units
----------------
Every point is expressed in the measurement frame ``world`` (docs/conventions.md) and every length is in
metres, every angle in radians. The module is pure numpy/scipy.

Methods
-------
``fit_circle_kasa``
    The method of Hayat et al. [H]_, section II.C, eqs. (1)-(9): SVD plane, then the algebraic (Kasa) circle.
``fit_circle_hyper``
    The same SVD plane, then the "hyper" algebraic circle of Al-Sharadqah & Chernov [AC]_ (no essential bias).
``fit_circle_geometric``
    Orthogonal-distance (maximum-likelihood for isotropic Gaussian noise) 3-D circle, started from the hyper fit.
``fit_axis_with_readings``
    Uses the recorded joint angles: the points are rotations of one rigid point about the axis by the readings.
    Much better than any circle fit on short arcs, because the angles tie down the radius.
``fit_line``
    Total-least-squares line for prismatic joints.
``fit_axis``
    Dispatch.
``oriented_bounding_box``
    Minimum-volume oriented bounding box of a point set ([H]_ Table IV).

Uncertainty
-----------
Covariances are first order: ``cov(theta) = s^2 (J^T J)^-1`` with ``J`` the Jacobian of the residual vector at the
solution and ``s^2 = SSR / (n_residuals - n_parameters)`` (``n_residuals`` counts scalar residual components: 2 per
point for a circle -- out-of-plane and radial --, 3 per point for the readings fit, 2 per point for a line), or
``s = noise_sigma`` when the caller knows the per-coordinate measurement noise. With a robust loss the final weights
``w`` enter as for weighted least squares, ``cov = s^2 A^-1 (J^T W^2 J) A^-1`` with ``A = J^T W J`` and
``s^2 = sum((w r)^2) / (sum(w^2) - n_parameters)``, so that a down-weighted outlier does not inflate the sigmas
(:func:`_weighted_cov`). The Kasa and hyper fits report the
covariance of the orthogonal-distance problem evaluated at their own estimate (an approximation: they are not the
maximum-likelihood estimator, and the Kasa fit is biased on short arcs).

References
----------
.. [H] A. A. Hayat, R. G. Chittawadigi, A. D. Udai, S. K. Saha, "Identification of Denavit-Hartenberg
   Parameters of an Industrial Robot", section II.C, eqs. (1)-(9); Table IV.
.. [AC] A. Al-Sharadqah, N. Chernov, "Error analysis for circle fitting algorithms", Electron. J. Statist. 3
   (2009) 886-911 (the "hyper" fit; Chernov's HyperSVD implementation).
.. [S] C. M. Shakarji, "Least-Squares Fitting Algorithms of the NIST Algorithm Testing System", J. Res. NIST
   103(6) (1998) 633-641 (3-D circle and line fits).
.. [C] N. Chernov, "Circular and Linear Regression: Fitting Circles and Lines by Least Squares", CRC 2010.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import optimize, spatial

from .errors import DegenerateError, DenavitError, NotConvergedError

__all__ = [
    "AxisFit",
    "BoundingBox",
    "DegenerateError",
    "DenavitError",
    "NotConvergedError",
    "fit_axis",
    "fit_axis_with_readings",
    "fit_circle_geometric",
    "fit_circle_hyper",
    "fit_circle_kasa",
    "fit_line",
    "oriented_bounding_box",
]

#: Points closer than this to their centroid (m) are "coincident".
COINCIDENT_TOL = 1e-12
#: sigma_2 / sigma_1 of the centred points below this means "collinear" for a circle fit.
COLLINEAR_TOL = 1e-9
#: Outlier threshold, in robust sigmas (1.4826 * MAD) of a 1-D residual.
OUTLIER_SIGMAS = 4.0
# For a misfit of k Gaussian components (sigma each): median of its norm, sqrt(chi2.ppf(0.5, k)), and the norm
# exceeded with the probability of a 1-D 4-sigma deviation, sqrt(chi2.isf(2 * norm.sf(4), k)) (scipy.stats).
_CHI_MEDIAN = {1: 0.6744897501960812, 2: 1.1774100225154749, 3: 1.5381722544550522}
_CHI_4SIGMA = {1: 4.0, 2: 4.397034069908339, 3: 4.696948013014455}
#: The readings fit raises if its robust misfit sigma exceeds this many times that of a free circle.
READINGS_MISMATCH = 10.0
#: Number of best bounding-box candidates refined by Nelder-Mead.
REFINE_STARTS = 4
#: Without readings, a sweep's net motion in point order must be at least this fraction of its extent.
ONE_WAY = 0.5
LOSSES = ("linear", "soft_l1", "huber")
METHODS = ("auto", "kasa", "hyper", "geometric", "readings", "line")


# ----------------------------------------------------------------------------------------------- results


@dataclass(frozen=True, eq=False)
class AxisFit:
    """A fitted joint axis (a line in ``world``) with its circle, residuals and uncertainty.

    Attributes
    ----------
    point : ndarray, shape (3,), metres, frame ``world``
        A point of the axis. Circle fits: the circle centre. Line fits: the centroid of the points.
    direction : ndarray, shape (3,), unit vector, frame ``world``
        Axis direction. With joint readings ``q``: increasing ``q`` turns counter-clockwise about it (right-hand
        rule), or moves along it (prismatic). Without readings: the points, in their given (time) order, turn
        counter-clockwise about it (circles) or advance along it (lines).
    radius : float, metres
        Circle radius; ``nan`` for line fits.
    residuals : ndarray, shape (m,), metres
        Circle fits: signed orthogonal distance of each point to the fitted circle, ``sign(rho - radius) *
        sqrt(h**2 + (rho - radius)**2)`` with ``h`` the out-of-plane offset and ``rho`` the distance from the axis
        (positive outside). Line fits: the (non-negative) distance of each point to the line.
    rms : float, metres
        ``sqrt(mean(residuals**2))``.
    cov : ndarray, shape (6, 6), m^2 / m / dimensionless blocks
        First-order covariance of ``[point (3), direction (3)]`` (rank 5 for circles -- the direction is a unit
        vector --, the point being the circle centre). ``nan`` when the fit has no redundancy and no
        ``noise_sigma`` was given.
    sigma_point_perp : float, metres
        RMS (1-sigma) displacement of the axis perpendicular to itself at ``point``:
        ``sqrt(trace(P cov_point P))`` with ``P = I - d d^T``.
    sigma_direction : float, radians
        RMS (1-sigma) tilt of the direction: ``sqrt(trace(cov_direction))``.
    method : str
        ``"kasa"``, ``"hyper"``, ``"geometric"``, ``"readings"`` or ``"line"`` (plus ``"+soft_l1"`` /
        ``"+huber"`` for robust fits).
    outliers : ndarray of bool, shape (m,)
        Points whose misfit exceeds ``OUTLIER_SIGMAS`` robust sigmas (flagged, never dropped). The misfit is the
        orthogonal distance to the circle / line, or for the readings fit the 3-D distance between the point and
        its predicted position. The robust sigma is ``median(|misfit|) / sqrt(chi2_k median)`` with ``k`` the
        misfit's components (2, or 3 for the readings fit), i.e. ``1.4826 * MAD`` for a 1-D residual; the threshold
        has the tail probability of a 1-D 4-sigma deviation (4.40 sigma for k = 2, 4.70 for k = 3).
    n_points : int
        Number of points ``m``.
    arc : float, radians
        Angular span covered by the points about the axis (``2 pi`` minus the largest angular gap);
        ``nan`` for line fits.
    scale : float
        Line fits with readings: metres of travel along ``direction`` per unit of ``q`` (a check of the joint's
        scale, ideally 1 for ``q`` in metres). ``nan`` otherwise.
    """

    point: np.ndarray
    direction: np.ndarray
    radius: float
    residuals: np.ndarray
    rms: float
    cov: np.ndarray
    sigma_point_perp: float
    sigma_direction: float
    method: str
    outliers: np.ndarray
    n_points: int
    arc: float
    scale: float = math.nan

    def __post_init__(self):
        for name in ("point", "direction", "residuals", "cov", "outliers"):
            a = np.array(getattr(self, name), copy=True)
            a.flags.writeable = False
            object.__setattr__(self, name, a)


@dataclass(frozen=True, eq=False)
class BoundingBox:
    """An oriented bounding box in ``world``.

    Attributes
    ----------
    center : ndarray, shape (3,), metres, frame ``world``
        Centre of the box.
    axes : ndarray, shape (3, 3), frame ``world``
        Rotation matrix (det +1) whose columns are the box axes, ordered as ``lengths``.
    lengths : ndarray, shape (3,), metres
        Edge lengths along the columns of ``axes``, sorted descending ([H]_ Table IV's l1, l2, l3).
    volume : float, m^3
        ``prod(lengths)``.
    """

    center: np.ndarray
    axes: np.ndarray
    lengths: np.ndarray
    volume: float

    def __post_init__(self):
        for name in ("center", "axes", "lengths"):
            a = np.array(getattr(self, name), dtype=float, copy=True)
            a.flags.writeable = False
            object.__setattr__(self, name, a)


# ----------------------------------------------------------------------------------------------- checks


def _pre(where: str) -> str:
    return f"{where}: " if where else ""


def _check_points(points, min_points: int, what: str, where: str) -> np.ndarray:
    """Points as a float (m, 3) array, or a clear error (shape, count, finiteness, coincidence)."""
    pre = _pre(where)
    try:
        p = np.array(points, dtype=float)
    except (TypeError, ValueError) as exc:
        raise DenavitError(f"{pre}{what} expects points as an (m, 3) array of numbers, got {type(points).__name__} ({exc})") from None
    if p.ndim != 2 or p.shape[1] != 3:
        raise DenavitError(f"{pre}{what} expects points of shape (m, 3), got shape {p.shape}")
    m = p.shape[0]
    if m < min_points:
        raise DegenerateError(f"{pre}{what} needs at least {min_points} points, got {m}")
    bad = np.flatnonzero(~np.isfinite(p).all(axis=1))
    if bad.size:
        raise DenavitError(f"{pre}{what} expects finite coordinates, got NaN/inf in {bad.size} row(s), first at index {bad[:5].tolist()}")
    spread = np.max(np.linalg.norm(p - p.mean(axis=0), axis=1))
    if spread <= COINCIDENT_TOL:
        raise DegenerateError(
            f"{pre}{what} needs distinct points, got all {m} points within {spread:.1e} m of their centroid "
            f"(tolerance {COINCIDENT_TOL:g} m; is the measured point on the joint axis?)"
        )
    return p


def _check_q(q, m: int, where: str) -> np.ndarray:
    pre = _pre(where)
    try:
        qa = np.array(q, dtype=float)
    except (TypeError, ValueError) as exc:
        raise DenavitError(f"{pre}joint readings q must be numbers, got {type(q).__name__} ({exc})") from None
    if qa.shape != (m,):
        raise DenavitError(f"{pre}joint readings q must have one value per point: expected shape ({m},), got {qa.shape}")
    if not np.isfinite(qa).all():
        bad = np.flatnonzero(~np.isfinite(qa))
        raise DenavitError(f"{pre}joint readings q must be finite, got NaN/inf at index {bad[:5].tolist()}")
    if np.ptp(qa) == 0.0:
        raise DegenerateError(f"{pre}joint readings q must vary, got all {m} readings equal to {qa[0]:g}")
    return qa


def _check_loss(loss: str, f_scale, where: str) -> None:
    if loss not in LOSSES:
        raise DenavitError(f"{_pre(where)}loss must be one of {', '.join(LOSSES)}, got {loss!r}")
    if f_scale is not None and not (np.isfinite(f_scale) and f_scale > 0):
        raise DenavitError(f"{_pre(where)}f_scale must be a positive length in metres or None, got {f_scale!r}")


def _check_positive(name: str, value, where: str) -> None:
    if value is not None and not (np.isfinite(value) and value > 0):
        raise DenavitError(f"{_pre(where)}{name} must be a positive length in metres or None, got {value!r}")


# ----------------------------------------------------------------------------------------------- geometry helpers


def _perp_basis(n: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two unit vectors t1, t2 with (t1, t2, n) a right-handed orthonormal frame."""
    a = np.eye(3)[np.argmin(np.abs(n))]
    t1 = np.cross(n, a)
    t1 /= np.linalg.norm(t1)
    return t1, np.cross(n, t1)


def _unit_from_params(n0, t1, t2, a, b):
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
    _, s, vt = np.linalg.svd(nmat, full_matrices=False)  # eq. (3)
    if s[1] <= COLLINEAR_TOL * s[0]:
        spread = s / math.sqrt(len(p)) * length * 1e3  # RMS extent along each principal direction, mm
        raise DegenerateError(
            f"{_pre(where)}{what} needs points spanning a plane, got collinear points (RMS spread about their centroid "
            f"{spread[0]:.3g} mm along the line, {spread[1]:.3g} and {spread[2]:.3g} mm across it: "
            f"sigma2/sigma1 = {s[1] / s[0]:.1e} <= {COLLINEAR_TOL:g}); if the joint is prismatic, declare it so (a line fit)"
        )
    v = vt.T.copy()
    v[:, 2] = np.cross(v[:, 0], v[:, 1])  # right-handed; v3 is the normal (eq. 4's third row)
    xy = nmat @ v[:, :2]  # eq. (4): R = V^T N^T, first two rows
    return centroid, v, s, xy


def _in_plane_angles(p, centre, n):
    t1, t2 = _perp_basis(n)
    d = p - centre
    return np.arctan2(d @ t2, d @ t1)  # counter-clockwise about n


def _arc_span(phi: np.ndarray) -> float:
    """Angular span covered by angles phi (rad): 2 pi minus the largest gap between neighbours."""
    s = np.sort(np.mod(phi, 2 * np.pi))
    gaps = np.diff(np.concatenate([s, [s[0] + 2 * np.pi]]))
    return float(2 * np.pi - gaps.max())


def _net_turn(phi: np.ndarray) -> float:
    """Net signed angle (rad) turned by the sequence of angles phi (each step taken in (-pi, pi])."""
    return float(np.sum(np.angle(np.exp(1j * np.diff(phi)))))


def _circle_parts(p, centre, n, r):
    d = p - centre
    h = d @ n
    w = d - np.outer(h, n)
    rho = np.linalg.norm(w, axis=1)
    return d, h, w, rho, rho - r


def _circle_signed(p, centre, n, r):
    _, h, _, _, g = _circle_parts(p, centre, n, r)
    return np.where(g >= 0, 1.0, -1.0) * np.hypot(h, g), h, g


def _rodrigues(n, delta):
    """Rotation matrices R(n, delta_k), shape (m, 3, 3) (right-hand rule)."""
    c, s = np.cos(delta), np.sin(delta)
    k = np.array([[0, -n[2], n[1]], [n[2], 0, -n[0]], [-n[1], n[0], 0]])
    return c[:, None, None] * np.eye(3) + s[:, None, None] * k + (1 - c)[:, None, None] * np.outer(n, n)


def _skew(v):
    return np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])


def _robust_sigma(misfit: np.ndarray, k: int) -> float:
    """Robust per-component noise sigma (metres) from per-point misfit norms of k Gaussian components.

    ``median(|misfit|) / sqrt(chi2_k median)``; for k = 1 this is ``1.4826 * MAD`` (deviations about zero, the
    residuals' expected centre). Pooling the norms (not the components) keeps it valid when the components differ
    in spread (e.g. radial vs out-of-plane residuals of a distorted fit).
    """
    return float(np.median(np.abs(misfit)) / _CHI_MEDIAN[k])


def _outliers(misfit: np.ndarray, k: int, size: float) -> np.ndarray:
    """|misfit| beyond the 4-robust-sigma level (same tail probability as a 1-D 4-sigma deviation, 6.3e-5).

    The robust sigma is floored at ``1e-12 * size`` (``size`` the RMS spread of the points, metres) so that
    round-off on exact data is not called an outlier.
    """
    sig = max(_robust_sigma(misfit, k), 1e-12 * size)
    return np.abs(misfit) > _CHI_4SIGMA[k] * sig


def _size(p: np.ndarray) -> float:
    """RMS distance (m) of the points from their centroid."""
    return math.sqrt(np.mean(np.sum((p - p.mean(axis=0)) ** 2, axis=1)))


def _loss_weight(loss: str, z: np.ndarray) -> np.ndarray:
    """rho'(z) of scipy.optimize.least_squares' losses, z = (distance / f_scale)^2 (IRLS weights)."""
    if loss == "soft_l1":
        return 1.0 / np.sqrt(1.0 + z)
    if loss == "huber":
        return np.where(z <= 1.0, 1.0, 1.0 / np.sqrt(np.maximum(z, 1.0)))
    return np.ones_like(z)


def _weighted_cov(j: np.ndarray, r: np.ndarray, w: np.ndarray, n_params: int, noise_sigma=None):
    """First-order covariance of a (robust) least-squares fit, and the singular values of ``W^1/2 J``.

    ``j`` (n_res, k) and ``r`` (n_res,) are the unweighted Jacobian and residuals at the solution, ``w`` (n_res,)
    the final weights (all 1 without a robust loss). Weighted least squares with these weights has
    ``cov = s^2 A^+ (J^T W^2 J) A^+``, ``A = J^T W J`` (pseudo-inverse ``A^+``); ``s^2 = noise_sigma^2``, or
    ``sum((w r)^2) / (sum(w^2) - n_params)``: the weighted residuals ``w r`` stay bounded (at most ``f_scale``) for
    down-weighted outliers, so an outlier does not inflate the sigmas. Without a robust loss this is the usual
    ``SSR / (n_res - n_params) (J^T J)^-1``.
    """
    psi = w * r
    dof = float(np.sum(w**2)) - n_params
    if noise_sigma is not None:
        s2 = float(noise_sigma) ** 2
    elif dof > 0:
        s2 = float(psi @ psi) / dof
    else:
        s2 = math.nan
    _, sv, vt = np.linalg.svd(j * np.sqrt(w)[:, None], full_matrices=False)
    inv = np.where(sv > 1e-13 * sv[0], 1.0 / np.maximum(sv, 1e-300) ** 2, 0.0)
    a_inv = (vt.T * inv) @ vt
    jw = j * w[:, None]
    return s2 * a_inv @ (jw.T @ jw) @ a_inv, sv


def _cov_from_jacobian(j: np.ndarray, r: np.ndarray, w: np.ndarray, n_params: int, noise_sigma, what: str, where: str):
    """:func:`_weighted_cov`, or a clear error when the Jacobian is singular (the axis is not identifiable)."""
    cov, sv = _weighted_cov(j, r, w, n_params, noise_sigma)
    if sv[-1] <= 1e-13 * sv[0]:
        raise DegenerateError(
            f"{_pre(where)}{what}: the axis is not identifiable from these points "
            f"(Jacobian singular values {sv[0]:.3g} ... {sv[-1]:.3g}; expected full rank {n_params})"
        )
    return cov


def _sigmas(cov6: np.ndarray, n: np.ndarray) -> tuple[float, float]:
    proj = np.eye(3) - np.outer(n, n)
    sp = float(np.sqrt(max(np.trace(proj @ cov6[:3, :3] @ proj), 0.0))) if np.isfinite(cov6).all() else math.nan
    sd = float(np.sqrt(max(np.trace(cov6[3:, 3:]), 0.0))) if np.isfinite(cov6).all() else math.nan
    return sp, sd


def _check_sigma(fit: AxisFit, max_sigma_point, where: str) -> AxisFit:
    if max_sigma_point is None:
        return fit
    s = fit.sigma_point_perp
    if not (s <= max_sigma_point):
        why = "unknown (no redundant points and no noise_sigma)" if math.isnan(s) else f"{s * 1e3:.3g} mm"
        raise DegenerateError(
            f"{_pre(where)}predicted axis position uncertainty (1-sigma, perpendicular to the axis) is {why}, "
            f"expected at most {max_sigma_point * 1e3:.3g} mm; the points cover an arc of "
            f"{math.degrees(fit.arc):.1f} deg with {fit.n_points} points and residual RMS {fit.rms * 1e3:.3g} mm "
            f"({fit.method} fit): widen the sweep, add points or use the joint readings"
        )
    return fit


def _flip(fit: AxisFit) -> AxisFit:
    """The same fit with the direction reversed (covariance cross terms change sign)."""
    f = np.diag([1, 1, 1, -1, -1, -1.0])
    return AxisFit(
        point=fit.point, direction=-fit.direction, radius=fit.radius, residuals=fit.residuals, rms=fit.rms,
        cov=f @ fit.cov @ f, sigma_point_perp=fit.sigma_point_perp, sigma_direction=fit.sigma_direction,
        method=fit.method, outliers=fit.outliers, n_points=fit.n_points, arc=fit.arc, scale=fit.scale,
    )


# ----------------------------------------------------------------------------------------------- circles


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


def _circle_result(p, centre, n, r, method, weights, noise_sigma, where) -> AxisFit:
    """Assemble an AxisFit for a circle (centre, unit normal n, radius r), with orientation and covariance.

    The normal is oriented so that the points, in their given order, turn counter-clockwise about it (net signed
    angle > 0; each step taken in (-pi, pi]).
    """
    phi = _in_plane_angles(p, centre, n)
    if _net_turn(phi) < 0:
        n = -n
        phi = -phi
    e, h, g = _circle_signed(p, centre, n, r)
    t1, t2 = _perp_basis(n)
    jac = _circle_jacobian(p, centre, n, r, np.column_stack([t1, t2]))
    cov_t = _cov_from_jacobian(jac, np.concatenate([h, g]), np.concatenate([weights, weights]), 6, noise_sigma, f"{method} circle fit", where)
    tmat = np.zeros((6, 6))
    tmat[:3, :3] = np.eye(3)
    tmat[3:, 3:5] = np.column_stack([t1, t2])
    cov6 = tmat @ cov_t @ tmat.T
    sp, sd = _sigmas(cov6, n)
    return AxisFit(
        point=centre, direction=n, radius=float(r), residuals=e, rms=float(np.sqrt(np.mean(e**2))), cov=cov6,
        sigma_point_perp=sp, sigma_direction=sd, method=method, outliers=_outliers(e, 2, _size(p)),
        n_points=p.shape[0], arc=_arc_span(phi),
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
    _, s, vt = np.linalg.svd(zxy1)
    if len(s) < 4 or s[3] < 1e-12 * s[0]:  # singular case: the points lie exactly on a circle (always for m = 3)
        coef = vt[3]
    else:
        rbar = zxy1.mean(axis=0)
        nmat = np.array([
            [8 * rbar[0], 4 * rbar[1], 4 * rbar[2], 2.0],
            [4 * rbar[1], 1.0, 0.0, 0.0],
            [4 * rbar[2], 0.0, 1.0, 0.0],
            [2.0, 0.0, 0.0, 0.0],
        ])
        w = vt.T @ np.diag(s) @ vt
        ymat = w @ np.linalg.solve(nmat, w)
        _, evecs = np.linalg.eigh((ymat + ymat.T) / 2)  # ascending eigenvalues
        coef = np.linalg.solve(w, evecs[:, 1])  # smallest positive eigenvalue (N has one negative eigenvalue)
    a0, a1, a2, a3 = coef
    if abs(a0) <= 1e-12 * np.max(np.abs(coef)):
        raise DegenerateError(f"{_pre(where)}{what}: the points lie on a straight line (infinite radius); expected an arc")
    c1, c2 = -a1 / (2 * a0), -a2 / (2 * a0)
    r = math.sqrt(max(a1 * a1 + a2 * a2 - 4 * a0 * a3, 0.0)) / (2 * abs(a0))
    return c1 * scale + mean[0], c2 * scale + mean[1], r * scale


def _plane_circle(p, algo, what, where, length: float = 1.0):
    centroid, v, _, xy = _plane(p, what, where, length)
    c1, c2, r = _kasa_2d(xy) if algo == "kasa" else _hyper_2d(xy, what, where)
    return centroid + c1 * v[:, 0] + c2 * v[:, 1], v[:, 2].copy(), r


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
    _check_positive("max_sigma_point", max_sigma_point, where)
    _check_positive("noise_sigma", noise_sigma, where)
    p = _check_points(points, 3, "circle fit", where)
    centre, n, r = _plane_circle(p, "kasa", "circle fit", where)
    fit = _circle_result(p, centre, n, r, "kasa", np.ones(len(p)), noise_sigma, where)
    return _check_sigma(fit, max_sigma_point, where)


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
    _check_positive("max_sigma_point", max_sigma_point, where)
    _check_positive("noise_sigma", noise_sigma, where)
    p = _check_points(points, 3, "circle fit", where)
    centre, n, r = _plane_circle(p, "hyper", "circle fit", where)
    fit = _circle_result(p, centre, n, r, "hyper", np.ones(len(p)), noise_sigma, where)
    return _check_sigma(fit, max_sigma_point, where)


def _irls(solve, misfit, state, loss, f_scale, k, what, where):
    """Iteratively reweighted least squares for a per-point robust loss (fixed point = robust M-estimate).

    ``solve(state, weights) -> state``; ``misfit(state) -> (m,)`` per-point distances of ``k`` components, used
    for the weights ``rho'((misfit / f)^2)`` (scipy's loss functions). With ``f_scale=None`` the scale is
    re-estimated at every step as ``f = 3`` robust sigmas of the current misfits (a concurrent scale estimate,
    so that the scale is not inflated by the outliers' pull on the least-squares start).
    """
    m = misfit(state).size
    w = np.ones(m)
    if loss == "linear":
        return state, w
    for _ in range(200):
        e = misfit(state)
        f = f_scale if f_scale is not None else 3.0 * _robust_sigma(e, k)
        if not f > 0:
            return state, w  # exact data: nothing to down-weight
        w_new = _loss_weight(loss, (e / f) ** 2)
        if np.max(np.abs(w_new - w)) < 1e-9:
            return state, w_new
        w = w_new
        state = solve(state, w)
    raise NotConvergedError(
        f"{_pre(where)}{what} with loss={loss!r}: reweighting did not converge in 200 iterations "
        "(expected the weights to settle to 1e-9)"
    )


def _lsq(fun, jac, x0, what, where):
    res = optimize.least_squares(fun, x0, jac=jac, method="lm", xtol=1e-12, ftol=1e-12, gtol=1e-12, max_nfev=400)
    if res.status <= 0:
        raise NotConvergedError(f"{_pre(where)}{what}: least squares stopped without converging ({res.message}; {res.nfev} evaluations)")
    return res.x


def fit_circle_geometric(
    points, *, loss: str = "linear", f_scale=None, max_sigma_point=None, noise_sigma=None, where: str = ""
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
    where : str
        Prefix for error messages.

    Returns
    -------
    AxisFit
        ``method="geometric"`` (``"geometric+soft_l1"``...); ``direction`` oriented so that the points, in order,
        turn counter-clockwise about it; ``cov`` from the Jacobian at the solution, ``s^2 = SSR / (2 m - 6)``
        (robust losses: weighted, see the module's Uncertainty section).
    """
    _check_loss(loss, f_scale, where)
    _check_positive("max_sigma_point", max_sigma_point, where)
    _check_positive("noise_sigma", noise_sigma, where)
    p = _check_points(points, 3, "circle fit", where)
    fit = _geometric(p, loss, f_scale, noise_sigma, "circle fit", where)
    return _check_sigma(fit, max_sigma_point, where)


def _geometric(p, loss, f_scale, noise_sigma, what, where) -> AxisFit:
    origin = p.mean(axis=0)
    length = _size(p)
    pn = (p - origin) / length  # normalised coordinates: O(1) parameters
    state = _plane_circle(pn, "hyper", what, where, length)

    def solve(st, w):
        c0, n0, r0 = st
        t1, t2 = _perp_basis(n0)
        sw = np.sqrt(np.concatenate([w, w]))

        def unpack(x):
            n, g = _unit_from_params(n0, t1, t2, x[3], x[4])
            return c0 + x[:3], n, r0 + x[5], g

        def fun(x):
            c, n, r, _ = unpack(x)
            _, h, _, _, gg = _circle_parts(pn, c, n, r)
            return np.concatenate([h, gg]) * sw

        def jac(x):
            c, n, r, g = unpack(x)
            return _circle_jacobian(pn, c, n, r, g) * sw[:, None]

        c, n, r, _ = unpack(_lsq(fun, jac, np.zeros(6), f"geometric {what}", where))
        return c, n, r

    def misfit(st):
        return _circle_signed(pn, *st)[0]

    state = solve(state, np.ones(len(pn)))
    state, w = _irls(solve, misfit, state, loss, f_scale, 2, f"geometric {what}", where)
    c, n, r = state
    method = "geometric" if loss == "linear" else f"geometric+{loss}"
    return _circle_result(p, origin + length * c, n, r * length, method, w, noise_sigma, where)


# ----------------------------------------------------------------------------------------------- readings


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
    f_scale : float, optional, metres
        Soft inlier threshold of the robust loss; default 3 robust sigmas of the current fit's misfits
        (re-estimated at each reweighting step).
    max_sigma_point : float, optional, metres
        Raise :class:`DegenerateError` if the predicted ``sigma_point_perp`` exceeds it.
    noise_sigma : float, optional, metres
        Known 1-sigma measurement noise per coordinate; used for the covariance instead of the residuals.
    where : str
        Prefix for error messages.

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
    _check_loss(loss, f_scale, where)
    _check_positive("max_sigma_point", max_sigma_point, where)
    _check_positive("noise_sigma", noise_sigma, where)
    p = _check_points(points, 3, "readings fit", where)
    qa = _check_q(q, p.shape[0], where)
    fit = _readings(p, qa, loss, f_scale, noise_sigma, where)
    return _check_sigma(fit, max_sigma_point, where)


def _readings_model(c, n, p0, delta):
    rot = _rodrigues(n, delta)
    return c + (rot @ (p0 - c)), rot


def _readings(p, q, loss, f_scale, noise_sigma, where) -> AxisFit:
    what = "readings fit"
    m = p.shape[0]
    origin = p.mean(axis=0)
    length = _size(p)
    pn = (p - origin) / length
    delta = q - q.mean()

    # start: hyper circle; the normal's sign and p0 from rotating the points back by the readings
    c0, n0, r0 = _plane_circle(pn, "hyper", what, where, length)
    best = None
    for sgn in (1.0, -1.0):
        back = c0 + np.einsum("kij,kj->ki", _rodrigues(sgn * n0, -delta), pn - c0)
        spread = math.sqrt(np.mean(np.sum((back - back.mean(axis=0)) ** 2, axis=1)))
        if best is None or spread < best[0]:
            best = (spread, sgn * n0, back.mean(axis=0))
    spread, n0, p00 = best
    if spread > 0.25 * r0:
        raise DenavitError(
            f"{_pre(where)}{what}: the points do not move as rotations by the readings q about one axis "
            f"(rotated back by q they scatter by {spread * length * 1e3:.3g} mm RMS on a circle of radius "
            f"{r0 * length * 1e3:.3g} mm; expected a small fraction of the radius): are q in radians and "
            "paired with the points in the same order?"
        )

    def solve(st, w):
        cr, nr, pr = st
        t1, t2 = _perp_basis(nr)
        tt = np.column_stack([t1, t2])
        sw = np.repeat(np.sqrt(w), 3)

        def unpack(x):
            n, g = _unit_from_params(nr, t1, t2, x[0], x[1])
            return cr + tt @ x[2:4], n, pr + x[4:7], g

        def fun(x):
            c, n, p0, _ = unpack(x)
            pred, _ = _readings_model(c, n, p0, delta)
            return (pred - pn).ravel() * sw

        def jac(x):
            c, n, p0, g = unpack(x)
            return _readings_jacobian(c, n, p0, delta, g, tt) * sw[:, None]

        c, n, p0, _ = unpack(_lsq(fun, jac, np.zeros(7), what, where))
        return c, n, p0

    def misfit(st):
        return np.linalg.norm(_readings_model(*st, delta)[0] - pn, axis=1)

    state = solve((c0, n0, p00), np.ones(m))
    state, w = _irls(solve, misfit, state, loss, f_scale, 3, what, where)

    # model check: with the readings, the point must be explained about as well as by a free circle
    sig_read = _robust_sigma(misfit(state), 3)
    sig_circ = _robust_sigma(_circle_signed(pn, c0, n0, r0)[0], 2)
    if m >= 6 and sig_read > READINGS_MISMATCH * sig_circ + 1e-9:  # a circle through < 6 points leaves too few dof
        raise DenavitError(
            f"{_pre(where)}{what}: the joint readings q do not explain the point motion: robust misfit "
            f"{sig_read * length * 1e3:.3g} mm per coordinate with the readings vs {sig_circ * length * 1e3:.3g} mm "
            f"for a free circle (expected at most {READINGS_MISMATCH:g}x): are q in radians, paired with the points "
            "in the same order, and is the joint's scale right? (method='geometric' ignores q)"
        )

    # back to metres; covariance re-linearised at the solution (a = b = u = v = 0)
    c, n, p0 = state
    c, p0 = origin + length * c, origin + length * p0
    t1, t2 = _perp_basis(n)
    tt = np.column_stack([t1, t2])
    pred, _ = _readings_model(c, n, p0, delta)
    resid = pred - p
    jac = _readings_jacobian(c, n, p0, delta, tt, tt)
    cov_t = _cov_from_jacobian(jac, resid.ravel(), np.repeat(w, 3), 7, noise_sigma, what, where)
    v = p0 - c
    hv = v @ n
    centre = c + hv * n
    radius = float(np.linalg.norm(v - hv * n))
    dcentre = np.hstack([(hv * np.eye(3) + np.outer(n, v)) @ tt, tt, np.outer(n, n)])  # d centre / d [a b u v p0]
    tmat = np.vstack([dcentre, np.hstack([tt, np.zeros((3, 5))])])
    cov6 = tmat @ cov_t @ tmat.T
    sp, sd = _sigmas(cov6, n)
    e, _, _ = _circle_signed(p, centre, n, radius)
    mis = np.linalg.norm(resid, axis=1)
    return AxisFit(
        point=centre, direction=n, radius=radius, residuals=e, rms=float(np.sqrt(np.mean(e**2))), cov=cov6,
        sigma_point_perp=sp, sigma_direction=sd, method="readings" if loss == "linear" else f"readings+{loss}",
        outliers=_outliers(mis, 3, length), n_points=m, arc=_arc_span(_in_plane_angles(p, centre, n)),
    )


def _readings_jacobian(c, n, p0, delta, g, tt):
    """d(model_k)/d[a, b, u, v, p0] for the readings model, shape (3 m, 7).

    d(R v)/dn = -sin [v]x + (1 - cos)((n.v) I + n v^T); d/dc = (I - R); d/dp0 = R.
    """
    v = p0 - c
    rot = _rodrigues(n, delta)
    s, co = np.sin(delta), 1 - np.cos(delta)
    dn = -s[:, None, None] * _skew(v) + co[:, None, None] * ((v @ n) * np.eye(3) + np.outer(n, v))
    j = np.concatenate([dn @ g, (np.eye(3) - rot) @ tt, rot], axis=2)
    return j.reshape(-1, 7)


# ----------------------------------------------------------------------------------------------- lines


def fit_line(points, *, q=None, max_sigma_point=None, noise_sigma=None, where: str = "") -> AxisFit:
    """Fit the axis of a prismatic joint: total-least-squares line (SVD of the centred points; [S]_).

    The line passes through the centroid along the first right-singular vector (the same SVD as [H]_ eqs. 1-3).

    Parameters
    ----------
    points : array_like, shape (m, 3), metres, frame ``world``
        The moving point, in time order (m >= 2, not coincident).
    q : array_like, shape (m,), optional, joint units (metres for a prismatic joint)
        Joint readings; if given, ``direction`` points along increasing ``q`` and ``scale`` is the travel per unit
        of ``q`` (least-squares slope of the position along the line against ``q``; 1 for a consistent joint).
    max_sigma_point : float, optional, metres
        Raise :class:`DegenerateError` if the predicted ``sigma_point_perp`` exceeds it.
    noise_sigma : float, optional, metres
        Known 1-sigma measurement noise per coordinate; used for the covariance instead of the residuals.
    where : str
        Prefix for error messages.

    Returns
    -------
    AxisFit
        ``method="line"``, ``point`` the centroid, ``radius`` and ``arc`` nan, ``residuals`` the distances to the
        line. Covariance: ``cov_point = s^2 / m I``, ``cov_direction = s^2 / sum(t_k^2) (I - d d^T)`` (``t_k`` the
        positions along the line), ``s^2 = SSR / (2 m - 4)``.
    """
    _check_positive("max_sigma_point", max_sigma_point, where)
    _check_positive("noise_sigma", noise_sigma, where)
    p = _check_points(points, 2, "line fit", where)
    m = p.shape[0]
    qa = None if q is None else _check_q(q, m, where)
    centroid = p.mean(axis=0)
    nmat = p - centroid
    _, _, vt = np.linalg.svd(nmat, full_matrices=False)
    d = vt[0].copy()
    t = nmat @ d
    scale = math.nan
    if qa is not None:
        qc = qa - qa.mean()
        slope = float(t @ qc / (qc @ qc))
        if slope < 0:
            d, t, slope = -d, -t, -slope
        scale = slope
    elif t[-1] - t[0] < 0:
        d, t = -d, -t
    perp = nmat - np.outer(t, d)
    dist = np.linalg.norm(perp, axis=1)
    n_res = 2 * m
    if noise_sigma is not None:
        s2 = float(noise_sigma) ** 2
    elif n_res > 4:
        s2 = float(np.sum(dist**2)) / (n_res - 4)
    else:
        s2 = math.nan
    cov6 = np.zeros((6, 6))
    cov6[:3, :3] = s2 / m * np.eye(3)
    cov6[3:, 3:] = s2 / float(t @ t) * (np.eye(3) - np.outer(d, d))
    sp, sd = _sigmas(cov6, d)
    fit = AxisFit(
        point=centroid, direction=d, radius=math.nan, residuals=dist, rms=float(np.sqrt(np.mean(dist**2))),
        cov=cov6, sigma_point_perp=sp, sigma_direction=sd, method="line",
        outliers=_outliers(dist, 2, _size(p)), n_points=m, arc=math.nan, scale=scale,
    )
    return _check_sigma(fit, max_sigma_point, where)


# ----------------------------------------------------------------------------------------------- dispatch


def fit_axis(
    points, q=None, method: str = "auto", *, loss: str = "linear", f_scale=None, max_sigma_point=None,
    noise_sigma=None, where: str = "",
) -> AxisFit:
    """Fit a joint axis from a sweep of one joint (dispatch to the fits of this module).

    Parameters
    ----------
    points : array_like, shape (m, 3), metres, frame ``world``
        The swept point, in time order.
    q : array_like, shape (m,), optional, radians (metres for ``method="line"``)
        Joint readings at each point.
    method : {"auto", "kasa", "hyper", "geometric", "readings", "line"}
        ``"auto"``: :func:`fit_axis_with_readings` when ``q`` is given, else :func:`fit_circle_geometric`.
        ``"kasa"`` is the paper's method ([H]_ eqs. 1-9).
    loss, f_scale
        Robust loss and its scale (metres) for ``"geometric"`` and ``"readings"``.
    max_sigma_point : float, optional, metres
        Raise :class:`DegenerateError` if the predicted ``sigma_point_perp`` exceeds it.
    noise_sigma : float, optional, metres
        Known 1-sigma measurement noise per coordinate (covariance scale).
    where : str
        Prefix for error messages.

    Returns
    -------
    AxisFit
        Direction orientation: with ``q``, increasing ``q`` turns counter-clockwise about it (right-hand rule) or
        moves along it; without ``q``, the points in their given (time) order turn counter-clockwise about it (the
        sweep direction), or advance along it for lines.

    Raises
    ------
    DenavitError
        Without ``q``, if the points do not go one way (net motion in point order below ``ONE_WAY`` of the arc
        or travel covered, e.g. an out-and-back sweep): their order cannot give the direction.
    """
    if method not in METHODS:
        raise DenavitError(f"{_pre(where)}method must be one of {', '.join(METHODS)}, got {method!r}")
    _check_loss(loss, f_scale, where)
    if method in ("kasa", "hyper", "line") and (loss != "linear" or f_scale is not None):
        raise DenavitError(
            f"{_pre(where)}a robust loss applies to the geometric and readings fits only, "
            f"got loss={loss!r} with method={method!r}"
        )
    if method == "auto":
        method = "readings" if q is not None else "geometric"
    if method == "readings" and q is None:
        raise DenavitError(f"{_pre(where)}method 'readings' needs the joint readings q, got q=None")
    kw = dict(max_sigma_point=max_sigma_point, noise_sigma=noise_sigma, where=where)
    if method == "readings":
        return fit_axis_with_readings(points, q, loss=loss, f_scale=f_scale, **kw)
    if method == "line":
        fit = fit_line(points, q=q, **kw)
        if q is None:
            t = (np.asarray(points, dtype=float) - fit.point) @ fit.direction
            _check_one_way(t[-1] - t[0], np.ptp(t), "travel", "a travel", 1e3, "mm", where)
        return fit
    p = _check_points(points, 3, "circle fit", where)
    qa = None if q is None else _check_q(q, p.shape[0], where)
    if method == "geometric":
        fit = fit_circle_geometric(p, loss=loss, f_scale=f_scale, **kw)
    elif method == "kasa":
        fit = fit_circle_kasa(p, **kw)
    else:
        fit = fit_circle_hyper(p, **kw)
    phi = _in_plane_angles(p, fit.point, fit.direction)
    if qa is None:
        _check_one_way(_net_turn(phi), fit.arc, "turn", "an arc", math.degrees(1), "deg", where)
    elif _net_turn(phi[np.argsort(qa, kind="stable")]) < 0:  # orient by the readings (sorted by q), not by the point order
        fit = _flip(fit)
    return fit


def _check_one_way(net: float, span: float, motion: str, extent: str, scale: float, unit: str, where: str) -> None:
    """Without readings only the point order gives the axis direction: the sweep must go one way.

    ``net`` is the net motion in point order (the fit is oriented so that it is positive), ``span`` the extent
    covered (rad or m, ``scale`` converts to ``unit``); a net motion below ``ONE_WAY`` of the extent means the
    sweep turned back (e.g. out and back), so its direction is unknown.
    """
    if not net >= ONE_WAY * span:
        raise DenavitError(
            f"{_pre(where)}without joint readings the point order gives the axis direction, but the points go back: "
            f"net {motion} {net * scale:.3g} {unit} over {extent} of {span * scale:.1f} {unit} (expected at least "
            f"{ONE_WAY:.0%} of it, one way): give the joint readings, or record the sweep in one direction"
        )


# ----------------------------------------------------------------------------------------------- bounding box


def _min_area_rect(xy: np.ndarray):
    """Minimum-area enclosing rectangle of 2-D points (rotating calipers over the convex-hull edges).

    Returns (area, u (2,) unit first side direction, lo (2,), hi (2,)) with extents in the (u, u_perp) basis.
    """
    try:
        hull = spatial.ConvexHull(xy)
        hv = xy[hull.vertices]  # counter-clockwise
    except spatial.QhullError:  # collinear in 2-D
        hv = xy
    if len(hv) < 3:
        hv = xy
    edges = np.roll(hv, -1, axis=0) - hv
    lens = np.linalg.norm(edges, axis=1)
    keep = lens > 0
    if not keep.any():
        return 0.0, np.array([1.0, 0.0]), hv.min(axis=0), hv.max(axis=0)
    u = edges[keep] / lens[keep, None]  # (E, 2)
    uperp = np.column_stack([-u[:, 1], u[:, 0]])
    a = hv @ u.T  # (k, E)
    b = hv @ uperp.T
    lo_a, hi_a, lo_b, hi_b = a.min(0), a.max(0), b.min(0), b.max(0)
    area = (hi_a - lo_a) * (hi_b - lo_b)
    i = int(np.argmin(area))
    return float(area[i]), u[i], np.array([lo_a[i], lo_b[i]]), np.array([hi_a[i], hi_b[i]])


def _rotvec(x: np.ndarray) -> np.ndarray:
    """Rotation matrix of a rotation vector (rad), Rodrigues' formula."""
    th = math.sqrt(float(x @ x))
    if th < 1e-300:
        return np.eye(3)
    k = _skew(x / th)
    return np.eye(3) + math.sin(th) * k + (1 - math.cos(th)) * (k @ k)


def _box_from_rotation(hv: np.ndarray, rot: np.ndarray):
    loc = hv @ rot
    lo, hi = loc.min(axis=0), loc.max(axis=0)
    return float(np.prod(hi - lo)), lo, hi


def _finish_box(rot, lo, hi) -> BoundingBox:
    lengths = hi - lo
    centre = rot @ ((lo + hi) / 2)
    order = np.argsort(-lengths, kind="stable")
    axes = rot[:, order]
    lengths = lengths[order]
    if np.linalg.det(axes) < 0:
        axes[:, 2] = -axes[:, 2]
    return BoundingBox(center=centre, axes=axes, lengths=lengths, volume=float(np.prod(lengths)))


def oriented_bounding_box(points, *, where: str = "") -> BoundingBox:
    """Minimum-volume oriented bounding box of a 3-D point set ([H]_ section III.C, Table IV).

    Candidates: the PCA box, and for every distinct face normal of the convex hull (one box axis flush with a
    hull face) the minimum-area rectangle of the hull projected along it (rotating calipers). The best few
    candidates are refined by Nelder-Mead over a rotation vector (a minimal box need not have a face flush with
    the hull -- O'Rourke 1985 -- so the face candidates alone are near-exact). The result is never larger than the
    PCA box. Degenerate (planar or collinear) sets give a flat box of volume 0.

    Parameters
    ----------
    points : array_like, shape (m, 3), metres, frame ``world``
        The points (m >= 1).
    where : str
        Prefix for error messages.

    Returns
    -------
    BoundingBox
        ``axes`` columns sorted by decreasing edge length, det +1.
    """
    pre = _pre(where)
    try:
        p = np.array(points, dtype=float)
    except (TypeError, ValueError) as exc:
        raise DenavitError(f"{pre}bounding box expects points as an (m, 3) array of numbers, got {type(points).__name__} ({exc})") from None
    if p.ndim != 2 or p.shape[1] != 3 or p.shape[0] < 1:
        raise DenavitError(f"{pre}bounding box expects points of shape (m, 3) with m >= 1, got shape {p.shape}")
    if not np.isfinite(p).all():
        raise DenavitError(f"{pre}bounding box expects finite coordinates, got NaN/inf")
    if np.max(np.linalg.norm(p - p.mean(axis=0), axis=1)) <= COINCIDENT_TOL:
        return BoundingBox(center=p.mean(axis=0), axes=np.eye(3), lengths=np.zeros(3), volume=0.0)
    centroid = p.mean(axis=0)
    pc = p - centroid
    _, s, vt = np.linalg.svd(pc, full_matrices=False)
    pca = vt.T.copy()
    if np.linalg.det(pca) < 0:
        pca[:, 2] = -pca[:, 2]
    hull = None
    if s[2] > 1e-12 * s[0]:
        try:
            hull = spatial.ConvexHull(pc)
        except spatial.QhullError:  # too flat for qhull
            hull = None
    if hull is None:  # planar (or collinear): minimum-area rectangle in the plane, zero height
        n = pca[:, 2]
        _, u, _, _ = _min_area_rect(pc @ pca[:, :2])
        e1 = pca[:, :2] @ u
        rot = np.column_stack([e1, np.cross(n, e1), n])
        _, lo, hi = _box_from_rotation(pc, rot)
        return _finish_box(rot, lo + rot.T @ centroid, hi + rot.T @ centroid)
    hv = pc[hull.vertices]
    cands = [(_box_from_rotation(hv, pca)[0], pca)]
    normals = hull.equations[:, :3] / np.linalg.norm(hull.equations[:, :3], axis=1, keepdims=True)
    # one candidate per distinct face direction (n and -n give the same box; coplanar facets repeat normals)
    sign = np.where(normals[np.arange(len(normals)), np.argmax(np.abs(normals), axis=1)] < 0, -1.0, 1.0)
    _, first = np.unique(np.round(normals * sign[:, None], 9), axis=0, return_index=True)
    for n in normals[np.sort(first)]:
        t1, t2 = _perp_basis(n)
        area, u, _, _ = _min_area_rect(hv @ np.column_stack([t1, t2]))
        e1 = u[0] * t1 + u[1] * t2
        rot = np.column_stack([e1, np.cross(n, e1), n])
        h = hv @ n
        cands.append((area * float(h.max() - h.min()), rot))
    cands.sort(key=lambda c: c[0])
    best_v, best_r = cands[0]

    def vol(rv, r0):
        return _box_from_rotation(hv, r0 @ _rotvec(rv))[0]

    for v0, r0 in cands[:REFINE_STARTS]:
        x, fx = np.zeros(3), v0
        for _ in range(4):  # restart Nelder-Mead from its own end point: the volume is only piecewise smooth
            res = optimize.minimize(
                vol, x, args=(r0,), method="Nelder-Mead",
                options={"initial_simplex": x + np.vstack([np.zeros(3), 0.02 * np.eye(3)]), "xatol": 1e-10,
                         "fatol": 1e-15 * max(v0, 1e-300), "maxiter": 2000},
            )
            if not res.fun < fx * (1 - 1e-12):
                break
            x, fx = res.x, float(res.fun)
        if fx < best_v * (1 - 1e-12):
            best_v, best_r = fx, r0 @ _rotvec(x)
    _, lo, hi = _box_from_rotation(pc, best_r)
    return _finish_box(best_r, lo + best_r.T @ centroid, hi + best_r.T @ centroid)
