"""Continuous recordings from instruments: time alignment of two clocks, segmentation into sweeps, sweep sets.

A :class:`Recording` is what a reader of :mod:`denavit.io.recordings` returns: rows in time order, each with a
time (s), optionally every joint reading (rad / m), and the measured target points (m, ``k`` targets per row,
e.g. 2-4 SMRs on one nest) or a 6-DoF pose. SI inside; each reader converts the units its file declares.

- :func:`align`: points and readings recorded by two clocks. The clock offset (and a drift, when the data
  asks for it) is estimated from the motion itself: the speed of the measured point and the speed of the
  joints are resampled on one uniform grid, smoothed and differentiated (Savitzky-Golay), cross-correlated
  (:func:`scipy.signal.correlate`, coarse lag), then the lag is refined as the maximum of the correlation
  coefficient over a continuous shift (:func:`scipy.optimize.minimize_scalar` on a spline of the readings'
  speed), once over the whole overlap and once per time window; the windows' scatter gives the offset's
  uncertainty and a straight-line fit of the window lags gives the drift. The readings are then interpolated
  (cubic spline) at the point times.
- :func:`segment`: which joint moves when. A row moves when a speed exceeds the noise (estimated from the
  data: robust scatter of the residuals of a local polynomial fit, propagated through the derivative filter),
  so dwell -- standing still within the noise -- is excluded from every motion. With readings the moving
  joint is the one whose reading changes, and a motion is one joint turning one way: a still span shorter than
  ``min_dwell`` is bridged only inside such a motion, and a motion ends where the moving joint changes or turns
  back, however short the pause (none at all: the cut falls where both are slowest); without, consecutive motions about
  one circle (same plane normal
  and centre) belong to one joint and a change of circle starts the next joint. Among a joint's motions the
  sweep is the one matching the given range, else the slowest (transits to and from home run at travel
  speed, a sweep at measuring speed).
- :func:`to_sweepset`: the sweeps of a segmentation as the package's :class:`~denavit.sweeps.SweepSet`."""

from .align import MIN_CORRELATION, Alignment, align, estimate_offset
from .data import Recording, check_time
from .segment import DWELL_ROWS, Segment, Segmentation, segment, static_poses, to_sweepset

__all__ = [
    "Alignment",
    "DWELL_ROWS",
    "MIN_CORRELATION",
    "Recording",
    "Segment",
    "Segmentation",
    "align",
    "check_time",
    "estimate_offset",
    "segment",
    "static_poses",
    "to_sweepset",
]
