"""The result of every axis fit (:class:`AxisFit`), and what the fits do to one: sigmas, the accuracy check, a flip."""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from ..errors import DegenerateError
from .checks import prefix


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
        The joint's motion per unit of its reading: line fits with readings, metres of travel along ``direction``
        per unit of ``q`` (a check of the joint's scale, ideally 1 for ``q`` in metres); joint fits that fit the
        readings' scale errors (:func:`denavit.fitting.joint.fit_sweeps` with ``scales``), radians of turn per
        radian of reading. ``nan`` otherwise.
    scale_sigma : float
        One-sigma of ``scale`` where the joint fit estimated it, else ``nan``.
    reading_sigma : float, radians (metres for prismatic joints)
        The estimated white error of the joint's readings (fits with readings), else ``nan``.
    noise : float, metres
        The estimated point noise per coordinate (fits with readings), else ``nan``.
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
    scale_sigma: float = math.nan
    reading_sigma: float = math.nan
    noise: float = math.nan

    def __post_init__(self):
        for name in ("point", "direction", "residuals", "cov", "outliers"):
            a = np.array(getattr(self, name), copy=True)
            a.flags.writeable = False
            object.__setattr__(self, name, a)

    def __repr__(self) -> str:
        shape = (
            f"radius {self.radius * 1e3:.5g} mm, arc {math.degrees(self.arc):.4g} deg"
            if math.isfinite(self.radius)
            else "line"
        )
        return (
            f"AxisFit({self.method}, {self.n_points} points, {shape}, rms {self.rms * 1e3:.3g} mm, sigma"
            f" {self.sigma_point_perp * 1e3:.3g} mm across / {math.degrees(self.sigma_direction):.3g} deg,"
            f" {int(np.count_nonzero(self.outliers))} outliers)"
        )


def axis_sigmas(cov6: np.ndarray, n: np.ndarray) -> tuple[float, float]:
    """(``sigma_point_perp``, ``sigma_direction``) of :class:`AxisFit` from the (6, 6) covariance of [point,
    direction]."""
    proj = np.eye(3) - np.outer(n, n)
    sp = float(np.sqrt(max(np.trace(proj @ cov6[:3, :3] @ proj), 0.0))) if np.isfinite(cov6).all() else math.nan
    sd = float(np.sqrt(max(np.trace(cov6[3:, 3:]), 0.0))) if np.isfinite(cov6).all() else math.nan
    return sp, sd


def check_sigma(fit: AxisFit, max_sigma_point, where: str) -> AxisFit:
    """``fit``, or a :class:`DegenerateError` when its ``sigma_point_perp`` exceeds ``max_sigma_point`` (m, None: no
    check)."""
    if max_sigma_point is None:
        return fit
    s = fit.sigma_point_perp
    if not (s <= max_sigma_point):
        why = "unknown (no redundant points and no noise_sigma)" if math.isnan(s) else f"{s * 1e3:.3g} mm"
        raise DegenerateError(
            f"{prefix(where)}predicted axis position uncertainty (1-sigma, perpendicular to the axis) is {why}, "
            f"expected at most {max_sigma_point * 1e3:.3g} mm; the points cover an arc of "
            f"{math.degrees(fit.arc):.1f} deg with {fit.n_points} points and residual RMS {fit.rms * 1e3:.3g} mm "
            f"({fit.method} fit): widen the sweep, add points or use the joint readings"
        )
    return fit


def flipped(fit: AxisFit) -> AxisFit:
    """The same fit with the direction reversed (covariance cross terms change sign)."""
    f = np.diag([1, 1, 1, -1, -1, -1.0])
    return replace(fit, direction=-fit.direction, cov=f @ fit.cov @ f)
