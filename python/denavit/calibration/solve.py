"""The calibration itself: one least-squares fit of the whole kinematic model (:func:`calibrate`; its result is
:class:`~denavit.calibration.result.Calibration`)."""

from __future__ import annotations

import math
import time
from dataclasses import replace

import numpy as np

from .. import _core
from ..errors import DenavitError, check_seed
from ..fitting.joint import as_tracker_noise
from ..fitting.robust import loss_weight
from ..progress import Stage
from ..robot import Robot, robot_of
from ..sweeps import SweepSet
from .compliance import held_note, with_compliance, with_payload
from .identifiability import analyze, parameter_status, plausible_sigmas
from .least_squares import covariance, fit_parameters, prior_block, residuals, weights
from .measurements import Measurements
from .parametrization import (
    Parametrization,
    configurations,
    parametrize,
    remembered,
    resolve_fix,
)
from .priors import PRIOR_DOMINATED, as_prior
from .registration import register
from .result import OUTLIER_SIGMAS, Calibration, Validation, correlation_notes
from .selection import MODELS, select_model
from .targets import calibrate_targets, several_targets, sweep_poses

#: scipy.optimize.least_squares' robust losses (per residual coordinate).
LOSSES = ("linear", "soft_l1", "huber", "cauchy", "arctan")


def _table_residuals(res: np.ndarray, measure: str) -> np.ndarray:
    return res.reshape(-1, 6 if measure == "pose" else 3)


@remembered()
def calibrate(
    meas: Measurements | SweepSet,
    nominal,
    *,
    convention: str = "edh",
    fix=(),
    loss: str = "linear",
    f_scale: float | None = None,
    start: str = "nominal",
    scale: bool = False,
    tool=None,
    noise: float | None = None,
    noise_rot: float | None = None,
    tracker_noise=None,
    holdout: float = 0.0,
    seed: int = 0,
    model: str = "auto",
    prior=None,
    payload=None,
    compliance=None,
    progress=None,
) -> Calibration:
    """Fit the whole kinematic model to measured tool points or poses (one least-squares problem).

    Parameters
    ----------
    meas : Measurements, SweepSet or TargetMeasurements
        Joint readings and measured points / poses in the measurement frame. Several targets per pose (a sweep set
        with ``targets``, :class:`~denavit.calibration.targets.TargetMeasurements`) are one fit with every target's
        point in the flange frame (:func:`~denavit.calibration.targets.calibrate_targets`; ``model`` and ``prior``
        do not apply there).
    nominal : Robot, Model, built-in name or robot file
        The nominal robot: the parametrisation, the start, names and limits.
    convention : {"edh", "mdh", "dh"}
        Parametrisation (module docstring).
    fix : iterable of str, or dict
        Parameters to hold at their start values, by name or shell pattern (``"base_*"``, ``"tool_z"``); a dict
        maps names to values (SI) to hold them at.
    loss : {"linear", "soft_l1", "huber", "cauchy", "arctan"}
        scipy's robust losses (per residual coordinate); ``f_scale`` (m) defaults to 3 robust sigmas of a
        first linear fit.
    start : {"nominal", "circles"}
        Start from the nominal model (base registered to the data), or from the circle-point identification
        (:func:`denavit.identification.identify`, global fit; sweep data only).
    scale : bool
        Also estimate a scale per joint.
    tool : array_like, optional
        Tool point (3,) in the flange frame, m (points), or ``T_flange_tool`` (4, 4) (poses); default nominal.
    noise, noise_rot : float, optional
        Known one-sigma noise per coordinate (m) and of the rotation (rad); default: estimated from the residuals.
    tracker_noise : :class:`~denavit.fitting.joint.TrackerNoise` or (sigma_range m, sigma_angle rad[, position (3,) m]),
    optional
        The tracker's range/angle noise model (as :func:`denavit.identification.identify`'s): each point's position
        residual is whitened by its covariance's shape (noise ``sigma_range`` along the line of sight from the
        tracker, ``sigma_angle`` times the range across it), the scale estimated from the residuals (so not with
        ``noise``). Default: isotropic.
    holdout : float
        Fraction of the poses held out of the fit to validate it (position error before / after).
    seed : int
        Seed of the held-out split.
    model : {"auto", "base-tool", "offsets", "full", "full-prior", "full-prior-no-beta", "full-prior-no-last"}
        Which parameters are free (:mod:`denavit.calibration.selection`): ``auto`` fits the nested candidates and
        keeps the simplest whose leave-one-pose-out tool-position error (from the hat matrix, about one fit each)
        is within one standard error of the best; a name fits that candidate alone. ``full`` is the least-squares
        fit of every identifiable parameter, the default before issue 36. The candidates' errors are in
        :attr:`Calibration.model_choice`. With a robust ``loss`` the candidates are scored on their linear fits and
        the one chosen is then fitted with the loss.
    prior : None, False, dict, str or :class:`~denavit.calibration.priors.Prior`
        The plausible-size priors of the ``full-prior*`` models (:mod:`denavit.calibration.priors`): None the
        defaults (1 mm, 0.1 deg, joint offsets 0.1 deg, scales 100 ppm; base and tool none), False none (those
        models are then not candidates), a dict of kind or parameter name / pattern -> width (SI). The fit is then
        maximum a posteriori, its sigmas include the prior, and parameters the data do not determine beyond their
        prior are held at their nominal values (status ``"fixed (prior)"``, listed in the notes).
    payload : float, (mass, (x, y, z)) or (N, 4), optional
        The payload on the flange (kg; its centre of mass in the flange frame, m) for every pose, where ``meas`` carries
        none (:attr:`Measurements.payload`: a pose file's ``payload_mass`` columns).
    compliance : None, True or False
        The joints' compliance under gravity and payload (:mod:`denavit.calibration.compliance`): None considers it
        when the data declare a payload, True always (both need the nominal's link inertials: without them a note
        says why), False never. Considered, ``auto`` also fits the ``+compliance`` candidates, which must predict
        better by more than a paired standard error to be chosen.
    progress : callable, optional
        Called with a short message as each stage starts, a :class:`denavit.progress.Stage` (a ``str``) whose
        ``fraction`` is the share of the work done before it, as :func:`denavit.identification.identify`'s.

    Returns
    -------
    Calibration
    """
    t0 = time.perf_counter()
    if several_targets(meas):  # marker clusters, SMR nests: one fit with every target's point in the flange
        return calibrate_targets(
            meas,
            nominal,
            convention=convention,
            fix=fix,
            loss=loss,
            start=start,
            scale=scale,
            tool=tool,
            noise=noise,
            tracker_noise=tracker_noise,
            holdout=holdout,
            seed=seed,
        )
    meas = sweep_poses(meas)  # 6-DoF sweeps (a probe's, the controller's poses): their orientations used (targets.py)
    if isinstance(meas, SweepSet):
        meas = Measurements.from_sweeps(meas)
    if not isinstance(meas, Measurements):
        raise DenavitError(f"calibrate: expected Measurements or a SweepSet, got {type(meas).__name__}")
    robot = robot_of(nominal)
    _check_options(meas, robot, loss, holdout, model, start, noise, noise_rot)
    prior_spec = as_prior(robot.prior if prior is None and robot.prior else prior)  # an explicit prior wins
    say = progress or (lambda _stage: None)

    def report(message: str, fraction: float) -> None:
        say(Stage(message, fraction))

    run = _Run(meas, robot, convention, tool, scale, noise, noise_rot, tracker_noise, payload, compliance, fix)
    run.split(holdout, seed)
    report(f"registering the measurement frame ({meas.n} poses)", 0.0)
    run.register()
    report("which parameters the data identify", 0.1)
    run.identifiability()
    report("fitting every identifiable parameter", 0.2)
    run.fit(start, convention)
    run.choose(model, prior_spec, report)
    report("covariance, held-out errors and notes", 0.9)
    return run.result(loss, f_scale, t0)


class _Run:
    """One calibration's steps, in :func:`calibrate`'s order; each sets the attributes the next ones use."""

    def __init__(self, meas, robot, convention, tool, scale, noise, noise_rot, tracker_noise, payload, compliance, fix):
        self.robot, self.noise, self.noise_rot = robot, noise, noise_rot
        self.notes: list[str] = []
        meas, ref = _tracker_weighting(meas, tracker_noise, noise, self.notes)
        pz = parametrize(robot, convention, measure=meas.kind, tool=tool, scale=scale)
        if payload is not None and getattr(meas, "payload", None) is None:
            meas = with_payload(meas, payload)
        pz, comp_notes = with_compliance(pz, meas, robot, compliance)  # k_i free in the +compliance candidates only
        self.notes += comp_notes
        self.meas, self.pz = meas, pz
        self.bounds = plausible_sigmas(pz)  # a parameter the data give a larger sigma is not determined by them
        self.x, self.user_fixed, self.candidates, self.comp = _free_candidates(pz, fix)
        # weights (1/sigma); pose data without declared noise: re-estimated after a first fit
        self.sig_p = noise if noise is not None else ref if ref is not None else 1e-5
        sig_r = noise_rot if noise_rot is not None else 1e-5
        self.w = weights(pz.measure, self.sig_p, sig_r)
        self.known = noise is not None and (pz.measure == "point" or noise_rot is not None)

    def split(self, holdout: float, seed: int) -> None:
        """The training poses and the held-out ones."""
        self.train, self.test_idx = _holdout_split(self.meas, holdout, seed, len(self.candidates), self.notes)

    def register(self) -> None:
        """Register the measurement frame, then fit base and tool only: the nominal geometry at its best."""
        pz, c, train = self.pz, self.candidates, self.train
        base_idx = [k for k in c if pz.names[k].startswith("base_")]
        tool_idx = [k for k in c if pz.names[k].startswith("tool_")]
        pz, x, reg_notes = register(pz, self.x, train, base_free=len(base_idx) == 6, tool_free=tool_idx)
        self.notes += reg_notes
        reg_free = [k for k in c if pz.names[k].startswith(("base_", "tool_"))]
        self.reg = analyze(pz, x, train, reg_free, self.w, explain=False)
        self.x_reg, _ = fit_parameters(pz, x, self.reg.kept_idx, train, self.w, "linear", None)
        self.pz, self.x = pz, x

    def identifiability(self) -> None:
        """Structural (configurations over the joint limits) and of these data."""
        # the sigmas are judged against the plausible sizes here only with the noise declared (an assumed 10 um would
        # drop what a finer instrument determines); else at the fit, with the noise its residuals give (fit)
        self.struct, self.structural, self.ana, self.hint = _identifiability(
            self.pz,
            self.robot,
            self.x_reg,
            self.meas,
            self.train,
            self.candidates,
            self.w,
            self.bounds if self.known else None,
        )

    def fit(self, start: str, convention: str) -> None:
        """The least-squares fit of every identifiable parameter from the start asked; then, with the noise the fit
        estimates, the parameters it leaves beyond their plausible size are dropped too (the analysis at the fit,
        where the measured point is) and the fit repeated without them."""
        self.x_start = self.x_reg.copy()
        if start == "circles":
            self.x_start = _circle_start(
                self.pz, self.x_reg, self.meas, self.robot, convention, self.ana.kept_idx, self.notes
            )
        for _ in range(3):
            kept = self.ana.kept_idx
            self.x_hat, self.sol, r, self.w, self.sig_p = _first_fit(
                self.pz, self.x_start, kept, self.train, self.w, self.noise, self.noise_rot, self.sig_p
            )
            # weighs the priors against the data
            self.s2_full = 1.0 if self.known else float(np.sum(r**2)) / max(len(r) - len(kept), 1)
            self.explains = _explains(self.pz, self.x_hat, self.train)
            if not self.explains:  # the residuals are no noise estimate: no sigma is judged by them
                break
            again = analyze(
                self.pz,
                self.x_hat,
                self.train,
                kept,
                self.w,
                self.struct,
                self.hint,
                bounds=self.bounds,
                s2=self.s2_full,
            )
            if again.rank == len(kept):
                break
            # what the first analysis dropped stays dropped (with its reasons); the fit restarts without the rest
            self.ana = replace(
                again, candidates=self.ana.candidates, unidentifiable=[*self.ana.unidentifiable, *again.unidentifiable]
            )

    def choose(self, model: str, prior_spec, report) -> None:
        """What is free: the candidate models scored by leave-one-pose-out prediction (selection.py); ``report``
        (message, fraction) says which candidate is fitted, from 0.35 to 0.9 of the work."""
        self.prior_spec = prior_spec
        self.choice = select_model(
            model,
            self.pz,
            self.train,
            self.w,
            prior=prior_spec,
            s2=self.s2_full,
            candidates=self.candidates,
            kept=self.ana.kept_idx,
            reg_kept=self.reg.kept_idx,
            x_reg=self.x_reg,
            x_full=self.x_hat,
            sol_full=self.sol,
            compliance=self.comp,
            bounds=self.bounds if self.explains else None,
            progress=lambda name, k, count: report(f"model {name} ({k + 1} of {count})", 0.35 + 0.55 * k / count),
        )

    def result(self, loss: str, f_scale, t0: float) -> Calibration:
        """The chosen model refitted with the loss, its covariance, statuses, misfits, held-out errors and notes."""
        pz, meas, train, w, won = self.pz, self.meas, self.train, self.w, self.choice.winner
        free, prior_rows = won.free, won.prior
        x_hat, sol, r, wt, robust_s2 = _robust_fit(pz, won.x, free, won.sol, train, w, loss, f_scale, prior_rows)
        # a compliance held at its bound 0 keeps the sigma the data give it (the covariance with it free there)
        bound = [pz.index(k) for k in won.at_bound]
        free = [*free, *bound]
        cov, s2 = _posterior(pz, x_hat, free, train, w, r, wt, self.known, robust_s2, self.s2_full, prior_rows)
        sd = np.sqrt(np.clip(np.diag(cov), 0, None))
        with np.errstate(invalid="ignore", divide="ignore"):
            corr = cov / np.outer(sd, sd)
        sigma = np.full(pz.n_params, np.nan)
        sigma[free] = sd
        if won.unidentifiable:  # compliances the data do not determine beside the chosen geometry: reported as such
            self.ana = replace(self.ana, unidentifiable=[*self.ana.unidentifiable, *won.unidentifiable])
        status = parameter_status(
            pz,
            free,
            self.user_fixed,
            self.structural,
            {u.name for u in self.ana.unidentifiable},
            held=set(won.prior_fixed),
            model_fixed=[*self.candidates, *self.comp],
        )
        for c in bound:
            status[c] = AT_BOUND
            self.notes.append(held_note(pz.names[c], pz.units[c], won.at_bound[pz.names[c]], sigma[c]))
        res_si, rms, rms_rot, outliers = _misfits(pz, x_hat, meas, r, w)
        validation = _held_out(pz, meas, train, self.test_idx, self.x_reg, x_hat)
        converged = sol is None or sol.status > 0
        _fit_notes(self.notes, pz, meas, x_hat, free, corr, rms, self.noise, won, converged, sol, outliers)
        noise_est = math.sqrt(s2) * self.sig_p if not self.known else self.sig_p
        return Calibration(
            pz,
            list(pz.names),
            x_hat,
            sigma,
            status,
            pz.x0,
            self.x_start,
            [pz.names[c] for c in free],
            cov,
            corr,
            self.ana,
            res_si,
            rms,
            rms_rot,
            outliers,
            validation,
            meas,
            loss,
            converged,
            0 if sol is None else int(sol.nfev),
            time.perf_counter() - t0,
            float(noise_est),
            self.notes,
            self.choice,
            None if prior_rows is None else self.prior_spec.sigma(pz),
        )


def _misfits(pz, x_hat, meas, r, w):
    """(the training residuals in SI (N, 3 or 6), the position and rotation RMS over every pose, the poses whose
    misfit is beyond :data:`OUTLIER_SIGMAS` robust sigmas)."""
    res_si = _table_residuals(r, pz.measure) / w[: (6 if pz.measure == "pose" else 3)]
    full_r, _, _ = residuals(pz, x_hat, replace(meas, whitening=None), np.ones(6), jacobian=False)
    full_r = _table_residuals(full_r, pz.measure)
    pos = np.linalg.norm(full_r[:, :3], axis=1)
    rms = float(np.sqrt(np.mean(pos**2)))
    rms_rot = float(np.sqrt(np.mean(np.sum(full_r[:, 3:] ** 2, axis=1)))) if pz.measure == "pose" else math.nan
    mis = np.linalg.norm(res_si[:, :3], axis=1)
    robust = float(np.median(mis)) / math.sqrt(2.366) if mis.size else 0.0
    return res_si, rms, rms_rot, np.flatnonzero(pos > OUTLIER_SIGMAS * max(robust, 1e-300))


def _check_options(meas, robot, loss, holdout, model, start, noise, noise_rot) -> None:
    """One-line errors for data that do not fit the nominal and options out of their ranges."""
    n = len(robot.names)
    if meas.nq != n:
        raise DenavitError(
            f"{meas.source}: the data has {meas.nq} joint readings per pose but the nominal model {robot.name} has {n}"
            f" joints ({', '.join(robot.names)})"
        )
    for j, (got, want) in enumerate(zip(meas.kinds or robot.table.kinds, robot.table.kinds, strict=True)):
        if got != want:
            unit = meas.units.get("angle" if got == "revolute" else "length", "?")
            raise DenavitError(
                f"{meas.source}: joint {j + 1} ({robot.names[j]}) of {robot.name} is {want}, but its readings were read"
                f" as {got} (in {unit}): "
                f'pass kinds={list(robot.table.kinds)} to read_measurements (or state "kinds" in a JSON file)'
            )
    if loss not in LOSSES:
        raise DenavitError(f"unknown loss {loss!r}: expected one of {', '.join(LOSSES)}")
    if not 0.0 <= holdout < 0.9:
        raise DenavitError(f"holdout: expected a fraction in [0, 0.9), got {holdout}")
    if model not in MODELS:
        raise DenavitError(f"model: expected one of {', '.join(MODELS)}, got {model!r}")
    if start not in ("nominal", "circles"):
        raise DenavitError(f"start: expected 'nominal' or 'circles', got {start!r}")
    for what, v, unit in (("noise", noise, "m"), ("noise_rot", noise_rot, "rad")):
        if v is not None and not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
            raise DenavitError(f"{what}: expected the known one-sigma noise, a finite value > 0 ({unit}), got {v!r}")


def _tracker_weighting(meas: Measurements, tracker_noise, noise, notes: list) -> tuple[Measurements, float | None]:
    """The measurements whitened by the tracker's noise model (and its mean per-coordinate sigma, m), or as given."""
    tracker = as_tracker_noise(tracker_noise)
    if tracker is None:
        return meas, None
    if noise is not None:
        raise DenavitError(
            f"noise = {noise!r} and tracker_noise: give one (the tracker's model declares the shape of each point's"
            " noise, its scale is estimated from the residuals)"
        )
    W, ref = tracker.whitening(meas.points)
    notes.append(
        f"points weighted by the tracker's noise model (range {tracker.sigma_range * 1e6:.3g} um, angles"
        f" {math.degrees(tracker.sigma_angle) * 3600:.3g} arcsec, tracker at"
        f" {', '.join(f'{v:.4g}' for v in tracker.position)} m; {ref * 1e3:.3g} mm per coordinate on average), the"
        " scale estimated from the residuals"
    )
    return replace(meas, whitening=W), ref


def _free_candidates(pz: Parametrization, fix) -> tuple[np.ndarray, dict, list, list]:
    """(start values with the user's held values, the user's fixed {index: value or None}, the candidate free
    parameters, the compliances among them)."""
    x = pz.x0.copy()
    user_fixed = resolve_fix(pz, fix)
    for k, v in user_fixed.items():
        if v is not None:
            x[k] = v
    rule_fixed = {pz.index(nm) for nm in pz.rules}
    candidates = [c for c in range(pz.n_params) if c not in user_fixed and c not in rule_fixed]
    comp = [c for c in candidates if c in set(getattr(pz, "compliance_idx", ()))]
    return x, user_fixed, [c for c in candidates if c not in comp], comp


def _holdout_split(meas: Measurements, holdout: float, seed: int, n_candidates: int, notes: list):
    """(the training poses, the held-out poses' indices) of a ``holdout`` fraction drawn with ``seed``."""
    if holdout > 0:
        n_test = int(round(holdout * meas.n))
        perm = np.random.default_rng(check_seed(seed)).permutation(meas.n)
        if n_test >= 1 and 3 * (meas.n - n_test) > n_candidates + 1:
            return meas.subset(np.sort(perm[n_test:])), np.sort(perm[:n_test])
        notes.append(f"holdout {holdout} skipped: {meas.n} poses are too few to hold any out")
    return meas, np.zeros(0, dtype=int)


def _identifiability(pz, robot, x_reg, meas, train, candidates, w, bounds) -> tuple:
    """(the structural analysis, the structurally unidentifiable parameters' names, the analysis of the training data
    (``bounds``: the plausible sizes of the parameters' errors, the noise as ``w`` declares it; or None), the hint on
    joints that never move), with one-line errors when the data are too few or a joint never moves where that leaves
    parameters undetermined."""
    n = len(robot.names)
    rich = Measurements(
        configurations(robot, max(2 * pz.n_params, 60)),
        np.zeros((max(2 * pz.n_params, 60), 3)),
        None,
        "spread configurations",
    )
    if pz.measure == "pose":
        rich = Measurements(rich.q, None, np.tile(np.eye(4), (rich.n, 1, 1)), rich.source)
    struct = analyze(pz, x_reg, rich, candidates, w, explain=False)
    structural = {u.name for u in struct.unidentifiable}
    still = [j for j in range(n) if np.ptp(train.q[:, j]) < 1e-9]
    hint = "".join(f"; joint {j + 1} ({robot.names[j]}) never moves in the data" for j in still)
    ana = analyze(pz, x_reg, train, candidates, w, struct, hint, bounds=bounds)
    data_only = [u.name for u in ana.unidentifiable if not u.structural and u.sigma is None]
    n_eq = train.n * (6 if pz.measure == "pose" else 3)
    if n_eq <= struct.rank:
        per = 6 if pz.measure == "pose" else 3
        raise DenavitError(
            f"{meas.source}: too few measurements: {train.n} {'poses' if per == 6 else 'points'} give {n_eq} equations"
            f" for the {struct.rank} parameters this model can identify ({', '.join(struct.base_parameters)}); need at"
            f" least {struct.rank // per + 1} {'poses' if per == 6 else 'points'} (many more to average the noise), or"
            " fix parameters"
        )
    if still and data_only:
        vals = ", ".join(
            f"q{j + 1} = {train.q[0, j]:.6g} {'m' if robot.table.kinds[j] == 'prismatic' else 'rad'}" for j in still
        )  # SI, labelled
        raise DenavitError(
            f"{meas.source}: joint(s) {', '.join(f'{j + 1} ({robot.names[j]})' for j in still)} never move in the data"
            f" ({vals} in all {train.n} poses): the data cannot identify {', '.join(data_only)} (beyond the parameters"
            " redundant in any case); move the joint(s), or hold these fixed:"
            f" fix={[u.name for u in ana.unidentifiable]}"
        )
    return struct, structural, ana, hint


def _first_fit(pz, x_start, free, train, w, noise, noise_rot, sig_p):
    """The least-squares fit of every identifiable parameter; pose data without a declared noise: the position and
    rotation noise re-estimated from its residuals and the fit repeated with them. (x, solution, whitened
    residuals, weights, position sigma)."""
    x_hat, sol = fit_parameters(pz, x_start, free, train, w, "linear", None)
    r = residuals(pz, x_hat, train, w, jacobian=False)[0]
    if pz.measure == "pose" and (noise is None or noise_rot is None):
        rr = _table_residuals(r, "pose")
        dof = max(len(r) - len(free), 1) / len(r)
        sig_p = noise if noise is not None else float(np.sqrt(np.sum((rr[:, :3] / w[0]) ** 2) / (rr[:, :3].size * dof)))
        sig_r = (
            noise_rot
            if noise_rot is not None
            else float(np.sqrt(np.sum((rr[:, 3:] / w[3]) ** 2) / (rr[:, 3:].size * dof)))
        )
        sig_p, sig_r = max(sig_p, 1e-12), max(sig_r, 1e-12)
        w = weights(pz.measure, sig_p, sig_r)
        x_hat, sol = fit_parameters(pz, x_hat, free, train, w, "linear", None)
        r = residuals(pz, x_hat, train, w, jacobian=False)[0]
    return x_hat, sol, r, w, sig_p


def _robust_fit(pz, x_hat, free, sol, train, w, loss, f_scale, prior_rows):
    """The chosen model refitted with a robust ``loss`` (as given for "linear"): (x, solution, whitened residuals,
    the loss's weights per residual, the robust variance or None)."""
    r = residuals(pz, x_hat, train, w, jacobian=False)[0]
    if loss == "linear":
        return x_hat, sol, r, np.ones_like(r), None
    # f_scale: 3 robust sigmas of the misfits, re-estimated once from the robust fit (the first estimate,
    # from the linear fit, is inflated by the outliers' pull)
    for _ in range(2 if f_scale is None else 1):
        mis = np.linalg.norm(_table_residuals(r, pz.measure)[:, :3], axis=1)
        robust = float(np.median(mis)) / math.sqrt(2.366) if mis.size else 1.0  # median of chi_3 = sqrt(2.366)
        fs = f_scale * w[0] if f_scale is not None else 3 * robust
        x_hat, sol = fit_parameters(pz, x_hat, free, train, w, loss, fs, prior=prior_rows)
        r = residuals(pz, x_hat, train, w, jacobian=False)[0]
    mis = np.linalg.norm(_table_residuals(r, pz.measure)[:, :3], axis=1)
    robust_s2 = (float(np.median(mis)) / math.sqrt(2.366)) ** 2
    return x_hat, sol, r, loss_weight(loss, (r / fs) ** 2), robust_s2


#: The status of a compliance fitted negative and held at its bound (``k >= 0``): estimated, at 0, with its sigma.
AT_BOUND = "held at 0 (k >= 0)"


def _posterior(pz, x_hat, free, train, w, r, wt, known, robust_s2, s2_full, prior_rows):
    """(the free parameters' covariance, the variance of unit weight it was scaled with)."""
    Jf = residuals(pz, x_hat, train, w, columns=free)[1]
    Jf *= np.sqrt(wt)[:, None]
    m_eq, p = Jf.shape
    s2 = 1.0 if known else robust_s2 if robust_s2 is not None else float(np.sum(r**2)) / max(m_eq - p, 1)
    if prior_rows is not None:  # the posterior covariance: the prior rows weigh in at the noise they were fitted with
        s2 = 1.0 if known else s2_full
        Jf = np.vstack([Jf, prior_block(prior_rows, free)])
    return covariance(Jf, s2), s2


def _held_out(pz, meas, train, test_idx, x_reg, x_hat) -> Validation | None:
    """The tool-position errors on the held-out poses before (the registered nominal) and after calibration."""
    if not test_idx.size:
        return None
    test = meas.subset(test_idx)
    before = np.linalg.norm(residuals(pz, x_reg, test, np.ones(6), jacobian=False)[2][:, :3, 3] - test.points, axis=1)
    after = np.linalg.norm(residuals(pz, x_hat, test, np.ones(6), jacobian=False)[2][:, :3, 3] - test.points, axis=1)
    return Validation(
        train.n,
        test.n,
        float(np.sqrt(np.mean(before**2))),
        float(before.max()),
        float(np.sqrt(np.mean(after**2))),
        float(after.max()),
        test_idx,
    )


#: A fit whose tool-position misfit (rms) exceeds this fraction of the measured volume's radius explains little of the
#: data (a note says so; its residuals are then no estimate of the noise).
EXPLAINS = 0.01


def _volume(meas: Measurements) -> float:
    """The measured volume's radius (m): the farthest measured point from their centroid (at least 1 mm)."""
    return max(float(np.max(np.linalg.norm(meas.points - meas.points.mean(axis=0), axis=1))), 1e-3)


def _explains(pz: Parametrization, x, meas: Measurements) -> bool:
    """Whether the model at ``x`` explains ``meas``: its tool-position misfit within :data:`EXPLAINS` of the volume."""
    pred = residuals(pz, x, meas, np.ones(6), jacobian=False)[2][:, :3, 3]
    rms = float(np.sqrt(np.mean(np.sum((pred - meas.points) ** 2, axis=1))))
    return rms <= EXPLAINS * _volume(meas)


def _fit_notes(notes, pz, meas, x_hat, free, corr, rms, noise, won, converged, sol, outliers) -> None:
    """What the user should know about the fit, added to ``notes``: a misfit far beyond the volume or the declared
    noise first, then parameters held by their prior, the solver, divergence, correlations and outliers."""
    size = _volume(meas)
    if rms > EXPLAINS * size:
        notes.insert(
            0,
            f"the fit explains little of the data: rms {rms * 1e3:.4g} mm against a measured volume of {size * 1e3:.4g}"
            " mm radius (are the joint readings in the units declared, the joints in the nominal's order, the nominal"
            " the right robot?)",
        )
    elif noise is not None and rms > 10 * noise * math.sqrt(3):
        notes.insert(
            0,
            f"the residual (rms {rms * 1e3:.4g} mm) is {rms / (noise * math.sqrt(3)):.3g} x what the declared noise"
            f" ({noise * 1e3:.3g} mm per coordinate) explains: the model or the data has errors the noise does not"
            " cover",
        )
    if won.prior_fixed:
        notes.append(
            f"not determined by the data beyond their prior (posterior sigma above {PRIOR_DOMINATED:g} of the prior"
            " width: the data alone would give more than 2 prior widths), held at their nominal values: "
            + ", ".join(f"{k} ({v:.3g} of its prior width)" for k, v in won.prior_fixed.items())
        )
    if not converged:
        notes.append(f"the least-squares solver stopped without meeting its tolerances ({sol.message})")
    lengths = [c for c in free if pz.units[c] == "length" and not pz.names[c].startswith("base_")]
    far = [pz.names[c] for c in lengths if abs(x_hat[c] - pz.x0[c]) > 10 * size]
    if far:
        notes.append(
            f"parameters moved by more than 10 x the measured volume ({', '.join(far)}): the fit may have diverged;"
            " check the nominal model and the units"
        )
    notes.extend(correlation_notes(corr, [pz.names[c] for c in free]))
    if outliers.size:
        notes.append(
            f"{outliers.size} pose(s) with a tool-position misfit above {OUTLIER_SIGMAS} robust sigmas:"
            f" {', '.join(meas.where[i] for i in outliers[:5])}{' ...' if outliers.size > 5 else ''}"
        )


def _circle_start(
    pz: Parametrization, x, meas: Measurements, robot: Robot, convention: str, free: list, notes: list
) -> np.ndarray:
    """Start values from the circle-point identification (global fit of the sweeps): the chain is fitted to
    the identified model's predictions at the measured configurations."""
    # (identify imports the fitting package: loaded for start="circles" only)
    from ..identification import identify  # noqa: PLC0415

    if meas.sweeps is None:
        raise DenavitError(
            f"{meas.source}: start='circles' needs sweep data (Measurements.from_sweeps); these are arbitrary poses:"
            " use start='nominal'"
        )
    if pz.measure != "point":
        raise DenavitError("start='circles' works with measured points (sweeps), not poses")
    res = identify(meas.sweeps, method="global", convention="edh", nominal=robot)
    m = res.model()
    tp = np.asarray(m.T_flange_tool)[:3, 3]
    T = _core.fk_batch(m.with_tool(np.eye(4)), meas.q)
    target = Measurements(meas.q, T[:, :3, :3] @ tp + T[:, :3, 3], None, "circle-point identification")
    xs, _ = fit_parameters(pz, x, free, target, np.ones(6), "linear", None)
    notes.append(f"started from the circle-point identification (global fit, residual rms {res.rms * 1e3:.4g} mm)")
    return xs
