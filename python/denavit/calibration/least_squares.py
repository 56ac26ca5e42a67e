"""The least-squares machinery of the calibration: weighted residuals and Jacobian rows, the solver, the
covariance, and the registration of the measurement frame.

Uncertainty: ``cov = s^2 (J^T J)^-1`` over the free parameters (``s^2`` from the residuals, or the declared
noise), the Cramér-Rao bound of Gaussian noise evaluated at the solution.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ..geometry import matrix_rotvec

if TYPE_CHECKING:
    from .measurements import Measurements
    from .parametrization import Parametrization

#: The base is first registered (Kabsch) to the data when the nominal model at its nominal base misses the
#: measured points by more than this (m, RMS): the measurement frame is then not the robot's base frame.
REGISTER_RMS = 0.02


def weights(measure: str, sigma_p: float, sigma_r: float) -> np.ndarray:
    """(6,) weights 1/sigma of the residual rows [position (3), rotation (3)]; rotation rows 0 for points."""
    return np.array([1 / sigma_p] * 3 + ([1 / sigma_r] * 3 if measure == "pose" else [0.0] * 3))


#: Rows per block of :func:`gram`: a block's product (P x GRAM_ROWS x P) stays under OpenBLAS's bound for
#: threading a matrix product, so every block runs on the calling thread.
GRAM_ROWS = 256


def gram(A: np.ndarray) -> np.ndarray:
    """``A^T A`` as a sum of blocks of :data:`GRAM_ROWS` rows, each a BLAS product on the calling thread. The
    matrices here are tall and thin (3N x P): one multithreaded BLAS call on them can be a hundred times slower
    on a loaded machine (its threads spin for cores others hold), and numpy's einsum does not use BLAS (5x the
    CPU time of the blocks at 150,000 x 27). Every factorisation below works on the small P x P Gram matrix."""
    m = len(A) // GRAM_ROWS * GRAM_ROWS
    blocks = A[:m].reshape(-1, GRAM_ROWS, A.shape[1])
    G = np.matmul(blocks.transpose(0, 2, 1), blocks).sum(axis=0)
    if m < len(A):
        G += A[m:].T @ A[m:]
    return G


def jacobian_rows(
    pz: Parametrization, x, q, w: np.ndarray, columns=None, whitening=None
) -> tuple[np.ndarray, np.ndarray]:
    """(predicted poses (N, 4, 4), weighted Jacobian rows (3N or 6N, len(columns))) at x for the readings q (N, n):
    the identification Jacobian's position (and for poses rotation) rows times the weights ``w`` (and each point's
    position rows by its ``whitening`` (N, 3, 3) matrix, :attr:`Measurements.whitening`), of the parameters
    ``columns`` (indices; default all). The core writes these weighted rows and columns alone, straight into the
    result."""
    k = 6 if pz.measure == "pose" else 3
    cols = np.arange(pz.n_params) if columns is None else np.asarray(columns, dtype=int)
    poses, J = pz.evaluate(x, q, True, rows=k, columns=cols, weights=w[:k])
    if whitening is not None:
        J[:, :3] = np.einsum("nij,njp->nip", whitening, J[:, :3])
    return poses, J.reshape(-1, len(cols))


def residuals(pz: Parametrization, x, meas: Measurements, w: np.ndarray, jacobian: bool = True, columns=None):
    """(weighted residuals (3N or 6N,), weighted Jacobian rows (3N or 6N, P) or None, predicted poses (N, 4, 4)) at x.

    Position residuals are whitened by ``meas.whitening`` where it is given (the tracker's noise model). Rotation
    residuals are the rotation vectors of ``R_pred R_meas^T`` (rad). ``columns``: the parameters
    (indices) whose Jacobian columns are returned (default all; :func:`jacobian_rows`).
    """
    q = pz.inputs(meas)  # the readings (with the gravity torques for a compliant chain)
    if jacobian:
        poses, J = jacobian_rows(pz, x, q, w, columns, meas.whitening)
    else:
        (poses, _), J = pz.evaluate(x, q, False), None
    rp = poses[:, :3, 3] - meas.points
    if meas.whitening is not None:
        rp = np.einsum("nij,nj->ni", meas.whitening, rp)
    if pz.measure == "pose":
        rr = matrix_rotvec(np.einsum("nij,nkj->nik", poses[:, :3, :3], meas.poses[:, :3, :3]))
        r = np.hstack([rp * w[0], rr * w[3]])
    else:
        r = rp * w[0]
    return r.ravel(), J, poses


def fit_parameters(
    pz: Parametrization,
    x_start,
    free: list,
    meas: Measurements,
    w: np.ndarray,
    loss: str,
    f_scale: float | None,
    max_nfev: int | None = None,
    prior: tuple | None = None,
):
    """Least squares over the parameters ``free`` (indices) from ``x_start``; returns (x, scipy result).

    The solver's trial points get residuals only; the Jacobian (of the free columns alone) is evaluated where
    the solver asks for it, at the points it accepts. Each call returns fresh arrays (MINPACK may write into them).

    ``prior``: (centre (P,), weight (P,)) of every parameter, the rows ``weight_c (x_c - centre_c)`` appended to
    the whitened residuals for the free parameters of nonzero weight (:mod:`denavit.calibration.priors`: the fit
    is then maximum a posteriori; the robust loss, if any, applies to them too, where they are small).
    """
    from scipy.optimize import least_squares  # noqa: PLC0415 (scipy is loaded when a fit first needs it)

    x_base = np.array(x_start, dtype=float)
    free = list(free)
    if not free:
        return x_base, None
    x0 = x_base[free].copy()

    # the unknowns are the changes from the start: MINPACK's first step is bounded by 100 |x| in scaled
    # units, which is useless when the start is (nearly) zero but not exactly
    def full(z):
        x = x_base.copy()
        x[free] = x0 + z
        return x

    pc, pw = prior_rows(prior, free)

    def fun(z):
        r = residuals(pz, full(z), meas, w, jacobian=False)[0]
        return r if pc is None else np.concatenate([r, pw * (x0[pc] + z[pc] - centre_of(prior, free, pc))])

    def jac(z):
        J = residuals(pz, full(z), meas, w, columns=free)[1]
        if pc is None:
            return J
        P = np.zeros((len(pc), len(free)))
        P[np.arange(len(pc)), pc] = pw
        return np.vstack([J, P])

    z0 = np.zeros(len(free))
    n_rows = meas.n * (6 if pz.measure == "pose" else 3) + (0 if pc is None else len(pc))
    method = "lm" if loss == "linear" and n_rows >= len(free) else "trf"
    kw = {} if loss == "linear" else {"loss": loss, "f_scale": f_scale or 1.0}
    sol = least_squares(
        fun,
        z0,
        jac=jac,
        method=method,
        x_scale="jac",
        xtol=1e-12,
        ftol=1e-12,
        gtol=1e-12,
        max_nfev=max_nfev or 100 * (len(free) + 1),
        **kw,
    )
    return full(sol.x), sol


def prior_rows(prior: tuple | None, free: list):
    """(positions within ``free`` of the parameters with a prior, their weights), or (None, None) without any."""
    if prior is None:
        return None, None
    weight = np.asarray(prior[1], dtype=float)[list(free)]
    pc = np.flatnonzero(weight > 0)
    return (pc, weight[pc]) if pc.size else (None, None)


def centre_of(prior: tuple, free: list, pc: np.ndarray) -> np.ndarray:
    """The prior centres of the free parameters at positions ``pc`` of ``free``."""
    return np.asarray(prior[0], dtype=float)[np.asarray(free, dtype=int)[pc]]


def prior_block(prior: tuple | None, free: list) -> np.ndarray:
    """The prior rows' matrix (rows of the free parameters with a prior, columns ``free``), to stack under the
    Jacobian of the free columns (the posterior covariance: :func:`covariance` of both)."""
    pc, pw = prior_rows(prior, free)
    P = np.zeros((0 if pc is None else len(pc), len(free)))
    if pc is not None:
        P[np.arange(len(pc)), pc] = pw
    return P


def covariance(J: np.ndarray, s2: float) -> np.ndarray:
    """``s2 (J^T J)^-1`` from the Gram matrix of the column-scaled J (stable for mixed units; see :func:`gram`)."""
    from scipy.linalg import cho_factor, cho_solve  # noqa: PLC0415 (scipy is loaded when first needed)

    if J.shape[1] == 0:
        return np.zeros((0, 0))
    G = gram(J)
    d = np.sqrt(np.clip(np.diag(G), 0, None))
    d = np.where(d > 0, d, 1.0)
    A = G / np.outer(d, d)
    try:
        inv = cho_solve(cho_factor(A, lower=True, check_finite=False), np.eye(len(A)), check_finite=False)
    except np.linalg.LinAlgError:  # singular: the pseudo-inverse (callers pass identifiable columns only)
        ev, V = np.linalg.eigh(A)
        inv = (V / np.maximum(ev, ev.max() * 1e-15)) @ V.T
    return s2 * inv / np.outer(d, d)
