"""Identifiability of a calibration model: the (weighted) identification Jacobian ``J`` with unit-norm columns is
reduced by a greedy
Gram-Schmidt in a fixed preference order (base, tool, link geometry, joint offsets, scales, translations along
joint axes last): a parameter whose column is (numerically) a combination of the columns kept before it is
*not identifiable*; it is named with that combination, fixed at its start value and reported, never returned
as a silent number. The kept set is a set of base parameters (Khalil & Dombre 2002, ch. 11). Parameters
redundant for *any* data (checked on configurations spread over the joint limits) are told apart from those
these measurements cannot separate. Observability indices of the kept, column-normalised ``J`` with singular
values ``s_1 >= ... >= s_L`` over ``m`` poses (Sun & Hollerbach 2008, "Observability index selection for robot
calibration", ICRA): O1 ``(s_1 ... s_L)^(1/L) / sqrt(m)`` (Borm & Menq 1991), O2 ``s_L / s_1`` (Driels & Pathre
1990), O3 ``s_L`` (Nahvi, Hollerbach & Hayward 1994), O4 ``s_L^2 / s_1`` (noise amplification, Nahvi &
Hollerbach 1996), O5 ``1 / (1/s_1 + ... + 1/s_L)`` (Sun & Hollerbach 2008).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from .least_squares import gram, jacobian_rows

if TYPE_CHECKING:
    from .measurements import Measurements
    from .parametrization import Parametrization

#: A unit-norm Jacobian column whose part independent of the columns kept before it is shorter than this is
#: not identifiable (its sigma would exceed 1e6 times the sigma it has alone).
RANK_TOL = 1e-6


@dataclass(frozen=True)
class Unidentifiable:
    """A parameter the data cannot identify, and why.

    ``combination`` maps the kept parameters whose joint effect equals this parameter's to the coefficients
    (SI units of the kept parameter per unit of this one); ``structural`` is True when no data could
    identify it in this parametrisation (it is redundant), False when these measurements cannot.
    """

    name: str
    reason: str
    structural: bool
    combination: dict


@dataclass(frozen=True, eq=False)
class Identifiability:
    """Rank, base parameters, conditioning and observability of the identification Jacobian.

    Attributes
    ----------
    candidates : list of str
        The parameters analysed (not fixed by the user or the parametrisation).
    rank : int
        Numerical rank of the column-normalised Jacobian (tolerance :data:`RANK_TOL`).
    base_parameters : list of str
        The identifiable set kept (``rank`` names).
    unidentifiable : list of Unidentifiable
    singular_values : ndarray
        Of the column-normalised Jacobian of the base parameters, descending.
    condition_number : float
        ``s_1 / s_L``.
    observability : dict
        ``O1`` ... ``O5`` (module docstring).
    n_poses : int
    """

    candidates: list
    rank: int
    base_parameters: list
    unidentifiable: list
    singular_values: np.ndarray
    condition_number: float
    observability: dict
    n_poses: int
    kept_idx: list = field(default_factory=list, repr=False)

    def __repr__(self) -> str:
        return f"Identifiability({self.summary()}; {len(self.unidentifiable)} unidentifiable)"

    def summary(self) -> str:
        o = self.observability
        return (
            f"rank {self.rank} of {len(self.candidates)} candidate parameters over {self.n_poses} poses; condition"
            f" number {self.condition_number:.3g}; " + ", ".join(f"{k} {v:.3g}" for k, v in o.items())
        )


def rank_reveal(J: np.ndarray, order: list, tol: float = RANK_TOL):
    """Rank-revealing Cholesky of the Gram matrix of the unit-norm columns, in preference order (the same
    decisions as a Gram-Schmidt QR in that order): a column whose squared distance from the span of the columns
    kept before it is below ``tol**2`` is dropped. Returns (kept, dropped, zero columns, column norms, L, G)
    with ``G`` the Gram matrix of the unit-norm columns and ``L`` (k x k, lower) its Cholesky factor on kept."""
    G = gram(J)
    norms = np.sqrt(np.clip(np.diag(G), 0, None))
    top = norms.max() if norms.size else 0.0
    safe = np.where(norms > 0, norms, 1.0)
    G = G / np.outer(safe, safe)
    # right-looking elimination in preference order: S is the Schur complement of the kept columns
    S = G.copy()
    cols = []
    kept, dropped, zero = [], [], set()
    for c in order:
        if not norms[c] > 1e-12 * top:
            dropped.append(c)
            zero.add(c)
            continue
        d = S[c, c]
        if d < tol**2:
            dropped.append(c)
            continue
        col = S[:, c] / math.sqrt(d)
        S -= np.outer(col, col)
        cols.append(col)
        kept.append(c)
    L = np.array(cols).T[kept] if kept else np.zeros((0, 0))  # G[kept][:, kept] = L L^T, lower triangular
    return kept, dropped, zero, norms, L, G


def _combinations(G: np.ndarray, L: np.ndarray, kept: list, dropped: list, norms: np.ndarray) -> dict:
    """For each dropped column: the kept columns whose combination reproduces it (SI coefficients per unit of
    the dropped parameter), largest first, at most 4, ignoring terms below 2 % of a unit-norm column."""
    from scipy.linalg import cho_solve  # noqa: PLC0415 (scipy is loaded when first needed)

    cols = [c for c in dropped if norms[c] > 0]
    if not kept or not cols:
        return {}
    coef = cho_solve((L, True), G[np.ix_(kept, cols)], check_finite=False)
    out = {}
    for i, c in enumerate(cols):
        d = {}
        for k in np.argsort(-np.abs(coef[:, i]))[:4]:
            if abs(coef[k, i]) < 0.02:
                break
            d[kept[k]] = float(coef[k, i] * norms[c] / norms[kept[k]])
        out[c] = d
    return out


def analyze(
    pz: Parametrization,
    x,
    meas: Measurements,
    candidates: list,
    w: np.ndarray,
    structural: Identifiability | None = None,
    joint_hint: str = "",
    explain: bool = True,
) -> Identifiability:
    """Rank-revealing analysis of the weighted identification Jacobian at x (module docstring); with
    ``explain=False`` only the kept / dropped sets (no reasons, no singular values).

    With ``structural`` (the analysis of the same candidates on configurations spread over the joint limits),
    the parameters it keeps come first: a structural dependency holds for any data, so what these data drop
    beyond it are parameters the structural analysis kept, and holding exactly those fixed restores full rank.
    """
    J = jacobian_rows(pz, x, pz.inputs(meas), w, whitening=meas.whitening)[1]
    cand = set(candidates)
    order = [c for c in pz.order if c in cand]
    if structural is not None:
        first = set(structural.kept_idx)
        order = [c for c in order if c in first] + [c for c in order if c not in first]
    kept, dropped, zero, norms, L, G = rank_reveal(J, order)
    combs = _combinations(G, L, kept, dropped, norms) if explain else {}
    un = []
    for c in dropped:
        name = pz.names[c]
        comb = combs.get(c, {})
        struct = structural is not None and c not in structural.kept_idx
        reason = _reason(pz, name, c in zero, comb, struct, joint_hint) if explain else ""
        un.append(Unidentifiable(name, reason, struct, {pz.names[k]: v for k, v in comb.items()}))
    names_order = [pz.names[c] for c in order]
    if not explain:
        return Identifiability(
            names_order, len(kept), [pz.names[c] for c in kept], un, np.zeros(0), math.nan, {}, meas.n, kept
        )
    # the unit-norm kept columns are Q L^T (Q orthonormal): their singular values are those of L
    sv = np.linalg.svd(L, compute_uv=False) if kept else np.zeros(0)
    m = meas.n
    if sv.size and sv[-1] > 0:
        obs = {
            "O1": float(np.exp(np.mean(np.log(sv))) / math.sqrt(m)),
            "O2": float(sv[-1] / sv[0]),
            "O3": float(sv[-1]),
            "O4": float(sv[-1] ** 2 / sv[0]),
            "O5": float(1.0 / np.sum(1.0 / sv)),
        }
        cond = float(sv[0] / sv[-1])
    else:
        obs = {k: 0.0 for k in ("O1", "O2", "O3", "O4", "O5")}
        cond = math.inf
    return Identifiability(names_order, len(kept), [pz.names[c] for c in kept], un, sv, cond, obs, m, kept)


def _fmt_coef(name: str, v: float, pz: Parametrization, dropped: str) -> str:
    u = {"length": "m", "angle": "rad", "ratio": ""}
    ku, du = u[pz.units[pz.names.index(name)]], u[pz.units[pz.names.index(dropped)]]
    unit = "" if ku == du else f" {ku}/{du}" if du else f" {ku}"
    return f"{v:+.4g}{unit} x {name}"


def _reason(pz: Parametrization, name: str, zero: bool, comb: dict, structural: bool, joint_hint: str) -> str:
    if zero:
        why = "the measurements do not depend on it at all"
        if name.startswith("tool_r") and pz.measure == "point":
            why += " (a rotation of the tool about its own measured point)"
    else:
        terms = ", ".join(_fmt_coef(pz.names[k], v, pz, name) for k, v in comb.items())
        why = (
            f"its effect on every measurement equals that of {terms}"
            if terms
            else "its effect is a combination of many parameters"
        )
    kept = [pz.names[k] for k in comb]
    hints = []
    if name.startswith(("c_", "d_")) and (pz.convention == "edh" and name.startswith("c_") or pz.convention != "edh"):
        j = int(name.split("_")[1]) + (1 if pz.convention == "edh" else 0)
        hints.append(
            f"it slides joint frame {j}'s origin along axis {j}, which "
            + ("the tool absorbs" if any(k.startswith("tool_") for k in kept) else "the following links absorb")
        )
    if any(k.startswith("base_") for k in kept) and not name.startswith("base_"):
        hints.append("the base frame, which is identified, already places joint frame 1")
    if name == f"offset_{pz.nq}" and any(k.startswith("tool_") for k in kept):
        hints.append("the tool's position about the last axis sets the same angle")
    if name.startswith("offset_") and pz.convention == "edh" and f"beta_{int(name.split('_')[1]) - 1}" in pz.names:
        i = int(name.split("_")[1])
        hints.append(
            f"axes {i - 1} and {i} are near-parallel, so the direction of x_{i - 1} (their common normal) is a free"
            f" choice, which offset_{i - 1} and the translations of link {i} absorb"
        )
    lead = (
        "redundant in the " + pz.convention + " parametrisation (no data can identify it)"
        if structural
        else "not determined by these measurements"
    )
    tail = f"; {'; '.join(hints)}" if hints else ""
    return f"{lead}: {why}{tail}{joint_hint}; fixed at its start value"


def parameter_status(pz: Parametrization, free, user_fixed, structural, dropped, held=(), model_fixed=()) -> list[str]:
    """Each parameter's status in a calibration's result, by precedence: ``"free"`` (estimated), ``"fixed"`` (by the
    user), ``"fixed (parametrisation)"`` (a rule of the convention), ``"redundant"`` / ``"unidentifiable"`` (dropped
    by the identifiability analysis: structurally, or by these data), ``"fixed (prior)"`` (``held``: names the data do
    not determine beyond their prior), ``"fixed (model)"`` (``model_fixed``: indices the chosen model leaves out),
    else ``"fixed"``."""
    free, user_fixed, model_fixed = set(free), set(user_fixed), set(model_fixed)
    return [
        (
            "free"
            if c in free
            else (
                "fixed"
                if c in user_fixed
                else (
                    "fixed (parametrisation)"
                    if nm in pz.rules
                    else (
                        ("redundant" if nm in structural else "unidentifiable")
                        if nm in dropped
                        else "fixed (prior)"
                        if nm in held
                        else "fixed (model)"
                        if c in model_fixed
                        else "fixed"
                    )
                )
            )
        )
        for c, nm in enumerate(pz.names)
    ]
