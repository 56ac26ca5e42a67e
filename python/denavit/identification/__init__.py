"""Circle-point identification: the robot's true joint axes and parameters from joint sweeps.

Hayat et al., *Identification of Denavit-Hartenberg Parameters of an Industrial Robot*: fit one circle per
swept joint (centroid, SVD plane, algebraic circle, eq. 1-9: method ``kasa``), take each circle's normal and
centre as the joint axis, and extract the parameters from consecutive axes by line geometry. Beyond the
paper: bias-free and geometric fits, a fit that uses the recorded joint readings, and a ``global`` fit of
all sweeps together (one shared tool point at home, one line per joint), covariance of every axis
propagated to every parameter, no absurd offsets on near-parallel axes (docs/conventions.md), and the
minimum-volume bounding box of the measured points (paper Table IV; :attr:`Identification.box`, computed
when first asked for).

The package: :func:`identify` (``denavit.identify`` is the same function) and :class:`Identification` (saved and
written as JSON by :mod:`denavit.io.results`); the steps in :mod:`.prepare`, :mod:`.choice`, :mod:`.frames`,
:mod:`.run`.
"""

from .prepare import decoupled, sweep_where
from .result import EXACT, METHODS, Identification
from .run import identify

__all__ = ["EXACT", "METHODS", "Identification", "decoupled", "identify", "sweep_where"]
