"""The axis of a prismatic joint: a total-least-squares line ([S]_ of :mod:`denavit.fitting`)."""

from __future__ import annotations

import math

import numpy as np

from .checks import check_points, check_positive, check_q
from .result import AxisFit, axis_sigmas, check_sigma
from .robust import flag_outliers, rms_spread


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
    check_positive("max_sigma_point", max_sigma_point, where)
    check_positive("noise_sigma", noise_sigma, where)
    p = check_points(points, 2, "line fit", where)
    m = p.shape[0]
    qa = None if q is None else check_q(q, m, where)
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
    sp, sd = axis_sigmas(cov6, d)
    fit = AxisFit(
        point=centroid,
        direction=d,
        radius=math.nan,
        residuals=dist,
        rms=float(np.sqrt(np.mean(dist**2))),
        cov=cov6,
        sigma_point_perp=sp,
        sigma_direction=sd,
        method="line",
        outliers=flag_outliers(dist, 2, rms_spread(p)),
        n_points=m,
        arc=math.nan,
        scale=scale,
    )
    return check_sigma(fit, max_sigma_point, where)
