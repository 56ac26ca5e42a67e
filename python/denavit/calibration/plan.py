"""Planning a calibration before anything is measured: sweep protocols, the predicted uncertainty of every
parameter (the Cramér-Rao bound at the nominal model) and of every axis, and D-optimal pose selection."""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from .. import _core, limits
from ..errors import DenavitError
from ..fitting import (
    BoundingBox,
    fit_axis_with_readings,
    fit_line,
    oriented_bounding_box,
)
from ..fitting.result import axis_sigmas
from ..robot import robot_of
from ..sweeps import PAPER_HOME_DEG, PAPER_RANGES_DEG
from .identifiability import Identifiability, analyze, rank_reveal
from .least_squares import covariance, jacobian_rows, residuals, weights
from .measurements import Measurements, as_array, check_finite
from .parametrization import (
    Parametrization,
    configurations,
    parametrize,
    resolve_fix,
)


@dataclass(frozen=True)
class Protocol:
    """A sweep protocol: joint *j* runs from ``ranges[j][0]`` to ``ranges[j][1]`` (rad / m, absolute) with the
    others at ``home`` (Hayat et al. Table II), ``points_per_sweep`` points each; the tool point (m) in the
    flange frame."""

    home: np.ndarray
    ranges: np.ndarray
    points_per_sweep: int = 30
    tool_point: np.ndarray = field(default_factory=lambda: np.array([0.05, 0.03, 0.10]))

    def __repr__(self) -> str:
        r = np.asarray(self.ranges, dtype=float)
        return (
            f"Protocol({len(r)} sweeps of {self.points_per_sweep} points, ranges"
            f" {', '.join(f'{a:.4g}..{b:.4g}' for a, b in r)} (rad / m), tool point"
            f" [{', '.join(f'{v * 1e3:.4g}' for v in self.tool_point)}] mm)"
        )

    @classmethod
    def paper(cls, degrees: int = 30, points_per_sweep: int = 30, tool_point=(0.05, 0.03, 0.10)) -> Protocol:
        """Hayat et al.'s protocol (Table II, 90 or 30 degree ranges, home A1 90, A2 -90, A3 90, A4 0, A5 90, A6 0)."""
        if degrees not in PAPER_RANGES_DEG:
            raise DenavitError(f"paper protocol: expected 90 or 30 degrees, got {degrees}")
        return cls(
            np.radians(PAPER_HOME_DEG),
            np.radians(PAPER_RANGES_DEG[degrees]),
            points_per_sweep,
            np.asarray(tool_point, dtype=float),
        )

    def configurations(self) -> np.ndarray:
        """(n * points_per_sweep, n) configurations, sweep by sweep (as :func:`denavit.sweeps.simulate`)."""
        home = limits.floats(self.home, "protocol: home")
        ranges = limits.floats(self.ranges, "protocol: ranges")
        n = len(home)
        if ranges.shape != (n, 2):
            raise DenavitError(f"protocol: expected ranges of shape ({n}, 2), got {ranges.shape}")
        if self.points_per_sweep < 3:
            raise DenavitError(f"protocol: points_per_sweep must be >= 3, got {self.points_per_sweep}")
        limits.check_count(
            self.points_per_sweep, "protocol: points_per_sweep", "points", least=3, what="points per sweep"
        )
        limits.check_size(
            n * self.points_per_sweep, "poses", "protocol", f"poses ({n} sweeps x {self.points_per_sweep:,} points)"
        )
        out = []
        for j in range(n):
            qs = np.tile(home, (self.points_per_sweep, 1))
            qs[:, j] = np.linspace(ranges[j, 0], ranges[j, 1], self.points_per_sweep)
            out.append(qs)
        return np.vstack(out)


@dataclass(frozen=True, eq=False)
class Plan:
    """Predicted uncertainty of a measurement protocol, before anything is measured.

    Attributes
    ----------
    names : list of str
        Every parameter of the parametrisation.
    sigma : ndarray, shape (P,)
        Cramér-Rao bound (one sigma) of each parameter for the given noise (NaN: not estimated; see
        ``identifiability``).
    covariance : ndarray, (F, F) over ``free_names``.
    identifiability : Identifiability
    q : ndarray, (N, n)
        Configurations of the plan (after selection).
    points : ndarray, (N, 3)
        Predicted tool points (nominal model).
    selected : ndarray of int or None
        Indices into the candidate set, in the order chosen (D-optimal greedy).
    axis_sigma : ndarray, shape (n, 2)
        Per joint: bound of the axis position across the axis (m, at the foot of the reference tool point, as
        :attr:`denavit.fitting.AxisFit.sigma_point_perp`) and of its direction (rad), at ``q_ref``.
    per_circle_sigma : ndarray, shape (n, 2) or None
        The same bounds for one readings fit per sweep (:func:`denavit.fitting.fit_axis_with_readings`,
        the best per-circle method), when a protocol of sweeps is planned.
    """

    parametrization: Parametrization
    names: list
    sigma: np.ndarray
    free_names: list
    covariance: np.ndarray
    identifiability: Identifiability
    q: np.ndarray
    points: np.ndarray
    noise: float
    selected: np.ndarray | None
    q_ref: np.ndarray
    axis_sigma: np.ndarray
    per_circle_sigma: np.ndarray | None
    notes: list = field(default_factory=list)

    def __repr__(self) -> str:
        est = int(np.count_nonzero(np.isfinite(self.sigma)))
        return (
            f"Plan({self.parametrization.robot.name}, {self.parametrization.convention}, {len(self.q)} poses, noise"
            f" {self.noise * 1e3:.3g} mm, {est} of {len(self.names)} parameters identifiable)\n  worst axis sigma"
            f" {np.nanmax(self.axis_sigma[:, 0]) * 1e3:.3g} mm across,"
            f" {np.degrees(np.nanmax(self.axis_sigma[:, 1])):.3g} deg; {len(self.notes)} notes"
        )

    @cached_property
    def box(self) -> BoundingBox:
        """Minimum oriented bounding box of the measured points (the measuring volume), computed when first
        asked for."""
        return oriented_bounding_box(self.points)

    def value(self, name: str) -> float:
        return float(self.sigma[self.parametrization.index(name)])


def plan(
    nominal,
    protocol: Protocol | None = None,
    *,
    q=None,
    noise: float = 2e-5,
    noise_rot: float | None = None,
    convention: str = "edh",
    fix=(),
    measure: str = "point",
    tool=None,
    scale: bool = False,
    select: int | None = None,
) -> Plan:
    """Predict every parameter's sigma (Cramér-Rao bound) and the measuring volume of a protocol.

    Parameters
    ----------
    nominal : Robot, Model, built-in name or robot file
    protocol : Protocol, optional
        Sweeps (ranges, points per sweep, tool point). Or give ``q``:
    q : array_like, shape (N, n), optional
        Candidate configurations; with ``select=k`` the k most informative are chosen (greedy D-optimal:
        each step adds the pose that most increases ``log det`` of the information matrix of the
        column-normalised Jacobian; Fedorov 1972).
    noise : float
        One-sigma noise per point coordinate (m); ``noise_rot`` (rad) for pose measurements.
    convention, fix, measure, tool, scale
        As in :func:`calibrate`; ``tool`` defaults to the protocol's tool point.
    """
    robot = robot_of(nominal)
    if protocol is None and q is None:
        raise DenavitError("plan: give a protocol (sweep ranges) or candidate configurations q")
    if not noise > 0:
        raise DenavitError(f"plan: noise must be > 0 (m), got {noise}")
    limits.check_noise(
        noise, "plan: noise", robot.model(), protocol.tool_point if tool is None and protocol is not None else tool
    )
    if noise_rot is not None:
        limits.check_angle_noise(noise_rot, "plan: noise_rot")
    n = len(robot.names)
    if protocol is not None:
        Q = protocol.configurations()
        if Q.shape[1] != n:
            raise DenavitError(f"plan: the protocol has {Q.shape[1]} joints, {robot.name} has {n}")
        tool = protocol.tool_point if tool is None else tool
        q_ref = np.asarray(protocol.home, dtype=float)
    else:
        Q = as_array(q, "q", "plan")
        if Q.ndim != 2 or Q.shape[1] != n:
            raise DenavitError(f"plan: q must have shape (N, {n}), got {Q.shape}")
        check_finite(Q, "q", "plan", [], cols="joint")
        limits.check_size(len(Q), "poses", "plan: q", "configurations")
        q_ref = np.zeros(n)
    pz = parametrize(robot, convention, measure=measure, tool=tool, scale=scale)
    x = pz.x0
    sig_r = noise_rot if noise_rot is not None else noise
    w = weights(measure, noise, sig_r)
    user_fixed = resolve_fix(pz, fix)
    rule_fixed = {pz.index(nm) for nm in pz.rules}
    candidates = [c for c in range(pz.n_params) if c not in user_fixed and c not in rule_fixed]
    selected = None
    if select is not None:
        selected = select_poses(pz, Q, int(select), candidates=candidates, w=w)
        Q = Q[selected]
    poses, _ = pz.evaluate(x, Q, False)
    meas = Measurements(Q, None, poses, "plan") if measure == "pose" else Measurements(Q, poses[:, :3, 3], None, "plan")
    rich_q = configurations(robot, max(2 * pz.n_params, 60))
    rich_p, _ = pz.evaluate(x, rich_q, False)
    rich = (
        Measurements(rich_q, None, rich_p, "spread")
        if measure == "pose"
        else Measurements(rich_q, rich_p[:, :3, 3], None, "spread")
    )
    ana = analyze(pz, x, meas, candidates, w, analyze(pz, x, rich, candidates, w, explain=False))
    _, J, _ = residuals(pz, x, meas, w)
    free = ana.kept_idx
    cov = covariance(J[:, free], 1.0)
    sigma = np.full(pz.n_params, np.nan)
    sigma[free] = np.sqrt(np.clip(np.diag(cov), 0, None))
    axis_sigma = _axis_sigma(pz, x, free, cov, q_ref)
    per_circle = _per_circle(pz, protocol, noise) if protocol is not None else None
    notes = []
    if meas.n * (6 if measure == "pose" else 3) <= len(free):
        notes.append(f"{meas.n} poses give fewer equations than the {len(free)} identifiable parameters")
    return Plan(
        pz,
        list(pz.names),
        sigma,
        [pz.names[c] for c in free],
        cov,
        ana,
        Q,
        meas.points,
        noise,
        selected,
        q_ref,
        axis_sigma,
        per_circle,
        notes,
    )


def axis_lines(model: _core.Model, q_ref, p_ref) -> tuple[np.ndarray, np.ndarray]:
    """Joint axes at ``q_ref`` as (n, 3) points (the foot of the point ``p_ref`` on each axis, the circle
    centre of a sweep through it) and (n, 3) unit directions."""
    F = _core.joint_frames(model, q_ref)
    o, z = F[:, :3, 3], F[:, :3, 2]
    c = o + z * np.sum((p_ref - o) * z, axis=1)[:, None]
    return c, z


def _axis_sigma(pz: Parametrization, x, free: list, cov: np.ndarray, q_ref) -> np.ndarray:
    """Per joint: sigma of the axis position across itself (at the circle centre of the tool point at q_ref)
    and of its direction, by first-order propagation (central differences of the joint frames)."""
    n = pz.nq
    p_ref = pz.evaluate(x, q_ref[None], False)[0][0, :3, 3]
    _, base_z = axis_lines(pz.model(x), q_ref, p_ref)
    D = np.zeros((6 * n, len(free)))
    for k, c in enumerate(free):
        h = 1e-7
        xp, xm = np.array(x, dtype=float), np.array(x, dtype=float)
        xp[c] += h
        xm[c] -= h
        cp, zp = axis_lines(pz.model(xp), q_ref, p_ref)
        cm, zm = axis_lines(pz.model(xm), q_ref, p_ref)
        D[:, k] = np.hstack([cp - cm, zp - zm]).ravel() / (2 * h)
    C = D @ cov @ D.T
    out = np.zeros((n, 2))
    for j in range(n):  # the documented formula, one function for every fit and the plan
        out[j] = axis_sigmas(C[6 * j : 6 * j + 6, 6 * j : 6 * j + 6], base_z[j])
    return out


def _per_circle(pz: Parametrization, protocol: Protocol, noise: float) -> np.ndarray:
    """First-order axis bounds of one readings fit per noise-free simulated sweep."""
    n = pz.nq
    Q = protocol.configurations().reshape(n, protocol.points_per_sweep, n)
    out = np.full((n, 2), np.nan)
    for j in range(n):
        pts = pz.evaluate(pz.x0, Q[j], False)[0][:, :3, 3]
        if pz.robot.table.kinds[j] == "prismatic":
            f = fit_line(pts, q=Q[j][:, j], noise_sigma=noise)
        else:
            f = fit_axis_with_readings(pts, Q[j][:, j], noise_sigma=noise)
        out[j] = (f.sigma_point_perp, f.sigma_direction)
    return out


def select_poses(pz: Parametrization, q, k: int, *, candidates=None, w=None) -> np.ndarray:
    """Greedy D-optimal selection of ``k`` configurations from the candidate set ``q`` (N, n): each step adds
    the pose maximising ``log det(I + J_c M^-1 J_c^T)`` (the gain in ``log det M``, M the information matrix of
    the column-normalised Jacobian of the identifiable parameters, started at a small ridge). Returns the
    indices in the order chosen.

    Every candidate's ``S_c = I + J_c M^-1 J_c^T`` (rows x rows) is kept and updated by the Woodbury identity as
    each pose is added (``M^-1`` changes by a term of rank ``rows``, ``V V^T``): one pass over the candidates'
    Jacobians per step, O(N rows^2 p), instead of rebuilding every ``S_c`` from ``M^-1`` (O(N rows^2 p^2)).
    The candidates' Jacobians and ``S`` are held components first (the candidate index last and contiguous), so
    each update is a few BLAS products and whole-vector operations over the candidates.
    """
    Q = as_array(q, "q", "select")
    N = Q.shape[0]
    if not 1 <= k <= N:
        raise DenavitError(f"select: expected 1 <= k <= {N} (the number of candidates), got {k}")
    w = weights(pz.measure, 1.0, 1.0) if w is None else w
    cand = list(range(pz.n_params)) if candidates is None else list(candidates)
    rows = 6 if pz.measure == "pose" else 3
    J = jacobian_rows(pz, pz.x0, Q, w, cand)[1].reshape(N, rows, len(cand))
    kept, _, _, norms, _, _ = rank_reveal(J.reshape(-1, len(cand)), [cand.index(c) for c in pz.order if c in cand])
    # Jt[i, :, n]: row i of candidate n's column-normalised Jacobian
    Jt = np.ascontiguousarray(J[:, :, kept].transpose(1, 2, 0))
    del J
    Jt /= norms[kept][None, :, None]
    p = len(kept)
    ridge = 1e-6 * N * rows / max(p, 1)
    Minv = np.eye(p) / ridge
    S = np.empty((rows, rows, N))  # I + J_c M^-1 J_c^T at M = ridge I
    for i in range(rows):
        for j in range(i + 1):
            S[i, j] = np.einsum("pn,pn->n", Jt[i], Jt[j]) / ridge + (i == j)
            S[j, i] = S[i, j]
    chosen: list[int] = []
    avail = np.ones(N, dtype=bool)
    eye = np.eye(rows)
    for _ in range(k):
        gain = _logdet(S)
        gain[~avail] = -np.inf
        c = int(np.argmax(gain))
        chosen.append(c)
        avail[c] = False
        # M + J_c^T J_c: M^-1 - V V^T with V = M^-1 J_c^T L^-T, L L^T = I + J_c M^-1 J_c^T (Woodbury)
        Jc = Jt[:, :, c]
        U = Minv @ Jc.T
        V = np.linalg.solve(np.linalg.cholesky(eye + Jc @ U), U.T).T
        B = np.matmul(V.T, Jt)  # B[i, k, n] = (J_n V)[i, k]: one pass over the candidates
        for i in range(rows):
            for j in range(i + 1):
                d = B[i, 0] * B[j, 0]
                for m in range(1, rows):
                    d += B[i, m] * B[j, m]
                S[i, j] -= d
                if j != i:
                    S[j, i] -= d
        Minv -= V @ V.T
    return np.array(chosen)


def _logdet(S: np.ndarray) -> np.ndarray:
    """log det of each symmetric positive definite matrix of S (r, r, N), components first: the 3 x 3
    determinant in closed form (points), else numpy's slogdet."""
    if S.shape[0] != 3:
        return np.linalg.slogdet(S.transpose(2, 0, 1))[1]
    a, b, c = S[0, 0], S[0, 1], S[0, 2]
    d, e, f = S[1, 1], S[1, 2], S[2, 2]
    return np.log(a * (d * f - e * e) - b * (b * f - e * c) + c * (b * e - d * c))
