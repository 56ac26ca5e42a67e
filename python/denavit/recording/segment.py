"""Segmentation (:func:`segment`): which joint moves when, the sweeps of a recording (:func:`to_sweepset`) and the
poses where it stood still (:func:`static_poses`)."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np

from ..errors import DenavitError
from ..sweeps import Sweep, SweepSet
from .data import Recording, _motion_signal, _noise, _window

# --- segmentation ---------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Segment:
    """One motion between two dwells: rows ``start`` .. ``stop - 1`` of the recording.

    joint : 1-based moving joint (without readings: the order of the circles). role : "sweep" or "transit"
    (to / from home, or a move not used). q_from / q_to : the moving joint's readings at the ends (SI) or nan.
    peak_speed : the largest speed in the motion (rad/s or m/s with readings, m/s of the point without).
    arc : the angle turned about the motion's axis (rad), from the readings or the fitted circle.
    """

    joint: int
    start: int
    stop: int
    t_start: float
    t_stop: float
    role: str
    q_from: float = math.nan
    q_to: float = math.nan
    peak_speed: float = math.nan
    arc: float = math.nan

    @property
    def rows(self) -> slice:
        return slice(self.start, self.stop)


@dataclass(frozen=True)
class Segmentation:
    """The motions of a recording; ``sweeps`` are the ones used, one per joint."""

    segments: list[Segment]
    method: str  # "readings", "geometry" or "labels"
    n_joints: int
    dwell_rows: int
    source: str
    kinds: list[str] | None = None

    @property
    def sweeps(self) -> list[Segment]:
        return [s for s in self.segments if s.role == "sweep"]

    def __repr__(self) -> str:
        return (
            f"Segmentation({self.source}, {self.method}: {len(self.sweeps)} sweeps, {len(self.segments)} motions,"
            f" {self.dwell_rows} dwell rows excluded)"
        )


DWELL_ROWS = 50


def _ends(
    x: np.ndarray, runs: list[tuple[int, int]], sigma: np.ndarray, k: float, joint_wise: bool
) -> list[tuple[int, int]]:
    """Each run's ends moved to where the rows leave the dwell before / after it by more than ``k`` sigma: rows
    still within the dwell's noise taken off (the derivative filter spreads a motion's start over half its window),
    rows beyond it added (the speed test misses the slow start and stop of a motion, where a point near its axis
    moves less per sample than the speed's noise). The dwell's level is the median of up to :data:`DWELL_ROWS` of
    its rows. ``joint_wise`` (readings): a row has left the dwell when one joint is beyond ``k`` sigma; else (points)
    when its distance from the dwell in noise units is beyond the quantile of the same false-alarm rate in as many
    dimensions (a direction-free test: the tracker's axes are arbitrary)."""
    from scipy.stats import chi2, norm  # noqa: PLC0415

    s = np.maximum(sigma, 1e-15)
    if joint_wise:

        def off(row, level):
            return bool(np.max(np.abs(row - level) / s) > k)

    else:
        kd = math.sqrt(float(chi2.isf(2 * norm.sf(k), x.shape[1])))

        def off(row, level):
            return bool(np.linalg.norm((row - level) / s) > kd)

    out, prev = [], 0
    bounds = [*runs, (len(x), len(x))]
    for (a, b), (na, _) in zip(runs, bounds[1:]):
        if a > prev:
            level = np.median(x[max(prev, a - DWELL_ROWS) : a], axis=0)
            while a > prev and off(x[a - 1], level):
                a -= 1
            while a < b and not off(x[a], level):
                a += 1
        if na > b:
            level = np.median(x[b : min(na, b + DWELL_ROWS)], axis=0)
            while b < na and off(x[b], level):
                b += 1
            while b > a and not off(x[b - 1], level):
                b -= 1
        if b > a:
            out.append((a, b))
            prev = b
    return out


def _closed(moving: np.ndarray, min_gap: int) -> np.ndarray:
    """``moving`` (N,) with its gaps shorter than ``min_gap`` rows closed."""
    from scipy.ndimage import binary_closing  # noqa: PLC0415

    if min_gap <= 1:
        return moving.copy()
    return binary_closing(np.r_[False, moving, False], structure=np.ones(min_gap, bool))[1:-1] | moving


def _by_joint(runs: list[tuple[int, int]], ratio: np.ndarray, min_points: int) -> list[tuple[int, int]]:
    """``runs`` split where the moving joint changes (readings; ``ratio`` (N, n) each joint's speed over its
    threshold): a pause shorter than the derivative filter's span leaves no still row between the motions of two
    joints. A row's joint is the one of the largest ratio among the rows that move; blocks of one joint shorter
    than ``min_points`` rows join the block before them (noise where two joints are both slow), and a run is cut
    between two blocks of different joints at the row of the smallest largest ratio (the pause)."""
    out = []
    for a, b in runs:
        r = ratio[a:b]
        top = r.max(axis=1)
        rows = np.flatnonzero(top > 1.0)
        raw: list[list[int]] = []  # [joint, first row, last row, rows] (rows of the run)
        for i, j in zip(rows.tolist(), np.argmax(r[rows], axis=1).tolist()):
            if raw and raw[-1][0] == j:
                raw[-1][2:] = [i, raw[-1][3] + 1]
            else:
                raw.append([j, i, i, 1])
        blocks: list[list[int]] = []
        for blk in raw:
            if blocks and (blk[3] < min_points or blocks[-1][0] == blk[0]):
                blocks[-1][2:] = [blk[2], blocks[-1][3] + blk[3]]
            else:
                blocks.append(blk)
        if len(blocks) > 1 and blocks[0][3] < min_points:
            first = blocks.pop(0)
            blocks[0][1] = first[1]
        start = a
        for prev, nxt in zip(blocks, blocks[1:]):
            if prev[0] != nxt[0]:
                cut = a + prev[2] + 1 + int(np.argmin(top[prev[2] + 1 : nxt[1] + 1]))
                out.append((start, cut))
                start = cut
        out.append((start, b))
    return out


def _dips(runs: list[tuple[int, int]], speed: np.ndarray, lim: float, depth: float = 0.25) -> list[tuple[int, int]]:
    """``runs`` cut at the rows where the speed dips deep: below ``depth`` times the lower of the two speed maxima
    that bound the dip (its prominence, as ``scipy.signal.find_peaks`` measures it: noise ripples on a slow start
    or stop are bounded by ripples, not by the motion's peak). A motion's speed rises and falls once; where one
    motion ends and the next begins after a short pause, or none, it falls to or nearly to zero between them.
    Each piece is trimmed to its rows that move (speed above ``lim``: a pause bridged in the run is no motion)."""
    from scipy.signal import find_peaks  # noqa: PLC0415

    out = []
    for a, b in runs:
        s = speed[a:b]
        minima, props = find_peaks(-s, prominence=0.0)
        cuts = [0] + [int(m) for m, p in zip(minima, props["prominences"]) if s[m] < depth * (s[m] + p)] + [b - a]
        for c0, c1 in zip(cuts, cuts[1:]):
            moving = np.flatnonzero(s[c0:c1] > lim)
            if len(moving):
                out.append((a + c0 + int(moving[0]), a + c0 + int(moving[-1]) + 1))
    return out


def _runs(moving: np.ndarray, min_gap: int, min_len: int) -> list[tuple[int, int]]:
    """[start, stop) of the runs of True, gaps shorter than ``min_gap`` closed, runs shorter than ``min_len``
    dropped."""
    from scipy.ndimage import label  # noqa: PLC0415

    lab, k = label(_closed(moving, min_gap))
    out = []
    for i in range(1, k + 1):
        idx = np.flatnonzero(lab == i)
        if len(idx) >= min_len:
            out.append((int(idx[0]), int(idx[-1]) + 1))
    return out


def segment(
    rec: Recording,
    *,
    ranges=None,
    n_joints: int | None = None,
    joints: Sequence[int] | None = None,
    threshold: float = 6.0,
    min_dwell: float = 0.25,
    smoothing: float = 0.1,
    min_points: int = 5,
    use_readings: bool = True,
    spans=None,
) -> Segmentation:
    """Split a continuous recording into motions and pick one sweep per joint.

    ranges : (n, 2) optional, the sweep of each joint from ``ranges[j][0]`` to ``ranges[j][1]`` (rad / m, as in
        :data:`denavit.sweeps.PAPER_RANGES_DEG` converted): with readings, the motion of the joint whose end
        readings are closest is its sweep; without, it is not used (the slowest motion is).
    n_joints : number of joints (default: from the readings, else the number of distinct circles).
    joints : without readings, the joint of each circle in recorded order (default 1, 2, ...).
    threshold : a row moves when a speed exceeds ``threshold`` times its noise (estimated from the data).
    min_dwell : s, shorter still spans inside one motion do not split it (a motion is one joint turning one way: with
        readings, of one joint; without, on one circle); between two joints' motions, or where a joint turns back,
        a motion ends however short the pause, or with none. smoothing : s, the derivative filter's span.
    min_points : shorter motions are ignored. use_readings : False segments from the geometry even when readings exist.
    spans : [(joint, t_start, t_stop), ...] (s) the user's sweeps, overriding all of the above (method "given").
    Rows labelled by the file (``rec.joint``) are used as they are (method "labels").
    """
    N = len(rec)
    if spans is not None:
        return _given(rec, spans, n_joints)
    if rec.joint is not None:
        return _labelled(rec, n_joints)
    if N < 3 * min_points:
        raise DenavitError(f"{rec.source}: {N} rows: too few to segment (expected at least {3 * min_points})")
    t, x, with_q, runs, lim, speed = _motions(
        rec,
        threshold=threshold,
        min_dwell=min_dwell,
        smoothing=smoothing,
        min_points=min_points,
        use_readings=use_readings,
    )
    if not runs:
        raise DenavitError(
            f"{rec.source}: nothing moves beyond the noise (speed threshold {float(np.max(lim)):.3g}): expected sweeps"
        )
    if with_q:
        segs = _by_readings(rec, t, runs, lim, speed)
        n, dwell = n_joints or rec.n_joints, N - sum(b - a for a, b in runs)
    else:
        segs, n, dwell = _by_circles(rec, t, x, runs, speed, min_dwell, n_joints, joints)
    segs = _pick_sweeps(segs, None if ranges is None or not with_q else ranges, speed, with_q)
    return Segmentation(segs, "readings" if with_q else "geometry", int(n), int(dwell), rec.source, rec.kinds)


def _given(rec: Recording, spans, n_joints: int | None) -> Segmentation:
    """:func:`segment` of the user's sweeps ``spans`` [(joint, t_start, t_stop), ...] (s): method "given"."""
    N = len(rec)
    t = rec.time if rec.time is not None else np.arange(N, dtype=float)
    segs = []
    for j, t0, t1 in spans:
        rows = np.flatnonzero((t >= t0) & (t <= t1))
        if len(rows) < 3:
            raise DenavitError(
                f"{rec.source}: the sweep of joint {j} at {t0:g}-{t1:g} s holds {len(rows)} rows: "
                f"expected at least 3 (the recording spans {t[0]:g}-{t[-1]:g} s)"
            )
        a, b = int(rows[0]), int(rows[-1]) + 1
        qf, qt = (float(rec.q[a, j - 1]), float(rec.q[b - 1, j - 1])) if rec.q is not None else (math.nan, math.nan)
        segs.append(Segment(int(j), a, b, float(t[a]), float(t[b - 1]), "sweep", qf, qt))
    return Segmentation(segs, "given", n_joints or rec.n_joints or max(s.joint for s in segs), 0, rec.source, rec.kinds)


def _labelled(rec: Recording, n_joints: int | None) -> Segmentation:
    """:func:`segment` of the rows labelled by the file (``rec.joint``), used as they are: method "labels"."""
    N = len(rec)
    segs = []
    cuts = np.flatnonzero(np.diff(rec.joint) != 0) + 1
    for a, b in zip(np.r_[0, cuts], np.r_[cuts, N]):
        j = int(rec.joint[a])
        if j <= 0:
            continue
        t0, t1 = (float(rec.time[a]), float(rec.time[b - 1])) if rec.time is not None else (float(a), float(b - 1))
        qf, qt = (float(rec.q[a, j - 1]), float(rec.q[b - 1, j - 1])) if rec.q is not None else (math.nan, math.nan)
        segs.append(Segment(j, int(a), int(b), t0, t1, "sweep", qf, qt))
    n = n_joints or (rec.n_joints or max(s.joint for s in segs))
    seen = [s.joint for s in segs]
    dup = sorted({j for j in seen if seen.count(j) > 1})
    if dup:
        second = [s for s in segs if s.joint == dup[0]][1]
        raise DenavitError(
            f"{rec.where[second.start]}: a second block of joint {dup[0]}'s rows: "
            "expected each joint's sweep in one block"
        )
    return Segmentation(segs, "labels", n, 0, rec.source, rec.kinds)


def _by_readings(rec: Recording, t: np.ndarray, runs, lim: np.ndarray, speed: np.ndarray) -> list[Segment]:
    """The motions ``runs`` of a recording with readings, each of the joint that moves most in it (all transits)."""
    segs = []
    for a, b in runs:
        d = np.abs(rec.q[b - 1] - rec.q[a])
        score = (speed[a:b] > lim).sum(axis=0)
        j = int(np.argmax(score))
        others = [i for i in range(rec.n_joints) if i != j and score[i] > 0.5 * (b - a)]
        if others:
            raise DenavitError(
                f"{rec.where[a]} .. {rec.where[b - 1]}: joints {j + 1} and "
                f"{', '.join(str(i + 1) for i in others)} move together: expected one joint at a time"
            )
        segs.append(
            Segment(
                j + 1,
                a,
                b,
                float(t[a]),
                float(t[b - 1]),
                "transit",
                float(rec.q[a, j]),
                float(rec.q[b - 1, j]),
                float(speed[a:b, j].max()),
                float(d[j]),
            )
        )
    return segs


def _by_circles(
    rec: Recording,
    t: np.ndarray,
    x: np.ndarray,
    runs,
    speed: np.ndarray,
    min_dwell: float,
    n_joints: int | None,
    joints: Sequence[int] | None,
) -> tuple[list[Segment], int, int]:
    """The motions ``runs`` of a recording without readings that follow a circle, pieces of one circle turning one
    way joined, numbered by distinct circle in recorded order (or by ``joints``): (segments, n_joints, dwell rows)."""
    from ..fitting import fit_axis  # noqa: PLC0415

    N = len(rec)

    def circle(a, b):
        try:
            return fit_axis(x[a:b], None, "kasa", where=f"{rec.where[a]} .. {rec.where[b - 1]}")
        except DenavitError:
            return None  # a straight, too short or out-and-back move: no circle

    def same_circle(f, g):
        return (
            abs(float(f.direction @ g.direction)) > math.cos(math.radians(3.0))
            and np.linalg.norm(np.cross(f.point - g.point, g.direction)) < 0.05 * max(f.radius, g.radius) + 1e-3
        )

    # _motions did not join motions across short still spans: pieces of one circle turning one way with a
    # still span shorter than min_dwell between them are one motion (a stutter); the motions of two joints,
    # or a joint turning back, stay apart however short the pause between them
    still = np.ones(N, bool)
    for a, b in runs:
        still[a:b] = False
    gap = max(1, int(round(min_dwell / float(np.median(np.diff(t))))))
    merged: list[tuple[int, int, object]] = []
    for a, b in runs:
        f = circle(a, b)
        if f is None:
            continue
        if merged:
            a0, b0, g = merged[-1]
            if still[b0:a].sum() < gap and same_circle(f, g) and float(f.direction @ g.direction) > 0:
                whole = circle(a0, b)
                if whole is not None:
                    merged[-1] = (a0, b, whole)
                    continue
        merged.append((a, b, f))
    dwell = N - sum(b - a for a, b, _ in merged)
    segs = []
    group, axis = 0, None
    for a, b, f in merged:
        if axis is None or not same_circle(f, axis):
            group, axis = group + 1, f
        segs.append(
            Segment(
                group,
                a,
                b,
                float(t[a]),
                float(t[b - 1]),
                "transit",
                peak_speed=float(speed[a:b, 0].max()),
                arc=float(f.arc),
            )
        )
    if not segs:
        raise DenavitError(
            f"{rec.source}: no motion of the points follows a circle ({len(runs)} motions): "
            "expected sweeps of one joint at a time"
        )
    n = n_joints or group
    if joints is not None:
        if len(joints) != group:
            raise DenavitError(
                f"{rec.source}: {group} distinct circles found but {len(joints)} joints given: "
                "expected one joint per circle in recorded order"
            )
        segs = [replace(s, joint=int(joints[s.joint - 1])) for s in segs]
    return segs, n, dwell


def _pick_sweeps(segs: list[Segment], ranges, speed: np.ndarray, with_q: bool) -> list[Segment]:
    """``segs`` with one sweep per joint, the rest transits: the motion whose end readings are closest to the
    joint's ``ranges`` row (with readings), else the slowest."""
    out = []
    ranges = None if ranges is None else np.asarray(ranges, dtype=float)
    for j in sorted({s.joint for s in segs}):
        mine = [k for k, s in enumerate(segs) if s.joint == j]
        if ranges is not None and j <= len(ranges):
            r = ranges[j - 1]
            pick = min(mine, key=lambda k: abs(segs[k].q_from - r[0]) + abs(segs[k].q_to - r[1]))
        else:
            # the slowest motion: by its median speed, so that a sweep joined to the faster transit that goes on
            # the same way after it (no pause) still counts as slow
            pick = min(
                mine,
                key=lambda k: float(np.median(speed[segs[k].start : segs[k].stop, segs[k].joint - 1 if with_q else 0])),
            )
        out.append(pick)
    return [replace(s, role="sweep" if k in out else "transit") for k, s in enumerate(segs)]


def _motions(
    rec: Recording,
    *,
    threshold: float,
    min_dwell: float,
    smoothing: float,
    min_points: int,
    use_readings: bool,
    sweeps: bool = True,
):
    """(time, signal, with readings, motion runs [(start, stop)], speed threshold, speed): the rows where the robot
    moves beyond the noise (estimated from the data), joined across still spans shorter than ``min_dwell``, their
    ends where the rows leave the dwell's noise (:func:`_ends`); the rest is dwell. ``sweeps`` (with readings): a
    motion is one joint turning one way (:func:`segment`); else any motion of the robot (:func:`static_poses`)."""
    N = len(rec)
    t = rec.time if rec.time is not None else np.arange(N, dtype=float)
    dt = float(np.median(np.diff(t)))
    w = _window(N, dt, smoothing)
    from scipy.signal import savgol_filter  # noqa: PLC0415

    with_q = rec.q is not None and use_readings
    x = rec.q if with_q else _motion_signal(rec)[0]
    v = savgol_filter(x, w, 2, deriv=1, delta=dt, axis=0)
    sigma_x, noise = _noise(x, w, dt)
    gap = max(1, int(round(min_dwell / dt)))
    if with_q:
        speed = np.abs(v)  # (N, n) per joint
        floor = 1e-3 * speed.max(axis=0)
        lim = np.maximum(threshold * noise, np.maximum(floor, 1e-12))
    if with_q and sweeps:
        # a still span shorter than min_dwell joins the motions on its sides only when they are one joint turning
        # one way (a stutter of one motion): between two joints, or where a joint turns back (a transit, then
        # the sweep), it ends a motion however short it is
        moving = np.zeros(N, bool)
        for j in range(x.shape[1]):
            for sign in (1.0, -1.0):
                moving |= _closed(sign * v[:, j] > lim[j], gap)
        runs = _by_joint(_runs(moving, 1, 1), speed / lim, min_points)
    elif with_q:
        runs = _runs((speed > lim).any(axis=1), gap, 1)
    else:
        speed = np.linalg.norm(v, axis=1)[:, None]
        lim = np.maximum(threshold * np.linalg.norm(noise), max(1e-3 * speed.max(), 1e-12))
        runs = _runs(speed[:, 0] > lim, gap, 1)
        if sweeps:
            # a short pause between two joints' motions, or none, is bridged above: cut where the speed dips deep
            # (segment() joins the pieces again where they are one circle turning one way)
            runs = _dips(runs, speed[:, 0], lim)
    runs = [(a, b) for a, b in _ends(x, runs, sigma_x, threshold, with_q) if b - a >= min_points]
    return t, x, with_q, runs, lim, speed


def static_poses(
    rec: Recording,
    *,
    target: int = 0,
    min_rows: int = 3,
    threshold: float = 6.0,
    min_dwell: float = 0.25,
    smoothing: float = 0.1,
):
    """The poses where the robot stood still: per dwell between motions of ``min_rows`` rows or more, the median
    joint readings and the median point of ``target`` (for calibration from a log of random poses).
    Returns (q (P, n), points (P, 3), where (P,) "file:line" of each dwell's middle row)."""
    if rec.q is None:
        raise DenavitError(f"{rec.source}: no joint readings: calibration needs the readings at each pose")
    if rec.points is None:
        raise DenavitError(f"{rec.source}: no measured points: calibration needs the measured tool point at each pose")
    N = len(rec)
    if rec.time is None or N < 3 * min_rows:
        rows = [(k, k + 1) for k in range(N)]  # a list of static measurements: every row a pose
    else:
        _, _, _, runs, _, _ = _motions(
            rec,
            threshold=threshold,
            min_dwell=min_dwell,
            smoothing=smoothing,
            min_points=3,
            use_readings=True,
            sweeps=False,
        )
        edges = [0, *[x for r in runs for x in r], N]
        rows = [(a, b) for a, b in zip(edges[::2], edges[1::2]) if b - a >= min_rows]
    if not rows:
        raise DenavitError(
            f"{rec.source}: the robot never stands still for {min_rows} rows: expected a log of poses with pauses"
        )
    q = np.array([np.median(rec.q[a:b], axis=0) for a, b in rows])
    pts = np.array([np.median(rec.points[a:b, target], axis=0) for a, b in rows])
    return q, pts, [rec.where[(a + b - 1) // 2] for a, b in rows]


def to_sweepset(
    rec: Recording,
    seg: Segmentation,
    *,
    target: int | None = None,
    tool_point=None,
    home=None,
    kinds: Sequence[str] | None = None,
    direction=1,
    max_points: int | None = None,
) -> SweepSet:
    """The sweeps of ``seg`` as a :class:`~denavit.sweeps.SweepSet`.

    target : which target (0-based) of ``rec.points`` is the swept point; None (default): every target (several per
        pose: :attr:`~denavit.sweeps.Sweep.targets`) and, for a recording of poses, their orientations
        (:attr:`~denavit.sweeps.Sweep.rotations`; not when every row has the same orientation, e.g. the identity of
        an SMR's tf: a point stream), one fit with shared axes in identify. tool_point : (3,) m, a point in the
    probe frame when the recording has poses (default its origin). home : (n,) SI, the locked configuration;
    default the median readings of each joint over the sweeps of the other joints; required without readings.
    direction : without readings, +1 or -1 (one for all or per joint): whether the joint value increased
    over its sweep (the point order then gives the axis orientation, as :func:`denavit.sweeps.read_joint_files`).
    max_points : keep at most this many rows per sweep, evenly spaced (a 1 kHz tracker gives thousands).
    """
    if rec.points is None:
        raise DenavitError(f"{rec.source}: no measured points: expected points or poses to make sweeps of")
    if target is not None and not 0 <= target < rec.n_targets:
        raise DenavitError(f"{rec.source}: target {target + 1} out of range: expected 1..{rec.n_targets} (1-based)")
    n = seg.n_joints
    picked = {s.joint: s for s in seg.sweeps}
    missing = [j for j in range(1, n + 1) if j not in picked]
    if missing:
        raise DenavitError(
            f"{rec.source}: no sweep of joint(s) {', '.join(map(str, missing))} found: expected one sweep of each joint"
            f" 1..{n} (found joints {sorted(picked)})"
        )
    if rec.poses is not None and tool_point is not None:
        tp = np.asarray(tool_point, dtype=float)
        pts = rec.poses[:, :3, :3] @ tp + rec.poses[:, :3, 3]
    else:
        pts = rec.points[:, target or 0]
    every = target is None and rec.n_targets > 1 and rec.poses is None
    rot = rec.poses[:, :3, :3] if target is None and rec.poses is not None else None
    if (
        rot is not None and np.max(np.ptp(rot, axis=0)) < 1e-9
    ):  # a constant orientation while the joints turn: a point stream (a tf of an SMR)
        rot = None
    kinds = list(kinds or rec.kinds or ["revolute"] * n)
    dirs = np.atleast_1d(np.asarray(direction, dtype=float))
    if dirs.ndim != 1 or dirs.size not in (1, n):
        raise DenavitError(
            f"{rec.source}: direction: expected 1 or {n} values (one per joint of the segmentation, {seg.method}), got"
            f" {dirs.size}"
        )
    dirs = np.broadcast_to(dirs, (n,))
    sweeps = []
    for j in range(1, n + 1):
        s = picked[j]
        rows = np.arange(s.start, s.stop)
        if max_points is not None and len(rows) > max_points:
            rows = rows[np.linspace(0, len(rows) - 1, max_points).round().astype(int)]
        if rec.q is None and dirs[j - 1] < 0:
            rows = rows[::-1]
        sweeps.append(
            Sweep(
                j,
                np.ascontiguousarray(pts[rows]),
                None if rec.q is None else rec.q[rows],
                [rec.where[i] for i in rows],
                rec.points[rows] if every else None,
                None if rot is None else rot[rows],
            )
        )
    if home is None:
        if rec.q is None:
            raise DenavitError(
                f"{rec.source}: no joint readings: the home configuration must be given (one value per joint)"
            )
        home = np.array(
            [
                np.median(np.concatenate([sw.q[:, i] for sw in sweeps if sw.joint != i + 1])) if n > 1 else 0.0
                for i in range(n)
            ]
        )
    home = np.asarray(home, dtype=float)
    if home.shape != (n,):
        raise DenavitError(f"{rec.source}: home: expected {n} values (one per joint), got {home.size}")
    return SweepSet(sweeps, n, home, kinds, rec.source, dict(rec.units) or {"length": "m", "angle": "rad"})
