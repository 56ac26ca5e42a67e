"""Joint sweeps: the measurements of circle-point identification (Hayat et al. sec. III.A).

A sweep moves one joint with the others locked at the home configuration and records a point on the
end-effector in the measurement frame. This module holds the data model (:class:`Sweep`, :class:`SweepSet`)
and the simulator used to plan measurements and to test; the file formats (long-form CSV, one file per
joint, JSON) are read and written by :mod:`denavit.io.sweeps`. Everything is SI (m, rad).
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass, field, replace

import numpy as np

from . import _core, limits
from .errors import DenavitError, check_seed
from .geometry import rotvec_matrix

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
    targets : (m, k, 3) every target measured at each pose (m; k = 2-4 SMRs on one nest, all on the last body),
        ``targets[:, 0]`` being ``points``; None: one target (``points``).
    rotations : (m, 3, 3) the measured orientation ``R_world_probe`` of a 6-DoF pose whose origin is ``points``
        (a 6-DoF probe, the controller's TCP), or None.
    payload : (m, 4) the payload on the flange at each point, ``[mass kg, x, y, z m]`` (its centre of mass in the flange
        frame; a sweep file's ``payload_mass`` columns, :mod:`denavit.calibration.compliance`), or None.
    """

    joint: int
    points: np.ndarray
    q: np.ndarray | None
    where: list[str] = field(default_factory=list)
    targets: np.ndarray | None = None
    rotations: np.ndarray | None = None
    payload: np.ndarray | None = None

    @property
    def n_targets(self) -> int:
        """Targets measured per pose (1 without ``targets``)."""
        return 1 if self.targets is None else self.targets.shape[1]

    def take(self, rows) -> Sweep:
        """The sweep at ``rows`` only (an index array or slice): points, readings, targets, rotations and ``where``."""
        w = self.where
        where = w[rows] if hasattr(w, "lines") else (list(np.asarray(w, dtype=object)[rows]) if len(w) else [])
        return replace(
            self,
            points=self.points[rows],
            q=None if self.q is None else self.q[rows],
            where=where,
            targets=None if self.targets is None else self.targets[rows],
            rotations=None if self.rotations is None else self.rotations[rows],
            payload=None if self.payload is None else self.payload[rows],
        )

    @property
    def moving(self) -> np.ndarray | None:
        """(m,) readings of the moving joint, or None."""
        return None if self.q is None else self.q[:, self.joint - 1]

    def __repr__(self) -> str:
        return (
            f"Sweep(joint {self.joint}, {len(self.points)} points, {'with' if self.q is not None else 'no'} joint"
            " readings)"
        )


@dataclass(frozen=True)
class SweepSet:
    """All sweeps of one measurement: n joints, the home configuration, the sources."""

    sweeps: list[Sweep]
    n_joints: int
    home: np.ndarray
    kinds: list[str]
    source: str = ""
    units: dict = field(default_factory=lambda: {"length": "m", "angle": "rad"})
    nest: np.ndarray | None = (
        None  # (k, 3) m: the targets' positions in the tool frame, when declared (several targets per pose)
    )

    def __post_init__(self):
        # one sweep per joint 1..n: a hand-built set missing one had raised IndexError, one with a sweep twice
        # had been identified with the other joint's axis silently missing
        joints = [s.joint for s in self.sweeps]
        wrong = {
            "missing sweeps of joint(s)": [j for j in range(1, self.n_joints + 1) if j not in joints],
            "a second sweep of joint(s)": sorted({j for j in joints if joints.count(j) > 1}),
            "sweeps of joint(s) out of range": [j for j in joints if not 1 <= j <= self.n_joints],
        }
        what = "; ".join(f"{k} {', '.join(map(str, v))}" for k, v in wrong.items() if v)
        if what:
            raise DenavitError(
                f"{self.source or 'sweeps'}: {what}: every joint 1..{self.n_joints} needs one sweep (got joints"
                f" {joints})"
            )
        if joints != sorted(
            joints
        ):  # in joint order: the fits are by position (a set built 1, 3, 2 had fitted joint 2 with joint 3's sweep)
            object.__setattr__(self, "sweeps", sorted(self.sweeps, key=lambda s: s.joint))
        k = {s.n_targets for s in self.sweeps}
        if len(k) > 1:
            raise DenavitError(
                f"{self.source or 'sweeps'}: sweeps with different numbers of targets per pose ({sorted(k)}): expected"
                " the same targets at every pose"
            )
        for s in self.sweeps:
            if s.targets is not None and (
                s.targets.ndim != 3
                or s.targets.shape[0] != len(s.points)
                or s.targets.shape[2] != 3
                or not np.array_equal(s.targets[:, 0], s.points)
            ):
                raise DenavitError(
                    f"{self.source or 'sweeps'}, joint {s.joint}: targets of shape {s.targets.shape}: expected"
                    f" ({len(s.points)}, k, 3) with the first target the points"
                )
            if s.rotations is not None and s.rotations.shape != (len(s.points), 3, 3):
                raise DenavitError(
                    f"{self.source or 'sweeps'}, joint {s.joint}: rotations of shape {s.rotations.shape}: expected"
                    f" ({len(s.points)}, 3, 3)"
                )
        if len({s.rotations is None for s in self.sweeps}) > 1:
            raise DenavitError(
                f"{self.source or 'sweeps'}: only some sweeps carry orientations: expected 6-DoF poses in every sweep"
                " or in none"
            )
        if self.nest is not None and np.shape(self.nest) != (self.n_targets, 3):
            raise DenavitError(
                f"{self.source or 'sweeps'}: nest of shape {np.shape(self.nest)}: expected ({self.n_targets}, 3), one"
                " point per target"
            )

    def __repr__(self) -> str:
        home = ", ".join(
            f"{v * 1e3:.4g} mm" if k == "prismatic" else f"{np.degrees(v):.4g}" for v, k in zip(self.home, self.kinds)
        )
        n_pts = sum(len(s.points) for s in self.sweeps)
        return (
            f"SweepSet({self.n_joints} joints, {len(self.sweeps)} sweeps, {n_pts} points,"
            f" {'with' if self.has_readings else 'no'} joint readings, home [{home}] deg, source {self.source or '-'})"
        )

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

    @property
    def n_targets(self) -> int:
        """Targets measured at every pose (:attr:`Sweep.targets`)."""
        return self.sweeps[0].n_targets if self.sweeps else 1

    @property
    def has_rotations(self) -> bool:
        """Whether every pose is a 6-DoF pose (:attr:`Sweep.rotations`)."""
        return bool(self.sweeps) and all(s.rotations is not None for s in self.sweeps)

    def target(self, k: int) -> SweepSet:
        """The sweeps of target ``k`` (0-based) alone, as a one-target set (the per-target fits of the consistency
        check)."""
        if not 0 <= k < self.n_targets:
            raise DenavitError(f"{self.source or 'sweeps'}: target {k + 1} out of range: expected 1..{self.n_targets}")
        if self.n_targets == 1:
            return replace(self, sweeps=[replace(s, rotations=None) for s in self.sweeps], nest=None)
        out = [
            replace(s, points=np.ascontiguousarray(s.targets[:, k]), targets=None, rotations=None) for s in self.sweeps
        ]
        return replace(self, sweeps=out, source=f"{self.source}, target {k + 1}", nest=None)


def merge_targets(sets: list[SweepSet], nest=None) -> SweepSet:
    """One sweep set with several targets per pose from one set per target of the same poses (same joints, readings
    and rows: e.g. three SMRs recorded as three point lists); ``nest`` (k, 3) m, optional: the targets' positions
    in the tool frame."""
    first = sets[0]
    for o in sets[1:]:
        if [len(s.points) for s in o.sweeps] != [len(s.points) for s in first.sweeps] or [
            s.joint for s in o.sweeps
        ] != [s.joint for s in first.sweeps]:
            raise DenavitError(
                f"{o.source}: not the poses of {first.source}: expected the same sweeps and rows for every target"
            )
    out = [
        replace(s, targets=np.stack([o.sweeps[i].points for o in sets], axis=1), rotations=None)
        for i, s in enumerate(first.sweeps)
    ]
    return replace(first, sweeps=out, nest=None if nest is None else np.asarray(nest, dtype=float))


def simulation(
    model: _core.Model,
    *,
    home,
    ranges,
    points_per_sweep: int = 30,
    tool_point=(0.05, 0.03, 0.10),
    noise: float = 0.0,
    noise_q: float = 0.0,
    seed: int = 0,
    targets=None,
    poses: bool = False,
    noise_rot: float = 0.0,
    rows: int | None = None,
) -> tuple[SweepSet, Iterator[Sweep]]:
    """:func:`simulate`'s sweeps a piece at a time, to write them as they are made (``denavit simulate``): (the set's
    shape: its joints, home, kinds and nest, each sweep with no points; the pieces, in order: sweeps of up to
    ``rows`` consecutive points of one sweep, default a whole sweep, with no ``where``). The same arguments and checks
    as :func:`simulate`, and the same numbers for a seed whatever ``rows``: a sweep's noise is drawn whole before its
    pieces, in the order :func:`simulate` has always drawn it (points, readings, orientations)."""
    n = model.nq
    home = limits.floats(home, "simulate: home")
    ranges = limits.floats(ranges, "simulate: ranges")
    if home.shape != (n,) or ranges.shape != (n, 2):
        raise DenavitError(f"simulate: expected home ({n},) and ranges ({n}, 2), got {home.shape} and {ranges.shape}")
    if (
        isinstance(points_per_sweep, (int, np.integer))
        and not isinstance(points_per_sweep, bool)
        and points_per_sweep < 3
    ):
        raise DenavitError(f"simulate: points_per_sweep must be >= 3, got {points_per_sweep}")
    points_per_sweep = limits.check_count(points_per_sweep, "simulate: points_per_sweep", "points", least=3)
    for name, value, unit in (("noise", noise, "m"), ("noise_q", noise_q, "rad or m"), ("noise_rot", noise_rot, "rad")):
        if not (np.isfinite(value) and value >= 0):  # NaN or a negative sigma had given exact data without a word
            raise DenavitError(f"simulate: {name} must be a finite sigma >= 0 in {unit}, got {value!r}")
    limits.check_joint_values(home, model.kinds, "simulate: home")
    limits.check_joint_values(ranges.T, model.kinds, "simulate: ranges")
    rng = np.random.default_rng(check_seed(seed))
    tools = np.atleast_2d(np.asarray(tool_point if targets is None else targets, dtype=float))
    if tools.ndim != 2 or tools.shape[1] != 3 or not 1 <= len(tools) <= 16:
        raise DenavitError(
            f"simulate: targets: expected (k, 3) points in the flange frame (m), got shape {tools.shape}"
        )
    limits.check_lengths(tools, "simulate: tool_point" if targets is None else "simulate: targets")
    limits.check_noise(noise, "simulate: noise", model, tools)
    if "revolute" in model.kinds:
        limits.check_angle_noise(noise_q, "simulate: noise_q (revolute joints)")
    if "prismatic" in model.kinds:
        limits.check_noise(noise_q, "simulate: noise_q (prismatic joints)", model, tools)
    limits.check_angle_noise(noise_rot, "simulate: noise_rot")
    flange = model.with_tool(np.eye(4))
    k = len(tools)
    shape = SweepSet(
        [
            Sweep(
                j + 1,
                np.zeros((0, 3)),
                np.zeros((0, n)),
                [],
                np.zeros((0, k, 3)) if k > 1 else None,
                np.zeros((0, 3, 3)) if poses else None,
            )
            for j in range(n)
        ],
        n,
        home,
        list(model.kinds),
        f"simulated {model.name}",
        {"length": "m", "angle": "rad"},
        tools if k > 1 else None,
    )
    step = points_per_sweep if rows is None else limits.check_count(rows, "simulate: rows", "points")
    sigmas = (noise, noise_q, noise_rot if poses else 0.0)
    return shape, _pieces(flange, home, ranges, points_per_sweep, tools, sigmas, poses, rng, step)


def _pieces(flange, home, ranges, m: int, tools, sigmas, poses: bool, rng, step: int) -> Iterator[Sweep]:
    """The pieces of :func:`simulation` (its docstring): per joint, the sweep's noise drawn whole, then ``step``
    points at a time their forward kinematics and noise."""
    n = len(home)
    noise, noise_q, noise_rot = sigmas
    for j in range(n):
        e_p = rng.normal(0.0, noise, (m, len(tools), 3)) if noise > 0 else None
        e_q = rng.normal(0.0, noise_q, (m, n)) if noise_q > 0 else None
        e_r = rng.normal(0.0, noise_rot, (m, 3)) if poses and noise_rot > 0 else None
        moving = np.linspace(ranges[j, 0], ranges[j, 1], m)
        for a in range(0, m, step):
            b = min(a + step, m)
            qs = np.tile(home, (b - a, 1))
            qs[:, j] = moving[a:b]
            T = _core.fk_batch(flange, qs)
            pts = np.stack([T[:, :3, :3] @ tool + T[:, :3, 3] for tool in tools], axis=1)
            pts = pts + e_p[a:b] if e_p is not None else pts
            rot = None
            if poses:
                rot = T[:, :3, :3] if e_r is None else rotvec_matrix(e_r[a:b]) @ T[:, :3, :3]
            yield Sweep(
                j + 1,
                np.ascontiguousarray(pts[:, 0]),
                qs + e_q[a:b] if e_q is not None else qs,
                [],
                pts if len(tools) > 1 else None,
                rot,
            )


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
    targets=None,
    poses: bool = False,
    noise_rot: float = 0.0,
) -> SweepSet:
    """Simulate sweeps of ``model``: joint j runs from ``ranges[j][0]`` to ``ranges[j][1]`` (rad / m,
    absolute joint values, as in Hayat Table II) with the others at ``home``; the tool point (m, in the
    flange frame, i.e. in ``T_flange_tool``'s parent frame: the flange, DH frame n for a DH robot) is recorded with
    Gaussian
    noise ``noise`` (m, per coordinate) and the readings with noise ``noise_q`` (rad / m).

    targets : (k, 3) m, optional -- several targets on the last body (flange frame; 2-4 SMRs on a nest), each
        recorded at every pose with its own noise (the first replaces ``tool_point``); the set's ``nest`` is them
        (the tool frame being the flange's orientation at the first target).
    poses : also record each pose's orientation (a 6-DoF probe whose frame is the flange's, at the tool point),
        with noise ``noise_rot`` (rad, a random rotation vector of that sigma per component).

    :func:`simulation` gives the same sweeps a piece at a time.
    """
    shape, pieces = simulation(
        model,
        home=home,
        ranges=ranges,
        points_per_sweep=points_per_sweep,
        tool_point=tool_point,
        noise=noise,
        noise_q=noise_q,
        seed=seed,
        targets=targets,
        poses=poses,
        noise_rot=noise_rot,
    )
    sweeps = [
        replace(s, where=[f"simulated sweep {s.joint}, point {k}" for k in range(len(s.points))]) for s in pieces
    ]  # one piece per sweep
    return replace(shape, sweeps=sweeps)
