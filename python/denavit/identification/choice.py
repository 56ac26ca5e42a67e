"""The measurement model ``auto`` chooses: the global joint fit with or without a home drift, reading scales and the
joints' compliances, by the evidence (Schwarz's criterion; the scales' marginal likelihood, Wakefield's approximate
Bayes factor), one rule for the three effects: each tested in the fit that frees it with the others chosen."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from ..errors import NotConvergedError
from ..fitting.chain import _chain
from ..fitting.joint import TrackerNoise, fit_sweeps, stride
from ..fitting.readings import READINGS_WORTHLESS
from ..fitting.result import axis_sigmas
from ..fitting.robust import _Levels, flag_outliers
from ..message import Length, Message
from ..sweeps import SweepSet
from .frames import SHORT_ARC
from .prepare import _motions


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
        out.append(
            replace(
                f,
                point=c,
                direction=nv,
                radius=radius,
                residuals=mis,
                rms=float(math.sqrt(np.mean(mis**2))),
                cov=cov6,
                sigma_point_perp=sp,
                sigma_direction=sd,
                outliers=flag_outliers(res["whitened"][k], res["components"], 1.0),
                method=label if loss == "linear" else f"{label}+{loss}",
                reading_sigma=res["reading_sigma"][k],
                noise=res["sigma"],
                scale=1 + res["scales"][j] if np.isfinite(res["scale_sigma"][j]) else f.scale,
                scale_sigma=res["scale_sigma"][j],
            )
        )
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
        est += (
            float(np.trace(P @ res["cov"][n6 + 3 * k : n6 + 3 * k + 3, n6 + 3 * k : n6 + 3 * k + 3] @ P)) * (S - 1) / S
        )
    sd2 = max(ss - est, 0.0) / (2 * max(S - 1, 1))
    for j in range(n6 // 6):
        cov[6 * j : 6 * j + 3, 6 * j : 6 * j + 3] += sd2 * np.eye(3)
    cov[n6:, n6:] += sd2 * np.eye(3)
    return cov, math.sqrt(sd2)


def _wald(theta: np.ndarray, C: np.ndarray) -> float:
    """``theta^T C^-1 theta``: the Wald statistic of the estimates ``theta`` with their covariance ``C`` (a
    pseudo-inverse: a direction the fit cannot see adds nothing)."""
    return float(theta @ np.linalg.pinv((C + C.T) / 2) @ theta)


def _drift_wald(d: dict) -> tuple[float, int]:
    """(the Wald statistic of a home point per sweep, its degrees): the differences of each sweep's home point from
    the first's (3 (S - 1)) against their covariance in the fit ``d`` with them, from that one fit on its own weights.
    Schwarz's criterion (:func:`_schwarz`) in this form, as the compliances' (:func:`_compliance_test`): a difference of
    two fits' sums of squares needs both on one weighting, and with 6-DoF poses each fit weighs the orientations by its
    own noise estimate. benchmarks/bench_identify_choice_poses.py (20 seeds, 50 poses per sweep, UR5 and KR5): on rigid
    poses that difference less 15 ln n came to a median of -286 and -272 where its expected value is 15 - 15 ln n =
    -97 (now -100 and -98; on points -88 and -87 against -87, as before), and a home moving 8 um per coordinate between
    sweeps was found on poses in 0 of 20 runs, now 13 and 12 of 20 (on points 5 and 4, now 9 and 7)."""
    homes = d["home"]
    S = len(homes)
    n6 = d["cov"].shape[0] - 3 * S
    T = np.zeros((3 * (S - 1), 3 * S))
    for k in range(1, S):
        T[3 * k - 3 : 3 * k, :3] = -np.eye(3)
        T[3 * k - 3 : 3 * k, 3 * k : 3 * k + 3] = np.eye(3)
    return _wald(T @ homes.reshape(-1), T @ d["cov"][n6:, n6:] @ T.T), 3 * (S - 1)


def _schwarz(chi2: float, k: int, n_res: int, what: str) -> tuple[float, str]:
    """Schwarz's criterion in its Wald form (the likelihood ratio's large-sample equal, from the richer fit alone):
    ``chi2`` of ``k`` extra parameters (``what``, for the notes) against ``k ln n``, n the residual count ``n_res``.
    Returns (chi2 less that penalty: positive, the richer model wins; the test in words). The AIC's 2 per parameter
    had picked a drift on exact 30 degree data in 3 % of runs (a home per sweep trades with the tilt of an axis about
    its arc's tangent)."""
    pen = k * math.log(max(n_res, 1))
    return (
        chi2 - pen,
        f"BIC, Wald form: chi^2 {chi2:.3g} of {what} {'>' if chi2 > pen else '<='} {k} ln {n_res} = {pen:.3g}",
    )


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
CHI2_MEDIAN = _Levels(
    {
        1: 0.454936423119572,
        2: 1.386294361119891,
        3: 2.3659738843753377,
        4: 3.3566939800333224,
        5: 4.351460191095526,
        6: 5.348120627447118,
        7: 6.345811195521515,
        8: 7.344121497701794,
        9: 8.342832692252955,
        10: 9.34181776559197,
        11: 10.340998074391827,
        12: 11.34032237742414,
    },
    lambda k: _chi2_quantile(0.5, k),
)


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
    hyperparameter tau (:func:`_scale_evidence`), n the fit's residual count ``n_res``: the rule of the drift's and the
    compliances' choices (:func:`_schwarz`), the scales integrated out (Schwarz 1978; Kass & Raftery 1995, sec.
    4.1.3). ``k`` the count of scale estimates. Like theirs, the evidence comes from one fit, its estimates and their
    covariance (the free scales' fit, on the weights of the fit before it).

    Shown against the out-of-sample error it stands for, the axes' true error (benchmarks/bench_identify_choice.py,
    the UR5 of issue 36, 100 seeds per case): on exact readings it fitted scales in 1 % of runs on 30 and on 90 degree
    arcs (the old rule, any positive spread: 49 and 51 %; n = k, the scale estimates the hyperparameter rests on as a
    variance component's groups, Pauler 1998: 5 and 2 %), and among the runs where the scale fit and the exact-scale
    fit differ it chose the one nearer the truth on the axes in 48/49 and 42/51 (n = k: 44/49, 41/51). 200 ppm scale
    errors on two joints, whose free sigmas are 20-60 ppm on 90 degree arcs, it fitted in every run (axes 0.26x the
    exact-scale fit's error, median); on 30 degree arcs (sigmas 240-470 ppm) in 1 %, where the scale fit was nearer
    the truth in 32 of 62 runs and farther in RMS (98 against 75 um): there no rule beat chance (29/62, n = k 26/62)."""
    return math.log(max(n_res, 1)), f"ln {n_res}"


def _scale_list(g: dict, n: int) -> str:
    return ", ".join(
        f"joint {j + 1} {g['scales'][j] * 1e6:+.4g} +/- {g['scale_sigma'][j] * 1e6:.2g} ppm"
        for j in range(n)
        if np.isfinite(g["scale_sigma"][j])
    )


#: The effects auto weighs (:func:`_select`; this order breaks a tie) against the joint fit with one home point,
#: exact reading scales and rigid joints, with their names in the notes.
EFFECTS = {
    "drift": "a home point per sweep",
    "scales": "the reading scales",
    "compliance": "the joints' compliances",
}


def _drift_test(d: dict, n_res: int) -> tuple[float, str, float]:
    """A home point per sweep in the fit ``d`` that frees one (:func:`_drift_wald`, :func:`_schwarz`)."""
    return (*_schwarz(*_drift_wald(d), n_res, "the home points' differences"), math.nan)


def _scales_test(d: dict, n_res: int) -> tuple[float, str, float]:
    """The readings' scale errors as a population in the fit ``d`` that frees every swept joint's scale: the evidence
    that they err at all (:func:`_scale_evidence`, the marginal likelihood of the scales as N(0, tau^2) against exact
    scales, one hyperparameter) less its penalty (:func:`_scale_penalty`), the evidence in words, and the joints'
    spread tau from those estimates (:func:`_scale_spread`; not shown at tau = 0)."""
    on = np.isfinite(d["scale_sigma"])
    lr, _ = _scale_evidence(d["scales"][on], d["scale_cov"][np.ix_(on, on)])
    pen, name = _scale_penalty(int(np.sum(on)), n_res)
    evidence = f"2 ln(marginal likelihood ratio) {lr:.3g} {'>' if lr > pen else '<='} {name} = {pen:.3g}"
    tau = math.sqrt(_scale_spread(d["scales"][on], d["scale_sigma"][on]))
    if lr > pen and not tau > 0:  # (the diagonal Q-profile against the full covariance's likelihood: rare)
        evidence += ", but the joints' scales scatter within their sigmas (tau = 0)"
    return (lr - pen if tau > 0 else min(lr - pen, 0.0)), evidence, tau


def _compliance_test(d: dict, n_res: int) -> tuple[float, str, float]:
    """The joints' compliances in the fit ``d`` that frees them (those held at their bound 0 among them): ``k^T C^-1
    k`` against ``ln n`` per free one (:func:`_schwarz`). With every one held at 0 the model is the rigid one (-inf)."""
    on = np.isfinite(d["compliance_sigma"])
    free = int(np.sum(on & ~d["compliance_held"]))
    if free:
        chi2 = _wald(d["compliance"][on], d["compliance_cov"][np.ix_(on, on)])
        return (*_schwarz(chi2, free, n_res, "the compliances"), math.nan)
    z = {j: -d["compliance_negative"][j] / d["compliance_sigma"][j] for j in np.flatnonzero(d["compliance_held"])}
    if not z:
        return -math.inf, "no joint's gravity torque changes in the data", math.nan
    why = (
        "every one fitted negative and held at 0 (a joint gives way under its torque): "
        + ", ".join(f"k_{j + 1} {v:.2g} sigma below 0" for j, v in z.items())
        + ("; check the payload and the nominal's inertials" if max(z.values()) > 2 else "")
    )
    return -math.inf, why, math.nan


_TESTS = {"drift": _drift_test, "scales": _scales_test, "compliance": _compliance_test}
#: Each effect's words when the fit with it does not converge.
_NO_CONVERGENCE = {
    "drift": "a home point per sweep does not converge on these arcs",
    "scales": "n/a: no convergence",
    "compliance": "the fit with them does not converge",
}


def _fit_from(sweeps: SweepSet, dqs: list, loss: str, models: dict, base: dict, **kw) -> dict:
    """A joint fit started from ``base``'s lines, home point, offsets and orientation."""
    return fit_sweeps(
        sweeps,
        dqs,
        list(zip(base["points"], base["directions"], strict=True)),
        base["home"].mean(axis=0),
        loss=loss,
        where=sweeps.source,
        offsets0=base["offsets"],
        rotation0=base["rotation"],
        **models,
        **kw,
    )


class _Models:
    """The joint fits of auto's choice, one per set of effects (:data:`EFFECTS`; kept once fitted): each from the
    first fit ``g``'s lines, home point, offsets and orientation, on its own weights (the variance components and the
    robust scale start at ``g``'s and are estimated with the effects: the simpler model's tangential misfit held the
    effect too), or on ``g``'s when that does not converge; None when neither does. ``tq``: the gravity torques that
    the compliances' fits carry (:func:`_torques`)."""

    def __init__(self, sweeps: SweepSet, dqs: list, loss: str, rotation_noise, tracker, g: dict, tq):
        self.sweeps, self.dqs, self.loss, self.g, self.tq = sweeps, dqs, loss, g, tq
        self.models = {"rotation_sigma": rotation_noise, "tracker": tracker}
        self.n_res = g["components"] * sum(len(s.points) for s in sweeps.sweeps)
        self.cache = {frozenset(): g}

    def options(self, effects: frozenset) -> dict:
        return {
            "per_sweep_home": "drift" in effects,
            "scales": "scales" in effects,
            "torques": self.tq if "compliance" in effects else None,
        }

    def fit(self, base: dict, effects: frozenset, **kw) -> dict:
        return _fit_from(self.sweeps, self.dqs, self.loss, self.models, base, **self.options(effects), **kw)

    def __getitem__(self, effects: frozenset) -> dict | None:
        if effects not in self.cache:
            g, out = self.g, None
            for weights in ({"weights0": (g["gamma"], g["robust_scale"])}, {"gamma": g["gamma"]}):
                try:
                    out = self.fit(g, effects, **weights)
                    break
                except NotConvergedError:
                    continue
            self.cache[effects] = out
        return self.cache[effects]


def _select(models: _Models, candidates: list) -> tuple[frozenset, dict, dict]:
    """auto's effects, one rule for all (stepwise, by Schwarz's criterion): every candidate effect not yet chosen is
    tested in the fit that frees it with those chosen, by its criterion less its penalty (:data:`_TESTS`: the
    drift's and the compliances' Schwarz criterion in its Wald form, the scales' marginal likelihood ratio against ln
    n; each about 2 ln of the Bayes factor for the effect); the one that gains most, if any gains, is chosen, and every
    chosen effect is then tested again in the fit with all chosen (one that no longer pays, the furthest below first,
    is dropped), until no candidate gains. So an effect is chosen only when it pays for itself in the presence of the
    others chosen, and of two that could be taken for each other the one that explains the data better comes first
    and holds the other out. A fit that does not converge gives its effect up.

    (Chosen one after another, each tested alone against the model without the rest, an effect took another's place:
    with a 5 kg payload declared on a rigid UR5 the compliances, chosen first, took 200 ppm reading scale errors on
    two joints in 20 of 20 runs on points (the scales found in none) and 5 of 20 on 6-DoF poses, a 30 um drift in 13
    and 2 of 20 (on a KR 210 at 100 kg: scale errors 20 and 20 of 20, a drift 12 and 11): benchmarks/
    bench_identify_choice_poses.py; now in none, the scales and the drift found as without a payload, the compliances
    of a KR 210 in 20 of 20 at full and 0.4x size, with the same held-out error. Nor does one fit that frees every
    effect decide: there the compliances and the scale errors on joints 2 and 3 trade so closely that neither shows
    (both below their penalties in all 20 of those UR5 runs), and dropping the weaker of the two from it kept the
    compliances in 5 of 20, while the scales alone gain 16-90 where the compliances alone gain 8-36. Where the data
    cannot tell them apart, the UR5's compliances at 0.4x size on points (each alone gains 4-26), the two are taken
    about equally often: 10 of 20.)

    Returns (the effects chosen, their fit, per candidate (chosen, (criterion less penalty, the test in words, tau of
    the scales), the other effects free in the fit that tested it last, that fit or None when it did not converge))."""
    n_res, order = models.n_res, list(EFFECTS)
    chosen = frozenset()
    for _ in range(2 * len(order) + 1):  # (a guard: each pass chooses one; a drop is never taken back at once)
        trials = {}
        for e in (e for e in order if e in candidates and e not in chosen):
            f = models[chosen | {e}]
            trials[e] = (f, (math.nan, _NO_CONVERGENCE[e], math.nan) if f is None else _TESTS[e](f, n_res))
        gains = [(t[0], -order.index(e), e) for e, (f, t) in trials.items() if f is not None and t[0] > 0]
        if not gains:
            break
        chosen |= {max(gains)[2]}
        while len(chosen) > 1:  # every chosen effect with the others chosen
            tests = {e: _TESTS[e](models[chosen], n_res) for e in chosen}
            worst = min(chosen, key=lambda e: (tests[e][0], order.index(e)))
            if tests[worst][0] > 0 or models[chosen - {worst}] is None:
                break
            chosen -= {worst}
    f = models[chosen]
    decided = {e: (True, _TESTS[e](f, n_res), chosen - {e}, f) for e in chosen}
    decided.update({e: (False, t, chosen, fe) for e, (fe, t) in trials.items()})
    return chosen, f, decided


def _beside(others: frozenset) -> str:
    """The words for the other effects free in the fit that tested one."""
    if not others:
        return ""
    return "; tested with " + " and ".join(EFFECTS[e] for e in EFFECTS if e in others) + " free"


def _first_fit(
    sweeps: SweepSet, fits: list, dqs: list, homes0, R0, loss: str, rotation_noise, tracker, torques=None
) -> dict:
    """The joint fit with one home point, from the per-sweep start lines; on no convergence, says why when the arcs
    are short (a 1 degree protocol had ended on "no convergence")."""
    starts = [(f.point, f.direction) for f in fits]
    try:
        start = {
            "offsets0": homes0[1:] - homes0[0],
            "rotation0": R0,
            "rotation_sigma": rotation_noise,
            "tracker": tracker,
            "torques": torques,
        }
        return fit_sweeps(sweeps, dqs, starts, homes0[0], loss=loss, where=sweeps.source, **start)
    except NotConvergedError as e:
        short = [
            (s.joint, f.arc)
            for s, f in zip(sweeps.sweeps, fits, strict=True)
            if sweeps.kinds[s.joint - 1] == "revolute" and f.arc < SHORT_ARC
        ]
        if not short:
            raise
        raise NotConvergedError(
            f"{e} (the arcs are too short: {len(short)} sweeps under {math.degrees(SHORT_ARC):g} deg, down to "
            f"{math.degrees(min(a for _, a in short)):.3g} deg on joint {min(short, key=lambda x: x[1])[0]}: "
            "sweep longer arcs)"
        ) from None


def _scales_note(post, full, tau: float, evidence: str, g: dict, n: int) -> str:
    """auto's note on the readings' scale errors: fitted (``post``, the fit with their prior) or not, and why."""
    if post is not None:
        return (
            f"auto: the readings' scale errors fitted (the evidence shows them as a population: {evidence}; the "
            f"joints' scales scatter by tau = {tau * 1e6:.3g} ppm beyond their sigmas, each fitted with that spread as "
            f"its prior: one the data cannot show stays near zero): {_scale_list(g, n)}"
        )
    why = (
        "n/a: no convergence"
        if full is None or tau > 0
        # (tau > 0 without a fit: the one with the prior did not converge)
        else (
            f"the evidence does not show them: {evidence}; the joints' scale estimates: {_scale_list(full, n)}; "
            "taken as exact in scale"
        )
    )
    return (
        f"auto: no reading scale errors fitted ({why}); a scale error the data cannot show moves each axis radially by "
        "about the scale times the arc's radius"
    )


def _drift_note(sweeps: SweepSet, g: dict, decided: tuple) -> Message | str:
    """auto's note on the home drift: a home point per sweep (``decided`` kept) or one, and why."""
    kept, (_, why, _), others, _ = decided
    why += _beside(others)
    if kept:
        return Message(
            "auto: readings (a home point per sweep) over global (one home point): {why}; the home tool point"
            " moves {sd:.3g} (1 sigma per coordinate) between sweeps, added to every axis's uncertainty",
            why=why,
            sd=Length(_with_drift(sweeps, g)[1]),
        )
    sq = ", ".join(f"{math.degrees(v) * 3600:.3g}" for v in g["reading_sigma"])
    return Message(
        "auto: global (one home point) over readings (a home point per sweep): {why}; estimated reading error"
        " {sq} arcsec per sweep, point noise {sigma:.3g}",
        why=why,
        sq=sq,
        sigma=Length(g["sigma"]),
    )


def _compliance_note(g: dict, decided: tuple) -> str:
    """auto's note on the joints' compliance (issue 37): fitted (``decided`` kept; ``g`` the chosen fit) or not, and
    why."""
    kept, (_, why, _), others, _ = decided
    if kept:
        return f"auto: joint compliance fitted ({why}{_beside(others)}): {_compliance_list(g)}"
    return f"auto: no joint compliance fitted ({why}{_beside(others)}): the joints taken as rigid"


def _decide(
    sweeps: SweepSet, fits: list, dqs: list, homes0, R0, loss: str, notes: list[str], chosen: str, models, tq=None
):
    """auto's measurement model by the evidence (:func:`_choose`) on ``sweeps`` and their motions ``dqs``: None when
    the readings are worth nothing, else (method, the chosen joint fit, its axes' covariance, drift, the scales'
    prior (tau, sigma) or None, the words of the scales' note: (full, tau, evidence)). The effects (a home point per
    sweep, the reading scales and, with ``tq`` the poses' gravity torques from home (:func:`_torques`), the joints'
    compliances) stepwise, each in the presence of the others chosen (:func:`_select`); reading scales chosen are
    refitted with the prior of their spread tau (:func:`_with_scale_prior`)."""
    g = _first_fit(sweeps, fits, dqs, homes0, R0, loss, *models, torques=None if chosen == "auto" else tq)
    if chosen != "auto":
        return "global", g, g["cov"], False, None, None
    if np.all(g["gamma"] < READINGS_WORTHLESS):
        sq = [f"{math.degrees(v) * 3600:.3g}" for v in g["reading_sigma"]]
        notes.append(
            "auto: geometric (per-sweep circles): the readings are worth nothing against the points (estimated "
            f"reading error {', '.join(sq)} arcsec per sweep)"
        )
        return None
    fits_ = _Models(sweeps, dqs, loss, *models, g, tq)
    effects, d, decided = _select(fits_, [e for e in EFFECTS if e != "compliance" or tq is not None])
    post, prior = None, None
    if "scales" in effects:
        post, prior = _with_scale_prior(fits_, d, effects, decided["scales"][1][2])
        if post is None:  # (given up: the fit without them)
            effects = effects - {"scales"}
            d = fits_[effects]
            effects, d = (effects, d) if d is not None else (frozenset(), g)
    g = d if post is None else post
    drift = "drift" in effects
    if tq is not None:
        notes.append(_compliance_note(g, decided["compliance"]))
    notes.append(_drift_note(sweeps, g, decided["drift"]))
    kept, (_, evidence, tau), others, full = decided["scales"]
    scale_words = (full, tau if kept else (math.nan if full is None else 0.0), evidence + _beside(others))
    cov = _with_drift(sweeps, g)[0] if drift else g["cov"]
    return "readings" if drift else "global", g, cov, drift, prior, scale_words


def _with_scale_prior(fits_: _Models, full: dict, effects: frozenset, tau: float) -> tuple[dict | None, tuple | None]:
    """The reading scales kept by the evidence, as a population (empirical Bayes): every scale refitted with the prior
    N(0, tau^2) (:func:`~denavit.fitting.joint.fit_sweeps`' ``scale_prior``), tau their spread in the fit ``full`` that
    freed them (the model ``effects``), the point noise that fit's: a scale the data show (sigma << tau) keeps its
    value, one they cannot show (sigma >> tau) stays near zero with about tau of uncertainty in its axis,
    continuously (no joint-by-joint choice: a chance 2.9-sigma scale on exact readings no longer moves its axis by 2.9
    of its full sigmas). (Before issue 36 any tau > 0 fitted the scales: the median-unbiased tau is positive in about
    half of all runs with exact readings, and on 30 degree arcs, where a scale trades with its axis's radial position,
    the fitted scales then moved the axes by up to 10x their error with exact scales.) Returns (the fit, its prior
    (tau, sigma)), or (None, None) when it does not converge."""
    prior = (tau, full["sigma"])
    try:
        weights0 = (full["gamma"], full["robust_scale"])
        return fits_.fit(full, effects, scale_prior=prior, weights0=weights0, start=full), prior
    except NotConvergedError:
        return None, None


def _compliance_list(g: dict) -> str:
    return ", ".join(
        f"k_{j + 1} {g['compliance'][j] * 1e6:.4g} +/- {g['compliance_sigma'][j] * 1e6:.2g} urad/(N m)"
        + (" (held at 0)" if g["compliance_held"][j] else "")
        for j in range(len(g["compliance"]))
        if np.isfinite(g["compliance_sigma"][j])
    )


def _torques(sweeps: SweepSet, dqs: list, model) -> tuple[np.ndarray, list]:
    """(the gravity torques (N m; N for a prismatic joint) the joints hold at home without a payload (n,), per sweep
    (m, n) those they hold at each pose (home plus the joint fit's motion, with the pose's payload) less those at home):
    :func:`denavit.calibration.compliance.gravity_torques` with ``model``'s inertials."""
    from ..calibration.compliance import gravity_torques  # noqa: PLC0415

    ref = gravity_torques(model, sweeps.home[None])[0]
    return ref, [
        gravity_torques(model, sweeps.home + dq[:], s.payload) - ref for s, dq in zip(sweeps.sweeps, dqs, strict=True)
    ]


def _deflections(sweeps: SweepSet, dqs: list, tq: list, g: dict) -> list:
    """Per sweep (m, 3) the displacement of each point by the compliances of the joint fit ``g``: the chain of its axes
    from its home point at the links' motion (the readings' less ``k dtau``, ``tq``) less at the readings'; the points
    less it are the undeflected arm's, on circles about the axes (:func:`~denavit.fitting.checks.misfit_notes`)."""
    n, kinds, s = sweeps.n_joints, sweeps.kinds, 1 + g["scales"]
    cs, ns, every = list(g["points"]), list(g["directions"]), list(range(sweeps.n_joints))
    out = []
    for k, (dq, t) in enumerate(zip(dqs, tq, strict=True)):
        dq, h = np.asarray(dq[:], dtype=float), g["home"][k]
        links = _chain(cs, ns, kinds, h, (dq - g["compliance"][:n] * t) * s, every, False)[0]
        out.append((links - _chain(cs, ns, kinds, h, dq * s, every, False)[0]).T)
    return out


def _every(sweeps: SweepSet, dqs: list, k: int) -> tuple[SweepSet, list]:
    """Every k-th pose of each sweep (views, no copies), and their motions."""
    rows = slice(None, None, k)
    return replace(sweeps, sweeps=[s.take(rows) for s in sweeps.sweeps]), [dq[rows] for dq in dqs]


def _choose(
    sweeps: SweepSet,
    fits: list,
    homes0: np.ndarray,
    R0,
    loss: str,
    notes: list[str],
    chosen: str,
    rotation_noise=None,
    tracker: TrackerNoise | None = None,
    torque_model=None,
):
    """The joint fit(s) with readings: ``chosen`` "global", or "auto" (evidence: the per-sweep fits when the
    readings are worth nothing, else the joint fit with the effects that pay for themselves, each tested with the
    others free (:func:`_select`): a home point per sweep (:func:`_drift_wald`), the readings' scale errors as a
    population (:func:`_scales_test`, then fitted with their spread as a prior) and the joints' compliances
    (:func:`_compliance_test`)). ``homes0`` (k, 3) the start home points of the targets, ``R0`` the start
    orientation at home (6-DoF poses) or None. Returns (method, fits, cov, tool point, rms, the joint fit's result or
    None, scales): ``scales`` None, or when fitted (values (n,), their covariance with [c_1, n_1, ..., p] (6n+3, n),
    their covariance (n, n)); zeros where a joint's scale was not fitted. ``tracker`` the tracker's range/angle noise
    model, or None (isotropic). ``torque_model``: the nominal's model with its links' inertials when the joints'
    compliance is considered (fitted with "global", chosen by the evidence with "auto": :func:`_select`), else None.

    Sweeps longer than :data:`~denavit.fitting.joint.SUBSAMPLE` poses: the choice, with its variance components and
    robust weights, on every k-th pose (:func:`_every`; auto's up to five joint fits had each passed over every point
    about six times), then one fit of the chosen model on all points from the subsample's answer, with a note."""
    dqs = _motions(sweeps, notes)
    models = (rotation_noise, tracker)
    k = stride(max(len(s.points) for s in sweeps.sweeps))
    work, wdqs = (sweeps, dqs) if k == 1 else _every(sweeps, dqs, k)
    ref, tq = (None, None) if torque_model is None else _torques(sweeps, dqs, torque_model)
    wtq = None if tq is None or k == 1 else [t[::k] for t in tq]
    decided = _decide(work, fits, wdqs, homes0, R0, loss, notes, chosen, models, tq if k == 1 else wtq)
    if decided is None:
        return "geometric", None, None, None, math.nan, None, None
    method, g, cov, drift, prior, scale_words = decided
    if k > 1:  # the chosen model once on all points, from the subsample's answer
        g = _fit_from(
            sweeps,
            dqs,
            loss,
            {"rotation_sigma": models[0], "tracker": models[1]},
            g,
            per_sweep_home=drift,
            scales=prior is not None,
            scale_prior=prior,
            weights0=(g["gamma"], g["robust_scale"]),
            start=g,
            torques=tq if np.any(np.isfinite(g["compliance_sigma"])) else None,
        )
        cov = _with_drift(sweeps, g)[0] if drift else g["cov"]
        notes.append(
            f"{chosen}: the joint fit's model, variance components and robust weights found on every k-th pose "
            f"(k = {k}: {len(work.sweeps[0].points)} of {len(sweeps.sweeps[0].points)} in the first sweep), then the "
            "fit refined once on all points"
        )
    scales = None if prior is None else (g["scales"].copy(), _scale_cross(g, sweeps.n_joints), g["scale_cov"])
    if ref is not None:
        g = {**g, "torque_home": ref}
        if np.any(np.isfinite(g["compliance_sigma"])):
            g["deflection"] = _deflections(sweeps, dqs, tq, g)
    if scale_words is not None:
        notes.append(_scales_note(g if prior else None, *scale_words, g, sweeps.n_joints))
    mis = np.concatenate(g["misfit"])
    return (
        method,
        _joint_fits(sweeps, fits, g, cov, loss, method),
        cov,
        g["home"].mean(axis=0),
        float(math.sqrt(np.mean(mis**2))),
        g,
        scales,
    )
