"""Which parameters a calibration frees, chosen by cross-validated prediction error (issue 36, "prediction
decides").

The job of a calibration is to predict where the robot goes at poses that were not measured; on a small data set
the largest model overfits. :func:`select_model` fits nested candidates (:data:`CANDIDATES`) to the same data and
scores each by its **leave-one-pose-out** tool-position error:

* ``base-tool``: the base and tool registration only (the nominal geometry at its best);
* ``offsets``: + the joint zero offsets;
* ``full``: every parameter of the convention the data identify, least squares (the default before issue 36);
* ``full-prior``: the same, maximum a posteriori with the plausible-size priors (:mod:`~denavit.calibration.priors`);
  parameters the data do not determine beyond their prior are then held at their nominal values;
* ``full-prior-no-beta``: that without the Hayati tilts (``beta``) of the near-parallel pairs;
* ``full-prior-no-last``: that with the last link's geometry (the placement of the last joint) held nominal, the
  tool absorbing what it can.

**Leave-one-out from the hat matrix.** For the whitened least squares linearised at the fit, residuals ``r`` and
Jacobian ``J`` of the free parameters, with the prior rows' information ``Λ`` (zero without priors),
``G = JᵀJ + Λ`` and the hat matrix ``H = J G⁻¹ Jᵀ``, the residual of pose ``i`` (its ``k`` rows, ``k`` = 3 for
points, 6 for poses) predicted by the fit made **without** it is::

    e_(i) = (I_k - H_ii)⁻¹ r_i

``H_ii`` the ``k x k`` diagonal block of pose ``i``. It is the deletion formula for a group of observations
(Cook & Weisberg 1982, *Residuals and Influence in Regression*, sec. 3.6, eq. 3.6.7; Belsley, Kuh & Welsch 1980,
sec. 2.1), for ``k = 1`` Allen's PRESS residual (Allen 1974, *Technometrics* 16, 125-127), from the
Sherman-Morrison-Woodbury identity. The prior rows are not deleted, so it holds for the ridge (MAP) fit as well.
It is exact for a linear model and first order for the kinematic one, and costs one ``k x k`` solve per pose
after the fit: a candidate costs one fit, not N. The score is the RMS over the poses of the position part of
``e_(i)``, unwhitened (m); the effective number of parameters of a candidate is ``trace(H)``.

**The rule** (:data:`RULE`, the one-standard-error rule of Breiman et al. 1984, *Classification and Regression
Trees*, sec. 3.4.3, on paired errors): the candidate with the smallest mean squared leave-one-out error is the
best; along the nested chain base-tool, offsets, full-prior (:data:`CHAIN`, ordered by effective number of
parameters; ``full`` in place of full-prior without priors) the simplest whose mean squared error exceeds the
best's by at most one standard error of their paired difference (the same poses left out:
``std(e_c^2 - e_best^2) / sqrt(N)``) wins; the alternatives (``full`` without the priors, the variants that hold
parameters exactly nominal) replace it only when they predict better by more than one such standard error
(:func:`choose`). So the choice never predicts worse than a simpler candidate beyond the noise of
the comparison, and takes the simpler one where the data cannot tell them apart.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING

import numpy as np

from ..errors import DenavitError
from .identifiability import analyze
from .least_squares import covariance, fit_parameters, gram, prior_block, residuals
from .priors import PRIOR_DOMINATED, prior_weights

if TYPE_CHECKING:
    from .measurements import Measurements
    from .parametrization import Parametrization
    from .priors import Prior

#: The candidate models, simplest first (see the module docstring).
CANDIDATES = ("base-tool", "offsets", "full", "full-prior", "full-prior-no-beta", "full-prior-no-last")
#: The suffix of a candidate with the joint compliances free (:mod:`~denavit.calibration.compliance`).
COMPLIANCE = "+compliance"
#: The compliance family: the geometric candidates of the nested chain (and ``full``) with the compliances free too.
COMPLIANCE_CANDIDATES = tuple(f"{c}{COMPLIANCE}" for c in ("base-tool", "offsets", "full", "full-prior"))
#: What ``model=`` takes: one candidate, or ``auto`` (chosen by prediction).
MODELS = ("auto", *CANDIDATES, *COMPLIANCE_CANDIDATES)
DESCRIPTIONS = {
    "base-tool": "base and tool registration only",
    "offsets": "registration and joint offsets",
    "full": "every identifiable parameter, least squares",
    "full-prior": "every identifiable parameter, with plausible-size priors (maximum a posteriori)",
    "full-prior-no-beta": "full-prior without the Hayati tilts of near-parallel pairs",
    "full-prior-no-last": "full-prior with the last link's geometry nominal (the tool absorbs it)",
    **{
        f"{c}{COMPLIANCE}": f"{c} with the joint compliances free (gravity and payload torques)"
        for c in ("base-tool", "offsets", "full", "full-prior")
    },
}
#: The selection rule, in words (the module docstring).
RULE = "the simplest within one standard error of the best"


@dataclass(frozen=True, eq=False)
class Candidate:
    """One candidate model fitted to the training poses, with its leave-one-pose-out errors.

    ``free``: the indices of its free parameters; ``prior``: (centre, weight) of its prior rows or None;
    ``prior_fixed``: the parameters held at their nominal values because the data do not determine them beyond
    their prior, name -> posterior sigma / prior width when they were free; ``at_bound``: the compliances fitted
    negative and held at their bound 0 (``k >= 0``), name -> the value they had been fitted at; ``loo``: (N,)
    leave-one-pose-out tool-position errors (m); ``cv_rms`` their RMS (m) and ``cv_se`` its standard error (m, from
    that of the mean square); ``dof``: the effective number of parameters ``trace(H)``.
    """

    name: str
    free: list
    x: np.ndarray
    prior: tuple | None
    prior_fixed: dict
    loo: np.ndarray
    dof: float
    sol: object = field(default=None, repr=False)
    at_bound: dict = field(default_factory=dict)
    #: the compliances the data do not determine beside its geometric part (``identifiability.Unidentifiable``)
    unidentifiable: tuple = ()

    @property
    def mse(self) -> float:
        return float(np.mean(self.loo**2)) if self.loo.size else math.nan

    @property
    def cv_rms(self) -> float:
        return math.sqrt(self.mse)

    @property
    def cv_se(self) -> float:
        n = self.loo.size
        if n < 2 or self.mse <= 0:
            return math.nan
        return float(np.std(self.loo**2, ddof=1) / math.sqrt(n)) / (2 * self.cv_rms)


@dataclass(frozen=True, eq=False)
class ModelChoice:
    """The candidates scored and the one chosen (``how``: ``"auto"``, chosen by :data:`RULE`, or ``"given"``)."""

    chosen: str
    how: str
    candidates: list

    @property
    def winner(self) -> Candidate:
        return next(c for c in self.candidates if c.name == self.chosen)

    def line(self, scale: float = 1e-3, unit: str = "mm") -> str:
        """The one line that says which model won and each candidate's leave-one-pose-out RMS (``unit``, ``scale``
        m per unit)."""
        cands = ", ".join(
            f"{c.name} {c.cv_rms / scale:.4g}{'*' if c.name == self.chosen else ''}" for c in self.candidates
        )
        why = (
            f"chosen by leave-one-pose-out prediction error ({RULE})"
            if self.how == "auto"
            else "as asked (--model / model=)"
        )
        return f"model {self.chosen} {why}; leave-one-pose-out tool-position rms [{unit}]: {cands}"

    def short(self) -> str:
        """:meth:`line` in brief (mm), for a result's repr."""
        cands = ", ".join(
            f"{c.name} {c.cv_rms * 1e3:.3g}{'*' if c.name == self.chosen else ''}" for c in self.candidates
        )
        return f"model {self.chosen} ({'auto' if self.how == 'auto' else 'given'}); leave-one-out rms [mm]: {cands}"

    def __repr__(self) -> str:
        return f"ModelChoice({self.line()})"

    def to_json(self) -> dict:
        return {
            "chosen": self.chosen,
            "how": self.how,
            "rule": RULE if self.how == "auto" else None,
            "criterion": "leave-one-pose-out tool-position rms (hat matrix)",
            "candidates": [
                {
                    "name": c.name,
                    "description": DESCRIPTIONS[c.name],
                    "cv_rms_m": c.cv_rms,
                    "cv_se_m": None if math.isnan(c.cv_se) else c.cv_se,
                    "effective_parameters": c.dof,
                    "n_free": len(c.free),
                    "prior": c.prior is not None,
                    "held_by_prior": list(c.prior_fixed),
                }
                for c in self.candidates
            ],
        }


def loo_residuals(J: np.ndarray, r: np.ndarray, k: int, P: np.ndarray | None = None) -> tuple[np.ndarray, float]:
    """(the leave-one-pose-out residuals (N, k), ``trace(H)``) of the whitened linear least squares with Jacobian
    ``J`` (kN, p), residuals ``r`` (kN,) at the fit and prior rows ``P`` (rows, p) (module docstring:
    ``e_(i) = (I - H_ii)^-1 r_i``, ``H = J (JᵀJ + PᵀP)^-1 Jᵀ``)."""
    from scipy.linalg import cho_factor, solve_triangular  # noqa: PLC0415 (scipy is loaded when first needed)

    n = len(r) // k
    p = J.shape[1]
    R = r.reshape(n, k)
    if p == 0:
        return R.copy(), 0.0
    G = gram(J) + (P.T @ P if P is not None and P.size else 0.0)
    d = np.sqrt(np.clip(np.diag(G), 0, None))
    d = np.where(d > 0, d, 1.0)
    Gs = G / np.outer(d, d)
    try:
        L = cho_factor(Gs, lower=True, check_finite=False)[0]
        Z = solve_triangular(np.tril(L), (J / d).T, lower=True, check_finite=False)  # (p, kN): H = Zᵀ Z
    except np.linalg.LinAlgError:  # singular: the pseudo-inverse's square root (callers pass identifiable columns)
        ev, V = np.linalg.eigh(Gs)
        Z = (V / np.sqrt(np.maximum(ev, ev.max() * 1e-15))).T @ (J / d).T
    Zb = Z.T.reshape(n, k, p)
    Hii = np.einsum("nkp,nlp->nkl", Zb, Zb)
    A = np.eye(k) - Hii
    try:
        E = np.linalg.solve(A, R[:, :, None])[:, :, 0]
    except np.linalg.LinAlgError:  # a pose that alone determines a parameter: it cannot be predicted without it
        E = np.einsum("nkl,nl->nk", np.linalg.pinv(A, rcond=1e-12), R)
    return E, float(np.trace(Hii, axis1=1, axis2=2).sum())


def position_errors(E: np.ndarray, meas: Measurements, w: np.ndarray) -> np.ndarray:
    """The tool-position errors (N,) (m) of whitened residual blocks ``E`` (N, k): the position rows unweighted
    (``w``) and un-whitened (``meas.whitening``)."""
    e = E[:, :3] / w[0]
    if meas.whitening is not None:
        e = np.linalg.solve(meas.whitening, e[:, :, None])[:, :, 0]
    return np.linalg.norm(e, axis=1)


def last_link(pz: Parametrization) -> set:
    """The indices of the last link's geometric parameters: the factors placing the last joint in the one before
    (and, in ``dh``, the link after it, before the flange), the joint offset excluded."""
    if pz.nq < 2:
        return set()
    lo, hi = pz.joint_factor[-2] + 1, pz.tool_start
    return {
        p
        for k, (axis, p, _, _) in enumerate(pz.factors[lo:hi], lo)
        if axis != "fixed" and k != pz.joint_factor[-1] and not pz.names[p].startswith("tool_")
    }


def _fit(
    name: str, pz: Parametrization, train: Measurements, w: np.ndarray, free: list, x_start, prior_sigma, s2: float
) -> Candidate:
    """One candidate: the fit (MAP with ``prior_sigma`` (P,) widths, SI, if given; prior-dominated parameters then
    held nominal and the fit repeated) and its leave-one-pose-out errors."""
    prior = None if prior_sigma is None else (pz.x0, prior_weights(prior_sigma, s2))
    free = list(free)
    x, sol = fit_parameters(pz, x_start, free, train, w, "linear", None, prior=prior)
    held = {}
    if prior is not None and free:
        J = residuals(pz, x, train, w, columns=free)[1]
        sd = np.sqrt(np.clip(np.diag(covariance(np.vstack([J, prior_block(prior, free)]), s2)), 0, None))
        with np.errstate(divide="ignore", invalid="ignore"):
            ratio = sd / prior_sigma[free]
        dom = [c for c, q in zip(free, ratio, strict=True) if np.isfinite(prior_sigma[c]) and q > PRIOR_DOMINATED]
        if dom:
            held = {pz.names[c]: float(q) for c, q in zip(free, ratio, strict=True) if c in dom}
            free = [c for c in free if c not in dom]
            xs = x.copy()
            xs[dom] = pz.x0[dom]
            x, sol = fit_parameters(pz, xs, free, train, w, "linear", None, prior=prior)
    nonneg = set(
        getattr(pz, "nonnegative", ())
    )  # compliances: k >= 0, one fitted negative held at zero and the fit repeated
    at_bound = {}
    for _ in range(len(nonneg)):
        neg = [c for c in free if c in nonneg and x[c] < 0]
        if not neg:
            break
        at_bound.update({pz.names[c]: float(x[c]) for c in neg})
        free = [c for c in free if c not in neg]
        x = x.copy()
        x[neg] = 0.0
        x, sol = fit_parameters(pz, x, free, train, w, "linear", None, prior=prior)
    r, J, _ = residuals(pz, x, train, w, columns=free)
    k = 6 if pz.measure == "pose" else 3
    E, dof = loo_residuals(J, r, k, prior_block(prior, free) if prior is not None else None)
    return Candidate(name, free, x, prior, held, position_errors(E, train, w), dof, sol, at_bound)


def _map_cost(pz: Parametrization, x, train: Measurements, w: np.ndarray, free: list, weight: np.ndarray) -> float:
    """The objective of the MAP fit at x: the whitened residuals' and the prior rows' squares."""
    r = residuals(pz, x, train, w, jacobian=False)[0]
    f = np.asarray(free, dtype=int)
    return float(np.sum(r**2) + np.sum((weight[f] * (x[f] - pz.x0[f])) ** 2))


def candidate_sets(pz: Parametrization, kept: list, reg_kept: list, offsets_kept: list, with_prior: bool) -> dict:
    """The free parameters of each candidate (module docstring), by name; variants that would equal another are
    left out."""
    out = {"base-tool": list(reg_kept), "offsets": list(offsets_kept), "full": list(kept)}
    if with_prior:
        out["full-prior"] = list(kept)
        betas = [c for c in kept if pz.names[c].startswith("beta_")]
        if betas:
            out["full-prior-no-beta"] = [c for c in kept if c not in betas]
        last = last_link(pz) & set(kept)
        if last:
            out["full-prior-no-last"] = [c for c in kept if c not in last]
    return out


#: The nested chain the one-standard-error rule walks (simplest first by effective parameters): with priors its
#: last member is ``full-prior``, without them ``full``. The other candidates are alternatives to the chain's choice.
CHAIN = ("base-tool", "offsets", "full-prior")


def _paired_se(a: Candidate, b: Candidate) -> float:
    """The standard error of the difference of the mean squared leave-one-out errors of ``a`` and ``b`` (the same
    poses left out: paired)."""
    n = a.loo.size
    return float(np.std(a.loo**2 - b.loo**2, ddof=1) / math.sqrt(n)) if n > 1 else 0.0


def choose_families(cands: list) -> Candidate:
    """:func:`choose` within each family (the geometric candidates; the same with the compliances free, names ending
    in :data:`COMPLIANCE`), then the compliance family's choice replaces the geometric one only when it predicts better
    by more than one paired standard error: a compliance must be earned as every alternative is."""
    geo = [c for c in cands if not c.name.endswith(COMPLIANCE)]
    comp = [c for c in cands if c.name.endswith(COMPLIANCE)]
    if not comp:
        return choose(geo)
    g, k = choose(geo), choose(comp, COMPLIANCE)
    return k if k.mse < g.mse - _paired_se(k, g) else g


def choose(cands: list, suffix: str = "") -> Candidate:
    """:data:`RULE` over fitted candidates (module docstring): along the nested :data:`CHAIN`, the simplest whose
    mean squared leave-one-out error exceeds the best candidate's by at most one paired standard error; an
    alternative (``full`` without priors, ``full-prior-no-beta``, ``full-prior-no-last``) replaces it only when it
    predicts better by more than one paired standard error. The priors are the belief about the robot before the
    data; dropping them (``full``) or holding parameters exactly nominal (the variants) must be earned: both bias
    predictions away from the training poses in ways leaving training poses out cannot see (in
    benchmarks/bench_generalization.py they predicted poses outside the training ranges 10-70 % worse than
    full-prior while their leave-one-out errors were within a standard error of it)."""
    best = min(cands, key=lambda c: c.mse)
    has_prior = any(c.name == f"full-prior{suffix}" for c in cands)
    names = tuple(f"{c}{suffix}" for c in (CHAIN if has_prior else ("base-tool", "offsets", "full")))
    chain = sorted((c for c in cands if c.name in names), key=lambda c: (c.dof, names.index(c.name)))
    pick = next((c for c in chain if c.mse - best.mse <= _paired_se(c, best)), chain[-1] if chain else best)
    better = [v for v in cands if v.name not in names and v.mse < pick.mse - _paired_se(v, pick)]
    return min(better, key=lambda c: c.mse) if better else pick


def select_model(
    model: str,
    pz: Parametrization,
    train: Measurements,
    w: np.ndarray,
    *,
    prior: Prior | None,
    s2: float,
    candidates: list,
    kept: list,
    reg_kept: list,
    x_reg,
    x_full,
    sol_full,
    compliance: list = (),
    bounds=None,
    progress=None,
) -> ModelChoice:
    """Fit the candidate models (``model="auto"``) or the one asked for, score each by its leave-one-pose-out
    tool-position error, and choose (module docstring).

    ``candidates``: the parameters not fixed by the user or the parametrisation; ``kept``: those the data identify
    (the full model); ``reg_kept``: the identifiable base and tool parameters, fitted at ``x_reg``; ``x_full``,
    ``sol_full``: the least-squares fit of ``kept``; ``s2``: the noise variance in the whitened units (1 when
    known), which weighs the priors against the data; ``compliance``: the joint compliances the data may show
    (indices; :mod:`~denavit.calibration.compliance`): with them ``auto`` fits the ``+compliance`` family too
    (:func:`choose_families`); ``bounds``: the plausible sizes of the parameters' errors (SI;
    :func:`~denavit.calibration.identifiability.plausible_sigmas`): a parameter the data give a larger sigma in a
    candidate is not freed there; ``progress``: called as ``progress(name, k, count)`` before candidate ``k`` of
    ``count`` is fitted.
    """
    if model not in MODELS:
        raise DenavitError(f"model: expected one of {', '.join(MODELS)}, got {model!r}")
    if prior is None and model.startswith("full-prior"):
        raise DenavitError(f"model {model!r} needs priors: got prior=False / --prior none")
    if model.endswith(COMPLIANCE) and not compliance:
        raise DenavitError(
            f"model {model!r}: the joint compliances are not modelled here (they need a payload declared with the data"
            " and the nominal's link inertials)"
        )
    want = (CANDIDATES + (COMPLIANCE_CANDIDATES if compliance else ())) if model == "auto" else (model,)
    offsets_kept = []
    if "offsets" in want or f"offsets{COMPLIANCE}" in want:
        offs = [c for c in candidates if pz.names[c].startswith("offset_")]
        offsets_kept = (
            analyze(pz, x_reg, train, list(reg_kept) + offs, w, explain=False, bounds=bounds, s2=s2).kept_idx
            if offs
            else list(reg_kept)
        )
    sets = candidate_sets(pz, kept, reg_kept, offsets_kept, prior is not None)
    if model == "auto" and set(sets["offsets"]) == set(sets["base-tool"]):
        del sets["offsets"]  # no offset the data identify: the same model as base-tool
    sigma = None if prior is None else prior.sigma(pz)
    out = []
    x_map = None
    fitted = {}
    for k, name in enumerate(want):
        if progress is not None:
            progress(name, k, len(want))
        if name.endswith(COMPLIANCE):
            c = _fit_compliant(name, pz, train, w, sets, fitted, compliance, x_reg, x_full, sigma, s2, bounds)
            if c is not None:
                out.append(c)
            elif model != "auto":
                raise DenavitError(
                    f"model {name!r}: its geometric part is not a model of these data: expected one of"
                    f" {', '.join(k + COMPLIANCE for k in sets)}"
                )
            continue
        if name not in sets:
            if model != "auto":
                why = "no Hayati tilt is free in this model" if "beta" in name else "no last-link parameter is free"
                raise DenavitError(f"model {name!r}: {why}: expected one of {', '.join(k for k in sets)}")
            continue
        free = sets[name]
        if name == "full":
            r, J, _ = residuals(pz, x_full, train, w, columns=free)
            E, dof = loo_residuals(J, r, 6 if pz.measure == "pose" else 3)
            out.append(
                Candidate(name, list(free), np.array(x_full), None, {}, position_errors(E, train, w), dof, sol_full)
            )
            fitted[name] = out[-1]
            continue
        if name in ("base-tool", "offsets"):
            out.append(_fit(name, pz, train, w, free, x_reg, None, s2))
            fitted[name] = out[-1]
            continue
        drop = [c for c in kept if c not in free]
        starts = [
            np.array(x_full if x_map is None else x_map),
            np.array(x_reg),
        ]  # the least-squares (or MAP) fit, or the nominal geometry registered
        for x in starts:
            x[drop] = pz.x0[drop]
        weight = prior_weights(sigma, s2)
        start = min(
            starts, key=lambda x: _map_cost(pz, x, train, w, free, weight)
        )  # where the data barely fix a parameter the fit may have swung it far
        c = _fit(name, pz, train, w, free, start, sigma, s2)
        if name == "full-prior":
            x_map = c.x
        fitted[name] = c
        out.append(c)
    chosen = choose_families(out) if model == "auto" else out[0]
    return ModelChoice(chosen.name, "auto" if model == "auto" else "given", out)


def _fit_compliant(
    name: str,
    pz: Parametrization,
    train: Measurements,
    w: np.ndarray,
    sets: dict,
    fitted: dict,
    compliance: list,
    x_reg,
    x_full,
    sigma,
    s2: float,
    bounds=None,
) -> Candidate | None:
    """A ``+compliance`` candidate: its geometric part's free parameters with the compliances the data identify beside
    them, from its geometric fit (compliances at their nominal), with the
    geometric part's priors (and the compliances' own) or none; None when the geometric part is not a candidate here."""
    base = name[: -len(COMPLIANCE)]
    if base not in sets:
        return None
    geo = fitted.get(base)
    free = list(
        sets[base]
    )  # (what the geometric fit's prior held is judged again: with the compliances the data may determine it)
    x0 = np.array(geo.x if geo is not None else (x_full if base.startswith("full") else x_reg))
    x0[list(compliance)] = pz.x0[list(compliance)]
    ana = analyze(pz, x0, train, free + list(compliance), w, bounds=bounds, s2=s2)
    comp = [c for c in ana.kept_idx if c in set(compliance)]
    fit = _fit(name, pz, train, w, free + comp, x0, sigma if base == "full-prior" else None, s2)
    return replace(fit, unidentifiable=tuple(u for u in ana.unidentifiable if pz.index(u.name) in set(compliance)))
