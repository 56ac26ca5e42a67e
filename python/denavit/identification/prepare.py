"""The sweeps made ready for the fits: locked joints, dwell rows, couplings undone, the per-sweep circle fits, the
motions."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import replace

import numpy as np

from ..errors import DenavitError
from ..fitting import fit_axis
from ..fitting.axis import axis_start
from ..fitting.circle import circle_misfit, robust_circle
from ..fitting.joint import TrackerNoise, stride
from ..fitting.motion import locked_motion
from ..fitting.robust import rms_spread, robust_sigma
from ..message import Length, Message
from ..progress import Stage
from ..sweeps import SweepSet

#: A locked joint whose reading leaves home by more than this during another joint's sweep gets a note
#: (rad for revolute joints, m for prismatic ones).
LOCKED_TOL = {"revolute": math.radians(0.1), "prismatic": 1e-4}


#: The share of an identification's work (for its progress) the per-sweep circle fits take before a joint fit of
#: every sweep, which takes most of the rest.
PER_SWEEP_SHARE = 0.3


def _locked_notes(sweeps: SweepSet) -> list[str]:
    """Notes on locked joints whose readings leave home beyond ``LOCKED_TOL`` (the fits use only the moving
    joint's readings and assume the others stayed at home)."""
    notes = []
    for s in sweeps.sweeps:
        if s.q is None:
            continue
        for i, kind in enumerate(sweeps.kinds):
            dev = s.q[:, i] - sweeps.home[i]
            k = int(np.argmax(np.abs(dev)))
            if i == s.joint - 1 or abs(dev[k]) <= LOCKED_TOL[kind]:
                continue
            scale, unit = (math.degrees(1), "deg") if kind == "revolute" else (1e3, "mm")
            at = f" at {s.where[k]}" if s.where else ""
            notes.append(
                f"{sweep_where(s, sweeps.source)}: locked joint {i + 1} reads {s.q[:, i].min() * scale:.4g} .."
                f" {s.q[:, i].max() * scale:.4g} {unit}, up to {abs(dev[k]) * scale:.3g} {unit} from its home"
                f" {sweeps.home[i] * scale:.4g} {unit}{at} (tolerance {LOCKED_TOL[kind] * scale:g} {unit}); the global"
                " fit follows the recorded readings (per-sweep fits use only the moving joint's): check the recording"
            )
    return notes


#: A point is still in the dwell at a sweep's end while it lies within this many point-noise sigmas (per
#: coordinate, times sqrt(1 + 1/k) for the noise of the mean of the k rows so far) of the mean of the dwell so
#: far (the norm of a 3-D Gaussian exceeds 5 sigma with probability 2e-5).
DWELL_SIGMAS = 5.0


def _dwell_rows(p: np.ndarray, noise: float) -> tuple[int, int]:
    """(rows standing still after the first, rows standing still before the last) of a sweep in time order:
    the run of points within ``DWELL_SIGMAS * noise`` of the running mean of the run (the first and last point
    of each run are the sweep's real ends and stay), when the sweep's pace would have carried that many rows beyond
    the tolerance (else the run is motion sampled finer than the noise)."""
    tol = DWELL_SIGMAS * noise

    def lead(x):
        # the first row that moved (rows 1..k-1 stand with row 0), looked for in leading pieces of growing length
        # (a run's test needs only the rows before it: a long sweep that moves at once is not scanned whole)
        n = 1024
        while True:
            y = x[: min(n, len(x))]
            m = len(y)
            run_mean = np.cumsum(y, axis=0) / np.arange(1, m + 1)[:, None]
            k = np.arange(1, m)  # the mean of k points has noise sigma / sqrt(k) of its own
            far = np.linalg.norm(y[1:] - run_mean[:-1], axis=1) > tol * np.sqrt(1 + 1 / k)
            if far.any():
                return int(np.argmax(far)) + 1
            if m == len(x):
                return m
            n *= 8

    a = lead(p) - 1
    b = lead(p[::-1]) - 1
    a, b = max(a, 0), max(b, 0)
    if a + b >= len(p) - 3:  # nothing moved: not a dwell to trim
        return 0, 0
    # a run is a stop only if motion at the sweep's pace could not have stayed within the tolerance that long:
    # densely sampled motion (a controller's 100 Hz-1 kHz) moves less than the noise from one row to the next, and
    # at constant pace v a run's newest point leads the run's mean by about half the run, k v / 2, so runs of up to
    # 2 tol / v rows stand "within the tolerance" while the robot moves (issue 40). The pace: the chord per row,
    # which never exceeds the arc's, so no motion is taken for a stop.
    pace = float(np.linalg.norm(p[-1] - p[0])) / max(len(p) - 1, 1)
    a = a if a * pace > 2 * tol else 0
    b = b if b * pace > 2 * tol else 0
    return a, b


def _drop_dwell(sweeps: SweepSet, notes: list[str]) -> SweepSet:
    """The sweeps without their dwell rows (found by :func:`_dwell_rows`, the noise from a trimmed circle or line
    fit, of every k-th point of a long sweep: :func:`~denavit.fitting.joint.stride`), with a note per sweep that had
    some (how many, which rows)."""
    out = []
    for s in sweeps.sweeps:
        p = s.points
        if sweeps.kinds[s.joint - 1] == "prismatic" or len(p) < 8:
            out.append(s)
            continue
        sub = p[:: stride(len(p))]  # (the noise of a long sweep from every k-th point)
        try:
            c, nv, r, _ = robust_circle(sub, "dwell check", sweep_where(s, sweeps.source))
        except DenavitError:
            out.append(s)
            continue
        e = circle_misfit(sub, c, nv, r)[0]
        noise = max(robust_sigma(e, 2), 1e-12 * rms_spread(sub))
        a, b = _dwell_rows(p, noise)
        if a + b == 0:
            out.append(s)
            continue
        keep = np.r_[0, a + 1 : len(p) - b - 1, len(p) - 1]
        name = s.where if s.where else [f"point {k}" for k in range(len(p))]
        parts = ([f"{a} at the start ({name[1]} .. {name[a]})"] if a else []) + (
            [f"{b} at the end ({name[len(p) - 1 - b]} .. {name[len(p) - 2]})"] if b else []
        )
        notes.append(
            Message(
                "{where}: {count} dwell rows (the motion stopped within {sigmas:g} sigma of the point noise,"
                " {noise:.2g}): {parts}; left out of the fit (keep_dwell keeps them)",
                where=sweep_where(s, sweeps.source),
                count=a + b,
                sigmas=DWELL_SIGMAS,
                noise=Length(noise),
                parts=" and ".join(parts),
            )
        )
        out.append(s.take(keep))
    return replace(sweeps, sweeps=out)


def decoupled(sweeps: SweepSet, coupling: np.ndarray) -> SweepSet:
    """The sweeps with joint values ``q = coupling @ reading`` for their readings and home (a robot file's
    ``[couplings]``, :func:`denavit.io.robotfile.parse_coupling`)."""
    C = np.asarray(coupling, dtype=float)
    out = [replace(s, q=None if s.q is None else s.q @ C.T) for s in sweeps.sweeps]
    return replace(sweeps, sweeps=out, home=C @ np.asarray(sweeps.home))


def sweep_where(s, source: str) -> str:
    """'file lines a-b, joint j' for messages about one sweep."""
    if not s.where:
        return f"{source}, joint {s.joint}"
    first, last = s.where[0], s.where[-1]
    if ":" in first and first.rsplit(":", 1)[1].isdigit():
        f, a = first.rsplit(":", 1)
        b = last.rsplit(":", 1)[1]
        return f"{f} lines {a}-{b}, joint {s.joint}"
    return f"{first} .. {last}, joint {s.joint}"


def _per_sweep(
    sweeps: SweepSet,
    method: str,
    loss: str,
    max_sigma: float | None,
    progress: Callable[[str], None],
    tracker: TrackerNoise | None = None,
) -> list:
    fits = []
    share = PER_SWEEP_SHARE if method == "global" else 0.85  # of the work: the joint fit follows, or the parameters
    for k, s in enumerate(sweeps.sweeps):
        where = sweep_where(s, sweeps.source)
        what = f"fitting sweep {k + 1} of {len(sweeps.sweeps)} (joint {s.joint}, {len(s.points)} points, {method})"
        progress(Stage(what, share * k / len(sweeps.sweeps)))
        q = s.moving
        if sweeps.kinds[s.joint - 1] == "prismatic":
            fm = "line"
        elif method in ("readings", "global"):
            fm = "readings" if method == "readings" else "hyper"  # the global fit starts from the hyper circles
            if q is None:
                raise DenavitError(
                    f"{where}: method '{method}' needs joint readings; this data has none (use geometric)"
                )
        else:
            fm = method
        robust = {"loss": loss} if fm in ("geometric", "readings") else {}
        if fm == "geometric" and tracker is not None:  # the tracker's noise model (the other per-sweep fits: isotropic)
            robust["tracker"] = tracker
        # oriented by the readings when there are some (increasing joint value, right-hand rule), else by the point
        # order
        if (
            method == "global" and fm == "hyper"
        ):  # the joint fit's start: its own covariance and outlier flags replace the circle's
            fits.append(axis_start(s.points, q, where=where))
            continue
        fits.append(fit_axis(s.points, q, fm, max_sigma_point=max_sigma, where=where, **robust))
    return fits


def _tool_point_geometric(sweeps: SweepSet, fits: list) -> np.ndarray:
    """Tool point at home without readings: the measured point closest to every other sweep's circle."""

    def dist_to_circle(p, f):
        rel = p - f.point
        h = rel @ f.direction
        r = np.linalg.norm(rel - np.outer(h, f.direction), axis=1)
        return np.hypot(h, r - (f.radius if np.isfinite(f.radius) else r))

    best, best_score = None, np.inf
    for s in sweeps.sweeps:
        score = sum(dist_to_circle(s.points, f) for f in fits)
        k = int(np.argmin(score))
        if score[k] < best_score:
            best, best_score = s.points[k], score[k]
    return np.asarray(best)


def _motions(sweeps: SweepSet, notes: list[str]) -> list:
    """Per sweep the joint motions from home the joint fit uses (:func:`~denavit.fitting.motion.locked_motion`),
    noting each locked reading that moves in lock-step with the swept joint (a coupling to declare)."""
    tol = np.array([LOCKED_TOL[k] / 100 for k in sweeps.kinds])
    out = []
    for s in sweeps.sweeps:
        dq, coupled = locked_motion(s.q, s.joint - 1, sweeps.home, tol)
        for i, slope in coupled:
            notes.append(
                f"{sweep_where(s, sweeps.source)}: the reading of joint {i + 1} moves in lock-step with joint"
                f" {s.joint}'s "
                f"({slope:+.3f} per unit): a coupling of the controller's readings to declare (as Fanuc controllers"
                " report J3: "
                "--coupling"
                f' "q{i + 1}=r{i + 1}{"+" if slope < 0 else "-"}'
                f'{format(abs(slope), ".4g") + "*" if abs(abs(slope) - 1) > 0.01 else ""}r{s.joint}",'
                " or the robot file's "
                f'[couplings] q{i + 1} = "r{i + 1} {"+" if slope < 0 else "-"} r{s.joint}"); the fit takes joint'
                f" {i + 1} as held at home"
            )
        out.append(dq)
    return out
