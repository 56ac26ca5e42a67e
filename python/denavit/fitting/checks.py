"""Input checks shared by the fits: points, joint readings, losses and positive lengths (one-line errors)."""

from __future__ import annotations

import numpy as np

from ..errors import DegenerateError, DenavitError

#: Points closer than this to their centroid (m) are "coincident".
COINCIDENT_TOL = 1e-12
#: The per-point losses of the geometric and readings fits (scipy.optimize.least_squares' names).
LOSSES = ("linear", "soft_l1", "huber")


def prefix(where: str) -> str:
    """``"where: "`` for the start of an error message, or nothing when ``where`` is empty."""
    return f"{where}: " if where else ""


def check_points(points, min_points: int, what: str, where: str) -> np.ndarray:
    """Points as a float (m, 3) array, or a clear error (shape, count, finiteness, coincidence)."""
    pre = prefix(where)
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


def check_q(q, m: int, where: str) -> np.ndarray:
    """Joint readings as a float (m,) array that varies, or a clear error (shape, finiteness, constant)."""
    pre = prefix(where)
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


def check_loss(loss: str, f_scale, where: str) -> None:
    """``loss`` one of :data:`LOSSES` and ``f_scale`` a positive length (m) or None, or a clear error."""
    if loss not in LOSSES:
        raise DenavitError(f"{prefix(where)}loss must be one of {', '.join(LOSSES)}, got {loss!r}")
    if f_scale is not None and not (np.isfinite(f_scale) and f_scale > 0):
        raise DenavitError(f"{prefix(where)}f_scale must be a positive length in metres or None, got {f_scale!r}")


def check_positive(name: str, value, where: str) -> None:
    """``value`` a positive length (m) or None, or a clear error naming ``name``."""
    if value is not None and not (np.isfinite(value) and value > 0):
        raise DenavitError(f"{prefix(where)}{name} must be a positive length in metres or None, got {value!r}")
