"""Joint-axis identification from measured joint sweeps (circle-point method) and oriented bounding boxes.

A revolute joint is swept while all other joints are locked; a point fixed to the moving link then traces a
circular arc whose centre lies on the joint axis and whose plane is perpendicular to it. A prismatic joint
moves the point along a straight line parallel to its axis. This module fits those circles and lines.

Frames and units
----------------
Every point is expressed in the measurement frame ``world`` (docs/conventions.md) and every length is in
metres, every angle in radians. The package is pure numpy/scipy (scipy imported when a fit first needs it).

Methods
-------
``fit_circle_kasa``
    The method of Hayat et al. [H]_, section II.C, eqs. (1)-(9): SVD plane, then the algebraic (Kasa) circle.
``fit_circle_hyper``
    The same SVD plane, then the "hyper" algebraic circle of Al-Sharadqah & Chernov [AC]_ (no essential bias).
``fit_circle_geometric``
    Orthogonal-distance (maximum-likelihood for isotropic Gaussian noise) 3-D circle, started from the hyper fit.
``fit_axis_with_readings``
    Uses the recorded joint angles: the points are rotations of one rigid point about the axis by the readings,
    weighted by what the readings are worth (their error is estimated: errors-in-variables). Much better than any
    circle fit on short arcs when the readings are good, because the angles tie down the radius; the geometric
    circle when they are not.
:func:`~denavit.fitting.joint.fit_sweeps`
    All sweeps in one fit (one line per joint, one home point, or one per sweep; several targets per pose, each
    with its own home point, and 6-DoF poses, the orientation at home fitted too), the global fit of
    :func:`denavit.identification.identify`.
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
(:func:`denavit.fitting.robust.weighted_cov`). The Kasa and hyper fits report the
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

Modules
-------
:mod:`~denavit.fitting.circle` (Kasa, hyper, geometric), :mod:`~denavit.fitting.readings` (with joint readings),
:mod:`~denavit.fitting.line` (prismatic axes), :mod:`~denavit.fitting.axis` (dispatch),
:mod:`~denavit.fitting.joint` (all sweeps in one fit), :mod:`~denavit.fitting.chain` (its chain of joint
motions and Jacobian), :mod:`~denavit.fitting.tracker` (a laser tracker's range/angle noise),
:mod:`~denavit.fitting.motion` (a
sweep's joint motions from home),
:mod:`~denavit.fitting.robust` (robust sigma, outliers, IRLS, weighted covariance),
:mod:`~denavit.fitting.box` (bounding box), :mod:`~denavit.fitting.result` (:class:`AxisFit`),
:mod:`~denavit.fitting.checks` (input checks).
"""

from ..errors import DegenerateError, DenavitError, NotConvergedError
from .axis import fit_axis
from .box import BoundingBox, oriented_bounding_box
from .circle import fit_circle_geometric, fit_circle_hyper, fit_circle_kasa
from .line import fit_line
from .readings import fit_axis_with_readings
from .result import AxisFit

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
