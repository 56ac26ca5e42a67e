"""The time alignment of two clocks (:func:`align`, :func:`estimate_offset`): the offset, and a drift when the data ask
for it, estimated from the motion itself (the package docstring says how)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import DenavitError
from .data import Recording, _motion_signal, _noise, _window
from .segment import segment


def _speed_on_grid(t: np.ndarray, x: np.ndarray, dt: float, span: float) -> tuple[np.ndarray, np.ndarray]:
    """Uniform grid (step ``dt``) over ``t`` and the smoothed speed |dx/dt| on it."""
    from scipy.interpolate import make_interp_spline  # noqa: PLC0415
    from scipy.ndimage import label  # noqa: PLC0415
    from scipy.signal import savgol_filter  # noqa: PLC0415

    grid = np.arange(t[0], t[-1], dt)
    xs = make_interp_spline(t, x, k=1)(grid)
    w = _window(len(grid), dt, span)
    v = savgol_filter(xs, w, 2, deriv=1, delta=dt, axis=0)
    speed = np.linalg.norm(v.reshape(len(grid), -1), axis=1)
    # each motion scaled to a unit peak: a point's speed is its joint's speed times a radius that differs from
    # joint to joint, so only the shape of each motion is common to the two streams
    noise = float(np.linalg.norm(_noise(xs.reshape(len(grid), -1), w, dt)[1]))
    runs, k = label(speed > max(6.0 * noise, 1e-3 * float(speed.max())))
    out = np.zeros_like(speed)
    for i in range(1, k + 1):
        sel = runs == i
        out[sel] = speed[sel] / speed[sel].max()
    return grid, out


def _corr(a: np.ndarray, b: np.ndarray) -> float:
    """Pearson correlation coefficient of two equal-length series (0 when one is constant)."""
    a, b = a - a.mean(), b - b.mean()
    den = math.sqrt(float(a @ a) * float(b @ b))
    return float(a @ b) / den if den > 0 else 0.0


@dataclass(frozen=True)
class Alignment:
    """Clock relation of a readings stream to a points stream: ``t_readings = t_points + offset + drift (t_points -
    t_ref)``.

    offset, sigma : s; drift, drift_sigma : s/s (0 when the data does not ask for one); t_ref : s (points clock);
    peak : correlation coefficient of the speed profiles at the offset; windows : number of window estimates;
    dropped : rows of the points stream outside the readings' time span (not in the result).
    """

    offset: float
    sigma: float
    drift: float
    drift_sigma: float
    t_ref: float
    peak: float
    windows: int
    dropped: int = 0

    def readings_time(self, t_points) -> np.ndarray:
        return (
            np.asarray(t_points, dtype=float)
            + self.offset
            + self.drift * (np.asarray(t_points, dtype=float) - self.t_ref)
        )

    def __str__(self) -> str:
        s = (
            f"clock offset {self.offset * 1e3:.3f} ms +- {self.sigma * 1e3:.3f} ms (readings minus points,"
            f" {self.windows} windows, correlation {self.peak:.3f})"
        )
        if self.drift:
            s += f", drift {self.drift * 1e6:.1f} +- {self.drift_sigma * 1e6:.1f} ppm"
        return s + (f"; {self.dropped} point rows outside the readings dropped" if self.dropped else "")


#: Below this correlation coefficient of the speed profiles the two clocks are not aligned (the motions differ).
MIN_CORRELATION = 0.5


def estimate_offset(
    points: Recording,
    readings: Recording,
    *,
    max_offset: float | None = None,
    window: float | None = 10.0,
    drift: bool | None = None,
) -> Alignment:
    """Estimate the clock offset (and drift) of ``readings`` relative to ``points`` from their motion.

    points : a Recording with points (or poses) and time; readings : a Recording with joint readings and time.
    max_offset : s, optional bound on |offset| (default: any). window : s, length of the windows whose lag
    estimates give the uncertainty and the drift (None: no windows, the uncertainty is the grid step's). drift : True to
    always fit one, False never, None (default)
    when the window lags show a slope beyond 3 sigma.
    """
    from scipy.interpolate import make_interp_spline  # noqa: PLC0415
    from scipy.optimize import minimize_scalar  # noqa: PLC0415
    from scipy.signal import correlate, correlation_lags  # noqa: PLC0415

    for rec, what in ((points, "points"), (readings, "joint readings")):
        if rec.time is None or len(rec) < 10:
            raise DenavitError(
                f"{rec.source}: cannot align clocks: the {what} need a time column and at least 10 rows, got {len(rec)}"
                f" rows{' without time' if rec.time is None else ''}"
            )
    if readings.q is None:
        raise DenavitError(f"{readings.source}: cannot align clocks: expected joint readings, the recording has none")
    tp, xp = points.time, _motion_signal(points)[0]
    tr, xr = readings.time, readings.q
    dt = min(float(np.median(np.diff(tp))), float(np.median(np.diff(tr))), 2e-3)
    dt = max(dt, 2e-4)
    span = 0.05
    gp, sp = _speed_on_grid(tp, xp, dt, span)
    gr, sr = _speed_on_grid(tr, xr, dt, span)
    za, zb = (sp - sp.mean()) / (sp.std() or 1.0), (sr - sr.mean()) / (sr.std() or 1.0)
    c = correlate(zb, za, mode="full", method="fft")
    lags = correlation_lags(len(zb), len(za), mode="full")
    shifts = gr[0] - gp[0] + lags * dt  # offset candidates: reading time of point-grid sample 0
    # normalise by the overlap so that partial overlaps at the ends do not win
    overlap = (np.minimum(len(za), len(zb) - lags) - np.maximum(0, -lags)).astype(float)
    ok = overlap >= 0.5 * min(len(za), len(zb))
    if max_offset is not None:
        ok &= np.abs(shifts) <= max_offset
    if not ok.any():
        raise DenavitError(
            f"{points.source} and {readings.source}: cannot align clocks: the recordings do not overlap by half of the"
            " shorter one within the allowed offset"
        )
    score = np.where(ok, c / np.maximum(overlap, 1.0), -np.inf)
    coarse = float(shifts[int(np.argmax(score))])
    spline = make_interp_spline(gr, sr, k=3)

    def coefficient(tau: float, sel=slice(None)) -> float:
        g = gp[sel]
        t = g + tau
        inside = (t >= gr[0]) & (t <= gr[-1])
        if inside.sum() < 10:
            return 0.0
        return _corr(sp[sel][inside], spline(t[inside]))

    def refine(tau0: float, sel=slice(None)) -> tuple[float, float]:
        res = minimize_scalar(
            lambda tau: -coefficient(tau, sel),
            bounds=(tau0 - 3 * dt, tau0 + 3 * dt),
            method="bounded",
            options={"xatol": dt * 1e-3},
        )
        return float(res.x), -float(res.fun)

    tau, peak = refine(coarse)
    if peak < MIN_CORRELATION:
        raise DenavitError(
            f"{points.source} and {readings.source}: cannot align clocks: the speed profiles correlate at {peak:.2f} at"
            f" best (offset {coarse * 1e3:.1f} ms), expected at least {MIN_CORRELATION}: are both recordings of the"
            " same motion?"
        )
    # windows: the scatter of local lags gives the uncertainty, their trend the drift
    edges = np.arange(gp[0], gp[-1] + 1e-12, window) if window else []
    centres, taus = [], []
    activity = sp.std()
    for a in edges:
        sel = (gp >= a) & (gp < a + window)
        if sel.sum() < 20 or sp[sel].std() < 0.1 * activity:
            continue
        tw, cw = refine(tau, sel)
        if cw >= MIN_CORRELATION:
            centres.append(float(gp[sel].mean()))
            taus.append(tw)
    centres, taus = np.array(centres), np.array(taus)
    t_ref = float(np.mean(centres)) if len(centres) else float(gp.mean())
    tau = float(tau)
    slope, slope_sigma, sigma = 0.0, 0.0, dt / math.sqrt(12.0)
    if len(taus) >= 3:
        A = np.column_stack([np.ones_like(centres), centres - t_ref])
        sol, *_ = np.linalg.lstsq(A, taus, rcond=None)
        res = taus - A @ sol
        s2 = float(res @ res) / (len(taus) - 2)
        cov = s2 * np.linalg.inv(A.T @ A)
        slope_sigma = math.sqrt(cov[1, 1])
        use = drift if drift is not None else abs(sol[1]) > 3 * slope_sigma and slope_sigma > 0
        if use:
            slope, tau, sigma = float(sol[1]), float(sol[0]), math.sqrt(cov[0, 0])
        else:
            tau = float(np.mean(taus))
            sigma = float(np.std(taus, ddof=1)) / math.sqrt(len(taus))
            slope_sigma = 0.0
    elif len(taus) == 2:
        tau = float(np.mean(taus))
        sigma = max(abs(taus[1] - taus[0]) / 2.0, sigma)
    return Alignment(tau, max(sigma, 1e-9), slope, slope_sigma, t_ref, peak, len(taus))


def _merge(points: Recording, readings: Recording, al: Alignment) -> Recording:
    """The points with the readings interpolated (cubic spline) at the point times mapped by ``al``."""
    from scipy.interpolate import CubicSpline  # noqa: PLC0415

    t_r = al.readings_time(points.time)
    keep = (t_r >= readings.time[0]) & (t_r <= readings.time[-1])
    if keep.sum() < 3:
        raise DenavitError(
            f"{points.source} and {readings.source}: cannot align clocks: at offset {al.offset * 1e3:.1f} ms only"
            f" {int(keep.sum())} point rows fall within the readings' time span"
            f" ({readings.time[0]:.3f}-{readings.time[-1]:.3f} s)"
        )
    q = CubicSpline(readings.time, readings.q, axis=0)(t_r[keep])
    idx = np.flatnonzero(keep)
    return Recording(
        points.time[keep],
        q,
        points.points[keep],
        [points.where[i] for i in idx],
        f"{points.source} + {readings.source}",
        f"{points.format}+{readings.format}",
        {**readings.units, **points.units},
        None if points.poses is None else points.poses[keep],
        readings.kinds,
        None if points.joint is None else points.joint[keep],
        readings.names,
        [*points.notes, *readings.notes],
    )


def _refine(
    points: Recording, readings: Recording, al: Alignment, drift: bool | None, max_rows: int = 600
) -> Alignment:
    """Refine the offset in the fit: per revolute sweep, the lag that minimises the misfit of the points as
    rotations of one rigid point by the interpolated readings (:func:`denavit.fitting.fit_axis_with_readings`);
    the sweeps' scatter gives the uncertainty, their trend the drift."""
    from scipy.interpolate import CubicSpline  # noqa: PLC0415
    from scipy.optimize import minimize_scalar  # noqa: PLC0415

    from ..fitting import fit_axis_with_readings  # noqa: PLC0415

    merged = _merge(points, readings, al)
    try:
        seg = segment(merged)
    except DenavitError:
        return al  # no single-joint motions to refine on: the speed profiles' estimate stands
    spline = CubicSpline(readings.time, readings.q, axis=0)
    kinds = readings.kinds or ["revolute"] * readings.n_joints
    centres, taus, sig = [], [], []
    dt = float(np.median(np.diff(readings.time)))
    for s in seg.sweeps:
        if kinds[s.joint - 1] != "revolute" or s.stop - s.start < 10:
            continue
        rows = np.linspace(s.start, s.stop - 1, min(max_rows, s.stop - s.start)).astype(int)
        t, p = merged.time[rows], merged.points[rows].mean(axis=1)

        def fit(tau, t=t, p=p, j=s.joint - 1):
            tt = al.readings_time(t) - al.offset + tau
            inside = (tt >= readings.time[0]) & (tt <= readings.time[-1])
            try:
                return fit_axis_with_readings(p[inside], spline(tt[inside])[:, j])
            except DenavitError:
                return None

        def misfit(tau):
            # the readings' error the fit estimates (a lag shows up as reading error along the motion), as the
            # tangential misfit it causes (m); the fit weighs readings by what they are worth, so its rms alone
            # would flatten as the lag grows
            f = fit(tau)
            return 1.0 if f is None or not np.isfinite(f.reading_sigma) else float(f.reading_sigma * f.radius)

        res = minimize_scalar(
            misfit, bounds=(al.offset - 2 * dt, al.offset + 2 * dt), method="bounded", options={"xatol": 1e-6}
        )
        if res.fun < 1.0:
            # precision of this lag: the tangential misfit per point over the point's speed, sqrt(m) points
            v = np.linalg.norm(np.gradient(p, t, axis=0), axis=1)
            centres.append(float(t.mean()))
            taus.append(float(res.x))
            best = fit(res.x)
            floor = best.noise if best is not None and np.isfinite(best.noise) else 1e-12
            sig.append(max(float(res.fun), float(floor), 1e-12) / (math.sqrt(float(np.mean(v**2))) * math.sqrt(len(t))))
    if len(taus) < 2:
        return al
    centres, taus, w = np.array(centres), np.array(taus), 1.0 / np.array(sig) ** 2
    t_ref = float(np.average(centres, weights=w))
    A = np.column_stack([np.ones_like(centres), centres - t_ref])
    sw = np.sqrt(w)
    sol, *_ = np.linalg.lstsq(A * sw[:, None], taus * sw, rcond=None)
    mean = float(np.average(taus, weights=w))
    # the scatter of the lags about their weighted mean scales the predicted precisions (at least 1)
    chi2 = float(np.sum(w * (taus - mean) ** 2)) / (len(taus) - 1)
    sigma = math.sqrt(max(chi2, 1.0) / float(np.sum(w)))
    if len(taus) >= 3:
        r = taus - A @ sol
        cov = max(float(np.sum(w * r**2)) / (len(taus) - 2), 1.0) * np.linalg.inv((A * w[:, None]).T @ A)
        use = drift if drift is not None else abs(sol[1]) > 3 * math.sqrt(cov[1, 1])
        if use:
            return Alignment(
                float(sol[0]), math.sqrt(cov[0, 0]), float(sol[1]), math.sqrt(cov[1, 1]), t_ref, al.peak, len(taus)
            )
    return Alignment(mean, max(sigma, 1e-9), 0.0, 0.0, t_ref, al.peak, len(taus))


def align(
    points: Recording,
    readings: Recording,
    *,
    offset: float | None = None,
    drift: float | bool | None = None,
    refine: bool = True,
    **options,
) -> tuple[Recording, Alignment]:
    """The points with the joint readings interpolated (cubic spline) at the point times.

    offset : s, the readings clock minus the points clock, when known (e.g. 0.0 for one clock); None
    estimates it: coarse from the speed profiles (:func:`estimate_offset`, ``options`` go there), then, with
    ``refine``, in the fit (per sweep, the lag minimising the misfit of the points as rotations of one rigid
    point by the readings); the sweeps' scatter is the uncertainty and their trend the drift (fitted when it
    exceeds 3 sigma, or always / never with ``drift`` True / False). With ``offset`` given, ``drift`` is s/s
    (default 0). Point rows outside the readings' time span are dropped (counted in the Alignment).
    Returns the merged Recording and the Alignment.
    """
    if points.points is None:
        raise DenavitError(
            f"{points.source}: expected measured points or poses to align readings with, the recording has none"
        )
    if readings.q is None or readings.time is None:
        raise DenavitError(
            f"{readings.source}: expected timed joint readings, the recording has"
            f" {'no readings' if readings.q is None else 'no time'}"
        )
    if points.time is None:
        raise DenavitError(f"{points.source}: cannot align: the points have no time column")
    if offset is None:
        options.setdefault("window", None if refine else 10.0)
        al = estimate_offset(points, readings, drift=None if drift is None else bool(drift), **options)
        if refine:
            al = _refine(points, readings, al, None if drift is None else bool(drift))
    else:
        al = Alignment(float(offset), 0.0, float(drift or 0.0), 0.0, float(points.time[0]), math.nan, 0)
    merged = _merge(points, readings, al)
    dropped = len(points) - len(merged)
    al = Alignment(al.offset, al.sigma, al.drift, al.drift_sigma, al.t_ref, al.peak, al.windows, dropped)
    return (
        Recording(
            merged.time,
            merged.q,
            merged.points,
            merged.where,
            merged.source,
            merged.format,
            merged.units,
            merged.poses,
            merged.kinds,
            merged.joint,
            merged.names,
            [*merged.notes, str(al)],
        ),
        al,
    )
