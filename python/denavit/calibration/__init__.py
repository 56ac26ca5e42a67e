"""Calibration beyond circles: one least-squares fit of the whole kinematic model, its identifiability, its
uncertainty, and the planning of measurements.

Data are measured tool points (or full tool poses) at arbitrary joint configurations whose readings are
known, in any measurement frame (``world``); the joint sweeps of the circle-point method (Hayat et al.) are one
case of it (:meth:`Measurements.from_sweeps`). The model is a chain of elementary factors (``Rx, Ry, Rz`` in
rad, ``Tx, Ty, Tz`` in m) with named parameters, generated from a nominal robot in a chosen convention; the
identification Jacobian of every parameter is computed analytically in the Rust core
(``denavit_core::calibration``) in one forward pass per pose.

Identifiability (a greedy Gram-Schmidt in a fixed preference order, base parameters, observability indices):
:mod:`denavit.calibration.identifiability`.

Uncertainty: ``cov = s^2 (J^T J)^-1`` over the free parameters (``s^2`` from the residuals, or the declared
noise), i.e. the Cramér-Rao bound of Gaussian noise evaluated at the solution; :func:`plan` evaluates the same
bound at the nominal model before anything is measured.


What is free is chosen by leave-one-pose-out prediction error among nested models
(:mod:`~denavit.calibration.selection`), with plausible-size priors about the nominal
(:mod:`~denavit.calibration.priors`): the fit is then maximum a posteriori and ``cov`` the posterior's.

Modules: :mod:`~denavit.calibration.parametrization` (the chain), :mod:`~denavit.calibration.identifiability`
(rank, base parameters, observability), :mod:`~denavit.calibration.least_squares` (residuals, solver,
covariance), :mod:`~denavit.calibration.selection` (the candidate models, the hat-matrix leave-one-out, the
rule), :mod:`~denavit.calibration.priors`, :mod:`~denavit.calibration.solve` (:func:`calibrate`),
:mod:`~denavit.calibration.plan`,
:mod:`~denavit.calibration.simulate`, :mod:`~denavit.calibration.measurements` (the data; files:
:mod:`denavit.io.measurements`).
"""

from .identifiability import Identifiability, Unidentifiable
from .measurements import Measurements
from .parametrization import Parametrization, configurations, parametrize
from .plan import Plan, Protocol, axis_lines, plan, select_poses
from .result import Calibration, Validation
from .simulate import simulate
from .solve import calibrate
from .targets import TargetMeasurements

__all__ = [
    "Calibration",
    "Identifiability",
    "Measurements",
    "Parametrization",
    "Plan",
    "Protocol",
    "TargetMeasurements",
    "Unidentifiable",
    "Validation",
    "axis_lines",
    "calibrate",
    "configurations",
    "parametrize",
    "plan",
    "select_poses",
    "simulate",
]
