"""Circle-point identification: the robot's true joint axes and parameters from joint sweeps.

Hayat et al., *Identification of Denavit-Hartenberg Parameters of an Industrial Robot*: fit one circle per
swept joint (centroid, SVD plane, algebraic circle, eq. 1-9: method ``kasa``), take each circle's normal and
centre as the joint axis, and extract the parameters from consecutive axes by line geometry. Beyond the
paper: bias-free and geometric fits, a fit that uses the recorded joint readings, and a ``global`` fit of
all sweeps together (one shared tool point at home, one line per joint), covariance of every axis
propagated to every parameter, no absurd offsets on near-parallel axes (docs/conventions.md), and the
minimum-volume bounding box of the measured points (paper Table IV; :attr:`Identification.box`, computed
when first asked for).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from functools import cached_property
from pathlib import Path

import numpy as np

from . import _core
from .errors import DegenerateError, DenavitError, NotConvergedError
from .fitting import AxisFit, BoundingBox, fit_axis, oriented_bounding_box
from .fitting.axis import axis_start
from .fitting.checks import check_loss, check_positive, check_sweep_labels, misfit_notes, nominal_plausibility
from .fitting.circle import circle_misfit, robust_circle
from .fitting.joint import TrackerNoise, as_tracker_noise, fit_sweeps, locked_motion, start_homes
from .fitting.readings import READINGS_WORTHLESS
from .fitting.result import axis_sigmas, flipped
from .fitting.robust import _Levels, flag_outliers, rms_spread, robust_sigma
from .geometry import matrix_rotvec, rotvec_matrix
from .io.output import json_text, write_text
from .robot import Robot
from .sweeps import SweepSet

METHODS = ("auto", "kasa", "hyper", "geometric", "readings", "global")
#: The conventions whose tables hold any pair of joint axes exactly (docs/conventions.md): what :meth:`Identification.save` writes by default.
#: Against a nominal, ED-H drops the tilt of a pair the nominal has parallel when it is within ``EDH_PARALLEL_SIGMAS``
#: of zero (its carried error says how much); POE is exact always.
EXACT = ("edh", "poe")
#: A carried tool-position error (m) at most this is round-off: the table is the identified geometry.
ROUND_OFF = 1e-9


@dataclass(frozen=True)
class Identification:
    """The result of :func:`identify` (SI inside; measurement frame = ``world``)."""

    method: str
    convention: str
    axes: _core.JointAxes
    fits: list[AxisFit]  # per joint: the per-sweep fit, or the global fit's view of it
    extraction: _core.Extraction
    sigma: np.ndarray  # (n, k) one-sigma of every table parameter
    axis_cov: np.ndarray  # (6n+3, 6n+3) covariance of [c1, n1, ..., cn, nn, tool point at home]
    tool_point: np.ndarray  # (3,) tool point at home in world (m)
    sweeps: SweepSet
    nominal: Robot | None = None
    nominal_table: _core.Table | None = None
    rms: float = 0.0
    notes: list[str] = field(default_factory=list)
    param_cov: np.ndarray | None = None  # (n k + 3 [+ n],) covariance of the table's parameters (row-major), the tool translation (, the reading scales)
    reading_scale: np.ndarray | None = None  # (n,) the readings' scale errors when auto fitted them (0 where not fitted), about the home
    axis_scale_cov: np.ndarray | None = None  # (6n+3+n,) covariance of [c1, n1, ..., tool point, reading scales] when they were fitted
    coupling: np.ndarray | None = None  # (n, n) joint values from the readings (q = coupling @ reading) the sweeps were decoupled with
    tool_orientation: str = "nominal"  # where the tool frame's orientation came from: "nominal", "poses", "nest" or "targets" (TOOL_ORIENTATION)
    tool_rotation_cov: np.ndarray | None = None  # (3, 3) rad^2: covariance of the tool frame's orientation at home (a small rotation in world), None if from the nominal
    target_points: np.ndarray | None = None  # (k, 3) m: each target's point at home in world (several targets per pose)
    tracker_noise: TrackerNoise | None = None  # the tracker's range/angle noise model the joint fit weighted the points by (None: isotropic)

    @property
    def tool_rotation_sigma(self) -> float:
        """RMS (1-sigma) angle of the tool frame's orientation error at home (rad), ``sqrt(trace(tool_rotation_cov))``;
        nan when the orientation is the nominal's (not identified)."""
        return math.nan if self.tool_rotation_cov is None else float(math.sqrt(max(np.trace(self.tool_rotation_cov), 0.0)))

    def __repr__(self) -> str:
        n_pts = sum(len(s.points) for s in self.sweeps.sweeps)
        name = self.nominal.name if self.nominal else "no nominal"
        err = self.extraction.max_position_error
        return (f"Identification({self.convention}, method {self.method}, {self.axes.nq} joints, {n_pts} points of {self.sweeps.source or 'sweeps'}, nominal {name})\n"
                f"  rms {self.rms * 1e3:.4g} mm; the {self.convention} table carries a tool error up to {err * 1e3:.3g} mm; {len(self.notes)} notes")

    @cached_property
    def box(self) -> BoundingBox:
        """The minimum-volume oriented bounding box of all measured points (the measuring volume, Hayat et al.
        Table IV), computed when first asked for (it costs more than the rest of :func:`identify`)."""
        return oriented_bounding_box(self.sweeps.all_points, where=self.sweeps.source)

    @property
    def table(self) -> _core.Table:
        return self.extraction.table

    def model(self, name: str = "identified", convention: str | None = None) -> _core.Model:
        """The identified model in its table's convention, or in ``convention`` (extracted from the same axes,
        e.g. "edh" for the exact geometry whatever a DH table could represent)."""
        names = self.nominal.names if self.nominal else [f"j{i + 1}" for i in range(self.axes.nq)]
        lower = self.nominal.lower if self.nominal else None
        upper = self.nominal.upper if self.nominal else None
        return self._extraction(convention).table.to_model(name, names, lower, upper)

    def _extraction(self, convention: str | None) -> _core.Extraction:
        """The identified axes in ``convention`` (None: the result's own table)."""
        convention = None if convention is None else _core.convention_info(convention)["name"]
        if convention is None or convention == self.convention:
            return self.extraction
        return _core.extract(self.axes, convention, **self._extract_options(convention))

    def _extract_options(self, convention: str) -> dict:
        """The extraction options of a table in another convention than the result's (:meth:`_extraction`)."""
        nominal = _nominal_table(self.nominal, convention, self.sweeps.home)
        tol = _edh_parallel_tol(self.fits, self.nominal, self.sweeps.home, PARALLEL_TOL) if convention == "edh" else PARALLEL_TOL
        return {"nominal": nominal, "origins": _origins(nominal, convention, self.sweeps.home), "parallel_tol": tol}

    def parameter_covariance(self, convention: str | None = None) -> np.ndarray:
        """The SI covariance of [the ``convention`` table's parameters (row-major), the tool's translation in its last
        frame (, the reading scales when auto fitted them)] (default: the result's own table, :attr:`param_cov`):
        the axes' covariance propagated through the core's extraction of that table, as for the result's own."""
        conv = self.convention if convention is None else _core.convention_info(convention)["name"]
        if conv == self.convention:
            return self.param_cov
        x = np.concatenate([np.concatenate([self.axes.points[j], self.axes.directions[j]]) for j in range(self.axes.nq)] + [self.tool_point])
        cov = self.axis_cov if self.axis_scale_cov is None else self.axis_scale_cov
        return _parameter_cov(x, cov, self.axes, self.sweeps, conv, self._extract_options(conv), self._extraction(conv).table.params)

    def robot(self, name: str | None = None, convention: str | None = None) -> Robot:
        """The identified robot as a :class:`Robot` (for :meth:`save` and :func:`denavit.io.urdf.save_urdf`): the
        nominal's names, limits and extras (a URDF nominal's meshes and limits ride along), the sweeps' home.

        convention : the table's convention; default :data:`EXACT` (the result's own table when it is ED-H or POE,
            else ED-H: against a nominal exact except a near-parallel pair's tilt within its noise, POE exact always).
            A DH or MDH table cannot hold a near-parallel pair's tilt (Hayati beta): ask for one by name.
        """
        conv = _core.convention_info(convention)["name"] if convention is not None else (self.convention if self.convention in EXACT else "edh")
        n = self.axes.nq
        names = list(self.nominal.names) if self.nominal else [f"j{i + 1}" for i in range(n)]
        limits = np.array([_core.default_limits(k) for k in self.sweeps.kinds])
        lower = self.nominal.lower if self.nominal else limits[:, 0]
        upper = self.nominal.upper if self.nominal else limits[:, 1]
        # compensate predicts the error after compensation from the covariance, and commands the readings through
        # the coupling and the reading scales (about the sweeps' home, where the identified offsets hold)
        return Robot(name=name or f"{self.nominal.name if self.nominal else 'robot'}_identified", table=self._extraction(conv).table, names=names, lower=lower,
                     upper=upper, description=f"identified from {self.sweeps.source} ({self.method} fit, {conv})", source=str(self.sweeps.source),
                     home=self.sweeps.home, extra=dict(self.nominal.extra) if self.nominal else {},
                     covariance=self.parameter_covariance(conv), coupling=self.coupling, reading_scale=self.reading_scale,
                     reading_reference=None if self.reading_scale is None else np.asarray(self.sweeps.home, dtype=float))

    def carried_error(self, convention: str | None = None, count: int = 256) -> tuple[float, int]:
        """(max tool-position deviation in m, configurations checked) of the table :meth:`robot` writes in
        ``convention`` from the identified geometry (the exact ED-H model of the axes): over the home and ``count``
        configurations spread over the joint limits (:func:`denavit.calibration.configurations`)."""
        from .calibration.parametrization import configurations  # noqa: PLC0415 (scipy's Halton sequence)

        conv = _core.convention_info(convention)["name"] if convention is not None else (self.convention if self.convention in EXACT else "edh")
        model = self.model(convention=conv)  # the table :meth:`robot` writes (without its covariance, which costs)
        exact = _core.extract(self.axes, "edh", fidelity=False).table.to_model()
        q = np.vstack([self.sweeps.home, configurations(model, count)])
        d = _core.fk_batch(model, q)[:, :3, 3] - _core.fk_batch(exact, q)[:, :3, 3]
        return float(np.linalg.norm(d, axis=1).max()), len(q)

    def save(self, path, convention: str | None = None, length: str = "m", angle: str = "deg", name: str | None = None, *, force: bool = False) -> None:
        """Write the identified robot as a robot file (.toml; :mod:`denavit.io.robotfile`), by default the ED-H or POE
        geometry (:meth:`robot`: POE exact, ED-H exact except a near-parallel pair's tilt within its noise, which it drops
        against the nominal), a lossy DH / MDH table only when ``convention`` asks for one. The file states in a comment
        whether it is exact and the tool-position error its table carries against the identified geometry (:meth:`carried_error`).

        A path ending in ``.urdf`` gets the URDF of the ED-H geometry instead (frames on the body; a URDF
        nominal's meshes and limits ride along; :func:`denavit.io.urdf.save_urdf`), in SI as URDF requires.

        The file is written whole or not at all, keeping the owner and mode of a file it replaces; ``force``:
        replace a read-only file, write through one with several hard links (:mod:`denavit.io.output`).
        """
        from .io.robotfile import dumps  # noqa: PLC0415

        suffix = Path(str(path)).suffix.lower()
        if str(path) != "-" and suffix not in ("", ".toml", ".urdf"):  # a .json name had received TOML without a word
            raise DenavitError(f"{path}: expected a robot file name ending in .toml (or .urdf for a URDF), got a {suffix} name")
        if suffix == ".urdf":
            from .io.urdf import save_urdf  # noqa: PLC0415 (lxml loads for a URDF only)

            if convention is not None and _core.convention_info(convention)["name"] != "edh":
                raise DenavitError(f"{path}: a URDF holds the exact geometry (ED-H frames on the body), got convention {convention!r}: save a robot file (.toml) for a {convention} table")
            save_urdf(self.model(convention="edh"), path, self.robot(name), force=force)
            return
        robot = self.robot(name, convention)
        err, count = self.carried_error(convention)
        if robot.convention in EXACT and err <= ROUND_OFF:
            how = f"exactly (its {robot.convention} table holds any pair of joint axes)"
        elif robot.convention in EXACT:
            how = f"exactly except {_DROPPED_TILT}; save as poe for the exact geometry"
        else:
            how = f"in a {robot.convention} table, which cannot hold a near-parallel pair's tilt (save as poe for the exact geometry)"
        note = (f"# The identified geometry, {how}.\n# Carried error: max tool-position deviation {err * 1e3:.3g} mm from the identified geometry "
                f"over {count} configurations (the home and {count - 1} spread over the joint limits).\n")
        write_text(path, note + dumps(robot, length, angle), force=force)


#: A locked joint whose reading leaves home by more than this during another joint's sweep gets a note
#: (rad for revolute joints, m for prismatic ones).
LOCKED_TOL = {"revolute": math.radians(0.1), "prismatic": 1e-4}


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
            notes.append(f"{sweep_where(s, sweeps.source)}: locked joint {i + 1} reads {s.q[:, i].min() * scale:.4g} .. {s.q[:, i].max() * scale:.4g} {unit}, "
                         f"up to {abs(dev[k]) * scale:.3g} {unit} from its home {sweeps.home[i] * scale:.4g} {unit}{at} (tolerance {LOCKED_TOL[kind] * scale:g} {unit}); "
                         "the global fit follows the recorded readings (per-sweep fits use only the moving joint's): check the recording")
    return notes


#: A point is still in the dwell at a sweep's end while it lies within this many point-noise sigmas (per
#: coordinate, times sqrt(1 + 1/k) for the noise of the mean of the k rows so far) of the mean of the dwell so
#: far (the norm of a 3-D Gaussian exceeds 5 sigma with probability 2e-5).
DWELL_SIGMAS = 5.0


def _dwell_rows(p: np.ndarray, noise: float) -> tuple[int, int]:
    """(rows standing still after the first, rows standing still before the last) of a sweep in time order:
    the run of points within ``DWELL_SIGMAS * noise`` of the running mean of the run (the first and last point
    of each run are the sweep's real ends and stay)."""
    tol = DWELL_SIGMAS * noise

    def lead(x):
        m = len(x)
        run_mean = np.cumsum(x, axis=0) / np.arange(1, m + 1)[:, None]
        k = np.arange(1, m)  # the mean of k points has noise sigma / sqrt(k) of its own
        far = np.linalg.norm(x[1:] - run_mean[:-1], axis=1) > tol * np.sqrt(1 + 1 / k)
        return int(np.argmax(far)) + 1 if far.any() else m  # the first row that moved: rows 1..k-1 stand with row 0

    a = lead(p) - 1
    b = lead(p[::-1]) - 1
    a, b = max(a, 0), max(b, 0)
    if a + b >= len(p) - 3:  # nothing moved: not a dwell to trim
        return 0, 0
    return a, b


def _drop_dwell(sweeps: SweepSet, notes: list[str]) -> SweepSet:
    """The sweeps without their dwell rows (found by :func:`_dwell_rows`, the noise from a trimmed circle or line
    fit), with a note per sweep that had some (how many, which rows)."""
    out = []
    for s in sweeps.sweeps:
        p = s.points
        if sweeps.kinds[s.joint - 1] == "prismatic" or len(p) < 8:
            out.append(s)
            continue
        try:
            c, nv, r, _ = robust_circle(p, "dwell check", sweep_where(s, sweeps.source))
        except DenavitError:
            out.append(s)
            continue
        e = circle_misfit(p, c, nv, r)[0]
        noise = max(robust_sigma(e, 2), 1e-12 * rms_spread(p))
        a, b = _dwell_rows(p, noise)
        if a + b == 0:
            out.append(s)
            continue
        keep = np.r_[0, a + 1 : len(p) - b - 1, len(p) - 1]
        name = s.where if s.where else [f"point {k}" for k in range(len(p))]
        parts = ([f"{a} at the start ({name[1]} .. {name[a]})"] if a else []) + ([f"{b} at the end ({name[len(p) - 1 - b]} .. {name[len(p) - 2]})"] if b else [])
        notes.append(f"{sweep_where(s, sweeps.source)}: {a + b} dwell rows (the motion stopped within {DWELL_SIGMAS:g} sigma of the "
                     f"point noise, {noise * 1e3:.2g} mm): {' and '.join(parts)}; left out of the fit (keep_dwell keeps them)")
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


def _per_sweep(sweeps: SweepSet, method: str, loss: str, max_sigma: float | None, progress: Callable[[str], None], tracker: TrackerNoise | None = None) -> list:
    fits = []
    for k, s in enumerate(sweeps.sweeps):
        where = sweep_where(s, sweeps.source)
        progress(f"fitting sweep {k + 1} of {len(sweeps.sweeps)} (joint {s.joint}, {len(s.points)} points, {method})")
        q = s.moving
        if sweeps.kinds[s.joint - 1] == "prismatic":
            fm = "line"
        elif method in ("readings", "global"):
            fm = "readings" if method == "readings" else "hyper"  # the global fit starts from the hyper circles
            if q is None:
                raise DenavitError(f"{where}: method '{method}' needs joint readings; this data has none (use geometric)")
        else:
            fm = method
        robust = {"loss": loss} if fm in ("geometric", "readings") else {}
        if fm == "geometric" and tracker is not None:  # the tracker's noise model (the other per-sweep fits: isotropic)
            robust["tracker"] = tracker
        # oriented by the readings when there are some (increasing joint value, right-hand rule), else by the point order
        if method == "global" and fm == "hyper":  # the joint fit's start: its own covariance and outlier flags replace the circle's
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


def _motions(sweeps: SweepSet, notes: list[str]) -> list[np.ndarray]:
    """Per sweep the joint motions from home the joint fit uses (:func:`~denavit.fitting.joint.locked_motion`),
    noting each locked reading that moves in lock-step with the swept joint (a coupling to declare)."""
    tol = np.array([LOCKED_TOL[k] / 100 for k in sweeps.kinds])
    out = []
    for s in sweeps.sweeps:
        dq, coupled = locked_motion(s.q, s.joint - 1, sweeps.home, tol)
        for i, slope in coupled:
            notes.append(f"{sweep_where(s, sweeps.source)}: the reading of joint {i + 1} moves in lock-step with joint {s.joint}'s "
                         f"({slope:+.3f} per unit): a coupling of the controller's readings to declare (as Fanuc controllers report J3: "
                         f"--coupling \"q{i + 1}=r{i + 1}{'+' if slope < 0 else '-'}{format(abs(slope), '.4g') + '*' if abs(abs(slope) - 1) > 0.01 else ''}r{s.joint}\", or the robot file's "
                         f"[couplings] q{i + 1} = \"r{i + 1} {'+' if slope < 0 else '-'} r{s.joint}\"); the fit takes joint {i + 1} as held at home")
        out.append(dq)
    return out


def _joint_fits(sweeps: SweepSet, fits: list, res: dict, cov: np.ndarray, loss: str, label: str) -> list:
    """The per-joint view (AxisFit) of a joint fit's result ``res`` (:func:`~denavit.fitting.joint.fit_sweeps`),
    ``cov`` the covariance of [c_1, n_1, ..., p]."""
    out = []
    ph = res["home"].mean(axis=0)
    for k, (s, f) in enumerate(zip(sweeps.sweeps, fits, strict=True)):
        j = s.joint - 1
        c, nv = res["points"][j], res["directions"][j]
        cov6 = cov[6 * j : 6 * j + 6, 6 * j : 6 * j + 6]
        sp, sd = axis_sigmas(cov6, nv)
        mis = res["misfit"][k]
        radius = float(np.linalg.norm(ph - c)) if sweeps.kinds[j] == "revolute" else math.nan
        out.append(replace(f, point=c, direction=nv, radius=radius, residuals=mis, rms=float(math.sqrt(np.mean(mis**2))), cov=cov6,
                           sigma_point_perp=sp, sigma_direction=sd, outliers=flag_outliers(res["whitened"][k], res["components"], 1.0),
                           method=label if loss == "linear" else f"{label}+{loss}", reading_sigma=res["reading_sigma"][k], noise=res["sigma"],
                           scale=1 + res["scales"][j] if np.isfinite(res["scale_sigma"][j]) else f.scale, scale_sigma=res["scale_sigma"][j]))
    return out


def _with_drift(sweeps: SweepSet, res: dict) -> tuple[np.ndarray, float]:
    """The covariance of [c_j, n_j, ..., p] of a per-sweep-home fit: the home points averaged, and the drift
    between sweeps (the spread of the per-sweep home points, sigma_d per coordinate) added to every axis point and
    to the home point, since a drifting robot moves its axes with it (the scatter beyond the home points' own
    estimation error). Returns (cov, sigma_d)."""
    homes = res["home"]
    S = len(homes)
    n6 = res["cov"].shape[0] - 3 * S
    T = np.zeros((n6 + 3, n6 + 3 * S))
    T[:n6, :n6] = np.eye(n6)
    for k in range(S):
        T[n6:, n6 + 3 * k : n6 + 3 * k + 3] = np.eye(3) / S
    cov = T @ res["cov"] @ T.T
    # the scatter of the home points beyond their own estimation error, across each sweep's motion only (along
    # it a home point rests on the readings, whose scale errors are not white: geometry alone is trusted)
    dev = homes - homes.mean(axis=0)
    ss, est = 0.0, 0.0
    for k, sweep in enumerate(sweeps.sweeps):
        j = sweep.joint - 1
        t = np.cross(res["directions"][j], homes[k] - res["points"][j])
        t = t / max(np.linalg.norm(t), 1e-300) if sweeps.kinds[j] == "revolute" else res["directions"][j]
        P = np.eye(3) - np.outer(t, t)
        ss += float(dev[k] @ P @ dev[k])
        est += float(np.trace(P @ res["cov"][n6 + 3 * k : n6 + 3 * k + 3, n6 + 3 * k : n6 + 3 * k + 3] @ P)) * (S - 1) / S
    sd2 = max(ss - est, 0.0) / (2 * max(S - 1, 1))
    for j in range(n6 // 6):
        cov[6 * j : 6 * j + 3, 6 * j : 6 * j + 3] += sd2 * np.eye(3)
    cov[n6:, n6:] += sd2 * np.eye(3)
    return cov, math.sqrt(sd2)


def _bic(simple: dict, rich: dict, k: int, n_res: int) -> float:
    """Schwarz's criterion of the richer of two nested joint fits on the same weights: the chi-square it gains,
    less its ``k`` extra parameters times ln(residuals) (positive: the richer model wins). The AIC's 2 per
    parameter picked a drift on exact 30 degree data in 3 % of runs (a home per sweep trades with the tilt of an
    axis about its arc's tangent)."""
    return (simple["ss_m"] - rich["ss_m"]) / rich["sigma"] ** 2 - k * math.log(n_res)


def _scale_cross(g: dict, n: int) -> np.ndarray:
    """The joint fit's scales' covariance with [c_1, n_1, ..., p] (6n+3, n): its home points averaged, as in the
    axes' covariance."""
    n6, cross = 6 * n, g["scale_cross"]
    return np.vstack([cross[:n6], cross[n6:].reshape(-1, 3, n).mean(axis=0)])


#: The joints' scale spread tau^2 is the Q-profile's tau^2 at this level of its chi-square (:func:`_scale_spread`): at
#: 0.5, the median-unbiased estimate. Its 90 % lower bound (used before) took real scale errors as smaller than they
#: are whenever few joints showed them (one 1.2 m joint-2 axis 60 um off at 3 of its sigmas), and fitting scales
#: joint by joint by the BIC put a chance 2.9-sigma joint-2 scale on exact 30 degree readings at full weight (d1, a1,
#: theta2 and a2 off by 2.7-2.9 of their sigmas): 0.6x the Monte Carlo spread in sigma on that protocol.
SCALE_SPREAD_LEVEL = 0.5


def _scale_spread(s: np.ndarray, sigma: np.ndarray) -> float:
    """The spread tau^2 of the joints' true reading scale errors, taken as a zero-mean normal population, from their
    estimates ``s`` with one-sigma ``sigma``: the tau^2 at which the Q statistic sum s^2 / (sigma^2 + tau^2) equals
    its chi-square quantile at ``SCALE_SPREAD_LEVEL`` with one degree per joint (the Q-profile, Viechtbauer 2007, with
    the mean known to be zero); zero when the estimates scatter less. Continuous in the estimates.

    Q is convex and falling in tau^2, so Newton's steps from zero rise to the root without passing it (no bracket;
    no scipy: importing scipy.stats and scipy.optimize for this had cost identify 2-3 s)."""
    if len(s) == 0:
        return 0.0
    bound = CHI2_MEDIAN[len(s)] if SCALE_SPREAD_LEVEL == 0.5 else _chi2_quantile(SCALE_SPREAD_LEVEL, len(s))
    s2, v = np.asarray(s, dtype=float) ** 2, np.asarray(sigma, dtype=float) ** 2
    t = 0.0
    if float(np.sum(s2 / v)) <= bound:
        return 0.0
    for _ in range(500):
        w = s2 / (v + t)
        step = (float(np.sum(w)) - bound) / float(np.sum(w / (v + t)))
        t += step
        if abs(step) <= 1e-15 * t:
            break
    return float(max(t, 0.0))


def _chi2_quantile(level: float, k: int) -> float:
    from scipy.stats import chi2  # noqa: PLC0415 (scipy is loaded when first needed)

    return float(chi2.ppf(level, k))


#: The chi-square's median (scipy.stats chi2.ppf(0.5, k)) for k degrees of freedom: the Q-profile's level
#: (:func:`_scale_spread`), k one per swept joint; more joints from scipy.
CHI2_MEDIAN = _Levels({1: 0.454936423119572, 2: 1.386294361119891, 3: 2.3659738843753377, 4: 3.3566939800333224, 5: 4.351460191095526,
                       6: 5.348120627447118, 7: 6.345811195521515, 8: 7.344121497701794, 9: 8.342832692252955, 10: 9.34181776559197,
                       11: 10.340998074391827, 12: 11.34032237742414}, lambda k: _chi2_quantile(0.5, k))


def _scale_evidence(s: np.ndarray, C: np.ndarray) -> tuple[float, float]:
    """The evidence that the joints' reading scales err at all: the freely fitted scale estimates ``s`` (k,), with
    their covariance ``C`` (k, k) (marginal over every other parameter of that fit), are under the population model
    N(0, C + tau^2 I) (the scales drawn from N(0, tau^2), integrated out: the marginal, or restricted, likelihood of
    the linearised fit, in which every parameter shared with the exact-scale fit cancels), and N(0, C) under exact
    scales (tau = 0, the nested simpler model): the form of Wakefield's approximate Bayes factor (Genet. Epidemiol.
    33, 2009, 79-86) for a vector of estimates. Returns (2 ln of the likelihood ratio at the maximum over tau^2, that
    tau^2; both 0 where the maximum is at tau = 0): one hyperparameter against the simpler model, for
    :func:`_scale_penalty`.

    In C's eigenbasis (eigenvalues l_i, u = V^T s) the log likelihood is -1/2 sum(u_i^2 / (l_i + t) + ln(l_i + t)):
    its maximum over t = tau^2 >= 0 from a log-spaced grid, refined by golden-section steps between the grid
    points about the best (the likelihood of heteroscedastic estimates can have more than one local maximum)."""
    s = np.asarray(s, dtype=float)
    if len(s) == 0:
        return 0.0, 0.0
    lam, V = np.linalg.eigh((np.asarray(C, dtype=float) + np.asarray(C, dtype=float).T) / 2)
    lam = np.maximum(lam, 1e-300)
    u2 = (V.T @ s) ** 2

    def ll(t):
        t = np.atleast_1d(np.asarray(t, dtype=float))[:, None]
        return -0.5 * np.sum(u2 / (lam + t) + np.log(lam + t), axis=1)

    grid = np.concatenate([[0.0], np.geomspace(1e-6 * lam.min(), 1e3 * max(lam.max(), float(np.sum(u2))), 400)])
    v = ll(grid)
    i = int(np.argmax(v))
    a, b = grid[max(i - 1, 0)], grid[min(i + 1, len(grid) - 1)]
    g = (math.sqrt(5) - 1) / 2
    for _ in range(60):  # golden section on [a, b] (the grid's neighbours of its best)
        x1, x2 = b - g * (b - a), a + g * (b - a)
        if ll(x1)[0] >= ll(x2)[0]:
            b = x2
        else:
            a = x1
    t = (a + b) / 2
    best = max((float(ll(t)[0]), t), (float(v[i]), float(grid[i])))
    lr = 2 * (best[0] - float(v[0]))
    return (lr, best[1]) if lr > 0 else (0.0, 0.0)


def _scale_penalty(k: int, n_res: int) -> tuple[float, str]:
    """Schwarz's penalty for the reading scales as a population, and its name for the notes: ln(n) for the one
    hyperparameter tau (:func:`_scale_evidence`), n the fit's residual count ``n_res``: the rule of the drift's choice
    (:func:`_bic`), the scales integrated out (Schwarz 1978; Kass & Raftery 1995, sec. 4.1.3). ``k`` the count of
    scale estimates.

    Shown against the out-of-sample error it stands for, the axes' true error (benchmarks/bench_identify_choice.py,
    the UR5 of issue 36, 100 seeds per case): on exact readings it fitted scales in 1 % of runs on 30 and on 90 degree
    arcs (the old rule, any positive spread: 49 and 51 %; n = k, the scale estimates the hyperparameter rests on as a
    variance component's groups, Pauler 1998: 5 and 2 %), and among the runs where the scale fit and the exact-scale
    fit differ it chose the one nearer the truth on the axes in 48/49 and 42/51 (n = k: 44/49, 41/51). 200 ppm scale
    errors on two joints, whose free sigmas are 20-60 ppm on 90 degree arcs, it fitted in every run (axes 0.26x the
    exact-scale fit's error, median); on 30 degree arcs (sigmas 240-470 ppm) in 1 %, where the scale fit was nearer
    the truth in 32 of 62 runs and farther in RMS (98 against 75 um): there no rule beat chance (29/62, n = k 26/62)."""
    return math.log(max(n_res, 1)), f"ln {n_res}"


def _reading_scales(richer: Callable, refit: Callable, base: dict, drift: bool, n_res: int) -> tuple[dict | None, dict | None, float, str]:
    """The readings' scale errors as a population (empirical Bayes): every swept joint's scale fitted once freely
    (``full``); whether they err at all by the evidence (:func:`_scale_evidence`: the marginal likelihood of the
    scales as a population N(0, tau^2) against exact scales, one hyperparameter, by Schwarz's criterion,
    :func:`_scale_penalty`); when they do, the joints' spread tau from those estimates (:func:`_scale_spread`), then
    every scale refitted with the prior N(0, tau^2) (:func:`~denavit.fitting.joint.fit_sweeps`' ``scale_prior``): a scale the
    data show (sigma << tau) keeps its value, one they cannot show (sigma >> tau) stays near zero with about tau of
    uncertainty in its axis, continuously (no joint-by-joint choice: a chance 2.9-sigma scale on exact readings no
    longer moves its axis by 2.9 of its full sigmas).

    (Before, any tau > 0 fitted the scales: the median-unbiased tau is positive in about half of all runs with exact
    readings, and on 30 degree arcs, where a scale trades with its axis's radial position (the arc's curvature alone
    tells them apart), the fitted scales then moved the axes by up to 10x their error with exact scales: issue 36.)
    Readings whose scales the evidence does not show are taken as exact in scale. Returns (the fit with the prior or
    None when the scales are not shown or a fit does not converge, the free fit or None, tau (nan without the free
    fit; 0 when not shown), the evidence in words for the notes)."""
    full, _ = richer(base, per_sweep_home=drift, scales=True)
    if full is None:
        return None, None, math.nan, ""
    on = np.isfinite(full["scale_sigma"])
    lr, _ = _scale_evidence(full["scales"][on], full["scale_cov"][np.ix_(on, on)])
    pen, name = _scale_penalty(int(np.sum(on)), n_res)
    evidence = f"2 ln(marginal likelihood ratio) {lr:.3g} {'>' if lr > pen else '<='} {name} = {pen:.3g}"
    tau = math.sqrt(_scale_spread(full["scales"][on], full["scale_sigma"][on]))
    if lr > pen and not tau > 0:  # (the diagonal Q-profile against the full covariance's likelihood: rare)
        evidence += ", but the joints' scales scatter within their sigmas (tau = 0)"
    if not (tau > 0 and lr > pen):
        return None, full, 0.0, evidence
    # (with its own weights: the variance components estimated with the scales, as a refit would)
    post = refit(full, per_sweep_home=drift, scales=True, scale_prior=(tau, base["sigma"]), strict=True)
    return post, full, tau, evidence


def _scale_list(g: dict, n: int) -> str:
    return ", ".join(f"joint {j + 1} {g['scales'][j] * 1e6:+.4g} +/- {g['scale_sigma'][j] * 1e6:.2g} ppm" for j in range(n) if np.isfinite(g["scale_sigma"][j]))


def _choose(sweeps: SweepSet, fits: list, homes0: np.ndarray, R0, loss: str, notes: list[str], chosen: str, rotation_noise=None,
            tracker: TrackerNoise | None = None):
    """The joint fit(s) with readings: ``chosen`` "global", or "auto" (evidence: the per-sweep fits when the
    readings are worth nothing, else one home point or one per sweep by the BIC, and the readings' scale errors as a
    population when the evidence shows them (:func:`_reading_scales`); with scales fitted, a home point per sweep must
    win again). ``homes0`` (k, 3) the start home points of the targets, ``R0`` the start orientation at home
    (6-DoF poses) or None. Returns (method, fits, cov, tool point, rms, the joint fit's result or None, scales): ``scales`` None, or
    when fitted (values (n,), their covariance with [c_1, n_1, ..., p] (6n+3, n), their covariance (n, n)); zeros
    where a joint's scale was not fitted. ``tracker`` the tracker's range/angle noise model, or None (isotropic)."""
    dqs = _motions(sweeps, notes)
    starts = [(f.point, f.direction) for f in fits]
    try:
        start = {"offsets0": homes0[1:] - homes0[0], "rotation0": R0, "rotation_sigma": rotation_noise, "tracker": tracker}
        g = fit_sweeps(sweeps, dqs, starts, homes0[0], loss=loss, where=sweeps.source, **start)
    except NotConvergedError as e:  # say why when the arcs are short (a 1 degree protocol had ended on "no convergence")
        short = [(s.joint, f.arc) for s, f in zip(sweeps.sweeps, fits, strict=True) if sweeps.kinds[s.joint - 1] == "revolute" and f.arc < SHORT_ARC]
        if not short:
            raise
        raise NotConvergedError(f"{e} (the arcs are too short: {len(short)} sweeps under {math.degrees(SHORT_ARC):g} deg, down to "
                                f"{math.degrees(min(a for _, a in short)):.3g} deg on joint {min(short, key=lambda x: x[1])[0]}: sweep longer arcs)") from None
    method, cov, drift, scales = "global", g["cov"], None, None
    if chosen == "auto":
        sq = [f"{math.degrees(v) * 3600:.3g}" for v in g["reading_sigma"]]
        if np.all(g["gamma"] < READINGS_WORTHLESS):
            notes.append(f"auto: geometric (per-sweep circles): the readings are worth nothing against the points (estimated reading error {', '.join(sq)} arcsec per sweep)")
            return "geometric", None, None, None, math.nan, None, None
        n_res = g["components"] * sum(len(s.points) for s in sweeps.sweeps)

        def richer(base, **kw):
            """(fit on base's weights, its BIC against base), or (None, -inf) when it does not converge."""
            try:
                r = fit_sweeps(sweeps, dqs, list(zip(base["points"], base["directions"], strict=True)), base["home"].mean(axis=0), loss=loss,
                               gamma=base["gamma"], where=sweeps.source, offsets0=base["offsets"], rotation0=base["rotation"], rotation_sigma=rotation_noise,
                               tracker=tracker, **kw)
            except NotConvergedError:  # (e.g. a home per sweep on arcs too short to hold one)
                return None, -math.inf
            return r, _bic(base, r, r["n_params"] - base["n_params"], n_res)

        def refit(r, strict=False, **kw):
            """r refitted with its own weights (the simpler model's tangential misfit held the effect too); r itself, or
            with ``strict`` None, when that does not converge."""
            try:
                return fit_sweeps(sweeps, dqs, list(zip(r["points"], r["directions"], strict=True)), r["home"].mean(axis=0), loss=loss,
                                  where=sweeps.source, offsets0=r["offsets"], rotation0=r["rotation"], rotation_sigma=rotation_noise,
                                  tracker=tracker, **kw)
            except NotConvergedError:
                return None if strict else r

        g_global = g
        d, bic = richer(g, per_sweep_home=True)
        if bic > 0:
            g, method = refit(d, per_sweep_home=True), "readings"
            cov, sd = _with_drift(sweeps, g)
            notes.append(f"auto: readings (a home point per sweep) over global (one home point): BIC lower by {bic:.3g}; the home tool point "
                         f"moves {sd * 1e3:.3g} mm (1 sigma per coordinate) between sweeps, added to every axis's uncertainty")
        else:
            why = f"BIC lower by {-bic:.3g}" if d is not None else "a home point per sweep does not converge on these arcs"
            notes.append(f"auto: global (one home point) over readings (a home point per sweep): {why}; estimated reading error "
                         f"{', '.join(sq)} arcsec per sweep, point noise {g['sigma'] * 1e3:.3g} mm")
        drift = method == "readings"
        post, full, tau, evidence = _reading_scales(richer, refit, g, drift, n_res)
        if drift and post is not None:
            # the drift was chosen before the scales: unmodelled scale errors look like a drift; with the scales
            # fitted, a home point per sweep must pay for itself again (the BIC, on the same weights)
            gs = refit(g_global, scales=True, scale_prior=(tau, g_global["sigma"]), strict=True)
            dd, bic_d = richer(gs, per_sweep_home=True, scales=True, scale_prior=(tau, g_global["sigma"])) if gs is not None else (None, math.inf)
            if bic_d <= 0:
                why = f"BIC higher by {-bic_d:.3g}" if dd is not None else "a home point per sweep does not converge with the scales"
                notes.append(f"auto: with the reading scales fitted, one home point again ({why}): the drift was the scale errors")
                method, drift, cov, g = "global", False, g_global["cov"], g_global
                post, full, tau, evidence = _reading_scales(richer, refit, g, drift, n_res)
        if post is not None:
            g = post
            cov = _with_drift(sweeps, g)[0] if drift else g["cov"]
            scales = (g["scales"].copy(), _scale_cross(g, sweeps.n_joints), g["scale_cov"])
            notes.append(f"auto: the readings' scale errors fitted (the evidence shows them as a population: {evidence}; the joints' scales scatter "
                         f"by tau = {tau * 1e6:.3g} ppm beyond their sigmas, each fitted with that spread as its prior: one the data cannot show stays "
                         f"near zero): {_scale_list(g, sweeps.n_joints)}")
        else:
            why = ("n/a: no convergence" if full is None or tau > 0 else  # (tau > 0 without a fit: the one with the prior did not converge)
                   f"the evidence does not show them: {evidence}; the joints' scale estimates: {_scale_list(full, sweeps.n_joints)}; taken as exact in scale")
            notes.append(f"auto: no reading scale errors fitted ({why}); a scale error the data cannot show moves each axis radially by about the "
                         "scale times the arc's radius")
    mis = np.concatenate(g["misfit"])
    return method, _joint_fits(sweeps, fits, g, cov, loss, method), cov, g["home"].mean(axis=0), float(math.sqrt(np.mean(mis**2))), g, scales


#: Where the tool frame's orientation at home comes from (:attr:`Identification.tool_orientation`).
TOOL_ORIENTATION = {
    "nominal": "the nominal's flange orientation at home (not identified: one target per pose has no orientation)",
    "poses": "the 6-DoF poses: the probe's frame at home, fitted with the axes",
    "nest": "the targets' points at home against the declared nest (their positions in the tool frame): the best rotation (Kabsch)",
    "targets": "the targets' points at home: x from target 1 to target 2, z across the plane of targets 1-3 (no nest declared)",
}


def _rotation_between(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The smallest rotation taking the direction of a (3,) onto that of b (3,)."""
    a, b = a / np.linalg.norm(a), b / np.linalg.norm(b)
    v = np.cross(a, b)
    return rotvec_matrix(v / max(np.linalg.norm(v), 1e-300) * math.atan2(np.linalg.norm(v), float(a @ b)))


def _tool_frame(sweeps: SweepSet, res: dict | None, R_nominal: np.ndarray, notes: list[str]) -> tuple[np.ndarray, str, np.ndarray | None]:
    """The tool frame's orientation at home in world, where it came from (:data:`TOOL_ORIENTATION`), and the
    (3, p) Jacobian of its small rotation (world) with respect to the joint fit's parameters (``res["cov_all"]``),
    None when it is the nominal's. Several targets: the frame of their home points (against the declared nest,
    or of the points themselves); 6-DoF poses: the fitted orientation."""
    K = sweeps.n_targets
    if res is None or (K == 1 and res["rotation"] is None):
        return R_nominal, "nominal", None
    p = res["cov_all"].shape[0]
    if res["rotation"] is not None:
        G = np.zeros((3, p))
        G[:, p - 3 :] = np.eye(3)
        return res["rotation"], "poses", G
    n6 = 6 * sweeps.n_joints
    H = res["n_homes"]
    nest = sweeps.nest
    if nest is None and K < 3:
        notes.append("tool frame: two targets per pose fix its orientation only up to a turn about the line through them; the nominal's is kept "
                     "(declare the nest, the targets' positions in the tool frame, for the rest)")
        return R_nominal, "nominal", None

    def frame(theta):
        homes = theta[: 3 * H].reshape(H, 3).mean(axis=0)
        P = np.vstack([homes, homes + theta[3 * H :].reshape(K - 1, 3)])
        if nest is None:
            x = (P[1] - P[0]) / np.linalg.norm(P[1] - P[0])
            z = np.cross(x, P[2] - P[0])
            z /= np.linalg.norm(z)
            return np.column_stack([x, np.cross(z, x), z])
        if K == 2:
            return _rotation_between(R_nominal @ (nest[1] - nest[0]), P[1] - P[0]) @ R_nominal
        a, b = nest - nest.mean(axis=0), P - P.mean(axis=0)
        u, _, vt = np.linalg.svd(b.T @ a)
        return u @ np.diag([1.0, 1.0, np.sign(np.linalg.det(u @ vt))]) @ vt

    theta0 = np.concatenate([res["home"][:H].ravel(), res["offsets"].ravel()])
    R = frame(theta0)
    J = np.zeros((3, len(theta0)))
    for i in range(len(theta0)):
        e = np.zeros_like(theta0)
        e[i] = 1e-7
        J[:, i] = (matrix_rotvec(frame(theta0 + e) @ R.T) - matrix_rotvec(frame(theta0 - e) @ R.T)) / 2e-7
    G = np.zeros((3, p))
    G[:, n6 : n6 + len(theta0)] = J
    how = "nest" if nest is not None else "targets"
    if how == "nest" and K == 2:
        notes.append("tool frame: two targets fix its orientation up to a turn about the line through them: that turn is the nominal's")
    if how == "targets":
        notes.append("tool frame: no nest declared (the targets' positions in the tool frame): its orientation is the frame of the targets' "
                     "points (x from target 1 to 2, z across the plane of targets 1-3)")
    return R, how, G


#: An axis whose predicted position is known no better than this (1 sigma, m) gets a note naming its arc and the
#: predicted sigma (issue 16: a 1-degree arc had given FK 438 mm off with no note unless --max-sigma was given).
SHORT_ARC_SIGMA = 1e-3
#: ... when its arc is shorter than this (rad): a long arc known that poorly has other causes (noise, a unit slip).
SHORT_ARC = math.radians(20.0)


def _short_arc_notes(sweeps: SweepSet, fits: list, notes: list[str]) -> list[str]:
    """A note per sweep whose arc is shorter than :data:`SHORT_ARC` and whose axis-position sigma exceeds
    :data:`SHORT_ARC_SIGMA` (too short, or too few points, for an axis worth calibrating with); the notes are also
    returned (the plausibility error cites them)."""
    short = []
    for s, f in zip(sweeps.sweeps, fits, strict=True):
        if sweeps.kinds[s.joint - 1] == "revolute" and not f.sigma_point_perp <= SHORT_ARC_SIGMA and f.arc < SHORT_ARC:
            short.append(f"{sweep_where(s, sweeps.source)}: the {np.degrees(f.arc):.3g} deg arc gives a predicted axis-position sigma of "
                         f"{f.sigma_point_perp * 1e3:.3g} mm (above {SHORT_ARC_SIGMA * 1e3:g} mm): sweep a longer arc or measure more points "
                         "(--max-sigma makes this an error)")
    notes.extend(short)
    return short


def _oriented_by_nominal(sweeps: SweepSet, fits: list, nominal: Robot, notes: list[str]) -> list:
    """Without readings a sweep's direction comes from the point order; one that runs against the nominal's
    axis direction (e.g. recorded with decreasing joint values, or listed newest-first) is turned to the
    nominal's, with a note naming the joint."""
    nom = _core.axes(nominal.model(), sweeps.home).directions
    out = []
    for s, f in zip(sweeps.sweeps, fits, strict=True):
        j = s.joint - 1
        if f.direction @ np.asarray(nom[j]) < 0:
            notes.append(f"{sweep_where(s, sweeps.source)}: without readings the sweep runs against the nominal's axis {j + 1} "
                         "(decreasing joint values, or rows newest-first?): oriented by the nominal")
            f = flipped(f)
        out.append(f)
    return out


def _nominal_table(nominal: Robot | None, convention: str, home: np.ndarray) -> _core.Table | None:
    if nominal is None:
        return None
    if nominal.convention == convention:
        return nominal.table
    m = nominal.model()
    return _core.extract(_core.axes(m, np.zeros(m.nq)), convention).table


def _origins(nominal_table: _core.Table | None, convention: str, home: np.ndarray) -> np.ndarray | None:
    """ED-H frame origins: the nominal's on-body origins at home (world points, one per axis), which the core
    projects along each identified axis (Guo et al. sec. III: the origins are chosen on the body, not at the
    circle centres); None without a nominal or in other conventions."""
    if nominal_table is None or convention != "edh":
        return None
    return np.array(nominal_table.frames(home))[1:, :3, 3]


#: Axes with sin(angle) below this are parallel (identify's default ``parallel_tol``; also the bound of the ED-H
#: tolerance below when a table in another convention is asked of a result).
PARALLEL_TOL = 1e-3

#: ED-H with a nominal: a pair of axes the nominal has parallel takes the nominal's x when its tilt is within this
#: many of its combined direction sigmas (the common normal of a pair parallel within its noise follows the noise).
EDH_PARALLEL_SIGMAS = 3.0


def _edh_parallel_tol(fits: list, nominal: Robot | None, home: np.ndarray, parallel_tol: float) -> float:
    """The ``parallel_tol`` of an ED-H extraction against ``nominal``: ``EDH_PARALLEL_SIGMAS`` combined direction
    sigmas of the pairs the nominal has parallel (at most ``parallel_tol``; at least 1e-9, the round-off of data
    written to 10 digits), so that only a tilt the data cannot tell from zero is dropped (Guo et al.'s ED-H is
    exact for every other pair)."""
    if nominal is None:
        return parallel_tol
    z = np.asarray(_core.axes(nominal.model(), home).directions)
    sig = [math.hypot(fits[k].sigma_direction, fits[k + 1].sigma_direction) for k in range(len(z) - 1)
           if np.linalg.norm(np.cross(z[k], z[k + 1])) < 1e-9 and np.isfinite(fits[k].sigma_direction) and np.isfinite(fits[k + 1].sigma_direction)]
    return min(parallel_tol, max(EDH_PARALLEL_SIGMAS * max(sig, default=0.0), 1e-9))


def _axes_from(x: np.ndarray, sweeps: SweepSet, tool_R: np.ndarray, T_world_base: np.ndarray, lower, upper) -> _core.JointAxes:
    n = sweeps.n_joints
    pts = np.array([x[6 * j : 6 * j + 3] for j in range(n)])
    dirs = np.array([x[6 * j + 3 : 6 * j + 6] for j in range(n)])
    T = np.eye(4)
    T[:3, :3] = tool_R
    T[:3, 3] = x[6 * n : 6 * n + 3]
    return _core.JointAxes(pts, dirs, kinds=sweeps.kinds, q_ref=sweeps.home, T_world_base=T_world_base, T_world_tool=T, lower=lower, upper=upper)


def _parameter_cov(x: np.ndarray, cov: np.ndarray, ax: _core.JointAxes, sweeps: SweepSet, convention: str, opts: dict, p_ref: np.ndarray,
                   n_rot: int = 0) -> np.ndarray:
    """The covariance of [the ``convention`` table's parameters (row-major, angles wrapped about ``p_ref``), the tool's
    translation (, the reading scales)] from the covariance ``cov`` of [c_1, n_1, ..., tool point (, the tool's small
    rotation in world: ``n_rot`` = 3) (, scales)] at ``x`` (the scales pass through), by central differences through
    the core's extraction with ``opts``."""
    n6 = 6 * sweeps.n_joints + 3
    tool_R, base = np.asarray(ax.T_world_tool)[:3, :3], np.asarray(ax.T_world_base)
    angle_cols = np.array(_core.Table(convention, p_ref, list(ax.kinds)).angle_columns)
    xs = np.concatenate([x, np.zeros(len(cov) - n6)])

    def params_of(xv):
        R = rotvec_matrix(xv[n6 : n6 + n_rot]) @ tool_R if n_rot else tool_R
        a = _axes_from(xv[:n6], sweeps, R, base, ax.lower, ax.upper)
        t = _core.extract(a, convention, fidelity=False, **opts).table  # the tool-error check: once, by the caller
        d = t.params - p_ref
        d[:, angle_cols] = (d[:, angle_cols] + np.pi) % (2 * np.pi) - np.pi
        return np.concatenate([(p_ref + d).ravel(), np.asarray(t.T_last_tool)[:3, 3], xv[n6 + n_rot :]])

    return _propagate(xs, cov, params_of)


def _propagate(x: np.ndarray, cov: np.ndarray, f) -> np.ndarray:
    """The covariance of f(x) (a flat vector, angles wrapped) from the covariance of x, by central differences."""
    y0 = f(x)
    J = np.zeros((len(y0), len(x)))
    for i in range(len(x)):
        h = 1e-7
        xp, xm = x.copy(), x.copy()
        xp[i] += h
        xm[i] -= h
        d = f(xp) - f(xm)
        J[:, i] = d / (2 * h)
    return J @ cov @ J.T


def identify(
    sweeps: SweepSet,
    *,
    method: str = "auto",
    convention: str = "dh",
    nominal: Robot | None = None,
    T_world_base=None,
    loss: str = "soft_l1",
    parallel_tol: float = PARALLEL_TOL,
    intersect_tol: float | None = None,
    max_sigma: float | None = None,
    keep_dwell: bool = False,
    coupling=None,
    rotation_noise: float | None = None,
    tracker_noise: TrackerNoise | tuple | None = None,
    allow_implausible: bool = False,
    progress: Callable[[str], None] | None = None,
) -> Identification:
    """Identify the joint axes and the parameter table of ``convention`` from ``sweeps``.

    method : "auto" (chosen by the evidence, with a note saying which and why: without readings "geometric";
        with readings the joint fit with one home point ("global") or one per sweep ("readings": the home
        drifted, and the drift is added to the sigmas) by the BIC of the two on the same weights, or the
        "geometric" circles when the readings are worth nothing against the points; then the readings' scale
        errors, fitted as one population only when the evidence shows them: :func:`_reading_scales`), "kasa" (the
        paper's eq. 1-9), "hyper" (Al-Sharadqah & Chernov 2009), "geometric" (orthogonal distance),
        "readings" (per sweep, points as rotations of one rigid point by the recorded angles), "global".
    nominal : a robot of any convention; breaks sign ties, fixes free origins and the last frame
        (docs/conventions.md), gives names and limits.
    T_world_base : (4, 4) base frame in the measurement frame (default: the measurement frame itself). When
        given, the nominal stands on it (its base frame is the robot base); otherwise the nominal's world is
        taken as the measurement frame.
    loss : "soft_l1" (default), "huber" or "linear": per-point robust loss of the geometric, readings and global
        fits (its scale 3 robust sigmas of the misfits); outlying points are flagged in each fit's ``outliers``, never
        dropped. The robust default is free on clean data (the axes and sigmas of 0.02 mm Gaussian noise are those of
        "linear" within a few percent) and keeps one blunder from moving an axis (a 5 mm blunder moved one by 0.74
        mm with "linear"; issue 16).
    max_sigma : float, metres, optional
        The accuracy asked for: a sweep whose predicted axis-position uncertainty (1 sigma, across the axis)
        exceeds it is an error that names the sweep and the predicted value (e.g. an arc too short).
    keep_dwell : keep the dwell rows in the fits. By default the rows where the motion stands still (within the
        point noise) at the ends of a sweep are left out of the fits (they would weigh one end of the arc many
        times over), with a note naming them; the result's ``sweeps`` are the rows fitted.
    coupling : (n, n), optional
        Joint values from the controller's readings, ``q = coupling @ reading`` (default: the nominal's
        ``coupling``, from its robot file's ``[couplings]``; else the readings are the joint values).
    rotation_noise : float, rad, optional
        6-DoF poses: the orientation noise (1 sigma per component of the rotation vector) that weights the
        orientation residuals against the points; default estimated from the data (a variance component).
    tracker_noise : :class:`~denavit.fitting.joint.TrackerNoise` or (sigma_range m, sigma_angle rad[, position (3,)
        m]), optional
        The tracker's range/angle noise model: each point's noise is sigma_range along the line of sight from the
        tracker (at ``position`` in the data's frame, default the origin: a tracker's own frame) and sigma_angle
        times the range across it; the joint fit weights every point by the inverse of that covariance, whose
        overall scale stays estimated from the data (its shape only is declared). Default: isotropic point noise.
        The geometric circles weight their points by it too; the other per-sweep methods (kasa, hyper: algebraic;
        readings) take the points as isotropic (with a note).

    Several targets per pose (:attr:`~denavit.sweeps.Sweep.targets`, 2-4 SMRs on a nest) and 6-DoF poses
    (:attr:`~denavit.sweeps.Sweep.rotations`) are one joint fit with shared axes (methods "global", "readings",
    and "auto" with readings; :func:`~denavit.fitting.joint.fit_sweeps`), and the tool frame's orientation is then
    identified with its covariance (:attr:`Identification.tool_orientation`, :data:`TOOL_ORIENTATION`). The
    per-sweep methods fit the first target alone.
    allow_implausible : keep a fit that is implausible against the nominal (the axes its mirror image, matching it
        with two joints exchanged, or most pairs of axes far from its: a unit slip, the wrong robot), with a note;
        by default it is an error (issue 16: such fits had come back with small sigmas and no word).
    progress : called with a short message as each stage starts (the CLI shows it).
    """
    progress = progress or (lambda _msg: None)
    if not isinstance(sweeps, SweepSet):
        raise DenavitError(f"identify: expected a SweepSet, got {type(sweeps).__name__}: denavit.identify(path, nominal=...) reads files and names")
    if nominal is not None and not isinstance(nominal, Robot):
        from .calibration.parametrization import as_robot  # noqa: PLC0415

        nominal = as_robot(nominal)  # a built-in name, a robot file or a Model, as calibrate takes
    if method not in METHODS:
        raise DenavitError(f"unknown method {method!r}: expected one of {', '.join(METHODS)}")
    check_loss(loss, None, "identify")
    check_positive("max_sigma", max_sigma, "identify")
    convention = _core.convention_info(convention)["name"]
    tracker = as_tracker_noise(tracker_noise)
    n = sweeps.n_joints
    if nominal is not None and len(nominal.names) != n:
        raise DenavitError(f"nominal model {nominal.name} has {len(nominal.names)} joints, the data has {n}")
    coupling = coupling if coupling is not None else (nominal.coupling if nominal is not None else None)
    if coupling is not None:
        sweeps = decoupled(sweeps, coupling)
    check_sweep_labels(sweeps, [sweep_where(x, sweeps.source) for x in sweeps.sweeps])
    notes = _locked_notes(sweeps)
    if not keep_dwell:
        sweeps = _drop_dwell(sweeps, notes)
    chosen = method
    if method == "auto":
        method = "global" if sweeps.has_readings else "geometric"
        if method == "geometric":
            notes.append("auto: geometric (per-sweep circles): the data has no joint readings")
    fits = _per_sweep(sweeps, method, loss, max_sigma if method != "global" else None, progress, tracker)
    homes0, R0 = start_homes(sweeps, [(f.point, f.direction) for f in fits]) if sweeps.has_readings else (None, None)
    p_home = homes0[0] if sweeps.has_readings else _tool_point_geometric(sweeps, fits)
    cov, joint, scales = None, None, None
    if method == "global":
        what = f"{sweeps.n_targets} targets per pose" if sweeps.n_targets > 1 else "shared tool point"
        progress(f"one fit of all {len(sweeps.sweeps)} sweeps ({what}{', 6-DoF poses' if sweeps.has_rotations else ''})")
        method, gfits, gcov, gp, grms, joint, scales = _choose(sweeps, fits, homes0, R0, loss, notes, chosen, rotation_noise, tracker)
        if gfits is None:  # the readings are worthless: the per-sweep geometric circles
            fits = _per_sweep(sweeps, method, loss, max_sigma, progress, tracker)
            p_home = _tool_point_geometric(sweeps, fits)
        else:
            fits, cov, p_home, rms = gfits, gcov, gp, grms
            for s, f in zip(sweeps.sweeps, fits, strict=True):
                if max_sigma is not None and f.sigma_point_perp > max_sigma:
                    raise DegenerateError(f"{sweep_where(s, sweeps.source)}: predicted axis-position uncertainty {f.sigma_point_perp * 1e3:.3g} mm (1 sigma) "
                                          f"exceeds the requested {max_sigma * 1e3:.3g} mm; the sweep covers {np.degrees(f.arc):.1f} deg: sweep a longer arc or measure more points")
    if cov is None:
        cov = np.zeros((6 * n + 3, 6 * n + 3))
        for j, f in enumerate(fits):
            cov[6 * j : 6 * j + 6, 6 * j : 6 * j + 6] = f.cov
        # the tool point: the spread of its per-point estimates
        cov[6 * n :, 6 * n :] = np.eye(3) * float(np.mean([f.rms for f in fits])) ** 2 / max(sum(f.n_points for f in fits), 1)
        rms = float(math.sqrt(np.mean([f.rms**2 for f in fits])))
    if tracker is not None:
        model = (f"the tracker's noise model (range {tracker.sigma_range * 1e6:.3g} um, angles {math.degrees(tracker.sigma_angle) * 3600:.3g} arcsec, "
                 f"tracker at {', '.join(f'{v:.4g}' for v in tracker.position)} m)")
        if joint is not None:
            notes.append(f"{model} weights the points (its shape; the scale from the data): point noise {joint['sigma'] * 1e3:.3g} mm RMS per "
                         f"coordinate, {joint['sigma'] / math.sqrt(joint['tracker_ref2']):.3g} times the declared")
        elif method == "geometric":
            notes.append(f"{model} weights each circle's points (its shape; the scale from the data)")
        else:
            notes.append(f"{model} is used by the joint fit (method global or auto, with readings) and the geometric circles; the {method} fit takes the "
                         "points as isotropic")
    if joint is None and (sweeps.n_targets > 1 or sweeps.has_rotations):
        notes.append(f"the {method} fit uses the first target's points alone: {sweeps.n_targets} targets per pose"
                     f"{' and 6-DoF poses' if sweeps.has_rotations else ''} are one fit with shared axes in the joint fit (method global or auto, with readings)")
    base = np.eye(4) if T_world_base is None else np.asarray(T_world_base, dtype=float)
    if T_world_base is not None and nominal is not None:  # the nominal's base frame is the robot base given
        t = nominal.table
        nominal = replace(nominal, table=_core.Table(t.convention, t.params, t.kinds, base, t.T_last_tool))
    nominal_table = _nominal_table(nominal, convention, sweeps.home)
    if nominal is not None:  # the nominal flange orientation at home
        tool_R = _core.fk(nominal.model().with_tool(np.eye(4)), sweeps.home)[:3, :3]
    else:
        tool_R = np.eye(3)
    tool_R, orientation, G_rot = _tool_frame(sweeps, joint, tool_R, notes)
    rot_cov, target_points = None, None
    if joint is not None and sweeps.n_targets > 1:
        ph = joint["home"].mean(axis=0)
        target_points = np.vstack([ph, ph + joint["offsets"]])
    if G_rot is not None:  # the covariance of [axes, tool point, tool rotation]: the chosen cov, and the rotation's from the joint fit
        ca = joint["cov_all"]
        n6, H = 6 * n, joint["n_homes"]
        Gf = np.zeros((n6 + 6, ca.shape[0]))
        Gf[:n6, :n6] = np.eye(n6)
        for k in range(H):
            Gf[n6 : n6 + 3, n6 + 3 * k : n6 + 3 * k + 3] = np.eye(3) / H
        Gf[n6 + 3 :] = G_rot
        full = Gf @ ca @ Gf.T
        full[: n6 + 3, : n6 + 3] = cov
        rot_cov = full[n6 + 3 :, n6 + 3 :]
    lower = nominal.lower if nominal is not None else None
    upper = nominal.upper if nominal is not None else None
    if nominal is not None and not sweeps.has_readings:
        fits = _oriented_by_nominal(sweeps, fits, nominal, notes)
    x = np.concatenate([np.concatenate([f.point, f.direction]) for f in fits] + [p_home])
    cov_full = cov if rot_cov is None else full
    tol = _edh_parallel_tol(fits, nominal, sweeps.home, parallel_tol) if convention == "edh" else parallel_tol
    opts = {"parallel_tol": tol, "nominal": nominal_table, "origins": _origins(nominal_table, convention, sweeps.home)}
    if intersect_tol is not None:
        opts["intersect_tol"] = intersect_tol
    ax = _axes_from(x, sweeps, tool_R, base, lower, upper)
    ex = _core.extract(ax, convention, **opts)
    short = _short_arc_notes(sweeps, fits, notes)
    misfit_notes(sweeps, fits, [sweep_where(x, sweeps.source) for x in sweeps.sweeps], notes)
    if nominal is not None:
        nominal_plausibility(ex, fits, nominal, sweeps.home, nominal.names, sweeps.source, notes, short, SHORT_ARC_SIGMA, allow_implausible,
                             lone_axis=not sweeps.has_readings)
    p_ref = ex.table.params
    full_cov = None
    if scales is not None:  # [axes, tool point, reading scales]: the scales' covariance with the axes kept
        full_cov = np.block([[cov, scales[1]], [scales[1].T, scales[2]]])
    # [axes, tool point (, tool rotation) (, reading scales)]: the tool rotation's covariance with the scales is not
    # carried (the scales come from the same fit; their cross terms with the rotation are dropped)
    cov_all = cov_full
    if scales is not None:
        n_r = len(cov_full) - len(cov)
        cross = np.vstack([scales[1], np.zeros((n_r, scales[1].shape[1]))])
        cov_all = np.block([[cov_full, cross], [cross.T, scales[2]]])
    progress(f"{convention} parameters and their sigmas")
    param_cov = _parameter_cov(x, cov_all, ax, sweeps, convention, opts, p_ref, n_rot=len(cov_full) - len(cov))
    sigma = np.sqrt(np.clip(np.diag(param_cov), 0, None))[: p_ref.size].reshape(p_ref.shape)
    for pd in ex.pairs:
        if pd.relation == "parallel" and abs(pd.hayati_beta) > 0 and convention in ("dh", "mdh"):
            notes.append(f"axes {pd.joint}-{pd.joint + 1} treated as parallel: misalignment {math.degrees(pd.hayati_beta):.2e} deg (Hayati beta) is not representable in {convention}")
    result = Identification(method, convention, ax, fits, ex, sigma, cov, p_home, sweeps, nominal, nominal_table, rms, notes, param_cov,
                            reading_scale=None if scales is None else scales[0], axis_scale_cov=full_cov, coupling=coupling,
                            tool_orientation=orientation, tool_rotation_cov=rot_cov, target_points=target_points,
                            tracker_noise=tracker if joint is not None or method == "geometric" else None)
    if convention in ("dh", "mdh", "edh"):  # what the table carries, measured as --save states it (Identification.carried_error)
        carried = result.carried_error()[0] if convention == "edh" else result.carried_error(convention)[0]
        if carried > 1e-6:
            edh = carried if convention == "edh" else result.carried_error("edh")[0]
            if convention != "edh":
                exact = "POE is exact; " + (f"ED-H carries {edh * 1e3:.4f} mm: it is exact except {_DROPPED_TILT}" if edh > ROUND_OFF else "ED-H is exact")
            else:
                exact = f"it is exact except {_DROPPED_TILT}; POE is exact"
            notes.append(f"the {convention} table carries a tool-position error up to {carried * 1e3:.4f} mm ({exact})")
    return result


#: What an ED-H table against the nominal leaves out (docs/conventions.md, "ED-H").
_DROPPED_TILT = f"the tilt of a pair of axes the nominal has parallel, dropped when within {EDH_PARALLEL_SIGMAS:g} sigma of zero, its noise"


def _finite(v: float) -> float | None:
    """``v`` as a float, or None where it is not finite (JSON has no NaN)."""
    return float(v) if np.isfinite(v) else None


def to_json(result: Identification, *, box: bool = True) -> dict:
    """The JSON document of a result, in SI with the unit in every scalar key's name (docs/cli.md, "--json").

    Lengths in m (``_m``), angles in rad (``_rad``); the parameter rows are keyed by the convention's columns
    in SI; a joint's ``reading_sigma`` is ``_rad`` for a revolute joint and ``_m`` for a prismatic one.
    ``box``: include the measuring volume (``"bounding_box"``, :attr:`Identification.box`, computed now if it
    was not yet); ``box=False`` leaves it out and does not compute it.
    """
    t = result.table
    names = result.nominal.names if result.nominal else [f"j{i + 1}" for i in range(result.axes.nq)]
    rows = []
    for i, (row, sig) in enumerate(zip(t.params, result.sigma, strict=True)):
        r = {"joint": names[i]}
        for c, v, s in zip(t.columns, row, sig, strict=True):
            r[c] = float(v)
            r[f"{c}_sigma"] = float(s)
        rows.append(r)
    joints = []
    for i, (f, kind) in enumerate(zip(result.fits, result.sweeps.kinds, strict=True)):
        joints.append({
            "joint": names[i],
            "kind": kind,
            "axis": {"point_m": np.asarray(result.axes.points[i]).tolist(), "direction": np.asarray(result.axes.directions[i]).tolist(),
                     "sigma_point_perp_m": f.sigma_point_perp, "sigma_direction_rad": f.sigma_direction},
            "circle": {"centre_m": f.point.tolist(), "normal": f.direction.tolist(), "radius_m": _finite(f.radius)},
            "residuals": {"rms_m": f.rms, "max_m": float(np.max(np.abs(f.residuals))), "n_points": int(f.n_points),
                          "outliers": [int(k) for k in np.flatnonzero(f.outliers)], "per_point_m": np.asarray(f.residuals).tolist()},
            "arc_rad": _finite(f.arc),
            ("reading_sigma_rad" if kind == "revolute" else "reading_sigma_m"): _finite(f.reading_sigma),
            # the joint turns (1 + value) times its reading's motion (fitted by auto where the data shows it)
            "reading_scale": {"value": f.scale - 1, "sigma": f.scale_sigma} if np.isfinite(f.scale_sigma) else None,
        })
    return {
        "units": {"length": "m", "angle": "rad"},
        "frame": "measurement",
        "method": result.method,
        "convention": t.convention,
        "source": result.sweeps.source,
        "home": np.asarray(result.sweeps.home, dtype=float).tolist(),
        "joints": joints,
        "parameters": rows,
        "pairs": [{"joint": p.joint, "relation": p.relation, "angle_rad": p.angle, "distance_m": p.distance, "hayati_beta_rad": p.hayati_beta} for p in result.extraction.pairs],
        "tool_point_home_m": np.asarray(result.tool_point).tolist(),
        "tool_frame": _tool_frame_json(result),
        **({"targets_home_m": np.asarray(result.target_points).tolist()} if result.target_points is not None else {}),
        "T_world_base": np.asarray(t.T_world_base).tolist(),
        "T_last_tool": np.asarray(t.T_last_tool).tolist(),
        "max_tool_position_error_m": result.extraction.max_position_error,
        **({"bounding_box": _box_json(result.box)} if box else {}),
        "rms_m": result.rms,
        # the tracker's range/angle noise model the joint fit weighted the points by (null: isotropic point noise)
        "tracker_noise": None if (tn := result.tracker_noise) is None else {"sigma_range_m": tn.sigma_range, "sigma_angle_rad": tn.sigma_angle,
                                                                             "position_m": list(tn.position)},
        "notes": result.notes,
    }


def _tool_frame_json(result: Identification) -> dict:
    """The tool frame's orientation at home: where it came from, R_world_tool, its roll-pitch-yaw (rad) and its
    covariance (a small rotation in world, rad^2; null when it is the nominal's)."""
    from .geometry import matrix_rpy  # noqa: PLC0415

    R = np.asarray(result.axes.T_world_tool)[:3, :3]
    c = result.tool_rotation_cov
    turn = None
    if result.nominal is not None:  # the angle from the nominal's flange orientation at home
        R_nom = _core.fk(result.nominal.model().with_tool(np.eye(4)), result.sweeps.home)[:3, :3]
        turn = float(np.linalg.norm(matrix_rotvec(R @ R_nom.T)))
    return {"orientation_from": result.tool_orientation, "how": TOOL_ORIENTATION[result.tool_orientation], "R_world_tool": R.tolist(),
            "rpy_rad": np.asarray(matrix_rpy(R)).tolist(), "sigma_rad": result.tool_rotation_sigma if c is not None else None,
            "cov_rad2": c.tolist() if c is not None else None, "angle_from_nominal_flange_rad": turn}


def _box_json(b: BoundingBox) -> dict:
    return {"lengths_m": b.lengths.tolist(), "volume_m3": b.volume, "centre_m": b.center.tolist(), "orientation": b.axes.tolist()}


def write_json(result: Identification, path, *, box: bool = True, force: bool = False) -> None:
    """Write the result as JSON in SI (whole or not at all); ``box`` as in :func:`to_json`, ``force`` as in
    :func:`denavit.io.output.write_text`."""
    write_text(path, json_text(to_json(result, box=box)), force=force)


__all__ = ["Identification", "METHODS", "identify", "to_json", "write_json", "DegenerateError"]
