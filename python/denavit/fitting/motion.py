"""A sweep's joint motions from home as the joint fit reads them (:func:`locked_motion`, :class:`Motion`): the swept
joint by its readings, each locked joint by the straight line in time of its readings, without an (m, n) array per
sweep."""

from __future__ import annotations

import math

import numpy as np

#: A locked reading whose correlation with the swept joint's reading exceeds this (and which moves) is coupled.
COUPLED_CORRELATION = 0.99


class Motion:
    """A sweep's joint motions from home (m, n), rad (m for prismatic joints), as the swept joint's column (its
    readings less home) and each locked joint's straight line ``offset + slope t`` (``t`` the row less the middle
    row); rows read (``motion[rows]``, ``motion[rows, j]``, ``motion[:, i]``) come out dense, a chunk at a time,
    with the values an (m, n) array of them would hold."""

    def __init__(self, swept: np.ndarray, joint: int, lines: np.ndarray):
        self.swept, self.joint, self.lines = swept, joint, lines
        self.shape = (len(swept), len(lines))

    def __len__(self) -> int:
        return self.shape[0]

    def __getitem__(self, key) -> np.ndarray:
        rows, col = key if isinstance(key, tuple) else (key, None)
        m, n = self.shape
        if col == self.joint:
            return self.swept[rows]
        idx = np.arange(*rows.indices(m), dtype=float) if isinstance(rows, slice) else np.asarray(rows, dtype=float)
        t = idx - (m - 1) / 2
        if col is not None:
            off, slope = self.lines[col]
            return off + slope * t
        out = np.zeros((len(t), n))
        out[:, self.joint] = self.swept[rows]
        for i, (off, slope) in enumerate(self.lines):
            if i != self.joint:
                out[:, i] = off + slope * t
        return out


def locked_motion(q: np.ndarray, joint: int, home: np.ndarray, tol: np.ndarray):
    """Per-point joint motion from home (m, n) used by the fit (a :class:`Motion`), and the locked joints coupled to
    the swept one.

    The swept joint (0-based ``joint``) moves by its readings; a locked joint by the straight-line (time) fit of
    its readings, minus home; a locked reading that moves (range beyond ``tol``) in lock-step with the swept
    joint (correlation above ``COUPLED_CORRELATION``) is a coupling of the readings: taken as locked at home
    and returned in ``coupled`` as (joint, slope of its reading against the swept one).
    """
    m, n = q.shape
    lines = np.zeros((n, 2))
    t = np.arange(m, dtype=float) - (m - 1) / 2
    coupled = []
    sw = q[:, joint] - q[:, joint].mean()
    sw_moves = np.std(sw) > 0
    for i in range(n):
        if i == joint:
            continue
        qi = q[:, i]
        if np.ptp(qi) > tol[i] and sw_moves and np.std(qi) > 0:
            r = float(np.corrcoef(qi, sw)[0, 1])
            if abs(r) > COUPLED_CORRELATION:
                coupled.append((i, float(np.polyfit(sw, qi, 1)[0])))
                continue
        # offset and creep from home, each kept only where it exceeds three of its standard errors (else noise)
        off = qi.mean() - home[i]
        slope = float(t @ (qi - qi.mean()) / (t @ t)) if m > 2 else 0.0
        rest = qi - qi.mean() - slope * t
        se = math.sqrt(float(rest @ rest) / (m - 2)) if m > 2 else 0.0
        off = off if abs(off) > max(3 * se / math.sqrt(m), 1e-12) else 0.0  # (1e-12 rad / m: round-off)
        slope = slope if m > 2 and abs(slope) * m > max(3 * se * m / math.sqrt(t @ t), 1e-12) else 0.0
        lines[i] = off, slope
    return Motion(q[:, joint] - home[joint], joint, lines), coupled
