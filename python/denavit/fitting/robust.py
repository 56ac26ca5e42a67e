"""Robust statistics of the fits: robust sigma, outlier flags, IRLS for per-point losses, weighted covariance.

Every fit of :mod:`denavit.fitting` (and the global fit of :mod:`denavit.identification`) flags outliers and weights
points with these, so one rule holds everywhere: the robust sigma of misfits of ``k`` Gaussian components is
``median(|misfit|) / sqrt(chi2_k median)`` (``1.4826 * MAD`` for k = 1), and a point is an outlier beyond the
level with the tail probability of a 1-D 4-sigma deviation.
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import DegenerateError, NotConvergedError
from .checks import prefix

#: Outlier threshold, in robust sigmas (1.4826 * MAD) of a 1-D residual.
OUTLIER_SIGMAS = 4.0


class _Levels(dict):
    """Levels of the norm of k Gaussian components, tabulated for k = 1..3 and computed by scipy for more (a pose
    of several targets, or a 6-DoF pose, has 6-15 components)."""

    def __init__(self, known: dict, f):
        super().__init__(known)
        self._f = f

    def __missing__(self, k: int) -> float:
        v = self[k] = float(self._f(k))
        return v


def _chi_median(k: int) -> float:
    from scipy.stats import chi2  # noqa: PLC0415

    return math.sqrt(chi2.ppf(0.5, k))


def _chi_4sigma(k: int) -> float:
    from scipy.stats import chi2, norm  # noqa: PLC0415

    return math.sqrt(chi2.isf(2 * norm.sf(4), k))


#: For a misfit of k Gaussian components (sigma each): median of its norm, sqrt(chi2.ppf(0.5, k)) (scipy.stats).
CHI_MEDIAN = _Levels({1: 0.6744897501960812, 2: 1.1774100225154749, 3: 1.5381722544550522}, _chi_median)
#: The norm exceeded with the probability of a 1-D 4-sigma deviation, sqrt(chi2.isf(2 * norm.sf(4), k)).
CHI_4SIGMA = _Levels({1: 4.0, 2: 4.397034069908339, 3: 4.696948013014455}, _chi_4sigma)


def robust_sigma(misfit: np.ndarray, k: int) -> float:
    """Robust per-component noise sigma (metres) from per-point misfit norms of k Gaussian components.

    ``median(|misfit|) / sqrt(chi2_k median)``; for k = 1 this is ``1.4826 * MAD`` (deviations about zero, the
    residuals' expected centre). Pooling the norms (not the components) keeps it valid when the components differ
    in spread (e.g. radial vs out-of-plane residuals of a distorted fit).
    """
    return float(np.median(np.abs(misfit)) / CHI_MEDIAN[k])


def flag_outliers(misfit: np.ndarray, k: int, size: float) -> np.ndarray:
    """|misfit| beyond the 4-robust-sigma level (same tail probability as a 1-D 4-sigma deviation, 6.3e-5).

    The robust sigma is floored at ``1e-12 * size`` (``size`` the RMS spread of the points, metres) so that
    round-off on exact data is not called an outlier.
    """
    sig = max(robust_sigma(misfit, k), 1e-12 * size)
    return np.abs(misfit) > CHI_4SIGMA[k] * sig


def rms_spread(p: np.ndarray) -> float:
    """RMS distance (m) of the points from their centroid."""
    return math.sqrt(np.mean(np.sum((p - p.mean(axis=0)) ** 2, axis=1)))


def loss_weight(loss: str, z: np.ndarray) -> np.ndarray:
    """IRLS weights ``rho'(z)`` of scipy.optimize.least_squares' losses, ``z = (residual / f_scale)^2``.

    ``loss`` is "linear", "soft_l1", "huber", "cauchy" or "arctan" (the fits of this package use the first
    three; :mod:`denavit.calibration` all five).
    """
    if loss == "soft_l1":
        return 1.0 / np.sqrt(1.0 + z)
    if loss == "huber":
        return np.where(z <= 1.0, 1.0, 1.0 / np.sqrt(np.maximum(z, 1.0)))
    if loss == "cauchy":
        return 1.0 / (1.0 + z)
    if loss == "arctan":
        return 1.0 / (1.0 + z**2)
    return np.ones_like(z)


def loss_dweight(loss: str, z: np.ndarray) -> np.ndarray:
    """d/dz of :func:`loss_weight` (``rho''(z)``), for the bread of an M-estimator's covariance."""
    z = np.asarray(z, dtype=float)
    if loss == "soft_l1":
        return -0.5 * (1.0 + z) ** -1.5
    if loss == "huber":
        return np.where(z <= 1.0, 0.0, -0.5 * np.maximum(z, 1.0) ** -1.5)
    if loss == "cauchy":
        return -1.0 / (1.0 + z) ** 2
    if loss == "arctan":
        return -2.0 * z / (1.0 + z**2) ** 2
    return np.zeros_like(z)


def tall_svd(a: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(singular values, V^T) of a tall matrix ``a`` (m, k), m >= k: the SVD of its R factor (Householder QR), the
    values and vectors of ``np.linalg.svd(a, full_matrices=False)`` without its (m, k) U factor (a third of the
    time for m = 1e5)."""
    _, s, vt = np.linalg.svd(np.linalg.qr(a, mode="r"))
    return s, vt


def weighted_cov(j: np.ndarray, r: np.ndarray, w: np.ndarray, n_params: int, noise_sigma=None):
    """First-order covariance of a (robust) least-squares fit, and the singular values of ``W^1/2 J``.

    ``j`` (n_res, k) and ``r`` (n_res,) are the unweighted Jacobian and residuals at the solution, ``w`` (n_res,)
    the final weights (all 1 without a robust loss). Weighted least squares with these weights has
    ``cov = s^2 A^+ (J^T W^2 J) A^+``, ``A = J^T W J`` (pseudo-inverse ``A^+``), with the misfit variance
    ``sum((w r)^2) / (sum(w^2) - n_params)``: the weighted residuals ``w r`` stay bounded (at most ``f_scale``) for
    down-weighted outliers, so an outlier does not inflate the sigmas. Without a robust loss this is the usual
    ``SSR / (n_res - n_params) (J^T J)^-1``. A declared ``noise_sigma`` is a floor, not a replacement:
    ``s^2 = max(noise_sigma^2, misfit variance)``, so that misfit beyond the declared noise (lack of fit)
    inflates the sigmas instead of being hidden.
    """
    s2 = misfit_variance(w * r, float(np.sum(w**2)) - n_params, noise_sigma)
    sv, vt = (
        tall_svd(j * np.sqrt(w)[:, None])
        if len(j) >= j.shape[1]
        else np.linalg.svd(j * np.sqrt(w)[:, None], full_matrices=False)[1:]
    )
    inv = np.where(sv > 1e-13 * sv[0], 1.0 / np.maximum(sv, 1e-300) ** 2, 0.0)
    a_inv = (vt.T * inv) @ vt
    jw = j * w[:, None]
    return s2 * a_inv @ (jw.T @ jw) @ a_inv, sv


def misfit_variance(psi: np.ndarray, dof: float, noise_sigma=None) -> float:
    """The variance factor of a covariance: ``psi @ psi / dof`` (nan without redundancy), floored at a declared
    ``noise_sigma^2`` (which alone is used when there is no redundancy)."""
    est = float(psi @ psi) / dof if dof > 0 else math.nan
    if noise_sigma is None:
        return est
    return max(float(noise_sigma) ** 2, est) if math.isfinite(est) else float(noise_sigma) ** 2


def cov_from_jacobian(j: np.ndarray, r: np.ndarray, w: np.ndarray, n_params: int, noise_sigma, what: str, where: str):
    """:func:`~denavit.fitting.robust.weighted_cov`, or a clear error when the Jacobian is singular (the axis is not
    identifiable)."""
    cov, sv = weighted_cov(j, r, w, n_params, noise_sigma)
    if sv[-1] <= 1e-13 * sv[0]:
        raise DegenerateError(
            f"{prefix(where)}{what}: the axis is not identifiable from these points "
            f"(Jacobian singular values {sv[0]:.3g} ... {sv[-1]:.3g}; expected full rank {n_params})"
        )
    return cov


def irls(solve, misfit, state, loss, f_scale, k, what, where):
    """Iteratively reweighted least squares for a per-point robust loss (fixed point = robust M-estimate).

    Returns ``(state, weights)``: the final state and the (m,) per-point weights (all 1 for ``loss="linear"``).

    ``solve(state, weights) -> state``; ``misfit(state) -> (m,)`` per-point distances of ``k`` components, used
    for the weights ``rho'((misfit / f)^2)`` (scipy's loss functions). With ``f_scale=None`` the scale is
    re-estimated at every step as ``f = 3`` robust sigmas of the current misfits (a concurrent scale estimate,
    so that the scale is not inflated by the outliers' pull on the least-squares start).
    The misfits are in units of the points' RMS spread (the fits normalize the points), so a scale below 1e-12
    is round-off on exact data: nothing is down-weighted (the weights of round-off never settle).
    """
    m = misfit(state).size
    w = np.ones(m)
    if loss == "linear":
        return state, w
    for _ in range(200):
        e = misfit(state)
        f = f_scale if f_scale is not None else 3.0 * robust_sigma(e, k)
        if not f > 1e-12:
            return state, w  # exact data (misfits of round-off: the fits pass them in units of the points' spread)
        w_new = loss_weight(loss, (e / f) ** 2)
        if np.max(np.abs(w_new - w)) < 1e-9:
            return state, w_new
        w = w_new
        state = solve(state, w)
    raise NotConvergedError(
        f"{prefix(where)}{what} with loss={loss!r}: reweighting did not converge in 200 iterations "
        "(expected the weights to settle to 1e-9)"
    )
