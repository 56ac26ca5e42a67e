"""Measured tool points or poses at known joint configurations (SI), and the checks every reader shares.

The file formats are read and written by :mod:`denavit.io.measurements`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from ..errors import DenavitError

if TYPE_CHECKING:
    from ..sweeps import SweepSet


@dataclass(frozen=True, eq=False)
class Measurements:
    """Measured tool points or poses at known joint configurations.

    Attributes
    ----------
    q : ndarray, shape (N, n), rad / m
        Joint readings of each pose.
    points : ndarray, shape (N, 3), metres, frame ``world`` (the measurement frame), or None
        Measured tool points.
    poses : ndarray, shape (N, 4, 4), metres, frame ``world``, or None
        Measured tool poses ``T_world_tool`` (then ``points`` are their origins).
    source : str
        Where the data came from (for messages).
    where : list of str, length N
        Where each pose came from ("file:line").
    units : dict
        Units of the source file (informative; everything here is SI).
    sweeps : SweepSet or None
        The sweeps these measurements were made of, if any (for ``start="circles"``).
    whitening : ndarray, shape (N, 3, 3), or None
        Per point the matrix that whitens its position residual (the tracker's range/angle noise model,
        :meth:`denavit.fitting.joint.TrackerNoise.whitening`: covariance ``ref^2 I`` after it); None: isotropic.
    kinds : tuple of str, length n, or None
        Joint kinds (``"revolute"`` / ``"prismatic"``) of the readings; read from a file, the kinds they were
        converted with from its units (revolute: angle unit, prismatic: length unit). :func:`calibrate`
        refuses a nominal model of other kinds. None: not stated (readings given in SI).
    """

    q: np.ndarray
    points: np.ndarray | None = None
    poses: np.ndarray | None = None
    source: str = "measurements"
    where: list = field(default_factory=list)
    units: dict = field(default_factory=lambda: {"length": "m", "angle": "rad"})
    sweeps: SweepSet | None = None
    kinds: tuple | None = None
    whitening: np.ndarray | None = None
    #: (N, 4) per pose the payload on the flange, ``[mass kg, x, y, z m]`` (its centre of mass in the flange frame;
    #: :mod:`denavit.calibration.compliance`), or None: no payload declared
    payload: np.ndarray | None = None

    def __repr__(self) -> str:
        what = "poses" if self.poses is not None else "points"
        return f"Measurements({self.q.shape[0]} {what}, {self.q.shape[1]} joints, source {self.source})"

    def __post_init__(self):
        q = as_array(self.q, "q", self.source)
        if q.ndim != 2 or q.shape[0] < 1:
            raise DenavitError(f"{self.source}: q must have shape (N, n) with one row per pose, got shape {q.shape}")
        object.__setattr__(self, "kinds", joint_kinds(self.kinds, q.shape[1], f"{self.source}: kinds"))
        check_finite(q, "q (joint readings)", self.source, self.where, cols="joint")
        n = q.shape[0]
        poses = self.poses
        points = self.points
        if poses is not None:
            poses = as_array(poses, "poses", self.source)
            if poses.shape != (n, 4, 4):
                raise DenavitError(
                    f"{self.source}: poses must have shape ({n}, 4, 4) (one per row of q), got shape {poses.shape}"
                )
            check_finite(poses.reshape(n, 16), "poses", self.source, self.where)
            err = np.abs(np.einsum("nji,njk->nik", poses[:, :3, :3], poses[:, :3, :3]) - np.eye(3)).max(axis=(1, 2))
            bad = np.flatnonzero((err > 1e-6) | (np.abs(poses[:, 3] - [0, 0, 0, 1]).max(axis=1) > 0))
            if bad.size:
                raise DenavitError(
                    f"{row_where(self.source, self.where, bad[0])}: pose is not a rigid transform (|R^T R - I| ="
                    f" {err[bad[0]]:.2e}, last row {poses[bad[0], 3].tolist()})"
                )
            points = poses[:, :3, 3].copy()
        elif points is not None:
            points = as_array(points, "points", self.source)
            if points.shape != (n, 3):
                raise DenavitError(
                    f"{self.source}: points must have shape ({n}, 3) (one per row of q), got shape {points.shape}"
                )
            check_finite(points, "points", self.source, self.where, cols="xyz")
        else:
            raise DenavitError(
                f"{self.source}: give measured points (N, 3) or poses (N, 4, 4) with the joint readings q"
            )
        object.__setattr__(self, "q", q)
        object.__setattr__(self, "points", points)
        object.__setattr__(self, "poses", poses)
        object.__setattr__(self, "where", list(self.where) or [f"pose {k + 1}" for k in range(n)])
        if self.payload is not None:
            pl = as_array(self.payload, "payload", self.source)
            if pl.shape != (n, 4) or not np.all(np.isfinite(pl)) or np.any(pl[:, 0] < 0):
                raise DenavitError(
                    f"{self.source}: payload must have shape ({n}, 4), [mass kg >= 0, x, y, z m] per pose, finite; got"
                    f" shape {pl.shape}"
                )
            object.__setattr__(self, "payload", pl)

    @property
    def n(self) -> int:
        """Number of poses N."""
        return self.q.shape[0]

    @property
    def nq(self) -> int:
        """Number of joints."""
        return self.q.shape[1]

    @property
    def kind(self) -> str:
        """``"point"`` or ``"pose"``."""
        return "pose" if self.poses is not None else "point"

    def subset(self, idx) -> Measurements:
        """The measurements of the rows ``idx``."""
        idx = np.asarray(idx, dtype=int)
        return Measurements(
            self.q[idx],
            None if self.poses is not None else self.points[idx],
            None if self.poses is None else self.poses[idx],
            self.source,
            [self.where[i] for i in idx],
            self.units,
            None,
            self.kinds,
            None if self.whitening is None else self.whitening[idx],
            None if self.payload is None else self.payload[idx],
        )

    @classmethod
    def from_sweeps(cls, sweeps: SweepSet) -> Measurements:
        """The points of every sweep with their joint readings (all joints recorded at every point)."""
        if not sweeps.has_readings:
            raise DenavitError(
                f"{sweeps.source}: calibration needs the joint readings of every point; these sweeps have none"
                " (per-joint files): use denavit.identify"
            )
        q = np.vstack([s.q for s in sweeps.sweeps])
        p = np.vstack([s.points for s in sweeps.sweeps])
        where = [
            w
            for s in sweeps.sweeps
            for w in s.where or [f"sweep {s.joint}, point {k + 1}" for k in range(len(s.points))]
        ]
        pays = [getattr(s, "payload", None) for s in sweeps.sweeps]
        payload = (
            np.vstack(pays) if pays and all(v is not None for v in pays) else None
        )  # (a sweep file's payload columns)
        return cls(
            q, p, None, sweeps.source or "sweeps", where, dict(sweeps.units), sweeps, sweeps.kinds, payload=payload
        )


def as_array(a, what: str, source: str) -> np.ndarray:
    """``a`` as a float array, or a one-line error naming ``what`` and ``source``."""
    from ..limits import floats  # noqa: PLC0415

    try:
        return floats(a, f"{source}: {what}")
    except (TypeError, ValueError) as exc:
        if isinstance(exc, DenavitError):
            raise
        raise DenavitError(f"{source}: {what} must be an array of numbers ({exc})") from None


def joint_kinds(kinds, n: int, where: str) -> tuple | None:
    """``kinds`` as a tuple of n joint kinds (None stays None), or an error saying what was expected."""
    if kinds is None:
        return None
    if isinstance(kinds, str) or not hasattr(kinds, "__len__"):
        raise DenavitError(f"{where}: expected a list of {n} joint kinds ('revolute' or 'prismatic'), got {kinds!r}")
    if len(kinds) != n:
        raise DenavitError(
            f"{where}: expected {n} joint kinds (one per joint reading), got {len(kinds)}: {list(kinds)}"
        )
    for j, k in enumerate(kinds):
        if k not in ("revolute", "prismatic"):
            raise DenavitError(f"{where}: joint {j + 1}: expected 'revolute' or 'prismatic', got {k!r}")
    return tuple(kinds)


def row_where(source: str, where: list, i: int) -> str:
    """Where row ``i`` came from ("file:line"), else "source, row i+1"."""
    return where[i] if where and i < len(where) else f"{source}, row {i + 1}"


def check_finite(a: np.ndarray, what: str, source: str, where: list, cols: str | None = None) -> None:
    """A one-line error naming the first non-finite entry of ``a`` (rows = poses; ``cols`` "joint", "xyz" or None)."""
    bad = np.argwhere(~np.isfinite(a))
    if bad.size:
        i, j = bad[0]
        col = (
            f"{cols} {j + 1}"
            if cols == "joint"
            else (f"column {'xyz'[j]}" if cols == "xyz" and j < 3 else f"entry {j}")
        )
        raise DenavitError(
            f"{row_where(source, where, i)}: {what} must be finite, got {a[i, j]} ({col}); {len(bad)} non-finite"
            " value(s) in all"
        )
