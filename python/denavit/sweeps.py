"""Joint sweeps: the measurements of circle-point identification (Hayat et al. sec. III.A).

A sweep moves one joint with the others locked at the home configuration and records a point on the
end-effector in the measurement frame. This module holds the data model (:class:`Sweep`, :class:`SweepSet`)
and the simulator used to plan measurements and to test; the file formats (long-form CSV, one file per
joint, JSON) are read and written by :mod:`denavit.io.sweeps`. Everything is SI (m, rad).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from . import _core
from .errors import DenavitError

# Hayat et al. Table II: range of motion given to each joint (deg), the paper's two protocols.
PAPER_RANGES_DEG = {
    90: [(-45.0, 45.0), (-60.0, -130.0), (120.0, 30.0), (90.0, 0.0), (90.0, 0.0), (0.0, 90.0)],
    30: [(-15.0, 15.0), (-60.0, -90.0), (120.0, 90.0), (90.0, 60.0), (90.0, 60.0), (0.0, 30.0)],
}
# Hayat et al. sec. III.A: the home configuration A1 90, A2 -90, A3 90, A4 0, A5 90, A6 0 (deg).
PAPER_HOME_DEG = [90.0, -90.0, 90.0, 0.0, 90.0, 0.0]


@dataclass(frozen=True)
class Sweep:
    """One joint moved with the others locked.

    joint : 1-based index of the moving joint.
    points : (m, 3) measured points in the measurement frame (m).
    q : (m, n) joint readings at each point (rad / m), or None when not recorded.
    where : (m,) where each point came from ("file:line"), for error messages.
    """

    joint: int
    points: np.ndarray
    q: np.ndarray | None
    where: list[str] = field(default_factory=list)

    @property
    def moving(self) -> np.ndarray | None:
        """(m,) readings of the moving joint, or None."""
        return None if self.q is None else self.q[:, self.joint - 1]

    def __repr__(self) -> str:
        return f"Sweep(joint {self.joint}, {len(self.points)} points, {'with' if self.q is not None else 'no'} joint readings)"


@dataclass(frozen=True)
class SweepSet:
    """All sweeps of one measurement: n joints, the home configuration, the sources."""

    sweeps: list[Sweep]
    n_joints: int
    home: np.ndarray
    kinds: list[str]
    source: str = ""
    units: dict = field(default_factory=lambda: {"length": "m", "angle": "rad"})

    def __post_init__(self):
        # one sweep per joint 1..n: a hand-built set missing one had raised IndexError, one with a sweep twice
        # had been identified with the other joint's axis silently missing
        joints = [s.joint for s in self.sweeps]
        wrong = {"missing sweeps of joint(s)": [j for j in range(1, self.n_joints + 1) if j not in joints],
                 "a second sweep of joint(s)": sorted({j for j in joints if joints.count(j) > 1}),
                 "sweeps of joint(s) out of range": [j for j in joints if not 1 <= j <= self.n_joints]}
        what = "; ".join(f"{k} {', '.join(map(str, v))}" for k, v in wrong.items() if v)
        if what:
            raise DenavitError(f"{self.source or 'sweeps'}: {what}: every joint 1..{self.n_joints} needs one sweep (got joints {joints})")
        if joints != sorted(joints):  # in joint order: the fits are by position (a set built 1, 3, 2 had fitted joint 2 with joint 3's sweep)
            object.__setattr__(self, "sweeps", sorted(self.sweeps, key=lambda s: s.joint))

    def __repr__(self) -> str:
        home = ", ".join(f"{v * 1e3:.4g} mm" if k == "prismatic" else f"{np.degrees(v):.4g}" for v, k in zip(self.home, self.kinds))
        n_pts = sum(len(s.points) for s in self.sweeps)
        return (f"SweepSet({self.n_joints} joints, {len(self.sweeps)} sweeps, {n_pts} points, {'with' if self.has_readings else 'no'} joint readings, "
                f"home [{home}] deg, source {self.source or '-'})")

    def sweep(self, joint: int) -> Sweep:
        for s in self.sweeps:
            if s.joint == joint:
                return s
        raise DenavitError(f"{self.source}: no sweep of joint {joint}")

    @property
    def all_points(self) -> np.ndarray:
        return np.vstack([s.points for s in self.sweeps])

    @property
    def has_readings(self) -> bool:
        return all(s.q is not None for s in self.sweeps)


def simulate(
    model: _core.Model,
    *,
    home,
    ranges,
    points_per_sweep: int = 30,
    tool_point=(0.05, 0.03, 0.10),
    noise: float = 0.0,
    noise_q: float = 0.0,
    seed: int = 0,
) -> SweepSet:
    """Simulate sweeps of ``model``: joint j runs from ``ranges[j][0]`` to ``ranges[j][1]`` (rad / m,
    absolute joint values, as in Hayat Table II) with the others at ``home``; the tool point (m, in the
    flange frame, i.e. in ``T_flange_tool``'s parent frame: the flange, DH frame n for a DH robot) is recorded with Gaussian
    noise ``noise`` (m, per coordinate) and the readings with noise ``noise_q`` (rad / m).
    """
    n = model.nq
    home = np.asarray(home, dtype=float)
    ranges = np.asarray(ranges, dtype=float)
    if home.shape != (n,) or ranges.shape != (n, 2):
        raise DenavitError(f"simulate: expected home ({n},) and ranges ({n}, 2), got {home.shape} and {ranges.shape}")
    if points_per_sweep < 3:
        raise DenavitError(f"simulate: points_per_sweep must be >= 3, got {points_per_sweep}")
    rng = np.random.default_rng(seed)
    tool = np.asarray(tool_point, dtype=float)
    flange = model.with_tool(np.eye(4))
    sweeps = []
    for j in range(n):
        qs = np.tile(home, (points_per_sweep, 1))
        qs[:, j] = np.linspace(ranges[j, 0], ranges[j, 1], points_per_sweep)
        T = _core.fk_batch(flange, qs)
        pts = T[:, :3, :3] @ tool + T[:, :3, 3]
        pts = pts + rng.normal(0.0, noise, pts.shape) if noise > 0 else pts
        readings = qs + rng.normal(0.0, noise_q, qs.shape) if noise_q > 0 else qs
        sweeps.append(Sweep(j + 1, pts, readings, [f"simulated sweep {j + 1}, point {k}" for k in range(points_per_sweep)]))
    return SweepSet(sweeps, n, home, list(model.kinds), f"simulated {model.name}", {"length": "m", "angle": "rad"})
