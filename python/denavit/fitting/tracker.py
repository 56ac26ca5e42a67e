"""A laser tracker's range/angle point noise (:class:`TrackerNoise`) and the whitening of points by it, for the joint
fit (:mod:`denavit.fitting.joint`), the geometric circles and calibrate.

The distance (ADM / interferometer) is precise, the two angles less so, so across the line of sight the noise grows
with the range: a point's covariance is ``sigma_range^2 u u^T + (sigma_angle rho)^2 (I - u u^T)`` (``u`` the unit line
of sight from the tracker to the point, ``rho`` its range), whitened by ``a^(-1/2) u u^T + b^(-1/2) (I - u u^T)``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import DenavitError


@dataclass(frozen=True)
class TrackerNoise:
    """A laser tracker's point noise, the range/angle model: the distance (ADM / interferometer) to a point has the
    noise ``sigma_range`` (m, 1 sigma) along the line of sight ``u`` from the tracker at ``position`` (m, in the data's
    frame; default the origin: a tracker's export is in its own frame), each of the two angles ``sigma_angle`` (rad),
    so across the line of sight the noise is ``sigma_angle`` times the range ``rho``::

        Sigma_k = sigma_range^2 u u^T + (sigma_angle rho_k)^2 (I - u u^T)

    (typical: 5 um and 0.5-1 arcsec, i.e. 7-15 um across at 2-3 m; cf. the makers' MPE of the form 15 um + 6 um/m,
    ASME B89.4.19). The joint fit takes the shape of these covariances from the declared values, and their scale
    from the data (:func:`fit_sweeps`)."""

    sigma_range: float
    sigma_angle: float
    position: tuple = (0.0, 0.0, 0.0)

    def __post_init__(self) -> None:
        for name, unit in (("sigma_range", "m"), ("sigma_angle", "rad")):
            v = getattr(self, name)
            try:
                ok = math.isfinite(float(v)) and float(v) > 0
            except (TypeError, ValueError):
                ok = False
            if not ok:
                raise DenavitError(f"tracker noise: {name} must be a finite value > 0 in {unit}, got {v!r}")
            object.__setattr__(self, name, float(v))
        try:
            pos = np.asarray(self.position, dtype=float)
        except (TypeError, ValueError):
            pos = None
        if pos is None or pos.shape != (3,) or not np.all(np.isfinite(pos)):
            raise DenavitError(f"tracker noise: position must be 3 finite values (x, y, z in m), got {self.position!r}")
        object.__setattr__(self, "position", tuple(float(v) for v in pos))

    def shape(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The points x (3, m): their lines of sight u (3, m), and the variances along (m,) and across them (m,),
        m^2."""
        d = x - np.asarray(self.position)[:, None]
        rho = np.linalg.norm(d, axis=0)
        return d / np.maximum(rho, 1e-300), np.full(rho.shape, self.sigma_range**2), (self.sigma_angle * rho) ** 2

    def reference_variance(self, x: np.ndarray) -> float:
        """The mean declared variance per coordinate (m^2) over the points x (3, m): the scale the fits whiten to."""
        _, a, b = self.shape(x)
        return float(np.mean((a + 2 * b) / 3))

    def whitening(self, points: np.ndarray) -> tuple[np.ndarray, float]:
        """Per point (N, 3) the matrix ``W_k = ref Sigma_k^(-1/2)`` (N, 3, 3) and ``ref`` (m): the root of
        :meth:`reference_variance`, so that ``W_k r_k`` has the covariance ``ref^2 I`` and stays in metres
        (calibrate's weighting of its points; the joint fit's :func:`_whitener` as matrices)."""
        x = np.asarray(points, dtype=float).T
        ref2 = self.reference_variance(x)
        u, ia, ib = _whitener(self, ref2, x)
        return ib[:, None, None] * np.eye(3) + ((ia - ib)[:, None, None] * np.einsum("in,jn->nij", u, u)), math.sqrt(
            ref2
        )


def as_tracker_noise(value) -> TrackerNoise | None:
    """``value`` as a :class:`TrackerNoise`: one already, None, or (sigma_range m, sigma_angle rad[, position m])."""
    if value is None or isinstance(value, TrackerNoise):
        return value
    try:
        items = None if isinstance(value, (str, bytes)) else list(value)
    except TypeError:
        items = None
    if items is None or len(items) not in (2, 3):
        raise DenavitError(
            "tracker noise: expected a TrackerNoise or (sigma_range m, sigma_angle rad[, position (x, y, z) m]), "
            f"got {value!r}"
        )
    return TrackerNoise(*items)


def _whitener(tracker: TrackerNoise, ref2: float, x: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The whitening Sigma_k^(-1/2) of the points x (3, m) (their covariance shapes over ``ref2``, m^2): (u, the
    factors along u and across it), applied by :func:`_whiten`."""
    u, va, vb = tracker.shape(x)
    return u, np.sqrt(ref2 / va), np.sqrt(ref2 / vb)


def _whiten(w: tuple, x: np.ndarray) -> np.ndarray:
    """x (..., 3, m) whitened per point by ``w`` (:func:`_whitener`): ib x + (ia - ib) u (u . x)."""
    u, ia, ib = w
    return x * ib + u * ((ia - ib) * np.einsum("im,...im->...m", u, x))[..., None, :]
