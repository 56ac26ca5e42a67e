"""A continuous recording (:class:`Recording`) and the check of its times."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from ..errors import DenavitError


@dataclass(frozen=True)
class Recording:
    """Rows of one recording in time order (SI inside).

    time : (N,) s, strictly increasing, or None when the file has no time (rows in file order).
    q : (N, n) joint readings (rad revolute, m prismatic), or None.
    points : (N, k, 3) m, k measured targets per row (a pose's origin when ``poses`` is given), or None.
    poses : (N, 4, 4) measured poses ``T_world_target`` (6-DoF probe, controller TCP), or None.
    where : (N,) "file:line" (or topic and index) of each row, for messages.
    source : the file read; format : the reader used; units : the units the file declared (or was read with).
    joint : (N,) 1-based joint each row's sweep belongs to, when the file labels it (tracker groups / names), else None.
    notes : what the reader guessed or chose (format detection, sweep pattern, topics), to echo to the user.
    """

    time: np.ndarray | None
    q: np.ndarray | None
    points: np.ndarray | None
    where: list[str]
    source: str
    format: str
    units: dict = field(default_factory=dict)
    poses: np.ndarray | None = None
    kinds: list[str] | None = None
    joint: np.ndarray | None = None
    names: list[str] | None = None
    notes: list[str] = field(default_factory=list)

    def __len__(self) -> int:
        return len(self.where)

    def __repr__(self) -> str:
        return f"Recording({self.describe().splitlines()[0]})"

    @property
    def n_joints(self) -> int:
        return 0 if self.q is None else self.q.shape[1]

    @property
    def n_targets(self) -> int:
        return 0 if self.points is None else self.points.shape[1]

    @property
    def rate(self) -> float:
        """Median sampling rate (Hz), nan without time."""
        if self.time is None or len(self.time) < 2:
            return math.nan
        return float(1.0 / np.median(np.diff(self.time)))

    def describe(self) -> str:
        """Lines that say what was found: rows, rate, joints, targets, units, notes."""
        what = [f"{self.source}: {self.format}, {len(self)} rows"]
        if self.time is not None and len(self.time) > 1:
            what.append(f"{self.time[-1] - self.time[0]:.3f} s at {self.rate:.4g} Hz")
        what.append(f"{self.n_joints} joint readings" if self.q is not None else "no joint readings")
        if self.poses is not None:
            what.append("poses (position + orientation)")
        elif self.points is not None:
            what.append(f"{self.n_targets} target(s) per row")
        if self.units:
            what.append("units " + " ".join(f"{k}={v}" for k, v in self.units.items()))
        return "\n".join([", ".join(what), *self.notes])


def check_time(t: np.ndarray, where: Sequence[str], what: str = "time") -> None:
    """A one-line error at the first row whose ``what`` is not after the previous row's."""
    t = np.asarray(t, dtype=float)
    bad = np.flatnonzero(~(np.diff(t) > 0))
    if bad.size:
        i = int(bad[0]) + 1
        raise DenavitError(
            f"{where[i]}: {what} goes backwards or repeats: {t[i]:.9g} s after {t[i - 1]:.9g} s at {where[i - 1]}:"
            " expected strictly increasing times"
        )


def _motion_signal(rec: Recording) -> tuple[np.ndarray, str]:
    """(N, d) coordinates whose speed shows the motion: the readings, else the mean of the targets."""
    if rec.points is not None:
        return rec.points.mean(axis=1), "points"
    if rec.q is not None:
        return rec.q, "readings"
    raise DenavitError(f"{rec.source}: neither points nor joint readings: nothing moves")


def _window(n_samples: int, dt: float, span: float) -> int:
    """Odd Savitzky-Golay window of about ``span`` seconds (at least 5 samples, at most the data)."""
    w = max(5, int(round(span / dt)) | 1)
    return min(w, n_samples - 1 if n_samples % 2 == 0 else n_samples)


def _noise(x: np.ndarray, w: int, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """Per-column 1-sigma noise of ``x`` and of its Savitzky-Golay speed: robust scatter (MAD) of the residuals
    of the smoothing, propagated through the derivative filter's coefficients."""
    from scipy.signal import savgol_coeffs, savgol_filter  # noqa: PLC0415

    r = x - savgol_filter(x, w, 2, axis=0)
    mad = np.median(np.abs(r - np.median(r, axis=0)), axis=0) * 1.4826
    # the residual of a degree-2 fit has variance (1 - h) sigma^2 with h the central hat value
    h = savgol_coeffs(w, 2)[w // 2]
    sigma = mad / math.sqrt(max(1.0 - h, 1e-6))
    return sigma, sigma * float(np.linalg.norm(savgol_coeffs(w, 2, deriv=1, delta=dt)))


#: Rows of a dwell next to a motion whose median is the dwell's level (:func:`_ends`).
