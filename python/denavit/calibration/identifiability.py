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

A numerical rank alone judges each column after scaling it to unit norm, so a parameter that moves the measurements
by almost nothing (a joint offset or compliance of the last joint with the measured point a few micrometres off its
axis; two parameters the point's position on an axis nearly ties together) is kept however large the sigma the data
give it. Given the plausible size of each parameter's error (:func:`plausible_sigmas`: ``fitting.checks.PLAUSIBLE``,
2 deg and 2 % of the robot's size) and the noise, :func:`analyze` also drops a parameter whose sigma, with the
parameters kept before it free, would exceed that size: the data do not determine it (status ``"unidentifiable"``,
the sigma it would have in its reason), and a fit that frees it swings it along a valley of equal residuals (on a UR5
measured at a reflector on the flange's axis: ``offset_5`` by 62 deg, ``a_5`` by 72 mm, ``k_6`` to 0.02 rad/(N m),
predicting the measured point as well as the nominal's values do and the flange not at all).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from .. import _core
from ..fitting.checks import PLAUSIBLE, SPECK, robot_size
from .least_squares import gram, jacobian_rows

if TYPE_CHECKING:
    from .measurements import Measurements
    from .parametrization import Parametrization

#: A unit-norm Jacobian column whose part independent of the columns kept before it is shorter than this is
#: not identifiable (its sigma would exceed 1e6 times the sigma it has alone).
RANK_TOL = 1e-6
#: Units of the sizes in the reasons (SI per unit, label) by the parameter's unit.
_SHOWN = {"length": (1e-3, "mm"), "angle": (math.pi / 180, "deg"), "ratio": (1e-6, "ppm")}


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
    #: the sigma (SI) the data would give it with the parameters kept before it free, when that is what dropped it
    #: (beyond its plausible size, :func:`plausible_sigmas`); None when its column is (numerically) dependent
    sigma: float | None = None


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
    kept before it is below ``tol**2`` is dropped. Returns (kept, dropped, zero columns, column norms, L, G) with
    ``G`` the Gram matrix of the unit-norm columns and ``L`` (k x k, lower) its Cholesky factor on kept."""
    G = gram(J)
    norms = np.sqrt(np.clip(np.diag(G), 0, None))
    safe = np.where(norms > 0, norms, 1.0)
    G = G / np.outer(safe, safe)
    kept, dropped, zero, L, _ = _eliminate(G, norms, order, np.full(len(norms), tol**2))
    return kept, dropped, zero, norms, L, G


def _eliminate(G: np.ndarray, norms: np.ndarray, order: list, floor: np.ndarray):
    """Right-looking elimination of the unit-norm Gram matrix ``G`` in preference order: (kept, dropped, zero
    columns, L, {dropped column: its squared distance from the span of the columns kept before it})."""
    top = norms.max() if norms.size else 0.0
    S = G.copy()  # the Schur complement of the kept columns
    cols = []
    kept, dropped, zero, dist = [], [], set(), {}
    for c in order:
        if not norms[c] > 1e-12 * top:
            dropped.append(c)
            zero.add(c)
            continue
        d = S[c, c]
        if d < floor[c]:
            dropped.append(c)
            dist[c] = max(float(d), 0.0)
            continue
        col = S[:, c] / math.sqrt(d)
        S -= np.outer(col, col)
        cols.append(col)
        kept.append(c)
    L = np.array(cols).T[kept] if kept else np.zeros((0, 0))  # G[kept][:, kept] = L L^T, lower triangular
    return kept, dropped, zero, L, dist


def plausible_sigmas(pz: Parametrization) -> np.ndarray:
    """The plausible size of each parameter's error (P,) (SI): the bounds of ``fitting.checks.PLAUSIBLE`` by which
    identify calls an axis implausible, 2 deg for an angle and 2 % of the robot's size (``fitting.checks.robot_size``
    at its home) for a length; a joint-reading scale's, the ratio that turns half a turn by 2 deg; a joint
    compliance's, the one that twists the joint by 2 deg (a prismatic joint: slides it by 2 % of the size) under the
    largest torque it holds in the data. The data determine a parameter when they give it a smaller sigma
    (:func:`analyze`)."""
    robot = pz.robot
    m = robot.model()
    size = robot_size(m, np.zeros(m.nq) if robot.home is None else np.asarray(robot.home, dtype=float))
    angle, frac = PLAUSIBLE
    per_torque = getattr(pz, "prior_factors", {})  # a compliance's 1 / max |tau| over the data
    out = np.full(pz.n_params, math.inf)
    for c, unit in enumerate(pz.units):
        if c in per_torque:
            out[c] = (angle if unit == "rad/(N m)" else frac * size) * per_torque[c]
        elif unit in ("length", "angle", "ratio"):
            out[c] = {"length": frac * size, "angle": angle, "ratio": angle / math.pi}[unit]
    return out


def _determined(G: np.ndarray, norms: np.ndarray, kept: list, bound2: np.ndarray) -> tuple[int, int, float] | None:
    """The first kept parameter to drop so that every kept one's sigma is within its plausible size, or None when
    they all are: (to drop, the parameter whose sigma it leaves beyond its size, that sigma squared in unit-norm
    units). ``bound2`` (P,): the largest variance each parameter may have, in the unit-norm columns' units. Of the
    parameters whose removal brings the worst one within its size, the last in preference order goes."""
    if not kept:
        return None
    C = np.linalg.inv(G[np.ix_(kept, kept)])
    var = np.diag(C)
    over = var / bound2[kept]
    o = int(np.argmax(over))
    if not over[o] > 1.0:
        return None
    for i in range(len(kept) - 1, -1, -1):  # kept is in preference order: the last first
        if i == o or var[o] - C[o, i] ** 2 / C[i, i] <= bound2[kept[o]]:
            return kept[i], kept[o], float(var[o])
    return None


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
    *,
    bounds: np.ndarray | None = None,
    s2: float = 1.0,
) -> Identifiability:
    """Rank-revealing analysis of the weighted identification Jacobian at x (module docstring); with
    ``explain=False`` only the kept / dropped sets (no reasons, no singular values).

    With ``structural`` (the analysis of the same candidates on configurations spread over the joint limits),
    the parameters it keeps come first: a structural dependency holds for any data, so what these data drop
    beyond it are parameters the structural analysis kept, and holding exactly those fixed restores full rank.

    With ``bounds`` (P,) (SI; :func:`plausible_sigmas`), a parameter is also dropped when the data would give it a
    sigma beyond its bound: in preference order, one whose sigma with the parameters kept before it free exceeds it;
    then, while a kept one's sigma (all kept free) exceeds its bound, the last in preference order whose removal
    brings that one within (:func:`_determined`). ``s2``: the variance of unit weight of the rows ``w`` whiten
    (1 when ``w`` holds the noise; the residuals' estimate otherwise).
    """
    J = jacobian_rows(pz, x, pz.inputs(meas), w, whitening=meas.whitening)[1]
    cand = set(candidates)
    order = [c for c in pz.order if c in cand]
    if structural is not None:
        first = set(structural.kept_idx)
        order = [c for c in order if c in first] + [c for c in order if c not in first]
    G = gram(J)
    norms = np.sqrt(np.clip(np.diag(G), 0, None))
    safe = np.where(norms > 0, norms, 1.0)
    G = G / np.outer(safe, safe)
    floor = np.full(len(norms), RANK_TOL**2)
    bound2 = np.full(len(norms), math.inf)
    if bounds is not None:  # in the unit-norm columns' units: a parameter's variance is s2 C_cc / norm_c^2
        b = np.asarray(bounds, dtype=float)[: len(norms)]
        with np.errstate(divide="ignore", over="ignore"):
            floor = np.maximum(floor, np.where(norms > 0, s2 / (safe * b) ** 2, 0.0))
        bound2 = (safe * b) ** 2 / s2
    kept, dropped, zero, L, dist = _eliminate(G, norms, order, floor)
    late = {}  # dropped after the elimination: {column: (the parameter beyond its size with it free, its variance)}
    while bounds is not None and (hit := _determined(G, norms, kept, bound2)) is not None:
        late[hit[0]] = hit[1:]
        kept, dropped, zero, L, dist = _eliminate(G, norms, [c for c in order if c not in late], floor)
        dropped = [c for c in order if c in late or c in dropped]
    combs = _combinations(G, L, kept, dropped, norms) if explain else {}
    un = []
    for c in dropped:
        name = pz.names[c]
        comb = combs.get(c, {})
        struct = structural is not None and c not in structural.kept_idx
        sigma = None
        beyond = None
        if c in late:
            o, var = late[c]
            beyond = (pz.names[o], math.sqrt(s2 * var) / safe[o], float(bounds[o]), None)
            if o == c:
                sigma = beyond[1]
        elif c in dist and dist[c] >= RANK_TOL**2:
            sigma = math.sqrt(s2 / dist[c]) / safe[c]
            beyond = (name, sigma, float(bounds[c]), dist[c])
        reason = _reason(pz, x, name, c in zero, comb, struct, joint_hint, beyond) if explain else ""
        un.append(Unidentifiable(name, reason, struct, {pz.names[k]: v for k, v in comb.items()}, sigma))
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
    ku, du = (u.get(pz.units[pz.names.index(k)], pz.units[pz.names.index(k)]) for k in (name, dropped))
    unit = "" if ku == du else f" {ku} per {du}" if "/" in du else f" {ku}/{du}" if du else f" {ku}"
    return f"{v:+.4g}{unit} x {name}"


def _fmt_size(v: float, unit: str) -> str:
    """A size ``v`` (SI) of a parameter in ``unit`` as the notes show it (mm, deg, ppm; a compliance SI)."""
    scale, label = _SHOWN.get(unit, (1.0, unit))
    return f"{v / scale:.3g} {label}"


def _on_last_axis(pz: Parametrization, x) -> str:
    """A hint when the measured point lies on or next to the last joint's axis at ``x`` (closer than
    ``fitting.checks.SPECK`` of the robot's size, as identify names a speck of a circle), else "": turning that joint
    hardly moves it."""
    if pz.measure != "point" or pz.nq < 1:
        return ""
    m = pz.model(x)
    q = np.zeros(m.nq)
    ax = _core.axes(m, q)
    p, z = np.asarray(ax.points)[-1], np.asarray(ax.directions)[-1]
    v = _core.fk(m, q)[:3, 3] - p
    r = float(np.linalg.norm(v - z * (v @ z)))
    if r >= SPECK * robot_size(m, q):
        return ""
    return (
        f"the measured point is {r * 1e3:.3g} mm from joint {m.nq}'s axis: that joint's turning (its offset, its"
        " compliance) and the last link's turn about the point hardly move it (a target off that axis determines them)"
    )


def _reason(
    pz: Parametrization,
    x,
    name: str,
    zero: bool,
    comb: dict,
    structural: bool,
    joint_hint: str,
    beyond: tuple | None = None,
) -> str:
    """Why parameter ``name`` was dropped; ``beyond``: (the parameter whose sigma exceeds its plausible size with
    ``name`` free, that sigma, that size (SI), the squared share of ``name``'s unit-norm column independent of the
    parameters kept before it, or None) when that is why."""
    if beyond is not None:
        other, sig, bound, own = beyond
        unit = pz.units[pz.index(other)]
        size = f"a sigma of {_fmt_size(sig, unit)}, beyond the plausible size of its error ({_fmt_size(bound, unit)})"
        terms = ", ".join(_fmt_coef(pz.names[k], v, pz, name) for k, v in comb.items())
        why = (f"the data would give it {size}" if other == name else f"free, it leaves {other} with {size}") + (
            "; it barely moves the measured points"  # most of its column is its own, and that is below the noise
            if own is not None and own > 0.25 or not terms
            else f"; its effect nearly equals that of {terms}"
        )
    elif zero:
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
    kept = [] if beyond is not None else [pz.names[k] for k in comb]  # (a near-combination is no structural reason)
    hints = []
    if (
        beyond is None
        and name.startswith(("c_", "d_"))
        and (pz.convention == "edh" and name.startswith("c_") or pz.convention != "edh")
    ):
        j = int(name.split("_")[1]) + (1 if pz.convention == "edh" else 0)
        hints.append(
            f"it slides joint frame {j}'s origin along axis {j}, which "
            + ("the tool absorbs" if any(k.startswith("tool_") for k in kept) else "the following links absorb")
        )
    if any(k.startswith("base_") for k in kept) and not name.startswith("base_"):
        hints.append("the base frame, which is identified, already places joint frame 1")
    if name == f"offset_{pz.nq}" and any(k.startswith("tool_") for k in kept):
        hints.append("the tool's position about the last axis sets the same angle")
    if (
        beyond is None
        and name.startswith("offset_")
        and pz.convention == "edh"
        and f"beta_{int(name.split('_')[1]) - 1}" in pz.names
    ):
        i = int(name.split("_")[1])
        hints.append(
            f"axes {i - 1} and {i} are near-parallel, so the direction of x_{i - 1} (their common normal) is a free"
            f" choice, which offset_{i - 1} and the translations of link {i} absorb"
        )
    last = name.startswith("tool_") or name.rsplit("_", 1)[-1] in (str(pz.nq - 1), str(pz.nq))
    if not structural and last and (hint := _on_last_axis(pz, x)):
        hints.append(hint)
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
