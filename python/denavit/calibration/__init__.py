"""Calibration beyond circles: one least-squares fit of the whole kinematic model, its identifiability, its
uncertainty, and the planning of measurements.

Data are measured tool points (or full tool poses) at arbitrary joint configurations whose readings are
known, in any measurement frame (``world``); the joint sweeps of the circle-point method (Hayat et al.) are one
case of it (:meth:`Measurements.from_sweeps`). The model is a chain of elementary factors (``Rx, Ry, Rz`` in
rad, ``Tx, Ty, Tz`` in m) with named parameters, generated from a nominal robot in a chosen convention; the
identification Jacobian of every parameter is computed analytically in the Rust core
(``denavit_core::calibration``) in one forward pass per pose.

Identifiability: the (weighted) identification Jacobian ``J`` with unit-norm columns is reduced by a greedy
Gram-Schmidt in a fixed preference order (base, tool, link geometry, joint offsets, scales, translations along
joint axes last): a parameter whose column is (numerically) a combination of the columns kept before it is
*not identifiable*; it is named with that combination, fixed at its start value and reported, never returned
as a silent number. The kept set is a set of base parameters (Khalil & Dombre 2002, ch. 11). Parameters
redundant for *any* data (checked on configurations spread over the joint limits) are told apart from those
these measurements cannot separate. Observability indices of the kept, column-normalised ``J`` with singular
values ``s_1 >= ... >= s_L`` over ``m`` poses (Sun & Hollerbach 2008, "Observability index selection for robot
calibration", ICRA): O1 ``(s_1 ... s_L)^(1/L) / sqrt(m)`` (Borm & Menq 1991), O2 ``s_L / s_1`` (Driels & Pathre
1990), O3 ``s_L`` (Nahvi, Hollerbach & Hayward 1994), O4 ``s_L^2 / s_1`` (noise amplification, Nahvi &
Hollerbach 1996), O5 ``1 / (1/s_1 + ... + 1/s_L)`` (Sun & Hollerbach 2008).

Uncertainty: ``cov = s^2 (J^T J)^-1`` over the free parameters (``s^2`` from the residuals, or the declared
noise), i.e. the Cramér-Rao bound of Gaussian noise evaluated at the solution; :func:`plan` evaluates the same
bound at the nominal model before anything is measured.


Modules: :mod:`~denavit.calibration.parametrization` (the chain), :mod:`~denavit.calibration.identifiability`
(rank, base parameters, observability), :mod:`~denavit.calibration.least_squares` (residuals, solver,
covariance), :mod:`~denavit.calibration.solve` (:func:`calibrate`), :mod:`~denavit.calibration.plan`,
:mod:`~denavit.calibration.simulate`, :mod:`~denavit.calibration.measurements` (the data; files:
:mod:`denavit.io.measurements`).
"""

from .identifiability import Identifiability, Unidentifiable
from .measurements import Measurements
from .parametrization import Parametrization, configurations, parametrize
from .plan import Plan, Protocol, axis_lines, plan, select_poses
from .simulate import simulate
from .solve import Calibration, Validation, calibrate, to_json, write_json

__all__ = [
    "Calibration",
    "Identifiability",
    "Measurements",
    "Parametrization",
    "Plan",
    "Protocol",
    "Unidentifiable",
    "Validation",
    "axis_lines",
    "calibrate",
    "configurations",
    "parametrize",
    "plan",
    "select_poses",
    "simulate",
    "to_json",
    "write_json",
]
