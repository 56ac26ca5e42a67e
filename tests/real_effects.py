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

ARCSEC = math.radians(1 / 3600)


def recording(
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
    seed: int = 0,
) -> sw.SweepSet:
    """A simulated recording of ``model`` swept over ``ranges`` (rad, (n, 2)) about ``home`` (rad).

    reading_arcsec : (lo, hi) -- each joint's white reading error, drawn uniformly in lo..hi arcsec (1 sigma),
        on the moving joint's readings; None: exact readings.
    offset_deg, scale : per-joint reading offset (uniform +-offset_deg) and scale error (uniform +-scale).
    drift : RMS length (m) of a per-sweep translation of the whole sweep (the home pose drifting).
    locked_deg : (lo, hi) -- each locked joint sits (and reads) lo..hi deg off home, random sign, per sweep.
    coupled : (i, j) 1-based -- the reading of joint i is the joint angle minus joint j's motion (a Fanuc J3/J2).
    dwell : rows of standing still added at each end of every sweep (same configuration, fresh point noise).
    """
    rng = np.random.default_rng(seed)
    n = model.nq
    home = np.asarray(home, dtype=float)
    flange = model.with_tool(np.eye(4))
    tool = np.array([0.05, 0.03, 0.10])
    sig_q = np.zeros(n) if reading_arcsec is None else rng.uniform(*reading_arcsec, n) * ARCSEC
    offset = rng.uniform(-1, 1, n) * math.radians(offset_deg)
    sc = rng.uniform(-1, 1, n) * scale
    out = []
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
        p = T[:, :3, :3] @ tool + T[:, :3, 3]
        p = p + rng.normal(0.0, noise, p.shape)
        if drift:
            p = p + rng.normal(0.0, drift / math.sqrt(3), 3)
        read = q * (1 + sc) + offset
        read[:, j] += rng.normal(0.0, sig_q[j], m)
        if coupled is not None and coupled[1] - 1 == j:
            read[:, coupled[0] - 1] -= q[:, j] - home[j]
        out.append(sw.Sweep(j + 1, p, read, [f"recording sweep {j + 1}, row {k + 1}" for k in range(m)]))
    return sw.SweepSet(out, n, home * (1 + sc) + offset, list(model.kinds), f"recording of {model.name}", {"length": "m", "angle": "rad"})
