"""One entry point for a joint axis from one sweep: :func:`fit_axis` picks the fit and orients the axis."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from ..errors import DenavitError
from .checks import check_loss, check_points, check_q, prefix
from .circle import (
    fit_circle_geometric,
    fit_circle_hyper,
    fit_circle_kasa,
    hyper_start,
    in_plane_angles,
    net_turn,
)
from .joint import stride
from .line import fit_line
from .readings import fit_axis_with_readings
from .result import AxisFit, flipped

#: Without readings, a sweep's net motion in point order must be at least this fraction of its extent.
ONE_WAY = 0.5
#: The ``method`` names of :func:`fit_axis`.
METHODS = ("auto", "kasa", "hyper", "geometric", "readings", "line")


def fit_axis(
    points,
    q=None,
    method: str = "auto",
    *,
    loss: str = "linear",
    f_scale=None,
    max_sigma_point=None,
    noise_sigma=None,
    tracker=None,
    where: str = "",
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
    tracker : :class:`~denavit.fitting.joint.TrackerNoise`, optional
        The tracker's range/angle noise model, for ``"geometric"`` (:func:`fit_circle_geometric`); the other fits
        take the points as isotropic.
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
        raise DenavitError(f"{prefix(where)}method must be one of {', '.join(METHODS)}, got {method!r}")
    check_loss(loss, f_scale, where)
    if method in ("kasa", "hyper", "line") and (loss != "linear" or f_scale is not None):
        raise DenavitError(
            f"{prefix(where)}a robust loss applies to the geometric and readings fits only, "
            f"got loss={loss!r} with method={method!r}"
        )
    if method == "auto":
        method = "readings" if q is not None else "geometric"
    if method == "readings" and q is None:
        raise DenavitError(f"{prefix(where)}method 'readings' needs the joint readings q, got q=None")
    kw = dict(max_sigma_point=max_sigma_point, noise_sigma=noise_sigma, where=where)
    if method == "readings":
        return fit_axis_with_readings(points, q, loss=loss, f_scale=f_scale, **kw)
    if method == "line":
        fit = fit_line(points, q=q, **kw)
        if q is None:
            t = (np.asarray(points, dtype=float) - fit.point) @ fit.direction
            _check_one_way(t[-1] - t[0], np.ptp(t), "travel", "a travel", 1e3, "mm", where)
        return fit
    p = check_points(points, 3, "circle fit", where)
    qa = None if q is None else check_q(q, p.shape[0], where)
    if method == "geometric":
        fit = fit_circle_geometric(p, loss=loss, f_scale=f_scale, tracker=tracker, **kw)
    elif method == "kasa":
        fit = fit_circle_kasa(p, **kw)
    else:
        fit = fit_circle_hyper(p, **kw)
    phi = in_plane_angles(p, fit.point, fit.direction)
    if qa is None:
        _check_one_way(net_turn(phi), fit.arc, "turn", "an arc", math.degrees(1), "deg", where)
    elif (
        net_turn(phi[np.argsort(qa, kind="stable")]) < 0
    ):  # orient by the readings (sorted by q), not by the point order
        fit = flipped(fit)
    return fit


def axis_start(points, q, where: str = "") -> AxisFit:
    """:func:`fit_axis` with ``method="hyper"`` and readings ``q`` without the circle's covariance and outlier flags
    (:func:`~denavit.fitting.circle.hyper_start`): the same circle, orientation and arc, as the start of the joint fit
    (which makes its own covariance and flags)."""
    p = check_points(points, 3, "circle fit", where)
    qa = check_q(q, p.shape[0], where)
    m, k = len(p), stride(len(p))
    if k > 1:  # a long sweep: the start circle of every k-th point and the last (the arc whole)
        rows = np.unique(np.r_[0:m:k, m - 1])
        p, qa = p[rows], qa[rows]
    fit = hyper_start(p, where)
    phi = in_plane_angles(p, fit.point, fit.direction)
    if net_turn(phi[np.argsort(qa, kind="stable")]) < 0:  # orient by the readings (sorted by q), as fit_axis
        fit = flipped(fit)
    return fit if k == 1 else replace(fit, n_points=m)


def _check_one_way(net: float, span: float, motion: str, extent: str, scale: float, unit: str, where: str) -> None:
    """Without readings only the point order gives the axis direction: the sweep must go one way.

    ``net`` is the net motion in point order (the fit is oriented so that it is positive), ``span`` the extent
    covered (rad or m, ``scale`` converts to ``unit``); a net motion below ``ONE_WAY`` of the extent means the
    sweep turned back (e.g. out and back), so its direction is unknown.
    """
    if not net >= ONE_WAY * span:
        raise DenavitError(
            f"{prefix(where)}without joint readings the point order gives the axis direction, but the points go back: "
            f"net {motion} {net * scale:.3g} {unit} over {extent} of {span * scale:.1f} {unit} (expected at least "
            f"{ONE_WAY:.0%} of it, one way): give the joint readings, or record the sweep in one direction"
        )
