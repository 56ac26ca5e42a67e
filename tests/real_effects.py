"""Simulated recordings with the effects of real ones (/work/shared/ANCHORS.md, "What real recordings look like"),
for the identification tests and benchmarks/bench_identify.py.

:func:`denavit.sweeps.simulate` gives exact sweeps (optionally white point / reading noise on every joint); real
controllers and trackers add: reading errors of the moving joint of 30-200 arcsec (white) with a per-joint offset
and scale error, a home pose that drifts between sweeps (0.2 mm), locked joints that sit 0.001-0.005 deg off
home (and read so), a coupled reading (Fanuc: the J3 reading moves against J2 while J3 stays), and dwell rows
(the robot standing still at both ends of a sweep).
"""

from __future__ import annotations

import math

import numpy as np

from denavit import _core
from denavit import sweeps as sw
from denavit.fitting.joint import as_tracker_noise
from denavit.geometry import rotvec_matrix

ARCSEC = math.radians(1 / 3600)
#: The target (tool point) in the flange frame (m), and the further targets of a nest of SMRs on one body.
TOOL = (0.05, 0.03, 0.10)
NEST = (TOOL, (-0.04, 0.06, 0.08), (0.03, -0.07, 0.13), (0.0, 0.0, 0.16))


def recording(model, home, ranges, **kw) -> sw.SweepSet:
    """:func:`recordings` of the one target ``TOOL``."""
    return recordings(model, home, ranges, **kw)[0]


def recordings(
    model,
    home,
    ranges,
    *,
    points: int = 40,
    noise: float = 2e-5,
    reading_arcsec=None,
    offset_deg: float = 0.0,
    scale: float = 0.0,
    drift: float = 0.0,
    locked_deg=None,
    coupled=None,
    dwell: int = 0,
    targets=(TOOL,),
    poses: bool = False,
    noise_rot: float = 1e-4,
    tracker_noise=None,
    seed: int = 0,
) -> list[sw.SweepSet]:
    """Simulated recordings of ``model`` swept over ``ranges`` (rad, (n, 2)) about ``home`` (rad), one per target.

    reading_arcsec : (lo, hi) -- each joint's white reading error, drawn uniformly in lo..hi arcsec (1 sigma),
        on the moving joint's readings; None: exact readings.
    offset_deg, scale : per-joint reading offset (uniform +-offset_deg) and scale error (uniform +-scale).
    drift : RMS length (m) of a per-sweep translation of the whole sweep (the home pose drifting).
    locked_deg : (lo, hi) -- each locked joint sits (and reads) lo..hi deg off home, random sign, per sweep.
    coupled : (i, j) 1-based -- the reading of joint i is the joint angle minus joint j's motion (a Fanuc J3/J2).
    dwell : rows of standing still added at each end of every sweep (same configuration, fresh point noise).
    targets : points on the last body (flange frame, m; e.g. ``NEST[:3]``) measured at every pose with their own
        tracker noise, under the same motion, readings and drift: one SweepSet per target (the first target's
        draws are those of a recording of it alone).
    poses : the first target is a 6-DoF probe: its sweeps carry the measured orientation (the flange's) with noise
        ``noise_rot`` (rad per component of a rotation vector, drawn after everything else).
    tracker_noise : a :class:`denavit.fitting.joint.TrackerNoise` (or (sigma_range m, sigma_angle rad[, position m])):
        the tracker's range/angle noise instead of the isotropic ``noise``: the same standard normal draws, their
        component along the line of sight from the tracker to the true point times sigma_range, across it times
        sigma_angle times the range.
    """
    rng = np.random.default_rng(seed)
    tracker = as_tracker_noise(tracker_noise)
    n = model.nq
    home = np.asarray(home, dtype=float)
    flange = model.with_tool(np.eye(4))
    tools = np.asarray(targets, dtype=float)
    sig_q = np.zeros(n) if reading_arcsec is None else rng.uniform(*reading_arcsec, n) * ARCSEC
    offset = rng.uniform(-1, 1, n) * math.radians(offset_deg)
    sc = rng.uniform(-1, 1, n) * scale
    out = [[] for _ in tools]
    for j in range(n):
        q = np.tile(home, (points, 1))
        q[:, j] = np.linspace(ranges[j][0], ranges[j][1], points)
        if locked_deg is not None:
            off = rng.uniform(*locked_deg, n) * rng.choice([-1.0, 1.0], n)
            off[j] = 0.0
            q = q + np.radians(off)
        if dwell:
            q = np.vstack([np.repeat(q[:1], dwell, axis=0), q, np.repeat(q[-1:], dwell, axis=0)])
        m = len(q)
        T = _core.fk_batch(flange, q)
        ps = [T[:, :3, :3] @ tool + T[:, :3, 3] for tool in tools]
        if tracker is None:
            ps = [
                p + (rng if k == 0 else np.random.default_rng([seed, j, k])).normal(0.0, noise, p.shape)
                for k, p in enumerate(ps)
            ]
        else:
            ps = [
                p
                + _tracker_draw(
                    tracker, p, (rng if k == 0 else np.random.default_rng([seed, j, k])).normal(0.0, 1.0, p.shape)
                )
                for k, p in enumerate(ps)
            ]
        if drift:
            d = rng.normal(0.0, drift / math.sqrt(3), 3)
            ps = [p + d for p in ps]
        read = q * (1 + sc) + offset
        read[:, j] += rng.normal(0.0, sig_q[j], m)
        if coupled is not None and coupled[1] - 1 == j:
            read[:, coupled[0] - 1] -= q[:, j] - home[j]
        rot = None
        if poses:
            rot = rotvec_matrix(np.random.default_rng([seed, j, 99]).normal(0.0, noise_rot, (m, 3))) @ T[:, :3, :3]
        for k, p in enumerate(ps):
            out[k].append(
                sw.Sweep(
                    j + 1,
                    p,
                    read,
                    [f"recording sweep {j + 1}, row {r + 1}" for r in range(m)],
                    None,
                    rot if k == 0 else None,
                )
            )
    return [
        sw.SweepSet(
            o,
            n,
            home * (1 + sc) + offset,
            list(model.kinds),
            f"recording of {model.name}" + (f", target {k + 1}" if len(tools) > 1 else ""),
            {"length": "m", "angle": "rad"},
        )
        for k, o in enumerate(out)
    ]


def _tracker_draw(tracker, p: np.ndarray, z: np.ndarray) -> np.ndarray:
    """The tracker's noise at the true points p (m, 3) from standard normal draws z (m, 3): along the line of sight
    times sigma_range, across it times sigma_angle times the range."""
    u, va, vb = tracker.shape(p.T)
    zu = np.einsum("im,mi->m", u, z)
    along = zu[:, None] * u.T
    return along * np.sqrt(va)[:, None] + (z - along) * np.sqrt(vb)[:, None]


#: chi2.ppf(0.99, k) (scipy.stats): the 99 % level of a chi-square with k degrees of freedom.
CHI2_99 = {2: 9.210340371976182, 3: 11.344866730144373, 4: 13.276704135987622}


def axis_chi2(a, b, kind: str = "revolute") -> tuple[float, int]:
    """(chi-square, degrees of freedom) of the difference of two fits of one axis (AxisFit ``a`` and ``b``, e.g.
    from two targets on one body) against their combined covariance (taken as independent): the lines compared
    across ``a``'s direction at ``a.point`` (position 2, direction 2; a prismatic axis: its direction only)."""
    from denavit.geometry import perpendicular_basis  # noqa: PLC0415

    n = a.direction
    u, v = perpendicular_basis(n)
    t = float((a.point - b.point) @ b.direction)
    J = np.eye(6)
    J[:3, 3:] = t * np.eye(3)  # b's line carried along itself to the foot of a.point
    cb = J @ b.cov @ J.T
    d = np.concatenate([b.point + t * b.direction - a.point, b.direction - n])
    P = np.zeros((4, 6))
    P[0, :3], P[1, :3], P[2, 3:], P[3, 3:] = u, v, u, v
    if kind == "prismatic":
        P = P[2:]
    S = P @ (a.cov + cb) @ P.T
    r = P @ d
    return float(r @ np.linalg.solve(S, r)), len(r)
